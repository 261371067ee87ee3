//! `frontseat bench`: the flags, then frontseat_bench does the measuring. The cross-process rows
//! start this very executable as their children, so its path is handed over here.

use std::process::ExitCode;

use clap::Args;
use frontseat_bench::BenchOptions;

#[derive(Args, Debug, Clone)]
pub struct BenchArgs {
    /// Run in seconds, to prove the benchmark runs (CI); figures are rough.
    #[arg(long)]
    pub quick: bool,
    /// Print the results as JSON instead of the Markdown table.
    #[arg(long)]
    pub json: bool,
}

pub async fn run(args: BenchArgs) -> ExitCode {
    let exe = match std::env::current_exe() {
        Ok(p) => p,
        Err(e) => {
            eprintln!("frontseat bench: cannot find its own executable: {e}");
            return ExitCode::from(1);
        }
    };
    frontseat_bench::run(BenchOptions {
        quick: args.quick,
        json: args.json,
        exe,
    })
    .await
}
