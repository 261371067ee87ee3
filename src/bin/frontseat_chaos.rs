//! `frontseat-chaos`: the chaos harness behind `frontseat chaos` (frontseat_chaos, tools/chaos) —
//! the real simulator, interface, helm and MOOS bridge in this process, faults on a seeded
//! schedule — an executable of its own so the service binary does not link it. `frontseat chaos
//! ARGS` runs `frontseat-chaos ARGS` from the same directory; run directly, it takes the same
//! flags. Prints the invariants table and exits non-zero on any violation.

use std::process::ExitCode;
use std::time::Duration;

use clap::Parser;
use frontseat_chaos::{self, ChaosHarnessError, ChaosOptions};
use frontseat_config::InterfaceConfig;

#[path = "../chaos_args.rs"]
mod chaos_args;

#[derive(Parser, Debug)]
#[command(
    name = "frontseat chaos",
    about = "Inject seeded faults into the real runtime"
)]
struct Cli {
    #[command(flatten)]
    args: chaos_args::ChaosArgs,
}

fn main() -> ExitCode {
    let args = Cli::parse().args;
    // A long run would fill the console with every injected fault at info level.
    frontseat_telemetry::set_default_console_level("warn");
    let mut telemetry = frontseat_telemetry::init(&Default::default(), "chaos", "");
    let code = match tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
    {
        Ok(rt) => rt.block_on(run(args)),
        Err(e) => {
            eprintln!("cannot start the async runtime: {e}");
            ExitCode::from(1)
        }
    };
    telemetry.shutdown();
    code
}

async fn run(args: chaos_args::ChaosArgs) -> ExitCode {
    if args.print_config {
        print!("{}", frontseat_chaos::DEFAULT_CONFIG);
        return ExitCode::SUCCESS;
    }
    let config: InterfaceConfig = match &args.config {
        Some(path) => match frontseat_config::load::<InterfaceConfig>(path) {
            Ok(c) => c,
            Err(e) => {
                eprintln!("{e}");
                return ExitCode::from(2);
            }
        },
        None => match frontseat_chaos::default_config() {
            Ok(c) => c,
            Err(e) => {
                eprintln!("embedded chaos config: {e}");
                return ExitCode::from(1);
            }
        },
    };
    if !(args.recovery_bound.is_finite() && args.recovery_bound > 0.0) {
        eprintln!("--recovery-bound must be a positive number of seconds");
        return ExitCode::from(2);
    }
    let family = match args.vehicle.as_str() {
        "basic" | "basic_simulator" => None,
        k => match frontseat_chaos::Family::from_key(k) {
            Some(f) => Some(f),
            None => {
                let keys: Vec<&str> = frontseat_chaos::Family::ALL
                    .iter()
                    .map(|f| f.key())
                    .collect();
                eprintln!(
                    "--vehicle: unknown vehicle {k:?}; one of basic, {}",
                    keys.join(", ")
                );
                return ExitCode::from(2);
            }
        },
    };
    let mut only = Vec::new();
    for k in &args.only {
        match frontseat_chaos::FaultKind::from_key(k) {
            Some(kind) => only.push(kind),
            None => {
                let keys: Vec<&str> = frontseat_chaos::FaultKind::ALL
                    .iter()
                    .chain(&frontseat_chaos::FaultKind::VEHICLE)
                    .map(|k| k.key())
                    .collect();
                eprintln!("--only: unknown fault {k:?}; one of {}", keys.join(", "));
                return ExitCode::from(2);
            }
        }
    }
    let opts = ChaosOptions {
        only,
        seed: args.seed,
        faults: args.faults,
        warp: args.warp,
        recovery_bound: Duration::from_secs_f64(args.recovery_bound),
        rss_growth_limit_kib: args.rss_growth_mib.saturating_mul(1024),
        moos: !args.no_moos,
        soak: args.soak,
        sample_every: args.sample_every,
    };
    if args.sample_every < Duration::from_secs(1) {
        eprintln!("--sample-every must be at least 1 s");
        return ExitCode::from(2);
    }
    eprintln!(
        "frontseat chaos: {}seed {}, {}{}",
        family
            .map(|f| format!("vehicle {}, ", f.key()))
            .unwrap_or_default(),
        opts.seed,
        match opts.soak {
            Some(d) => format!(
                "soak for {}, resources every {}",
                humantime::format_duration(d),
                humantime::format_duration(opts.sample_every)
            ),
            None => format!("{} faults", opts.faults),
        },
        args.config
            .as_ref()
            .map(|p| format!(", config {}", p.display()))
            .unwrap_or_default()
    );
    let report = match family {
        Some(f) => frontseat_chaos::run_family(f, config, opts, |p| eprintln!("chaos: {p}")).await,
        None => frontseat_chaos::run(config, opts, |p| eprintln!("chaos: {p}")).await,
    };
    match report {
        Ok(report) => {
            print!("{}", report.render());
            if report.passed() {
                ExitCode::SUCCESS
            } else {
                ExitCode::from(1)
            }
        }
        Err(e @ ChaosHarnessError::Refused(_)) => {
            let file = args
                .config
                .as_ref()
                .map(|p| p.display().to_string())
                .unwrap_or_default();
            eprintln!("frontseat chaos: {file}: {e}");
            ExitCode::from(2)
        }
        Err(e @ ChaosHarnessError::Options(_)) => {
            eprintln!("frontseat chaos: {e}");
            ExitCode::from(2)
        }
        Err(e) => {
            eprintln!("frontseat chaos: {e}");
            ExitCode::from(1)
        }
    }
}
