//! The frontseat runtime: the in-process bus, the generated wiring (messages, groups, ports), the
//! FrontSeatInterface and its supervised DriverActor, the drivers, and the glue that embeds the
//! simulator. Pure logic lives in plain modules; actors are thin shells around it.
#![forbid(unsafe_code)]

pub mod bus;
pub mod generated;

pub use generated::{groups, ports, proto};
