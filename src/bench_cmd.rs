//! `frontseat bench`: runs the sibling executable `frontseat-bench` (src/bin/frontseat_bench.rs)
//! with the same arguments, so this binary does not link the benchmark; its output and exit
//! code are the sibling's.

use std::process::ExitCode;

pub use crate::bench_args::BenchArgs;

/// `args` were parsed here only to check them (and for `--help`); the sibling parses them again.
pub fn run(_args: BenchArgs) -> ExitCode {
    crate::sibling::exec("bench", "frontseat-bench")
}
