//! What the FrontSeatInterface actor hears besides the bus, what it answers a probe with, and the
//! error codes of the command responses it gives itself.

use std::time::Duration;

use ractor::RpcReplyPort;

use crate::nav_gate::NavField;
use crate::ports::FrontSeatInterfaceInbox;
use crate::proto::goby::middleware::frontseat::protobuf::InterfaceStatus;

/// Error codes in CommandResponse.error_code for the failures the interface itself answers.
pub mod error_code {
    pub const NOT_IN_COMMAND: i32 = 2;
    pub const TIMEOUT: i32 = 3;
    pub const DRIVER_FAILED: i32 = 4;
    pub const SHUTTING_DOWN: i32 = 5;
    /// Outside the safety envelope (`[limits]`, non-finite values): see the error string.
    pub const OUTSIDE_ENVELOPE: i32 = 6;
}

pub enum FsiMsg {
    Bus(FrontSeatInterfaceInbox),
    Tick,
    StatusTick,
    /// From the driver's start function, before the DriverActor is spawned: statuses from now on
    /// are the new driver's (`restarts`: how many starts came before).
    DriverStarting {
        restarts: u32,
    },
    /// The DriverActor started.
    DriverUp,
    /// From the driver's supervisor: the DriverActor ended (it decides on the restart).
    DriverDown(String),
    /// Orderly shutdown: refuse further commands, stop the driver, publish a last status.
    Shutdown(RpcReplyPort<()>),
    /// A snapshot for tests and the systemd watchdog: answering proves the actor is alive.
    Snapshot(RpcReplyPort<Snapshot>),
}

impl FsiMsg {
    pub(super) fn kind(&self) -> &'static str {
        match self {
            FsiMsg::Bus(m) => m.group(),
            FsiMsg::Tick => "tick",
            FsiMsg::StatusTick => "status_tick",
            FsiMsg::DriverStarting { .. } => "driver_starting",
            FsiMsg::DriverUp => "driver_up",
            FsiMsg::DriverDown(_) => "driver_down",
            FsiMsg::Shutdown(_) => "shutdown",
            FsiMsg::Snapshot(_) => "snapshot",
        }
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct Snapshot {
    pub status: InterfaceStatus,
    pub providing_data: bool,
    pub driver_restarts: u32,
    pub driver_up: bool,
    /// False when the driver actor is up but has not handled its 10 Hz loop tick for
    /// `DRIVER_HUNG_AFTER`: it is stuck in a handler (a driver that is down is not hung).
    pub driver_responsive: bool,
    pub commands_gated: u64,
    pub setpoints_refused: u64,
    pub nav_refused: u64,
    /// Navigation fields dropped as out of bounds (the message itself was published).
    pub nav_fields_dropped: u64,
    /// Per field (index: [`NavField::index`]), how often it was out of bounds.
    pub nav_field_violations: [u64; NavField::COUNT],
    /// raw_send_requests passed to the driver, and refused by the raw gate.
    pub raw_sent: u64,
    pub raw_refused: u64,
    /// Courses the setpoint lane wrote from their publisher's thread (`crate::setpoint_lane`).
    pub setpoints_direct: u64,
}

/// How long a running driver actor may go without handling its loop tick before the watchdog
/// probe calls it hung (wall time; ticks come every 100 ms / warp).
pub const DRIVER_HUNG_AFTER: Duration = Duration::from_secs(2);
