//! Bluefin Huxley as a frontseat: everything about the vehicle that does not need the frontseat
//! runtime. [`codec`] is the "Standard Payload Interface" sentence codec (pure, shared with the
//! driver in `actors/src/drivers/bluefin/`), [`emulator`] the Huxley's side as pure state on the
//! simulator's vehicle model, [`server`] the payload-port TCP server that runs it
//! (`frontseat sim --vehicle bluefin`). See README.md for what was verified against what.

#![forbid(unsafe_code)]

pub mod codec;
pub mod emulator;
pub mod server;

pub use emulator::{Huxley, HuxleyOptions, Refusal};
pub use server::{HuxleyHandle, HuxleyServer, HuxleyServerOptions, HuxleyStats};

/// The Huxley payload port Goby3's driver connects to by default.
pub const DEFAULT_PORT: u16 = 29500;
