//! `frontseat-bench`: the benchmark behind `frontseat bench` (frontseat_bench, tools/bench), an
//! executable of its own so the service binary does not link it. `frontseat bench ARGS` runs
//! `frontseat-bench ARGS` from the same directory; run directly, it takes the same flags. The
//! cross-process rows start the `frontseat` executable (`FRONTSEAT_EXE`, set by `frontseat bench`,
//! else the one next to this file) as their children.

use std::process::ExitCode;

use clap::Parser;
use frontseat_bench::BenchOptions;

#[path = "../bench_args.rs"]
mod bench_args;

#[derive(Parser, Debug)]
#[command(
    name = "frontseat bench",
    about = "Measure latency, throughput, capacity and footprint"
)]
struct Cli {
    #[command(flatten)]
    args: bench_args::BenchArgs,
}

fn main() -> ExitCode {
    // The bench's own F1 publishers, started by the bench as a child of its own.
    if let Ok(spec) = std::env::var(frontseat_bench::PUBLISHER_ENV) {
        return frontseat_bench::publisher_main(&spec);
    }
    // L4's putting peer (a floor), likewise.
    if let Ok(spec) = std::env::var(frontseat_bench::L4_PEER_ENV) {
        return frontseat_bench::l4_peer_main(&spec);
    }
    let args = Cli::parse().args;
    let exe = match std::env::var_os("FRONTSEAT_EXE") {
        Some(p) => std::path::PathBuf::from(p),
        None => match std::env::current_exe() {
            Ok(p) => p.with_file_name(format!("frontseat{}", std::env::consts::EXE_SUFFIX)),
            Err(e) => {
                eprintln!("frontseat bench: cannot find its own executable: {e}");
                return ExitCode::from(1);
            }
        },
    };
    let mut telemetry = frontseat_telemetry::init(&Default::default(), "bench", "");
    let code = match tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
    {
        Ok(rt) => rt.block_on(frontseat_bench::run(BenchOptions {
            quick: args.quick,
            json: args.json,
            exe,
            rows: args.rows,
            against: args.against,
            pairs: args.pairs,
        })),
        Err(e) => {
            eprintln!("cannot start the async runtime: {e}");
            ExitCode::from(1)
        }
    };
    telemetry.shutdown();
    code
}
