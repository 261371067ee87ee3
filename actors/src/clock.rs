//! Simulated time: monotonic (tokio) time since the service started, scaled by sim_warp_factor.
//! Every timer of the interface and its drivers reads this clock, never the wall clock, so clock
//! jumps do nothing and tests run on paused tokio time.

use std::time::Duration;
use tokio::time::Instant;

#[derive(Clone, Copy, Debug)]
pub struct SimClock {
    start: Instant,
    warp: f64,
}

impl SimClock {
    pub fn new(warp: f64) -> Self {
        let warp = if warp.is_finite() && warp > 0.0 {
            warp
        } else {
            1.0
        };
        Self {
            start: Instant::now(),
            warp,
        }
    }
    pub fn warp(&self) -> f64 {
        self.warp
    }
    /// Simulated time since start.
    pub fn now(&self) -> Duration {
        self.start.elapsed().mul_f64(self.warp)
    }
    /// The wall (monotonic) duration that lasts `sim` in simulated time.
    pub fn wall(&self, sim: Duration) -> Duration {
        sim.div_f64(self.warp)
    }
    /// Unix time in seconds as a frontseat stamps it (wall clock: only for message `time` fields).
    pub fn unix_now() -> f64 {
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_secs_f64())
            .unwrap_or(0.0)
    }
}

static HEARTBEAT_EPOCH: std::sync::OnceLock<std::time::Instant> = std::sync::OnceLock::new();

/// Milliseconds on a process-wide monotonic clock, for the driver heartbeat.
pub fn heartbeat_now() -> u64 {
    let epoch = HEARTBEAT_EPOCH.get_or_init(std::time::Instant::now);
    epoch.elapsed().as_millis() as u64
}
