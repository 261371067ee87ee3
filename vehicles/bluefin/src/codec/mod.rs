//! The Bluefin Huxley "Standard Payload Interface" sentences: `$BF…` from the vehicle, `$BP…`
//! from the payload, NMEA-framed with an XOR checksum. Pure text in, typed values out (and
//! back); no I/O, no clock. Both the driver (`driver`) and the
//! Huxley emulator ([`crate::emulator`]) speak through this module, so a golden session replays
//! against both sides with the same bytes.
//!
//! Facts (field order, units, mode codes) are from Goby3's Bluefin driver as recorded in the
//! project's protocol fact sheet; where Goby3 reads input loosely (NaN for a bad number, fixed
//! digit counts for longitude) this codec is strict or robust instead, and says so.
//!
//! Three parts, re-exported here so `codec::X` names any of them: the NMEA layer both
//! directions share (`sentence`), the Huxley's sentences (`huxley`) and the payload's
//! (`payload`); each direction is read and written, by the driver on one side and the
//! emulator on the other.

mod huxley;
mod payload;
mod sentence;

pub use huxley::*;
pub use payload::*;
pub use sentence::*;

#[cfg(test)]
mod tests;
