//! MOOS wire protocol.
