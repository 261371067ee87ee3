//! `frontseat driver-host --library PATH`: the child process the interface runs a driver plugin
//! in (crash isolation). It speaks frames on stdin/stdout with the interface that spawned it, so
//! it must print nothing else to stdout; the protocol loop lives in frontseat-driver-sdk.

use std::path::PathBuf;
use std::process::ExitCode;

use frontseat_actors::drivers::plugin::sdk::child::{self, HostArgs};

#[derive(clap::Args, Debug)]
pub struct DriverHostArgs {
    /// The driver library (.so) to load.
    #[arg(long, value_name = "PATH")]
    pub library: PathBuf,
    /// Only check that the library loads, has every symbol and the right ABI version; exit 0
    /// if so, else 3 (file missing), 4 (symbol missing), 5 (ABI mismatch), 6 (not loadable).
    #[arg(long)]
    pub check: bool,
}

pub fn run(args: DriverHostArgs) -> ExitCode {
    child::run(&HostArgs {
        library: args.library,
        check: args.check,
    })
}
