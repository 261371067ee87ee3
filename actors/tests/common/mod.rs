//! What the vehicle-side tests share.

pub mod frontseat;
pub mod lane;
