//! One started vehicle: its START parameters, the vehicle model, the tick schedule, the control
//! state and the scheduled faults. Owned by a connection; parked in the server's shared state
//! while its client reconnects.

use tokio::time::Instant;

use crate::ScheduledFault;
use crate::SimOptions;
use crate::codec::{CtrlState, StartParams};
use crate::schedule::Schedule;
use crate::vehicle::{Limits, Vehicle};

/// A started vehicle.
pub(crate) struct Run {
    pub params: StartParams,
    pub vehicle: Vehicle,
    pub schedule: Schedule,
    pub started: Instant,
    /// The tick at which DURATION is up (IDLE instead of NAV).
    pub end_tick: Option<u64>,
    pub ctrl: CtrlState,
    pub sim_time: f64,
    /// NAV is suppressed before this simulated time ([`Fault::StopNav`]).
    pub nav_resume_at: f64,
    pub faults: Vec<ScheduledFault>,
    pub next_fault: usize,
}

impl Run {
    pub fn new(params: StartParams, opts: &SimOptions, now: Instant) -> Self {
        let limits = Limits {
            accel: params.accel,
            hdg_rate: params.hdg_rate,
            z_rate: params.z_rate,
        };
        let current = (opts.current_east, opts.current_north);
        let end_tick = (params.duration > 0.0)
            .then(|| ((params.duration * params.freq - 1e-9).ceil() as u64).max(1));
        let mut faults = opts.scheduled_faults.clone();
        faults.sort_by(|a, b| a.at_s.total_cmp(&b.at_s));
        Self {
            params,
            vehicle: Vehicle::new(params.lat, params.lon, limits, current),
            schedule: Schedule::new(params.freq * params.warp),
            started: now,
            end_tick,
            ctrl: CtrlState::Payload,
            sim_time: 0.0,
            nav_resume_at: 0.0,
            faults,
            next_fault: 0,
        }
    }

    pub fn next_deadline(&self) -> Instant {
        self.started + self.schedule.next_deadline()
    }
}
