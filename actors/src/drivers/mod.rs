//! Built-in drivers, selected by name in the config (`driver.name`).

pub mod basic_simulator;

use crate::driver::{Driver, DriverFactory};
use frontseat_config::InterfaceConfig;

#[derive(Debug, thiserror::Error)]
pub enum DriverSelectError {
    #[error("unknown driver `{0}` (built-in drivers: basic_simulator)")]
    Unknown(String),
}

/// The factory for the driver the config names.
pub fn factory(cfg: &InterfaceConfig) -> Result<DriverFactory, DriverSelectError> {
    match cfg.driver.name.as_str() {
        "basic_simulator" => {
            let settings = basic_simulator::Settings::from_config(cfg);
            Ok(std::sync::Arc::new(move || {
                Box::new(basic_simulator::BasicSimulatorDriver::new(settings.clone()))
                    as Box<dyn Driver>
            }))
        }
        other => Err(DriverSelectError::Unknown(other.to_string())),
    }
}
