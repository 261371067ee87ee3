//! MOOS time: wall-clock seconds since the Unix epoch multiplied by the community's time warp
//! (protocol.md §9). Every process of a community must use the same warp.

use std::time::{SystemTime, UNIX_EPOCH};

/// Seconds since the Unix epoch, with sub-microsecond resolution.
pub fn unix_time() -> f64 {
    // A clock set before 1970 is a host problem; treat it as the epoch rather than fail.
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| d.as_secs_f64())
        .unwrap_or(0.0)
}

/// The current MOOS time for a community running at `warp` (1.0 = real time).
pub fn moos_time(warp: f64) -> f64 {
    unix_time() * warp
}
