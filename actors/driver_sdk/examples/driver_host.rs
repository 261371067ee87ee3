//! A stand-alone driver host: the same code as `frontseat driver-host`, for hosting drivers
//! from a binary that is not `frontseat` (the tests point FRONTSEAT_DRIVER_HOST at it).
//! Usage: `driver_host driver-host --library PATH [--check]`.
#![forbid(unsafe_code)]

use std::process::ExitCode;

use frontseat_driver_sdk::child::{self, HostArgs};

fn main() -> ExitCode {
    let mut args = std::env::args_os().skip(1);
    if args.next().as_deref() != Some(std::ffi::OsStr::new("driver-host")) {
        eprintln!("usage: driver_host driver-host --library PATH [--check]");
        return ExitCode::from(2);
    }
    match HostArgs::parse(args) {
        Ok(a) => child::run(&a),
        Err(e) => {
            eprintln!("driver_host: {e}");
            ExitCode::from(2)
        }
    }
}
