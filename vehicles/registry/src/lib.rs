//! The built-in drivers: the one list of the vehicles a binary links (each vehicle crate under
//! `vehicles/` exports its `DRIVER`), and driver selection over it. Selection itself (plugins,
//! Goby3 library names) is the runtime's (`frontseat_actors::drivers`); this crate only adds the
//! list, so the runtime depends on no vehicle and adding a vehicle edits this file only.

#![forbid(unsafe_code)]

use frontseat_actors::driver::DriverFactory;
use frontseat_actors::drivers::{self, BuiltIn, DriverSelectError};
use frontseat_config::InterfaceConfig;

/// Every built-in driver, in the order `unknown driver` errors list them (the config's order:
/// `frontseat_config::BUILT_IN_DRIVERS`).
pub const BUILT_IN: &[BuiltIn] = &[
    frontseat_basic_simulator::DRIVER,
    frontseat_iver3::DRIVER,
    frontseat_waveglider_sv2::DRIVER,
    frontseat_bluefin::DRIVER,
    frontseat_ardupilot::DRIVER,
    frontseat_dune::DRIVER,
];

/// The factory for the driver the environment and the config select.
pub fn factory(cfg: &InterfaceConfig) -> Result<DriverFactory, DriverSelectError> {
    drivers::factory(cfg, BUILT_IN)
}

/// [`factory`] with the environment given (tests).
pub fn factory_with_env(
    cfg: &InterfaceConfig,
    env: &dyn Fn(&str) -> Option<String>,
) -> Result<DriverFactory, DriverSelectError> {
    drivers::factory_with_env(cfg, env, BUILT_IN)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_configurable_driver_is_built_in_once() {
        let names: Vec<&str> = BUILT_IN.iter().map(|b| b.name).collect();
        assert_eq!(names, frontseat_config::BUILT_IN_DRIVERS.to_vec());
    }

    #[test]
    fn an_unknown_driver_is_refused_with_the_list() {
        let mut cfg = InterfaceConfig::default();
        cfg.driver.name = "no_such_vehicle".into();
        let e = factory_with_env(&cfg, &|_| None)
            .err()
            .map(|e| e.to_string());
        assert_eq!(
            e.as_deref(),
            Some(
                "unknown driver `no_such_vehicle` (built-in drivers: basic_simulator, iver3, \
                 waveglider_sv2, bluefin, ardupilot, dune)"
            )
        );
    }
}
