//! ArduPilot (Rover with a boat frame; Sub) as a frontseat, over MAVLink: everything about the
//! vehicle that does not need the runtime. Read top to bottom: [`codec`] (the wire: bounded
//! deframing, CRC, decode/encode through the `mavlink` crate), [`modes`] (the autopilot's mode
//! numbers), [`infer`] (what a backseat concludes from what the vehicle says, and what it sends
//! for a course — pure functions), [`emulator`] (what ArduPilot Rover answers, on the
//! simulator's vehicle model). The driver that uses these lives in the actors crate
//! (`actors/src/drivers/ardupilot/`); see README.md for why it is split that way.

#![forbid(unsafe_code)]

pub mod codec;
pub mod emulator;
pub mod infer;
pub mod modes;

pub use mavlink::dialects::ardupilotmega as dialect;
