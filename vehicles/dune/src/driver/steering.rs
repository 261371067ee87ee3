//! How the backseat steers a DUNE vehicle: our one-maneuver plan (PlanControl START with
//! FollowReference, control_src = us, a timeout), a Reference toward a point ahead on the helm's
//! heading, and the end of the plan (a MANDONE Reference, then PlanControl STOP) — or the
//! vehicle's word that it ended.

use std::time::Duration;

use super::{DuneDriver, Plan};
use crate::imc::{self, consts};
use crate::infer;
use frontseat_actors::driver::SignalSink;

impl DuneDriver {
    pub(super) fn ours(&self) -> bool {
        self.plan.is_some()
            || self
                .pcs
                .as_ref()
                .is_some_and(|p| p.plan_id == self.settings.plan_id)
    }

    pub(super) fn plan_ended(&mut self, why: &str) {
        if self.plan.take().is_some() {
            self.counters.maneuver_failures += 1;
            tracing::warn!(target: super::LOG_TARGET, %why, "DUNE: our FollowReference plan ended");
        }
    }

    pub(super) fn start_plan(&mut self, now: Duration, sig: &mut dyn SignalSink) {
        self.request_id = self.request_id.wrapping_add(1);
        let msg = imc::PlanControl {
            kind: consts::plan_control::REQUEST,
            op: consts::plan_control::START,
            request_id: self.request_id,
            plan_id: self.settings.plan_id.clone(),
            flags: 0,
            arg: Some(Box::new(
                imc::FollowReference {
                    control_src: self.settings.own_id,
                    control_ent: imc::ANY_ENTITY,
                    timeout: self.settings.maneuver_timeout,
                    loiter_radius: 0.0,
                    altitude_interval: 0.0,
                }
                .into(),
            )),
            info: String::new(),
        };
        self.last_start = Some(now);
        if self.send(msg.into(), sig) {
            self.counters.plan_starts += 1;
            self.command_entered = false;
            tracing::info!(
                target: super::LOG_TARGET,
                timeout_s = self.settings.maneuver_timeout,
                "DUNE: PlanControl START FollowReference"
            );
            self.plan = Some(Plan {
                started: now,
                request_id: self.request_id,
                confirmed: false,
                last_reference: None,
            });
            self.send_reference(now, sig);
        }
    }

    pub(super) fn stop_plan(&mut self, why: &str, now: Duration, sig: &mut dyn SignalSink) {
        let Some(plan) = self.plan.take() else {
            return;
        };
        // No lane Reference after the MANDONE.
        self.steer.lock().ready = None;
        self.last_stop = Some(now);
        tracing::info!(target: super::LOG_TARGET, %why, "DUNE: ending our FollowReference plan (MANDONE, STOP)");
        let (lat, lon) = self
            .position
            .map(|p| (p.lat.to_radians(), p.lon.to_radians()))
            .unwrap_or_default();
        self.send(
            imc::Reference {
                flags: consts::reference::MANDONE,
                speed: None,
                z: None,
                lat,
                lon,
                radius: 0.0,
            }
            .into(),
            sig,
        );
        self.send(
            imc::PlanControl {
                kind: consts::plan_control::REQUEST,
                op: consts::plan_control::STOP,
                request_id: plan.request_id,
                plan_id: self.settings.plan_id.clone(),
                flags: 0,
                arg: None,
                info: String::new(),
            }
            .into(),
            sig,
        );
        self.counters.plan_stops += 1;
    }

    /// Every course's Reference is written here, through the actors: the setpoint lane's design
    /// for this driver (a snapshot of our running plan and the last position, published by the
    /// driver) is in ARCHITECTURE.md "The lane per vehicle family", not yet coded.
    pub(super) fn send_reference(&mut self, now: Duration, sig: &mut dyn SignalSink) {
        // Under the lane's lock: a course the lane wrote since this message began is taken in
        // first, so a re-send never writes an older course after the lane's newer one.
        let steer = self.steer.clone();
        let mut st = steer.lock();
        if let Some(w) = st.written.take() {
            self.adopt(w, now);
        }
        let (Some(c), Some(p)) = (self.course, self.position) else {
            return;
        };
        if now.saturating_sub(c.renewed) > self.settings.course_timeout {
            return;
        }
        let r = infer::steering_reference(
            p.lat,
            p.lon,
            c.heading,
            c.speed,
            c.depth,
            self.settings.lookahead_m,
        );
        if self.send(r.into(), sig) {
            self.counters.references_sent += 1;
            if let Some(plan) = &mut self.plan {
                plan.last_reference = Some(now);
            }
        }
    }
}
