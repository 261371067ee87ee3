//! The frontseat runtime.
