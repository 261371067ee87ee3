//! `frontseat chaos`: runs the chaos harness (frontseat_chaos, tools/chaos) — the real
//! simulator, interface, helm and MOOS bridge in this process, faults on a seeded schedule —
//! prints the invariants table and exits non-zero on any violation.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use clap::Args;
use frontseat_chaos::{self, ChaosHarnessError, ChaosOptions};
use frontseat_config::InterfaceConfig;

#[derive(Args, Debug, Clone)]
pub struct ChaosArgs {
    /// Seed of the fault schedule: the same seed gives the same faults, parameters and timings.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// How many faults to inject.
    #[arg(long, default_value_t = 200)]
    pub faults: u32,
    /// Time warp (overrides the config's sim_warp_factor; the embedded config uses 100).
    #[arg(long)]
    pub warp: Option<f64>,
    /// Interface config (TOML); it must contain `[chaos]` with `enabled = true`. Without -c an
    /// embedded config with chaos enabled is used. The simulator and the MOOS broker always run
    /// in this process on loopback, whatever the config's addresses say.
    #[arg(short = 'c', long = "config", value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Wall seconds within which the interface must be back in COMMAND after a fault clears.
    #[arg(long, default_value_t = 5.0)]
    pub recovery_bound: f64,
    /// Largest allowed growth of the resident set over its warm baseline, MiB.
    #[arg(long, default_value_t = 64)]
    pub rss_growth_mib: u64,
    /// Leave out the MOOS bridge and the broker-restart fault.
    #[arg(long)]
    pub no_moos: bool,
    /// Soak: inject faults for this long (wall time, e.g. `20m`, `2h`) instead of `--faults`,
    /// reporting RSS, open fds, threads and tasks every `--sample-every`; the report adds a
    /// table of the samples and fails on a drift.
    #[arg(long, value_name = "DURATION", value_parser = humantime::parse_duration)]
    pub soak: Option<Duration>,
    /// How often a soak samples and prints the process's resources (e.g. `1m`, `30s`).
    #[arg(long, value_name = "DURATION", value_parser = humantime::parse_duration, default_value = "1m")]
    pub sample_every: Duration,
    /// Only these faults, comma-separated (e.g. `moos-crash-loop,web-flood`; `--only help` lists
    /// them): to find which fault a resource drift comes with.
    #[arg(long, value_name = "KINDS", value_delimiter = ',')]
    pub only: Vec<String>,
    /// Print the embedded default config and exit.
    #[arg(long)]
    pub print_config: bool,
}

pub async fn run(args: ChaosArgs) -> ExitCode {
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
    let mut only = Vec::new();
    for k in &args.only {
        match frontseat_chaos::FaultKind::from_key(k) {
            Some(kind) => only.push(kind),
            None => {
                let keys: Vec<&str> = frontseat_chaos::FaultKind::ALL
                    .iter()
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
        "frontseat chaos: seed {}, {}{}",
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
    match frontseat_chaos::run(config, opts, |p| eprintln!("chaos: {p}")).await {
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
