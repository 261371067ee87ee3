//! What a run is asked to do: the embedded default config, the options, and the errors that
//! refuse a run or end its start.

use std::time::Duration;

use frontseat_actors::chaos::ChaosError;
use frontseat_config::InterfaceConfig;

use crate::plan::FaultKind;

/// The config `frontseat chaos` uses without `-c`: chaos enabled, warped, short reconnect and
/// restart delays, and a restart limit that a fault every few hundred milliseconds stays under.
pub const DEFAULT_CONFIG: &str = r#"# frontseat chaos: the embedded default config
name = "chaos-auv"
sim_warp_factor = 100.0
status_period = 1.0

[driver.basic_simulator]
reconnect_initial_ms = 10
reconnect_max_ms = 100
nav_timeout = 5.0

[supervision]
restart_initial_delay_ms = 10
restart_max_delay_ms = 100
max_restarts = 100
restart_window_s = 30.0

[chaos]
enabled = true
"#;

/// The embedded default config, parsed.
pub fn default_config() -> Result<InterfaceConfig, frontseat_config::ConfigError> {
    frontseat_config::parse::<InterfaceConfig>(DEFAULT_CONFIG, "<embedded chaos config>")
}

/// What to run.
#[derive(Clone, Debug)]
pub struct ChaosOptions {
    /// Seed of the fault schedule.
    pub seed: u64,
    /// Faults to inject.
    pub faults: u32,
    /// Overrides the config's sim_warp_factor.
    pub warp: Option<f64>,
    /// Wall time within which the interface must be back in COMMAND after a fault clears.
    pub recovery_bound: Duration,
    /// Largest allowed growth of the resident set over its value once the system is warm.
    pub rss_growth_limit_kib: u64,
    /// Run the MOOS bridge against a broker of ours and restart that broker as a fault.
    pub moos: bool,
    /// A soak: inject faults for this long (wall) instead of `faults` of them.
    pub soak: Option<Duration>,
    /// How often the resources (RSS, open fds, threads, tasks) are sampled and reported.
    pub sample_every: Duration,
    /// Only these fault kinds (empty: all). To find which fault a resource drift comes with.
    pub only: Vec<FaultKind>,
}

impl Default for ChaosOptions {
    fn default() -> Self {
        Self {
            seed: 1,
            faults: 200,
            warp: None,
            recovery_bound: Duration::from_secs(5),
            rss_growth_limit_kib: 64 * 1024,
            moos: true,
            soak: None,
            sample_every: Duration::from_secs(60),
            only: Vec::new(),
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum ChaosHarnessError {
    #[error(transparent)]
    Refused(#[from] ChaosError),
    #[error("bad chaos options: {0}")]
    Options(String),
    #[error("another chaos run is active in this process")]
    AlreadyRunning,
    #[error("simulator: {0}")]
    Sim(#[from] frontseat_sim::SimError),
    #[error("interface: {0}")]
    Start(#[from] frontseat_actors::interface::StartError),
    #[error("MOOS broker: {0}")]
    Moos(#[from] frontseat_moos::MoosError),
    #[error("MOOS bridge: {0}")]
    Translation(String),
    #[error("web commander: {0}")]
    Web(String),
    #[error("gobyd stand-in or Goby3 gateway: {0}")]
    Goby3(String),
    #[error("vehicle emulator: {0}")]
    Vehicle(String),
    #[error("the interface did not reach COMMAND within {0:?} at start")]
    NoStart(Duration),
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn embedded_config_enables_chaos_and_parses() {
        let c = default_config().unwrap();
        assert!(c.chaos.enabled);
        assert!(c.sim_warp_factor > 1.0);
    }
}
