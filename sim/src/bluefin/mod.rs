//! The Bluefin Huxley emulator: the vehicle side of the Huxley "Standard Payload Interface"
//! over TCP, on top of the basic simulator's vehicle model. [`codec`] is the sentence codec
//! shared with the driver (`frontseat_actors::drivers::bluefin`), [`emulator`] the pure Huxley
//! state, [`server`] the payload-port TCP server.

pub mod codec;
pub mod emulator;
pub mod server;

pub use emulator::{Huxley, HuxleyOptions, Refusal};
pub use server::{HuxleyHandle, HuxleyServer, HuxleyServerOptions, HuxleyStats};

/// The Huxley payload port Goby3's driver connects to by default.
pub const DEFAULT_PORT: u16 = 29500;
