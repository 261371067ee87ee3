//! Nothing to link: this crate holds `tests/compile_fail.rs`, the proof that wiring mistakes do
//! not build, apart from `frontseat-actors` so the project trybuild compiles for each case depends
//! on the runtime alone (see Cargo.toml), as an actor or a binary outside the runtime would.
#![forbid(unsafe_code)]
