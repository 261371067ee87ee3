//! Driver selection: a plugin library when FRONTSEAT_DRIVER_LIBRARY or `driver.library` names
//! one (see plugin.rs), otherwise the built-in driver the config names (`driver.name`).

pub mod basic_simulator;
pub mod bluefin;
pub mod plugin;

use crate::driver::{Driver, DriverFactory};
use frontseat_config::InterfaceConfig;

#[derive(Debug, thiserror::Error)]
pub enum DriverSelectError {
    #[error("unknown driver `{0}` (built-in drivers: basic_simulator, bluefin)")]
    Unknown(String),
    #[error(transparent)]
    Plugin(#[from] plugin::PluginError),
}

/// The factory for the driver the environment and the config select.
pub fn factory(cfg: &InterfaceConfig) -> Result<DriverFactory, DriverSelectError> {
    factory_with_env(cfg, &|k| std::env::var(k).ok())
}

/// [`factory`] with the environment given (tests). A plugin is checked before this returns:
/// a missing file, a missing symbol or an ABI mismatch is an error here, not a restart loop.
pub fn factory_with_env(
    cfg: &InterfaceConfig,
    env: &dyn Fn(&str) -> Option<String>,
) -> Result<DriverFactory, DriverSelectError> {
    if let Some(settings) = plugin::PluginSettings::select(cfg, env)? {
        settings.preflight()?;
        return Ok(std::sync::Arc::new(move || {
            Box::new(plugin::PluginDriver::new(settings.clone())) as Box<dyn Driver>
        }));
    }
    match cfg.driver.name.as_str() {
        "basic_simulator" => {
            let settings = basic_simulator::Settings::from_config(cfg);
            Ok(std::sync::Arc::new(move || {
                Box::new(basic_simulator::BasicSimulatorDriver::new(settings.clone()))
                    as Box<dyn Driver>
            }))
        }
        "bluefin" => {
            let settings = bluefin::Settings::from_config(cfg);
            Ok(std::sync::Arc::new(move || {
                Box::new(bluefin::BluefinDriver::new(settings.clone())) as Box<dyn Driver>
            }))
        }
        other => Err(DriverSelectError::Unknown(other.to_string())),
    }
}
