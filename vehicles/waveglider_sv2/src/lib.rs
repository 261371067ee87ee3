//! The Liquid Robotics Wave Glider SV2 as a frontseat, over the binary payload protocol of its
//! Command & Control board: everything about the vehicle that does not need the frontseat
//! runtime. [`codec`] is the wire (CRC-16/ARC, byte stuffing, a bounded resynchronising frame
//! decoder, the typed messages, the C&C's units), [`emulator`] the C&C board's side on the
//! simulator's vehicle model (`frontseat sim --vehicle waveglider_sv2`). The driver is
//! `actors/src/drivers/waveglider_sv2/`; README.md says why and what was verified against what.

#![forbid(unsafe_code)]

pub mod codec;
pub mod emulator;

pub use emulator::{Sv2Options, Sv2Session};
