//! The Rust SDK: a driver is a [`FrontseatDriver`] impl, exported with [`crate::export_driver!`].
//! It mirrors Goby3's `InterfaceBase`: the constructor reads the config, three sends, `loop()`,
//! two state queries; the four signals (and state changes, and logs) go out through [`Host`],
//! which any thread of the driver may use.
#![forbid(unsafe_code)]

use std::sync::Arc;
use std::time::Duration;

use prost::Message;

use crate::proto::goby::middleware::frontseat::protobuf::{
    CommandRequest, CommandResponse, FrontSeatState, InterfaceData, Raw,
};

/// Which of the four Goby3 signals a byte buffer is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SignalKind {
    CommandResponse,
    DataFromFrontseat,
    RawFromFrontseat,
    RawToFrontseat,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LogLevel {
    Error,
    Warn,
    Info,
    Debug,
}

impl LogLevel {
    pub fn to_abi(self) -> i32 {
        match self {
            LogLevel::Error => crate::abi::LOG_ERROR,
            LogLevel::Warn => crate::abi::LOG_WARN,
            LogLevel::Info => crate::abi::LOG_INFO,
            LogLevel::Debug => crate::abi::LOG_DEBUG,
        }
    }
    /// Unknown levels read as Info: a log line is never lost for its level.
    pub fn from_abi(level: i32) -> Self {
        match level {
            crate::abi::LOG_ERROR => LogLevel::Error,
            crate::abi::LOG_WARN => LogLevel::Warn,
            crate::abi::LOG_DEBUG => LogLevel::Debug,
            _ => LogLevel::Info,
        }
    }
}

/// Where the host receives what a driver emits. Implemented by the ABI glue, and by tests.
pub trait Emit: Send + Sync {
    fn signal(&self, kind: SignalKind, msg: &[u8]);
    fn state_changed(&self, state: FrontSeatState, providing_data: bool);
    fn log(&self, level: LogLevel, msg: &str);
}

/// The driver's handle on the host: cheap to clone, usable from any thread until the driver is
/// dropped (a driver joins its threads in `Drop`).
#[derive(Clone)]
pub struct Host {
    emit: Arc<dyn Emit>,
}

impl Host {
    pub fn new(emit: Arc<dyn Emit>) -> Self {
        Self { emit }
    }
    pub fn command_response(&self, r: &CommandResponse) {
        self.emit
            .signal(SignalKind::CommandResponse, &r.encode_to_vec());
    }
    pub fn data_from_frontseat(&self, d: &InterfaceData) {
        self.emit
            .signal(SignalKind::DataFromFrontseat, &d.encode_to_vec());
    }
    pub fn raw_from_frontseat(&self, r: &Raw) {
        self.emit
            .signal(SignalKind::RawFromFrontseat, &r.encode_to_vec());
    }
    pub fn raw_to_frontseat(&self, r: &Raw) {
        self.emit
            .signal(SignalKind::RawToFrontseat, &r.encode_to_vec());
    }
    pub fn state_changed(&self, state: FrontSeatState, providing_data: bool) {
        self.emit.state_changed(state, providing_data);
    }
    pub fn log(&self, level: LogLevel, msg: &str) {
        self.emit.log(level, msg);
    }
}

/// The driver cannot go on: the interface reports FS_ERROR(NOT_CONNECTED) and restarts it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DriverFailure(pub String);

/// A frontseat driver (Goby3's `InterfaceBase`). The host calls these from one thread, one at a
/// time; emit through the [`Host`] from any thread.
pub trait FrontseatDriver: Send + Sized + 'static {
    /// The constructor: `config` is the interface config as JSON (see frontseat_driver.h).
    /// `Err(reason)` rejects it.
    fn load(config: &[u8], host: Host) -> Result<Self, String>;
    fn send_command_to_frontseat(&mut self, req: CommandRequest) -> Result<(), DriverFailure>;
    fn send_data_to_frontseat(&mut self, data: InterfaceData) -> Result<(), DriverFailure>;
    fn send_raw_to_frontseat(&mut self, raw: Raw) -> Result<(), DriverFailure>;
    /// Goby3's `loop()`, at 10 Hz of simulated time; `now` is simulated time since the start.
    fn do_loop(&mut self, now: Duration) -> Result<(), DriverFailure>;
    fn frontseat_state(&self) -> FrontSeatState;
    fn frontseat_providing_data(&self) -> bool;
}
