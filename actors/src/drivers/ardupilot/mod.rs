//! The built-in `ardupilot` driver: an ArduPilot vehicle (Rover with a boat frame, or Sub) over
//! MAVLink on TCP, UDP or a serial port. The wire, the mode tables and the pure inference rules
//! live in the `frontseat-ardupilot` crate (`vehicles/ardupilot/`); [`driver`] is the state, the
//! I/O and the glue to the Driver trait.

pub mod driver;

pub use driver::{ArdupilotCounters, ArdupilotDriver, Settings};
