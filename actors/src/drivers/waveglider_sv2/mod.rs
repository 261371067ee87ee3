//! The built-in `waveglider_sv2` driver: Liquid Robotics Wave Glider SV2 payload protocol
//! (binary frames, 115200 8N1 by default) over a serial port or serial-over-IP TCP. [`codec`]
//! is the pure edge, [`driver`] the state and I/O.

pub mod codec;
pub mod driver;

pub use driver::{Settings, WavegliderSv2Driver};
