//! The basic frontseat simulator.
