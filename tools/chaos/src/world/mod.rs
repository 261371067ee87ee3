//! The world around the interface under test, each part as a deployment has it and each
//! restartable where a fault needs it: the simulator (the vehicle), the helm on the bus, the MOOS
//! broker and bridge, gobyd and the Goby3 gateway, and web clients of the commander.

pub(crate) mod goby3;
pub(crate) mod helm;
pub(crate) mod moos;
pub(crate) mod rebind;
pub(crate) mod sim;
pub(crate) mod web;
