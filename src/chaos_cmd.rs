//! `frontseat chaos`: runs the sibling executable `frontseat-chaos` (src/bin/frontseat_chaos.rs)
//! with the same arguments, so this binary does not link the chaos harness; its output and exit
//! code are the sibling's.

use std::process::ExitCode;

pub use crate::chaos_args::ChaosArgs;

/// `args` were parsed here only to check them (and for `--help`); the sibling parses them again.
pub fn run(_args: ChaosArgs) -> ExitCode {
    crate::sibling::exec("chaos", "frontseat-chaos")
}
