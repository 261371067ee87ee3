//! The built-in drivers and driver selection: a plugin library when FRONTSEAT_DRIVER_LIBRARY or
//! `driver.library` names one (see plugin.rs), otherwise the built-in driver the config names
//! (`driver.name`). Each built-in driver speaks through its vehicle crate's pure codec
//! (`vehicles/<vehicle>/`; the basic simulator's is `frontseat_sim::codec`) and takes the glue
//! they all need from [`kit`].

pub mod ardupilot;
pub mod basic_simulator;
pub mod bluefin;
pub mod iver3;
pub mod kit;
pub mod plugin;
pub mod waveglider_sv2;

use crate::driver::{Driver, DriverFactory};
use frontseat_config::InterfaceConfig;

#[derive(Debug, thiserror::Error)]
pub enum DriverSelectError {
    #[error(
        "unknown driver `{0}` (built-in drivers: basic_simulator, bluefin, iver3, waveglider_sv2, ardupilot)"
    )]
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
    // A Goby3 driver library named by the environment or the config selects our built-in
    // driver (normally already applied when the config was loaded; applied here too so every
    // caller of the factory agrees with the service).
    let mut resolved;
    let mut cfg = cfg;
    let env_library = env("FRONTSEAT_DRIVER_LIBRARY");
    if frontseat_config::goby3_import::goby3_driver_for_library(
        env_library.as_deref().unwrap_or(""),
    )
    .is_some()
        || cfg
            .driver
            .library
            .as_deref()
            .and_then(frontseat_config::goby3_import::goby3_driver_for_library)
            .is_some()
    {
        resolved = cfg.clone();
        resolved.select_goby3_driver(env_library.as_deref());
        cfg = &resolved;
    }
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
        frontseat_config::BLUEFIN => {
            let settings = bluefin::Settings::from_config(cfg);
            Ok(std::sync::Arc::new(move || {
                Box::new(bluefin::BluefinDriver::new(settings.clone())) as Box<dyn Driver>
            }))
        }
        frontseat_config::IVER3 => {
            let settings = iver3::Settings::from_config(cfg);
            Ok(std::sync::Arc::new(move || {
                Box::new(iver3::Iver3Driver::new(settings.clone())) as Box<dyn Driver>
            }))
        }
        frontseat_config::WAVEGLIDER_SV2 => {
            let settings = waveglider_sv2::Settings::from_config(cfg);
            Ok(std::sync::Arc::new(move || {
                Box::new(waveglider_sv2::WavegliderSv2Driver::new(settings.clone()))
                    as Box<dyn Driver>
            }))
        }
        frontseat_config::ARDUPILOT => {
            let settings = ardupilot::Settings::from_config(cfg);
            Ok(std::sync::Arc::new(move || {
                Box::new(ardupilot::ArdupilotDriver::new(settings.clone())) as Box<dyn Driver>
            }))
        }
        other => Err(DriverSelectError::Unknown(other.to_string())),
    }
}

/// The byte link a vehicle driver's config describes: its serial port (Goby3's port and baud
/// fields) or TCP, with the shared framing, parity, flow control and backoff settings.
pub fn vehicle_link(
    c: &frontseat_config::VehicleLinkConfig,
    serial_port: &str,
    serial_baud: u32,
    framing: crate::link::framing::Framing,
) -> crate::link::byte::ByteLinkConfig {
    use crate::link::byte::Transport;
    use crate::link::serial::{SerialFlowControl, SerialParity, SerialSettings};
    use frontseat_config::{FlowControlConfig, ParityConfig, TransportKind};
    let transport = match c.transport {
        TransportKind::Serial => Transport::Serial(SerialSettings {
            path: serial_port.to_string(),
            baud: serial_baud,
            data_bits: c.data_bits,
            parity: match c.parity {
                ParityConfig::None => SerialParity::None,
                ParityConfig::Odd => SerialParity::Odd,
                ParityConfig::Even => SerialParity::Even,
            },
            stop_bits: c.stop_bits,
            flow_control: match c.flow_control {
                FlowControlConfig::None => SerialFlowControl::None,
                FlowControlConfig::Software => SerialFlowControl::Software,
                FlowControlConfig::Hardware => SerialFlowControl::Hardware,
            },
        }),
        TransportKind::Tcp => Transport::Tcp {
            host: c.tcp_address.clone(),
            port: c.tcp_port,
        },
    };
    crate::link::byte::ByteLinkConfig {
        transport,
        framing,
        backoff_initial: std::time::Duration::from_millis(c.reconnect_initial_ms.max(1)),
        backoff_max: std::time::Duration::from_millis(
            c.reconnect_max_ms.max(c.reconnect_initial_ms).max(1),
        ),
    }
}
