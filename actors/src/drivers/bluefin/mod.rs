//! The Bluefin Huxley driver (Goby3's `BluefinFrontSeat`): a TCP client of the Huxley payload
//! port speaking `$BF…`/`$BP…` sentences. [`codec`] is the sentence codec of the vehicle's crate
//! (`vehicles/bluefin/`, shared with the Huxley emulator); [`driver`] is the state inference, the
//! acknowledgement queue and the heartbeat. The driver stays in the runtime crate because it
//! implements the `Driver` trait on the generated protobuf types.

pub mod driver;

pub use driver::{BluefinDriver, BluefinStats, Settings};
pub use frontseat_bluefin::codec;
