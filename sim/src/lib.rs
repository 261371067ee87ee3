//! The basic frontseat simulator: Goby3's `goby_basic_frontseat_simulator` protocol, done better.
//!
//! A TCP server where each connection is its own vehicle with its own START, ticking on
//! deadlines, with validated input, fault injection and a ground-truth stream for embedding.
//! Pure parts: [`vehicle`] (dynamics), [`codec`] (lines), [`schedule`] (tick deadlines); the
//! server and its connections are tasks that own their state and talk through channels.
//! The protocol is written down in `PROTOCOL.md`. [`vehicle`] and [`emulator`] (the pty/TCP
//! runner of a pure vehicle session) are also what the vehicle crates under `vehicles/` build their
//! emulators on; those crates depend on this one, never the reverse.
// One audited `unsafe` block: registering the pty master with tokio (see pty.rs).
#![deny(unsafe_code)]

pub mod bench;
pub mod codec;
mod connection;
pub mod emulator;
pub mod geodesy;
pub mod pty;
mod run;
pub mod schedule;
mod server;
mod shared;
pub mod vehicle;

pub use bench::{CapacityReport, capacity_bench};
pub use codec::CtrlState;
pub use server::{SimHandle, SimServer};

use std::time::Duration;

/// How the simulator runs; the configuration layer maps its file onto this.
#[derive(Debug, Clone, PartialEq)]
pub struct SimOptions {
    /// Longest accepted input line in bytes, terminator excluded; a longer one closes its
    /// connection.
    pub max_line_bytes: usize,
    /// Ocean current towards the east, m/s, added to every vehicle's motion over ground.
    pub current_east: f64,
    /// Ocean current towards the north, m/s.
    pub current_north: f64,
    /// Faults every vehicle suffers at the given simulated time after each START.
    pub scheduled_faults: Vec<ScheduledFault>,
    /// Most vehicles (connections) at once; more are told why and closed.
    pub max_vehicles: usize,
    /// How long a vehicle whose connection dropped is kept: a client that reconnects within it
    /// and repeats the same START gets the same vehicle back (position, heading, speed,
    /// setpoint). Zero: every START makes a new vehicle, as Goby3's simulator does.
    pub resume_grace: Duration,
    /// A connection that has not sent a valid START within this long after it was accepted is
    /// closed (counted in [`SimStats::start_timeouts`]): a silent client must not hold a
    /// vehicle slot for ever. Zero: never (Goby3's simulator waits for ever).
    pub start_timeout: Duration,
    /// Most connections waiting for their first START at once. A new connection past it closes
    /// the oldest waiting one (counted in [`SimStats::evicted`]), so however many silent
    /// connections are held open, a client that connects and sends START gets in. At least 1.
    pub max_pending: usize,
}

impl Default for SimOptions {
    fn default() -> Self {
        Self {
            max_line_bytes: 1024,
            current_east: 0.0,
            current_north: 0.0,
            scheduled_faults: Vec::new(),
            max_vehicles: 1024,
            resume_grace: Duration::from_secs(10),
            start_timeout: Duration::from_secs(10),
            max_pending: 64,
        }
    }
}

/// A fault that fires `at_s` simulated seconds after each START of every vehicle.
#[derive(Debug, Clone, PartialEq)]
pub struct ScheduledFault {
    pub at_s: f64,
    pub fault: Fault,
}

/// Misbehaviour a vehicle can be told to show (see PROTOCOL.md for the exact bytes).
#[derive(Debug, Clone, PartialEq)]
pub enum Fault {
    /// Close the connection (the vehicle is gone).
    DropConnection,
    /// Send no NAV for this many simulated seconds; the vehicle keeps moving and truth keeps
    /// flowing.
    StopNav { seconds: f64 },
    /// Send this many garbage lines (unknown key, malformed NAV, invalid UTF-8, empty).
    Garbage { lines: u32 },
    /// Send one 64 KiB line.
    OversizedLine,
    /// Send `CTRL,STATE:<state>`; AUV makes CMD answer ERROR until PAYLOAD; IDLE also ends the
    /// run (no NAV until the next START).
    Ctrl(CtrlState),
    /// The vehicle's task panics (chaos): only its connection closes; the server counts it and
    /// every other vehicle keeps its ticks.
    Panic,
}

/// Ground truth of one vehicle at one reported tick.
#[derive(Debug, Clone, PartialEq)]
pub struct Truth {
    pub vehicle: u64,
    /// Simulated seconds since START.
    pub sim_time: f64,
    pub lat: f64,
    pub lon: f64,
    pub depth: f64,
    pub heading: f64,
    /// Through the water, m/s.
    pub speed: f64,
    /// Metres east of START.
    pub x: f64,
    /// Metres north of START.
    pub y: f64,
}

/// Counters since the server started.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SimStats {
    /// Connections accepted (including refused ones).
    pub connections: u64,
    /// Connections refused because `max_vehicles` were connected.
    pub refused: u64,
    pub nav_lines: u64,
    /// Lines that were empty, not UTF-8 or had an unknown key.
    pub bad_lines: u64,
    /// Lines over `max_line_bytes` (each closed its connection).
    pub oversized: u64,
    /// CMD answered with `CMD,RESULT:ERROR`.
    pub cmd_errors: u64,
    /// START answered with `ERROR,REASON:`.
    pub start_errors: u64,
    /// Reported ticks more than [`schedule::LATE_AFTER`] after their deadline.
    pub late_ticks: u64,
    /// Ticks whose step ran: reported, skipped as stale, or with NAV stopped by a fault. Over a
    /// window in which every vehicle runs, this against vehicles·FREQ·WARP·window is the share
    /// of ticks the simulator kept; `nav_lines` of them were reported.
    pub integrated_ticks: u64,
    /// Integrated ticks whose deadline lies in the window of [`SimHandle::count_ticks_due_in`],
    /// counted whenever they are integrated: against what was due in the window, the share kept.
    pub window_ticks: u64,
    /// Of [`window_ticks`](Self::window_ticks), those reported with a NAV line (the others
    /// were skipped as stale or had their NAV stopped by a fault).
    pub window_navs: u64,
    /// Ticks integrated but not reported because they were stale (see [`schedule`]).
    pub skipped_ticks: u64,
    /// Ticks given up by re-anchoring after a suspension.
    pub dropped_ticks: u64,
    /// Worst lateness of a reported tick.
    pub worst_lateness: Duration,
    /// Faults carried out.
    pub faults: u64,
    /// Vehicle tasks that panicked (each closed only its own connection).
    pub vehicle_panics: u64,
    /// Connections closed because no START came within `start_timeout`.
    pub start_timeouts: u64,
    /// Connections without a START closed to make room for a new one (`max_pending`).
    pub evicted: u64,
    /// Vehicles running now: connections that sent a valid START and are still open (not a
    /// counter: it goes down when one closes).
    pub running: u64,
}

/// Everything that can go wrong in this crate.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    #[error("cannot bind the simulator to {addr}: {source}")]
    Bind {
        addr: std::net::SocketAddr,
        source: std::io::Error,
    },
    #[error("simulator i/o: {0}")]
    Io(#[from] std::io::Error),
}
