//! `frontseat bench`: reproducible latency, throughput, capacity and footprint figures.
//! (Being written; see issue 10.)

use std::process::ExitCode;

use clap::Args;

#[derive(Args, Debug, Clone)]
pub struct BenchArgs {
    /// Run in seconds, to prove the benchmark runs (CI); figures are rough.
    #[arg(long)]
    pub quick: bool,
}

pub async fn run(_args: BenchArgs) -> ExitCode {
    eprintln!("frontseat bench: not implemented yet");
    ExitCode::from(1)
}
