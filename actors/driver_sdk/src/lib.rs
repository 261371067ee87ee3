//! Frontseat driver plugins. The stable C ABI (`include/frontseat_driver.h`, mirrored in [`abi`]),
//! the Rust SDK (a driver is a [`FrontseatDriver`] impl plus [`export_driver!`]), and, with the
//! `host` feature, the host side: loading a library ([`loader`]), the driver-host child process
//! ([`child`]) and the interface's client of it ([`isolate`]), spoken over [`frame`]s.
//!
//! `unsafe` lives only in [`export`] (the plugin side of the ABI) and [`loader`] (the host side);
//! every other module forbids it.
#![deny(unsafe_code)]

pub mod abi;
pub mod driver;
pub mod error;
#[doc(hidden)]
pub mod export;
pub mod frame;
pub mod proto;

#[cfg(feature = "host")]
pub mod child;
#[cfg(feature = "host")]
pub mod isolate;
#[cfg(feature = "host")]
pub mod loader;

pub use driver::{DriverFailure, FrontseatDriver, Host, LogLevel};
pub use error::Error;
pub use proto::goby::middleware::frontseat::protobuf::{
    CommandRequest, CommandResponse, FrontSeatState, InterfaceData, Raw,
};
