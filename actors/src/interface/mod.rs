//! FrontSeatInterface: the state machine, the gate between helm and driver, compute_missing, the
//! status publications, and the host of its DriverActor's supervisor.
//!
//! The driver is the one child of a nested [`Supervisor`](crate::supervisor) (`spawn_nested`),
//! which alone decides its restarts, with the same [`Policy`] and decider as every other child:
//! `[supervision]`'s backoff and limit, vehicle side. The interface maps what the supervisor tells
//! it onto Goby3's states: a driver that panics or stops is at once a frontseat NOT_CONNECTED (→
//! FS_ERROR by the ordinary rules) and its pending commands fail with DRIVER_FAILED; the
//! interface climbs back STANDBY → LISTEN → COMMAND by itself once data flows again. When the
//! supervisor gives up (more than `max_restarts` within `restart_window`), the service ends with
//! [`ServiceExit::RestartLimit`] so that systemd restarts the whole process.
//!
//! Split by what each part owns: `settings` (what it is told at its start), `messages` (what
//! its actor hears and answers besides the bus), `state` (the state machine, the status
//! publications, the driver's supervision), `commands` (a helm's commands through the gates,
//! the pending table, raw sends), `extensions` (a vehicle's extension groups both ways),
//! `navigation` (the navigation gate and compute_missing), `actor` (start and dispatch) and
//! `service` (the running interface as its users hold it).

/// Every log line of the interface keeps the target it had as one file, whatever part it now
/// comes from: operators filter and grep on `frontseat_actors::interface`.
const LOG_TARGET: &str = "frontseat_actors::interface";

mod actor;
mod commands;
mod extensions;
mod messages;
mod navigation;
mod service;
mod settings;
mod state;
mod vehicle_thread;

pub use crate::clock::heartbeat_now;
/// Why the service ended (the supervision tree's word; the interface's path kept for its users).
pub use crate::supervisor::ServiceExit;
pub use actor::{FrontSeatInterface, FsiArgs};
pub use messages::{DRIVER_HUNG_AFTER, FsiMsg, Snapshot, error_code};
pub use navigation::compute_missing;
pub use service::{InterfaceService, StartError};
pub use settings::{InterfaceSettings, command_timeout, driver_node};
pub use state::FsiState;
pub use vehicle_thread::THREAD_NAME as VEHICLE_THREAD;
