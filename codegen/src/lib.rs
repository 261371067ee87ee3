//! The interface compiler (see README).
