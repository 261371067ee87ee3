//! The built-in `iver3` driver: OceanServer/L3Harris Iver3 UVC "Remote Helm" NMEA over a
//! serial port (19200 8N1 by default) or serial-over-IP TCP. [`codec`] is the pure edge (units,
//! modes), [`driver`] the state and I/O.

pub mod codec;
pub mod driver;

pub use driver::{Iver3Driver, Settings};
