//! The flags of `frontseat chaos`, shared by the service binary (which parses them, so `--help`
//! and a bad flag read as ever) and the sibling executable `frontseat-chaos` that runs them.

use std::path::PathBuf;
use std::time::Duration;

use clap::Args;

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
    /// The vehicle to run: `basic` (the basic simulator, the default) or a vehicle family —
    /// `bluefin`, `iver3`, `waveglider_sv2`, `ardupilot`, `ardusub`, `dune` — whose emulator and
    /// real driver run behind a chaos link that drops, silences, delays and corrupts the line in
    /// the vehicle's own protocol. A family run takes no MOOS bridge and no --soak.
    #[arg(long, value_name = "FAMILY", default_value = "basic")]
    pub vehicle: String,
    /// Print the embedded default config and exit.
    #[arg(long)]
    pub print_config: bool,
}
