//! The crate's one error type: what can go wrong loading and hosting a driver, each with the
//! wording the README documents.
#![forbid(unsafe_code)]

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error("driver library {path}: file not found")]
    LibraryMissing { path: PathBuf },
    #[error("driver library {path}: cannot be loaded: {reason}")]
    LibraryNotLoadable { path: PathBuf, reason: String },
    #[error(
        "driver library {path}: symbol `{symbol}` missing (a driver exports every function of frontseat_driver.h)"
    )]
    SymbolMissing { path: PathBuf, symbol: String },
    #[error(
        "driver library {path}: ABI version mismatch: the library is built for driver ABI version {found}, this frontseat speaks version {expected}; rebuild the driver against this frontseat's frontseat_driver.h"
    )]
    AbiMismatch {
        path: PathBuf,
        found: u32,
        expected: u32,
    },
    #[error("driver config rejected by the driver: {reason}")]
    ConfigRejected { reason: String },
    #[error("driver host: {0}")]
    Host(String),
    #[error("driver host protocol: {0}")]
    Frame(String),
    #[error("driver host I/O: {0}")]
    Io(#[from] std::io::Error),
}

impl Error {
    /// The exit status of `frontseat driver-host` for this error (documented in the README).
    pub fn exit_code(&self) -> u8 {
        match self {
            Error::LibraryMissing { .. } => 3,
            Error::SymbolMissing { .. } => 4,
            Error::AbiMismatch { .. } => 5,
            Error::LibraryNotLoadable { .. } => 6,
            Error::ConfigRejected { .. } => 7,
            Error::Host(_) | Error::Frame(_) | Error::Io(_) => 9,
        }
    }
}
