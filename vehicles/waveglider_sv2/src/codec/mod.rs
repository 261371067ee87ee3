//! The Wave Glider SV2 payload protocol, pure: CRC-16/ARC, byte stuffing, a bounded
//! resynchronising frame decoder (`frame`), and the typed messages both sides exchange
//! (`message`). No I/O. Both are re-exported here, so `codec::X` names either.

mod frame;
mod message;

pub use frame::*;
pub use message::*;

#[cfg(test)]
mod tests;
