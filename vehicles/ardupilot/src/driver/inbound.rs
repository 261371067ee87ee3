//! What the vehicle says, frame by frame: decode, adopt the autopilot (the first one heard when
//! the config names none), keep to its system and component, and hand each message to the part
//! of the driver that owns it; the vehicle's STATUSTEXT words kept to explain refusals.

use std::time::Duration;

use crate::codec::{self, FrameError, MavMessage};
use crate::dialect::{MavSeverity, MavSysStatusSensor, MavType};
use crate::infer::{self, Beat};

use super::state::{ArdupilotDriver, Local};
use frontseat_actors::driver::SignalSink;
use frontseat_actors::drivers::kit::{log_due, raw_binary};

/// STATUSTEXT's 50 bytes as text: up to the first NUL, invalid UTF-8 replaced, not dropped.
fn statustext(bytes: &[u8]) -> String {
    let end = bytes.iter().position(|&b| b == 0).unwrap_or(bytes.len());
    String::from_utf8_lossy(&bytes[..end]).into_owned()
}

impl ArdupilotDriver {
    pub(super) fn on_frame(&mut self, bytes: Vec<u8>, now: Duration, sig: &mut dyn SignalSink) {
        let decoded = codec::decode(&bytes);
        sig.raw_from_frontseat(raw_binary(bytes));
        let (h, msg) = match decoded {
            Ok(x) => x,
            Err(e @ FrameError::UnknownMessage(_)) => {
                self.counters.unknown_messages += 1;
                return self.bad(&e.to_string());
            }
            Err(e) => return self.bad(&e.to_string()),
        };
        self.counters.frames += 1;
        let (sys, comp) = match self.vehicle {
            Some(v) => v,
            None => {
                // Adopt the first autopilot heard (0 in the config); a GCS or companion is not one.
                match &msg {
                    MavMessage::HEARTBEAT(hb)
                        if Beat::of(hb).is_some()
                            && !matches!(
                                hb.mavtype,
                                MavType::MAV_TYPE_GCS | MavType::MAV_TYPE_ONBOARD_CONTROLLER
                            )
                            && (self.settings.system_id == 0
                                || self.settings.system_id == h.system_id) =>
                    {
                        tracing::info!(
                            target: super::LOG_TARGET,
                            system = h.system_id,
                            component = h.component_id,
                            "ArduPilot autopilot found"
                        );
                        self.vehicle = Some((h.system_id, h.component_id));
                        (h.system_id, h.component_id)
                    }
                    _ => {
                        self.counters.ignored += 1;
                        return;
                    }
                }
            }
        };
        if h.system_id != sys {
            self.counters.foreign_system += 1;
            return self.bad(&format!(
                "message {} from system {} (the vehicle is {sys})",
                h.message_id, h.system_id
            ));
        }
        // Other components of the vehicle (gimbal, camera) may speak; only STATUSTEXT of theirs counts.
        if h.component_id != comp && !matches!(msg, MavMessage::STATUSTEXT(_)) {
            self.counters.ignored += 1;
            return;
        }
        match msg {
            MavMessage::HEARTBEAT(hb) => match Beat::of(&hb) {
                Some(b) => self.on_heartbeat(b, now, sig),
                None => self.counters.ignored += 1,
            },
            MavMessage::GLOBAL_POSITION_INT(p) => match infer::position(&p) {
                Ok(pos) => self.on_position(pos, now, sig),
                Err(why) => {
                    self.counters.nav_refused += 1;
                    self.bad(&format!("GLOBAL_POSITION_INT refused: {why}"));
                }
            },
            MavMessage::ATTITUDE(a) => {
                let v = [a.roll, a.pitch, a.yaw];
                if v.iter().all(|x| x.is_finite() && x.abs() <= 7.0) {
                    self.attitude = Some((
                        f64::from(a.roll).to_degrees(),
                        f64::from(a.pitch).to_degrees(),
                        frontseat_sim::vehicle::wrap_heading(f64::from(a.yaw).to_degrees()),
                    ));
                } else {
                    self.bad("ATTITUDE with non-finite or out-of-range angles");
                }
            }
            MavMessage::EKF_STATUS_REPORT(e) => self.ekf = Some(e.flags),
            MavMessage::GPS_RAW_INT(g) => self.gps_fix = Some(g.fix_type),
            MavMessage::STATUSTEXT(t) => {
                self.on_statustext(t.severity, &statustext(&t.text[..]), now, sig)
            }
            MavMessage::COMMAND_ACK(a) => self.on_ack(a.command, a.result, now, sig),
            MavMessage::SYS_STATUS(st) => {
                let gps = MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_GPS;
                self.gps_unhealthy = st.onboard_control_sensors_present.contains(gps)
                    && st.onboard_control_sensors_enabled.contains(gps)
                    && !st.onboard_control_sensors_health.contains(gps);
            }
            MavMessage::LOCAL_POSITION_NED(l) => {
                if ![l.x, l.y, l.z].iter().all(|v| v.is_finite()) {
                    // Kept all the same: a NaN depth reaches the navigation gate, which refuses
                    // and counts it; targets are anchored only on finite positions.
                    self.bad("LOCAL_POSITION_NED with a non-finite position");
                }
                self.local = Some(Local::from(&l));
            }
            MavMessage::VFR_HUD(_) => {}
            _ => self.counters.ignored += 1,
        }
    }

    pub(super) fn on_statustext(
        &mut self,
        severity: MavSeverity,
        text: &str,
        now: Duration,
        sig: &mut dyn SignalSink,
    ) {
        self.counters.statustexts += 1;
        let text = text.trim_end_matches('\0').to_string();
        let serious = (severity as u8) <= MavSeverity::MAV_SEVERITY_WARNING as u8;
        if let Some(suppressed) = log_due(&mut self.text_log) {
            if serious {
                tracing::warn!(target: super::LOG_TARGET, %text, ?severity, suppressed, "ArduPilot says");
            } else {
                tracing::info!(target: super::LOG_TARGET, %text, ?severity, suppressed, "ArduPilot says");
            }
        }
        // Rover refuses a target by its mask only in words: the course waiting for a verdict fails
        // with them.
        if serious {
            self.serious_text = Some((now, text.clone()));
        }
        if text.starts_with("Ignoring") || text.contains("ACC_IGNORE") {
            self.fail_course_verdicts(&format!("vehicle refused the target: {text}"), sig);
        }
        self.last_text = Some((now, text));
    }
}
