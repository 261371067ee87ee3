//! The Bluefin Huxley driver (Goby3's `BluefinFrontSeat`): a TCP client of the Huxley payload
//! port speaking `$BF…`/`$BP…` sentences. [`codec`] is the sentence codec shared with the Huxley
//! emulator (it lives in `frontseat_sim::bluefin::codec` because the simulator cannot depend on
//! this crate); [`driver`] is the state inference, the acknowledgement queue and the heartbeat.

pub mod driver;

pub use driver::{BluefinDriver, BluefinStats, Settings};
pub use frontseat_sim::bluefin::codec;
