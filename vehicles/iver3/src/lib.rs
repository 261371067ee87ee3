//! The OceanServer/L3Harris Iver3 as a frontseat, over the UVC's "Remote Helm" NMEA sentences:
//! everything about the vehicle that does not need the frontseat runtime. [`codec`] is the wire
//! (sentences, checksums, in the UVC's feet and knots), [`units`] the UVC's units and mode
//! letters, [`emulator`] the UVC's side on the simulator's vehicle model
//! (`frontseat sim --vehicle iver3`). The driver is `actors/src/drivers/iver3/`; README.md says why
//! and what was verified against what.

#![forbid(unsafe_code)]

pub mod codec;
pub mod emulator;
pub mod units;

pub use emulator::{IverOptions, IverSession};
