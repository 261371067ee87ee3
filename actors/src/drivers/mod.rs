//! Driver selection and the driver kit: a plugin library when FRONTSEAT_DRIVER_LIBRARY or
//! `driver.library` names one (see plugin.rs), otherwise the built-in driver the config names
//! (`driver.name`) among the [`BuiltIn`]s the caller passes. The built-in drivers live with their
//! vehicles (`vehicles/<vehicle>/`, each on its own pure codec) and the list of them is the
//! registry crate's (`vehicles/registry`, `frontseat-drivers`), so this runtime names no vehicle;
//! every driver takes the glue they all need from [`kit`] and its byte link from [`vehicle_link`].

pub mod kit;
pub mod plugin;

use std::time::Duration;

use crate::driver::{Driver, DriverFactory};
use crate::raw_gate::RawFraming;
use frontseat_config::InterfaceConfig;

/// A built-in driver: the name `driver.name` selects it by, how it is built from a config
/// (settings read once; the factory makes a fresh driver for every (re)start), and what the
/// interface must know of its vehicle without naming it.
#[derive(Clone, Copy)]
pub struct BuiltIn {
    pub name: &'static str,
    pub factory: fn(&InterfaceConfig) -> DriverFactory,
    /// How long the vehicle may take to answer a command under this config (its resends or
    /// its ack timeout): the interface waits past it before answering failed itself, so the
    /// vehicle's own answer is the one the helm gets.
    pub ack_budget: fn(&InterfaceConfig) -> Duration,
    /// How the vehicle's wire delimits messages: what the raw gate lets one raw_send_request be.
    pub raw_framing: RawFraming,
}

/// For a driver whose vehicle answers at once (or never): no budget beyond the interface's own.
pub fn no_ack_budget(_: &InterfaceConfig) -> Duration {
    Duration::ZERO
}

/// The driver the config selects, with what the interface needs to know of it.
#[derive(Clone)]
pub struct SelectedDriver {
    pub factory: DriverFactory,
    /// [`BuiltIn::ack_budget`] under the config (zero for a plugin).
    pub ack_budget: Duration,
    /// [`BuiltIn::raw_framing`] (frames for a plugin: only its size and source are checked).
    pub raw_framing: RawFraming,
}

impl std::fmt::Debug for SelectedDriver {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SelectedDriver")
            .field("ack_budget", &self.ack_budget)
            .field("raw_framing", &self.raw_framing)
            .finish()
    }
}

impl std::fmt::Debug for BuiltIn {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("BuiltIn").field("name", &self.name).finish()
    }
}

#[derive(Debug, thiserror::Error)]
pub enum DriverSelectError {
    #[error("unknown driver `{name}` (built-in drivers: {built_in})")]
    Unknown { name: String, built_in: String },
    #[error(transparent)]
    Plugin(#[from] plugin::PluginError),
}

/// The factory for the driver the environment and the config select.
pub fn factory(
    cfg: &InterfaceConfig,
    built_in: &[BuiltIn],
) -> Result<DriverFactory, DriverSelectError> {
    factory_with_env(cfg, &|k| std::env::var(k).ok(), built_in)
}

/// [`factory`] with the environment given (tests).
pub fn factory_with_env(
    cfg: &InterfaceConfig,
    env: &dyn Fn(&str) -> Option<String>,
    built_in: &[BuiltIn],
) -> Result<DriverFactory, DriverSelectError> {
    select_with_env(cfg, env, built_in).map(|s| s.factory)
}

/// The driver the environment and the config select, with its properties.
pub fn select(
    cfg: &InterfaceConfig,
    built_in: &[BuiltIn],
) -> Result<SelectedDriver, DriverSelectError> {
    select_with_env(cfg, &|k| std::env::var(k).ok(), built_in)
}

/// [`select`] with the environment given (tests). A plugin is checked before this returns:
/// a missing file, a missing symbol or an ABI mismatch is an error here, not a restart loop.
pub fn select_with_env(
    cfg: &InterfaceConfig,
    env: &dyn Fn(&str) -> Option<String>,
    built_in: &[BuiltIn],
) -> Result<SelectedDriver, DriverSelectError> {
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
        return Ok(SelectedDriver {
            factory: std::sync::Arc::new(move || {
                Box::new(plugin::PluginDriver::new(settings.clone())) as Box<dyn Driver>
            }),
            ack_budget: Duration::ZERO,
            raw_framing: RawFraming::Frames,
        });
    }
    match built_in.iter().find(|b| b.name == cfg.driver.name) {
        Some(b) => Ok(SelectedDriver {
            factory: (b.factory)(cfg),
            ack_budget: (b.ack_budget)(cfg),
            raw_framing: b.raw_framing,
        }),
        None => Err(DriverSelectError::Unknown {
            name: cfg.driver.name.clone(),
            built_in: built_in
                .iter()
                .map(|b| b.name)
                .collect::<Vec<_>>()
                .join(", "),
        }),
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
