//! ArduSub's course, by the method its mode takes (`shared/protocol/ardupilot/ardusub.md`):
//! GUIDED → a SET_POSITION_TARGET_LOCAL_NED position + velocity + yaw target anchored on the
//! latest LOCAL_POSITION_NED; ALT_HOLD → SET_ATTITUDE_TARGET for the heading, MANUAL_CONTROL
//! thrust for the speed and a z-only depth target; and the neutral MANUAL_CONTROL that ends our
//! thrust when the course does.

use std::time::Duration;

use crate::codec::MavMessage;
use crate::infer;
use crate::modes::sub;

use super::state::{ArdupilotDriver, Course, LOOP_SLACK};
use frontseat_actors::driver::SignalSink;
use frontseat_actors::drivers::kit::log_due;

/// How often the Sub's ALT_HOLD depth target is repeated (one per second as measured on SITL).
const DEPTH_TARGET_PERIOD: Duration = Duration::from_secs(1);

impl ArdupilotDriver {
    /// The Sub's course, by the method its mode takes (ardusub.md): GUIDED → a LOCAL_NED
    /// position + velocity + yaw target; ALT_HOLD → attitude (heading) and MANUAL_CONTROL
    /// (thrust) each time, the z-only depth target once a second or when it changes.
    pub(super) fn send_sub_target(
        &mut self,
        c: Course,
        sys: u8,
        comp: u8,
        now: Duration,
        sig: &mut dyn SignalSink,
    ) {
        let boot_ms = now.as_millis().min(u128::from(u32::MAX)) as u32;
        let mode = self.beat.map(|b| b.mode);
        if mode == Some(sub::ALT_HOLD) {
            let att = infer::sub_attitude_target(c.heading, sys, comp, boot_ms);
            let x = infer::thrust_for_speed(c.speed, self.settings.thrust_per_mps);
            let mc = infer::manual_control(x, sys);
            let mut ok = self.write(&MavMessage::SET_ATTITUDE_TARGET(att), sig);
            ok &= self.write(&MavMessage::MANUAL_CONTROL(mc), sig);
            self.counters.manual_controls_sent += 1;
            self.manual_at = Some(now);
            self.thrusting = x != 0;
            if let Some(d) = c.depth
                && self.depth_sent.is_none_or(|(t, sent)| {
                    sent != d || now.saturating_sub(t) + LOOP_SLACK >= DEPTH_TARGET_PERIOD
                })
            {
                let t = infer::sub_depth_target(d, sys, comp, boot_ms);
                ok &= self.write(&MavMessage::SET_POSITION_TARGET_GLOBAL_INT(t), sig);
                self.depth_sent = Some((now, d));
            }
            if ok {
                self.counters.targets_sent += 1;
            }
        } else {
            let Some(l) = self.local.filter(|l| l.x.is_finite() && l.y.is_finite()) else {
                self.counters.targets_without_position += 1;
                if let Some(suppressed) = log_due(&mut self.bad_log) {
                    tracing::warn!(
                        target: super::LOG_TARGET,
                        suppressed,
                        "no finite LOCAL_POSITION_NED to anchor the Sub's GUIDED target: not sent"
                    );
                }
                return;
            };
            let depth = match c.depth.or(Some(f64::from(l.z)).filter(|z| z.is_finite())) {
                Some(d) => d,
                None => return,
            };
            let t = infer::sub_guided_target(
                c.heading,
                c.speed,
                depth,
                f64::from(l.x),
                f64::from(l.y),
                sys,
                comp,
                boot_ms,
            );
            if self.write(&MavMessage::SET_POSITION_TARGET_LOCAL_NED(t), sig) {
                self.counters.targets_sent += 1;
            }
        }
        if let Some(c) = &mut self.course {
            c.sent = Some(now);
        }
    }

    /// After ALT_HOLD thrust, one neutral MANUAL_CONTROL at once: ArduSub keeps an RC override
    /// for 3 s, and the pilot's mode must not inherit our forward thrust.
    pub(super) fn stop_thrust(&mut self, now: Duration, sig: &mut dyn SignalSink) {
        self.depth_sent = None;
        if !std::mem::take(&mut self.thrusting) {
            return;
        }
        if let Some((sys, _)) = self.vehicle {
            self.write(
                &MavMessage::MANUAL_CONTROL(infer::manual_control(0, sys)),
                sig,
            );
            self.counters.manual_controls_sent += 1;
            self.manual_at = Some(now);
        }
    }
}
