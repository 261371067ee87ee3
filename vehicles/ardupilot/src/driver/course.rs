//! The helm's course to the vehicle: checked (finite, the vehicle accepting commands; for a Sub
//! a depth ≥ 0 and a LOCAL_POSITION_NED to anchor GUIDED on), kept, sent at once when new or
//! changed and re-sent at the configured rate while the helm renews it; the Rover's form, a
//! GUIDED SET_POSITION_TARGET_GLOBAL_INT (the Sub's forms: `sub_course`).

use std::time::Duration;

use crate::codec::MavMessage;
use crate::infer;
use crate::modes::sub;

use super::state::{ArdupilotDriver, Course, LOOP_SLACK};
use frontseat_actors::driver::SignalSink;
use frontseat_actors::drivers::kit::{Asker, Awaiting, refuse};
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CommandRequest, FrontSeatState,
};

impl ArdupilotDriver {
    /// A helm's course (the `Driver` entry and a mode command's riding course both come here).
    /// A new course armed in GUIDED may instead have been written by the setpoint lane
    /// (`lane`), whose course the driver takes in at its next message as if it came here.
    pub(super) fn take_course(
        &mut self,
        req: &CommandRequest,
        now: Duration,
        sig: &mut dyn SignalSink,
    ) {
        let Some(c) = &req.desired_course else {
            refuse(
                req,
                "the ArduPilot driver takes desired_course (or the ardupilot_command extension)",
                sig,
            );
            return;
        };
        let (heading, speed) = (c.heading(), c.speed());
        if !(heading.is_finite() && speed.is_finite() && speed >= 0.0) {
            refuse(
                req,
                "desired_course needs a finite heading and a finite, non-negative speed",
                sig,
            );
            return;
        }
        if self.state != FrontSeatState::FrontseatAcceptingCommands {
            refuse(
                req,
                format!(
                    "vehicle not armed in GUIDED ({}): ArduPilot ignores targets outside GUIDED",
                    self.mode_words()
                ),
                sig,
            );
            return;
        }
        let mut depth = c.depth.filter(|d| d.is_finite());
        if self.is_sub() {
            if c.depth.is_some_and(|d| !(d.is_finite() && d >= 0.0)) {
                refuse(
                    req,
                    "desired_course depth must be finite and ≥ 0 (m, down)",
                    sig,
                );
                return;
            }
            let guided = self.beat.is_some_and(|b| b.mode != sub::ALT_HOLD);
            let here = self
                .local
                .filter(|l| [l.x, l.y, l.z].iter().all(|v| v.is_finite()));
            if guided && here.is_none() {
                refuse(
                    req,
                    "no LOCAL_POSITION_NED from the Sub yet: its GUIDED target is anchored on it",
                    sig,
                );
                return;
            }
            // No depth asked for: hold the depth the course finds (the target always carries z).
            if depth.is_none() {
                depth = self
                    .course
                    .and_then(|c| c.depth)
                    .or(here.map(|l| f64::from(l.z)));
            }
        }
        let unchanged = self
            .course
            .is_some_and(|c| c.heading == heading && c.speed == speed && c.depth == depth);
        let sent = self.course.and_then(|c| c.sent);
        self.course = Some(Course {
            heading,
            speed,
            depth,
            renewed: now,
            sent,
        });
        // A new or changed course goes out at once; an unchanged one keeps its re-send rhythm
        // (a helm publishing at 10 Hz must not double the vehicle's traffic).
        if !unchanged {
            self.send_target(now, sig);
        }
        if req.response_requested() {
            self.push_pending(
                Awaiting {
                    asker: Asker::of(req),
                    deadline: now + self.settings.verdict_after,
                    what: None,
                },
                sig,
            );
        }
    }

    /// Each loop tick: drop a course the helm stopped renewing, or re-send it when due.
    pub(super) fn resend_course(&mut self, now: Duration, sig: &mut dyn SignalSink) {
        if let Some(c) = self.course {
            if now.saturating_sub(c.renewed) > self.settings.course_timeout {
                // The helm stopped: stop re-sending, and the vehicle's own 3 s timeout stops it.
                tracing::info!(target: super::LOG_TARGET, "helm course not renewed: no longer re-sending the GUIDED target");
                self.course = None;
                self.stop_thrust(now, sig);
            } else if c.sent.is_none_or(|s| {
                // Half a loop tick of slack: waiting for a full period after a late tick would
                // drop the rate below the one configured (the vehicle wants ≥ 5 Hz).
                now.saturating_sub(s) + LOOP_SLACK >= self.settings.resend_period
            }) {
                self.send_target(now, sig);
            }
        }
    }

    pub(super) fn send_target(&mut self, now: Duration, sig: &mut dyn SignalSink) {
        let (Some(c), Some((sys, comp))) = (self.course, self.vehicle) else {
            return;
        };
        if self.is_sub() {
            return self.send_sub_target(c, sys, comp, now, sig);
        }
        let t = infer::course_target(
            self.settings.firmware,
            c.heading,
            c.speed,
            c.depth,
            sys,
            comp,
            now.as_millis().min(u128::from(u32::MAX)) as u32,
        );
        if self.write(&MavMessage::SET_POSITION_TARGET_GLOBAL_INT(t), sig) {
            self.counters.targets_sent += 1;
        }
        if let Some(c) = &mut self.course {
            c.sent = Some(now);
        }
    }
}
