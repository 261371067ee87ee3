//! The ArduPilot driver's state and I/O. It reads HEARTBEATs into a frontseat state (armed +
//! GUIDED accepts commands, the autopilot's own modes and failsafes are it in control, manual,
//! HOLD and disarmed are idle, silence is not connected), position streams into NodeStatus while
//! the estimate is usable, and turns the helm's course into a GUIDED target it re-sends while the
//! helm keeps commanding. It never arms or changes mode on its own: only the ArduPilot
//! CommandRequest extension does, and only with `allow_mode_commands`.
//!
//! ArduSub (`vehicle = "sub"`, `shared/protocol/ardupilot/ardusub.md`): in GUIDED the course is a
//! LOCAL_NED position + velocity + yaw target (depth its z, x/y the vehicle's latest
//! LOCAL_POSITION_NED); in ALT_HOLD (with `alt_hold_accepts_commands`) depth is a z-only target,
//! heading a SET_ATTITUDE_TARGET and speed MANUAL_CONTROL thrust. Depth in NodeStatus is
//! LOCAL_POSITION_NED.z. The vehicle's failsafes stay its watchdog on us: our HEARTBEAT (and,
//! with `pilot_input_keepalive`, a neutral MANUAL_CONTROL) go out only while we run and hear it.

use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::Duration;

use crate::codec::{self, FrameError, MavMessage, Sender};
use crate::dialect::{
    COMMAND_LONG_DATA, EkfStatusFlags, GpsFixType, HEARTBEAT_DATA, LOCAL_POSITION_NED_DATA,
    MavAutopilot, MavCmd, MavModeFlag, MavResult, MavSeverity, MavState, MavSysStatusSensor,
    MavType,
};
use crate::infer::{self, Beat};
use crate::modes::{Control, Firmware, sub};
use frontseat_config::{ArdupilotVehicle, InterfaceConfig, MavlinkAddress};

use frontseat_actors::clock::SimClock;
use frontseat_actors::driver::{Driver, DriverContext, DriverExtension, DriverIoEvent, SignalSink};
use frontseat_actors::drivers::kit::{
    AckQueue, Asker, Awaiting, DataWatch, OwnedTask, TIMED_OUT, base_command, log_due,
    own_extension, raw_binary, refuse, send_bytes, state_of,
};
use frontseat_actors::link::LineWriter;
use frontseat_actors::link::byte::{self, ByteLinkConfig, LinkStats, Transport};
use frontseat_actors::link::framing::{FrameCutter, Framing};
use frontseat_actors::link::serial::SerialSettings;
use frontseat_actors::proto::frontseat::protobuf::ardupilot::{
    CommandRequest as ArdupilotCommandRequest, ardupilot_command::Action,
};
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CommandRequest, EulerAngles, FrontSeatState, InterfaceData, NodeStatus, Raw, Speed,
};
use frontseat_actors::proto::goby::middleware::protobuf::LatLonPoint;
use frontseat_actors::ratelog::RateLimitedLog;

/// The type of our ArduPilot extension (field 1002), as its group declares it.
pub const COMMAND: &str =
    frontseat_actors::groups::FRONTSEAT_ARDUPILOT_ARDUPILOT_COMMAND_REQUEST.type_name();

/// Requests awaiting a verdict at most (older ones are answered as failed).
const MAX_PENDING: usize = 64;
/// Half of the driver loop's 10 Hz period.
const LOOP_SLACK: Duration = Duration::from_millis(50);
/// A raw_send_request larger than this is not a handful of MAVLink frames.
const MAX_RAW_BYTES: usize = 16 * codec::MAX_FRAME;

#[derive(Clone, Debug)]
pub struct Settings {
    /// None when the address did not parse (a config that skipped validation): never connects.
    pub link: Option<ByteLinkConfig>,
    pub address: String,
    pub firmware: Firmware,
    pub system_id: u8,
    pub component_id: u8,
    pub own_system_id: u8,
    pub own_component_id: u8,
    pub heartbeat_timeout: Duration,
    pub resend_period: Duration,
    pub course_timeout: Duration,
    pub verdict_after: Duration,
    pub ack_timeout: Duration,
    /// (message id, Hz) to ask for at each connection.
    pub streams: Vec<(u32, f64)>,
    pub modes: BTreeMap<u32, FrontSeatState>,
    pub allow_mode_commands: bool,
    /// Navigation waits for an EKF_STATUS_REPORT / GPS_RAW_INT when they are streamed: a
    /// position before them may be the backup estimate.
    pub require_ekf: bool,
    pub require_gps: bool,
    /// Sub: feed the pilot-input failsafe with a neutral MANUAL_CONTROL while alive.
    pub pilot_input_keepalive: bool,
    /// Sub: ALT_HOLD accepts the helm's course (depth, heading, open-loop thrust).
    pub alt_hold_accepts_commands: bool,
    /// Sub in ALT_HOLD: MANUAL_CONTROL x per m/s.
    pub thrust_per_mps: f64,
    /// Sub: depth comes from LOCAL_POSITION_NED (streamed).
    pub depth_from_local: bool,
}

impl Settings {
    pub fn from_config(cfg: &InterfaceConfig) -> Self {
        let c = &cfg.driver.ardupilot;
        let transport = match MavlinkAddress::parse(&c.address) {
            Ok(MavlinkAddress::TcpOut { host, port }) => Some(Transport::Tcp { host, port }),
            Ok(MavlinkAddress::UdpIn { host, port }) => Some(Transport::UdpIn { host, port }),
            Ok(MavlinkAddress::UdpOut { host, port }) => Some(Transport::UdpOut { host, port }),
            Ok(MavlinkAddress::Serial { path, baud }) => {
                Some(Transport::Serial(SerialSettings::new_8n1(path, baud)))
            }
            Err(_) => None,
        };
        let r = &c.stream_rates;
        use mavlink_ids::*;
        let is_sub = c.vehicle == ArdupilotVehicle::Sub;
        let local_hz = if is_sub { r.local_position_ned } else { 0.0 };
        Self {
            link: transport.map(|transport| ByteLinkConfig {
                transport,
                framing: Framing::Frames(mavlink_frames),
                backoff_initial: Duration::from_millis(c.reconnect_initial_ms.max(1)),
                backoff_max: Duration::from_millis(
                    c.reconnect_max_ms.max(c.reconnect_initial_ms).max(1),
                ),
            }),
            address: c.address.clone(),
            firmware: match c.vehicle {
                ArdupilotVehicle::Rover => Firmware::Rover,
                ArdupilotVehicle::Sub => Firmware::Sub,
            },
            system_id: c.system_id,
            component_id: c.component_id,
            own_system_id: c.own_system_id,
            own_component_id: c.own_component_id,
            heartbeat_timeout: secs(c.heartbeat_timeout),
            resend_period: secs(1.0 / c.resend_rate.clamp(1.0, 50.0)),
            course_timeout: secs(c.course_timeout),
            verdict_after: secs(c.target_verdict_after),
            ack_timeout: secs(c.ack_timeout),
            streams: [
                (GLOBAL_POSITION_INT, r.global_position_int),
                (ATTITUDE, r.attitude),
                (VFR_HUD, r.vfr_hud),
                (SYS_STATUS, r.sys_status),
                (GPS_RAW_INT, r.gps_raw_int),
                (EKF_STATUS_REPORT, r.ekf_status_report),
                (LOCAL_POSITION_NED, local_hz),
            ]
            .into_iter()
            .filter(|(_, hz)| hz.is_finite() && *hz > 0.0)
            .collect(),
            modes: c
                .modes
                .iter()
                .map(|m| (m.mode, state_of(m.state)))
                .collect(),
            allow_mode_commands: c.allow_mode_commands,
            require_ekf: r.ekf_status_report > 0.0,
            // A Sub's position comes from a DVL, underwater GPS or visual odometry: the EKF's
            // flags say whether it has one; GPS_RAW_INT says nothing under water.
            require_gps: r.gps_raw_int > 0.0 && !is_sub,
            pilot_input_keepalive: is_sub && c.pilot_input_keepalive,
            alt_hold_accepts_commands: is_sub && c.alt_hold_accepts_commands,
            thrust_per_mps: c.alt_hold_thrust_per_mps,
            depth_from_local: is_sub && local_hz > 0.0,
        }
    }
}

/// Message ids the driver asks streams of.
mod mavlink_ids {
    pub const GLOBAL_POSITION_INT: u32 = 33;
    pub const ATTITUDE: u32 = 30;
    pub const VFR_HUD: u32 = 74;
    pub const SYS_STATUS: u32 = 1;
    pub const GPS_RAW_INT: u32 = 24;
    pub const EKF_STATUS_REPORT: u32 = 193;
    pub const LOCAL_POSITION_NED: u32 = 32;
}

/// How often the Sub's neutral MANUAL_CONTROL goes out (ArduSub disarms 3 s after the last).
const KEEPALIVE_PERIOD: Duration = Duration::from_millis(500);
/// How often the Sub's ALT_HOLD depth target is repeated (one per second as measured on SITL).
const DEPTH_TARGET_PERIOD: Duration = Duration::from_secs(1);
/// A STATUSTEXT this recent explains a failsafe or a disarm.
const REASON_TEXT_AGE: Duration = Duration::from_secs(10);

fn secs(s: f64) -> Duration {
    if s.is_finite() && s > 0.0 {
        Duration::from_secs_f64(s.min(1e6))
    } else {
        Duration::from_secs(1)
    }
}

/// What the driver counted (read by tests and logs).
#[derive(Debug, Default, Clone, PartialEq)]
pub struct ArdupilotCounters {
    pub frames: u64,
    pub heartbeats: u64,
    pub bad_input: u64,
    pub unknown_messages: u64,
    pub foreign_system: u64,
    pub nav_published: u64,
    pub nav_refused: u64,
    pub targets_sent: u64,
    pub statustexts: u64,
    pub acks: u64,
    pub unmatched_acks: u64,
    pub ack_timeouts: u64,
    pub write_failures: u64,
    pub ignored: u64,
    /// Sub: MANUAL_CONTROL frames sent (thrust and keepalive).
    pub manual_controls_sent: u64,
    /// Sub: courses not sent for want of a LOCAL_POSITION_NED to anchor the target.
    pub targets_without_position: u64,
}

#[derive(Debug, Clone, Copy)]
struct Course {
    heading: f64,
    speed: f64,
    depth: Option<f64>,
    /// When the helm last gave it.
    renewed: Duration,
    sent: Option<Duration>,
}

/// LOCAL_POSITION_NED's position: north, east, down (m).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Local {
    x: f32,
    y: f32,
    z: f32,
}

impl From<&LOCAL_POSITION_NED_DATA> for Local {
    fn from(l: &LOCAL_POSITION_NED_DATA) -> Self {
        Self {
            x: l.x,
            y: l.y,
            z: l.z,
        }
    }
}

/// What a request waits for: the COMMAND_ACK of its COMMAND_LONG, or None for a course (judged
/// at the deadline).
type Pending = Option<MavCmd>;

pub struct ArdupilotDriver {
    settings: Settings,
    writer: Option<LineWriter>,
    link_task: OwnedTask,
    pub link_stats: Arc<LinkStats>,
    tx: Sender,
    /// The autopilot (system, component) spoken to: configured, or the first heard.
    vehicle: Option<(u8, u8)>,
    beat: Option<Beat>,
    last_heartbeat: Option<Duration>,
    state: FrontSeatState,
    streams_requested: bool,
    own_heartbeat_at: Option<Duration>,
    ekf: Option<EkfStatusFlags>,
    gps_fix: Option<GpsFixType>,
    /// SYS_STATUS says the GPS is present and enabled but unhealthy.
    gps_unhealthy: bool,
    attitude: Option<(f64, f64, f64)>,
    /// Usable positions.
    nav: DataWatch,
    nav_problem: Option<String>,
    course: Option<Course>,
    pending: AckQueue<Pending>,
    last_text: Option<(Duration, String)>,
    /// The latest warning-or-worse STATUSTEXT ("Leak Detected", "… heartbeat lost").
    serious_text: Option<(Duration, String)>,
    /// Why the frontseat state is what it is, in words (mode, arming, failsafe and its text).
    reason: String,
    /// Sub: the latest LOCAL_POSITION_NED (north, east, down m; as sent, unchecked).
    local: Option<Local>,
    /// Sub: when the last MANUAL_CONTROL went out, and whether it carried thrust.
    manual_at: Option<Duration>,
    thrusting: bool,
    /// Sub in ALT_HOLD: when the depth target last went out, and which.
    depth_sent: Option<(Duration, f64)>,
    bad_log: RateLimitedLog,
    text_log: RateLimitedLog,
    pub counters: ArdupilotCounters,
}

/// STATUSTEXT's 50 bytes as text: up to the first NUL, invalid UTF-8 replaced, not dropped.
fn statustext(bytes: &[u8]) -> String {
    let end = bytes.iter().position(|&b| b == 0).unwrap_or(bytes.len());
    String::from_utf8_lossy(&bytes[..end]).into_owned()
}

impl ArdupilotDriver {
    pub fn new(settings: Settings) -> Self {
        let tx = Sender::new(settings.own_system_id, settings.own_component_id);
        let vehicle = (settings.system_id != 0 && settings.component_id != 0)
            .then_some((settings.system_id, settings.component_id));
        Self {
            settings,
            writer: None,
            link_task: OwnedTask::default(),
            link_stats: Arc::new(LinkStats::default()),
            tx,
            vehicle,
            beat: None,
            last_heartbeat: None,
            state: FrontSeatState::FrontseatNotConnected,
            streams_requested: false,
            own_heartbeat_at: None,
            ekf: None,
            gps_fix: None,
            gps_unhealthy: false,
            attitude: None,
            nav: DataWatch::default(),
            nav_problem: None,
            course: None,
            pending: AckQueue::new(MAX_PENDING),
            last_text: None,
            serious_text: None,
            reason: "no HEARTBEAT yet".into(),
            local: None,
            manual_at: None,
            thrusting: false,
            depth_sent: None,
            bad_log: RateLimitedLog::for_bad_input(),
            text_log: RateLimitedLog::for_bad_input(),
            counters: ArdupilotCounters::default(),
        }
    }

    /// The vehicle's mode number and armed flag, once heard.
    pub fn mode(&self) -> Option<(u32, bool)> {
        self.beat.map(|b| (b.mode, b.armed))
    }

    /// Why the frontseat state is what it is (mode, arming, failsafe, the vehicle's words).
    pub fn state_reason(&self) -> &str {
        &self.reason
    }

    /// Why navigation is not published, if it is not.
    pub fn nav_problem(&self) -> Option<&str> {
        self.nav_problem.as_deref()
    }

    fn mode_words(&self) -> String {
        match self.beat {
            Some(b) => format!(
                "{} ({}), {}",
                self.settings
                    .firmware
                    .mode_name(b.mode)
                    .unwrap_or("unknown mode"),
                b.mode,
                if b.armed { "armed" } else { "disarmed" }
            ),
            None => "no HEARTBEAT yet".into(),
        }
    }

    fn bad(&mut self, what: &str) {
        self.counters.bad_input += 1;
        frontseat_actors::drivers::kit::bad_line();
        if let Some(suppressed) = log_due(&mut self.bad_log) {
            tracing::warn!(%what, suppressed, "bad input from the ArduPilot vehicle");
        }
    }

    fn write(&mut self, msg: &MavMessage, sig: &mut dyn SignalSink) -> bool {
        let frame = self.tx.frame(msg);
        self.write_bytes(frame, sig)
    }

    fn write_bytes(&mut self, frame: Vec<u8>, sig: &mut dyn SignalSink) -> bool {
        let Some(w) = &self.writer else {
            self.counters.write_failures += 1;
            return false;
        };
        match send_bytes(w, frame, sig) {
            Ok(()) => true,
            Err(e) => {
                self.counters.write_failures += 1;
                if let Some(suppressed) = log_due(&mut self.bad_log) {
                    tracing::warn!(error = %e, suppressed, "MAVLink frame to the vehicle not sent");
                }
                false
            }
        }
    }

    fn push_pending(&mut self, p: Awaiting<Pending>, sig: &mut dyn SignalSink) {
        self.pending
            .push(p, "too many requests awaiting a verdict", sig);
    }

    fn command_long(
        &mut self,
        command: MavCmd,
        p1: f32,
        p2: f32,
        sig: &mut dyn SignalSink,
    ) -> bool {
        let Some((sys, comp)) = self.vehicle else {
            return false;
        };
        let msg = MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
            param1: p1,
            param2: p2,
            command,
            target_system: sys,
            target_component: comp,
            ..Default::default()
        });
        self.write(&msg, sig)
    }

    fn own_heartbeat(&mut self, now: Duration, sig: &mut dyn SignalSink) {
        self.own_heartbeat_at = Some(now);
        let msg = MavMessage::HEARTBEAT(HEARTBEAT_DATA {
            custom_mode: 0,
            mavtype: MavType::MAV_TYPE_ONBOARD_CONTROLLER,
            autopilot: MavAutopilot::MAV_AUTOPILOT_INVALID,
            base_mode: MavModeFlag::empty(),
            system_status: MavState::MAV_STATE_ACTIVE,
            mavlink_version: 3,
        });
        self.write(&msg, sig);
    }

    fn request_streams(&mut self, sig: &mut dyn SignalSink) {
        self.streams_requested = true;
        for (id, hz) in self.settings.streams.clone() {
            let us = (1e6 / hz).round() as f32;
            self.command_long(MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL, id as f32, us, sig);
        }
    }

    fn control_of(&self, mode: u32) -> Control {
        match self.settings.modes.get(&mode) {
            Some(FrontSeatState::FrontseatAcceptingCommands) => Control::AcceptingCommands,
            Some(FrontSeatState::FrontseatInControl) => Control::InControl,
            Some(_) => Control::Idle,
            None if self.is_sub()
                && mode == sub::ALT_HOLD
                && self.settings.alt_hold_accepts_commands =>
            {
                Control::AcceptingCommands
            }
            None => self.settings.firmware.default_control(mode),
        }
    }

    fn is_sub(&self) -> bool {
        self.settings.firmware == Firmware::Sub
    }

    /// The vehicle's recent warning-or-worse words, to explain a failsafe or a disarm.
    fn recent_serious_text(&self, now: Duration) -> Option<&str> {
        self.serious_text
            .as_ref()
            .filter(|(t, _)| now.saturating_sub(*t) <= REASON_TEXT_AGE)
            .map(|(_, s)| s.as_str())
    }

    fn on_heartbeat(&mut self, beat: Beat, now: Duration, sig: &mut dyn SignalSink) {
        self.counters.heartbeats += 1;
        self.last_heartbeat = Some(now);
        let (control, why) = infer::control(beat, &|m| self.control_of(m));
        let state = match control {
            Control::Idle => FrontSeatState::FrontseatIdle,
            Control::InControl => FrontSeatState::FrontseatInControl,
            Control::AcceptingCommands => FrontSeatState::FrontseatAcceptingCommands,
        };
        let previous = self.beat.replace(beat);
        let changed = state != self.state
            || previous.map(|p| (p.mode, p.armed)) != Some((beat.mode, beat.armed));
        if changed {
            // A failsafe or a disarm says why in a STATUSTEXT just before ("Leak Detected",
            // "MYGCS: 255, heartbeat lost", "Lost manual control"): keep its words.
            let text = (control != Control::AcceptingCommands)
                .then(|| self.recent_serious_text(now))
                .flatten()
                .map(|t| format!("; vehicle said \"{t}\""))
                .unwrap_or_default();
            self.reason = format!("{}: {why}{text}", self.mode_words());
            if self.state == FrontSeatState::FrontseatAcceptingCommands
                && state != FrontSeatState::FrontseatAcceptingCommands
            {
                tracing::warn!(reason = %self.reason, state = ?state, "ArduPilot vehicle no longer accepts commands");
            } else {
                tracing::info!(reason = %self.reason, state = ?state, "ArduPilot vehicle state");
            }
        }
        // Another commanded mode (GUIDED ↔ ALT_HOLD) takes other messages: start afresh.
        let mode_changed = previous.is_some_and(|p| p.mode != beat.mode);
        self.state = state;
        if (control != Control::AcceptingCommands || mode_changed) && self.course.take().is_some() {
            // Targets are ignored outside the commanded modes: stop sending them, and say so to
            // whoever waits.
            tracing::warn!(reason = %self.reason, "no longer sending the helm's course");
            let why = format!("vehicle left its commanded mode: {}", self.reason);
            self.fail_course_verdicts(&why, sig);
            self.stop_thrust(now, sig);
        }
        if !self.streams_requested {
            self.request_streams(sig);
        }
    }

    fn fail_course_verdicts(&mut self, why: &str, sig: &mut dyn SignalSink) {
        for p in self.pending.take_all(|command| command.is_none()) {
            p.asker.fail(sig, 4, why);
        }
    }

    fn on_frame(&mut self, bytes: Vec<u8>, now: Duration, sig: &mut dyn SignalSink) {
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

    /// Why navigation is not to be steered by, or Ok.
    fn nav_ready(&self) -> Result<(), String> {
        if self.settings.require_ekf && self.ekf.is_none() {
            return Err("no EKF_STATUS_REPORT heard yet".into());
        }
        if self.settings.require_gps && self.gps_fix.is_none() {
            return Err("no GPS_RAW_INT heard yet".into());
        }
        if self.gps_unhealthy {
            return Err("SYS_STATUS: GPS present and enabled but unhealthy".into());
        }
        if self.is_sub() {
            return self.sub_nav_usable();
        }
        infer::nav_usable(self.ekf, self.gps_fix)
    }

    /// A Sub's estimate: attitude and a horizontal position, absolute (UGPS, GPS) or relative
    /// (DVL, visual odometry, from the EKF origin); in ALT_HOLD with
    /// `alt_hold_accepts_commands`, attitude and depth suffice.
    fn sub_nav_usable(&self) -> Result<(), String> {
        let Some(f) = self.ekf else { return Ok(()) };
        if !f.contains(EkfStatusFlags::EKF_ATTITUDE)
            || f.contains(EkfStatusFlags::EKF_UNINITIALIZED)
        {
            return Err(format!("EKF has no attitude (flags {:#06x})", f.bits()));
        }
        let horizontal = f
            .intersects(EkfStatusFlags::EKF_POS_HORIZ_ABS | EkfStatusFlags::EKF_POS_HORIZ_REL)
            && !f.contains(EkfStatusFlags::EKF_CONST_POS_MODE);
        let alt_hold = self.settings.alt_hold_accepts_commands
            && self.beat.is_some_and(|b| b.mode == sub::ALT_HOLD);
        if horizontal || alt_hold {
            Ok(())
        } else {
            Err(format!(
                "EKF has no horizontal position (flags {:#06x}): GUIDED needs a DVL, underwater GPS or visual odometry",
                f.bits()
            ))
        }
    }

    fn on_position(&mut self, pos: infer::Position, now: Duration, sig: &mut dyn SignalSink) {
        if let Err(why) = self.nav_ready() {
            if self.nav_problem.as_deref() != Some(why.as_str()) {
                tracing::warn!(%why, "ArduPilot navigation not usable: not providing data");
            }
            self.nav_problem = Some(why);
            self.nav.lost();
            return;
        }
        if self.nav_problem.take().is_some() {
            tracing::info!("ArduPilot navigation usable again");
        }
        let (roll, pitch, yaw) = match self.attitude {
            Some((r, p, y)) => (Some(r), Some(p), Some(y)),
            None => (None, None, None),
        };
        // Sub: depth is LOCAL_POSITION_NED.z, unclamped (the navigation gate judges a reading
        // above the surface or beyond its bounds); relative_alt's zero moves at each arming.
        let depth = if self.settings.depth_from_local {
            let Some(l) = self.local else {
                let why = "no LOCAL_POSITION_NED (depth) heard yet".to_string();
                if self.nav_problem.as_deref() != Some(why.as_str()) {
                    tracing::warn!(%why, "ArduSub navigation not usable: not providing data");
                }
                self.nav_problem = Some(why);
                self.nav.lost();
                return;
            };
            f64::from(l.z)
        } else {
            (-pos.relative_alt).max(0.0)
        };
        let ns = NodeStatus {
            time: SimClock::unix_now(),
            global_fix: LatLonPoint {
                lat: pos.lat,
                lon: pos.lon,
                depth: Some(depth),
                altitude: None,
            },
            pose: EulerAngles {
                heading: pos.heading.or(yaw),
                roll,
                pitch,
                ..Default::default()
            },
            speed: Speed {
                over_ground: pos.speed_over_ground,
                over_water: None,
            },
            ..Default::default()
        };
        self.counters.nav_published += 1;
        self.nav.fresh(now);
        sig.data_from_frontseat(InterfaceData {
            node_status: Some(ns),
            ..Default::default()
        });
    }

    fn on_statustext(
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
                tracing::warn!(%text, ?severity, suppressed, "ArduPilot says");
            } else {
                tracing::info!(%text, ?severity, suppressed, "ArduPilot says");
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

    fn on_ack(
        &mut self,
        command: MavCmd,
        result: MavResult,
        now: Duration,
        sig: &mut dyn SignalSink,
    ) {
        self.counters.acks += 1;
        let Some(i) = self.pending.position(|p| *p == Some(command)) else {
            if command != MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL {
                self.counters.unmatched_acks += 1;
            }
            if result != MavResult::MAV_RESULT_ACCEPTED {
                tracing::debug!(?command, ?result, "COMMAND_ACK not accepted");
            }
            return;
        };
        if result == MavResult::MAV_RESULT_IN_PROGRESS {
            return;
        }
        let Some(p) = self.pending.remove(i) else {
            return;
        };
        let ok = result == MavResult::MAV_RESULT_ACCEPTED;
        // A refusal's reason comes as a STATUSTEXT just before the ACK (e.g. "PreArm: …").
        let reason = self
            .last_text
            .as_ref()
            .filter(|(t, _)| now.saturating_sub(*t) <= Duration::from_secs(1))
            .map(|(_, s)| format!(": {s}"))
            .unwrap_or_default();
        p.asker.answer(
            sig,
            ok,
            result as i32,
            (!ok).then(|| format!("vehicle answered {command:?} with {result:?}{reason}")),
        );
    }

    fn send_target(&mut self, now: Duration, sig: &mut dyn SignalSink) {
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

    /// The Sub's course, by the method its mode takes (ardusub.md): GUIDED → a LOCAL_NED
    /// position + velocity + yaw target; ALT_HOLD → attitude (heading) and MANUAL_CONTROL
    /// (thrust) each time, the z-only depth target once a second or when it changes.
    fn send_sub_target(
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
    fn stop_thrust(&mut self, now: Duration, sig: &mut dyn SignalSink) {
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

    /// The neutral MANUAL_CONTROL that feeds ArduSub's pilot-input failsafe, while the link is
    /// up and the vehicle heard (so if we die or lose it, the vehicle's failsafe acts).
    fn keepalive(&mut self, now: Duration, sig: &mut dyn SignalSink) {
        if !self.settings.pilot_input_keepalive || self.writer.is_none() || self.beat.is_none() {
            return;
        }
        let Some((sys, _)) = self.vehicle else { return };
        if self
            .manual_at
            .is_some_and(|t| now.saturating_sub(t) + LOOP_SLACK < KEEPALIVE_PERIOD)
        {
            return;
        }
        self.write(
            &MavMessage::MANUAL_CONTROL(infer::manual_control(0, sys)),
            sig,
        );
        self.counters.manual_controls_sent += 1;
        self.manual_at = Some(now);
    }

    fn heartbeat_lost(&mut self, sig: &mut dyn SignalSink) {
        self.state = FrontSeatState::FrontseatNotConnected;
        self.nav.lost();
        self.beat = None;
        self.last_heartbeat = None;
        self.streams_requested = false;
        self.local = None;
        self.thrusting = false;
        self.depth_sent = None;
        self.reason = "vehicle link lost (no HEARTBEAT)".into();
        if self.course.take().is_some() {
            self.fail_course_verdicts("vehicle link lost", sig);
        }
    }
}

impl ArdupilotDriver {
    pub fn send_ardupilot_command(
        &mut self,
        req: &ArdupilotCommandRequest,
        now: Duration,
        sig: &mut dyn SignalSink,
    ) {
        let base = base_command!(req);
        if !self.settings.allow_mode_commands {
            refuse(
                &base,
                "ArduPilot mode and arming commands are off ([driver.ardupilot] allow_mode_commands = false)",
                sig,
            );
            return;
        }
        let action = req.ardupilot_command.as_ref().map(|c| c.action());
        let fw = self.settings.firmware;
        let (cmd, p1, p2) = match action {
            Some(Action::Guided) => {
                // README: GUIDED before the estimate is ready ends in an EKF failsafe to HOLD.
                if let Err(why) = self.nav_ready() {
                    refuse(
                        &base,
                        format!("navigation not ready for GUIDED: {why}"),
                        sig,
                    );
                    return;
                }
                if !self.nav.providing() {
                    refuse(
                        &base,
                        "navigation not ready for GUIDED: no usable position yet",
                        sig,
                    );
                    return;
                }
                (MavCmd::MAV_CMD_DO_SET_MODE, 1.0, fw.guided() as f32)
            }
            Some(Action::Hold) => (MavCmd::MAV_CMD_DO_SET_MODE, 1.0, fw.hold() as f32),
            Some(Action::Arm) => (MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, 1.0, 0.0),
            Some(Action::Disarm) => (MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, 0.0, 0.0),
            Some(Action::Unknown) | None => {
                if base.desired_course.is_some() {
                    self.send_command_to_frontseat(&base, now, sig);
                } else {
                    refuse(&base, "ardupilot_command without an action", sig);
                }
                return;
            }
        };
        if self.vehicle.is_none() || !self.command_long(cmd, p1, p2, sig) {
            refuse(&base, "not connected to the vehicle: command not sent", sig);
            return;
        }
        let with_course = base.desired_course.is_some();
        self.push_pending(
            Awaiting {
                asker: Asker {
                    request_id: base.request_id,
                    respond: base.response_requested() && !with_course,
                },
                deadline: now + self.settings.ack_timeout,
                what: Some(cmd),
            },
            sig,
        );
        if with_course {
            self.send_command_to_frontseat(&base, now, sig);
        }
    }
}

impl Driver for ArdupilotDriver {
    fn send_extension(&mut self, ext: &DriverExtension, now: Duration, sig: &mut dyn SignalSink) {
        if let Some(r) = own_extension::<ArdupilotCommandRequest>(ext, COMMAND, sig, self.name()) {
            self.send_ardupilot_command(&r, now, sig);
        }
    }

    fn name(&self) -> &str {
        "ardupilot"
    }

    fn start(&mut self, ctx: DriverContext) {
        match self.settings.link.clone() {
            Some(link) => {
                self.link_task
                    .set(byte::spawn(link, ctx.io, self.link_stats.clone()));
            }
            None => tracing::error!(
                address = %self.settings.address,
                "ArduPilot address does not parse (tcpout:HOST:PORT, udpin:ADDR:PORT, udpout:HOST:PORT, serial:PATH:BAUD); not connecting"
            ),
        }
    }

    fn handle_io(&mut self, ev: DriverIoEvent, now: Duration, sig: &mut dyn SignalSink) {
        match ev {
            DriverIoEvent::Connected(w) => {
                tracing::info!(address = %self.settings.address, "MAVLink link open");
                self.writer = Some(w);
                self.streams_requested = false;
                // A companion announces itself; SITL's first serial port starts talking on it.
                self.own_heartbeat(now, sig);
            }
            DriverIoEvent::Frame(b) => self.on_frame(b, now, sig),
            DriverIoEvent::Line(_) => self.bad("text line on a MAVLink link"),
            DriverIoEvent::BadInput(what) => self.bad(&what),
            DriverIoEvent::Disconnected(reason) => {
                tracing::warn!(%reason, "MAVLink link lost; reopening");
                self.writer = None;
                self.heartbeat_lost(sig);
            }
        }
    }

    fn send_command_to_frontseat(
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

    fn send_data_to_frontseat(
        &mut self,
        _data: &InterfaceData,
        _now: Duration,
        _sig: &mut dyn SignalSink,
    ) {
        // No data channel to the autopilot.
    }

    fn send_raw_to_frontseat(&mut self, raw: &Raw, _now: Duration, sig: &mut dyn SignalSink) {
        let bytes = raw.raw.as_deref().unwrap_or_default();
        if bytes.is_empty() || bytes.len() > MAX_RAW_BYTES {
            return self.bad("raw_send_request is not 1 to 4480 bytes of MAVLink frames");
        }
        // Whole, checked frames only: a broken frame would desynchronise the vehicle's parser.
        let mut d = codec::Deframer::new();
        let mut ok = true;
        d.feed(bytes, &mut |r| ok &= r.is_ok());
        if !ok || d.buffered() != 0 {
            return self.bad("raw_send_request is not whole MAVLink frames with good CRCs");
        }
        self.write_bytes(bytes.to_vec(), sig);
    }

    fn do_loop(&mut self, now: Duration, sig: &mut dyn SignalSink) {
        if self.writer.is_some()
            && self
                .own_heartbeat_at
                .is_none_or(|t| now.saturating_sub(t) >= Duration::from_secs(1))
        {
            self.own_heartbeat(now, sig);
        }
        if let Some(t) = self.last_heartbeat
            && now.saturating_sub(t) > self.settings.heartbeat_timeout
        {
            tracing::warn!(
                "no HEARTBEAT from the vehicle for {:?}: not connected",
                self.settings.heartbeat_timeout
            );
            self.heartbeat_lost(sig);
        }
        if self.nav.expired(now, self.settings.heartbeat_timeout) {
            tracing::warn!("no usable position from the vehicle: not providing data");
        }
        if let Some(c) = self.course {
            if now.saturating_sub(c.renewed) > self.settings.course_timeout {
                // The helm stopped: stop re-sending, and the vehicle's own 3 s timeout stops it.
                tracing::info!("helm course not renewed: no longer re-sending the GUIDED target");
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
        if self.is_sub() {
            self.keepalive(now, sig);
        }
        while let Some(p) = self.pending.due(now) {
            match p.what {
                None => {
                    let ok = self.state == FrontSeatState::FrontseatAcceptingCommands;
                    let why =
                        (!ok).then(|| format!("vehicle not in GUIDED: {}", self.mode_words()));
                    p.asker.answer(sig, ok, if ok { 0 } else { 4 }, why);
                }
                Some(cmd) => {
                    self.counters.ack_timeouts += 1;
                    p.asker.fail(
                        sig,
                        TIMED_OUT,
                        format!(
                            "no COMMAND_ACK for {cmd:?} within {:?}",
                            self.settings.ack_timeout
                        ),
                    );
                }
            }
        }
    }

    fn frontseat_state(&self) -> FrontSeatState {
        self.state
    }

    fn frontseat_providing_data(&self) -> bool {
        self.nav.providing()
    }

    fn stop(&mut self) {
        self.writer = None;
    }
}

/// MAVLink 1/2 frames of the ardupilotmega dialect on a byte link, CRC-checked by the codec's
/// bounded deframer.
pub fn mavlink_frames() -> Box<dyn FrameCutter> {
    Box::new(MavlinkFrames(codec::Deframer::new()))
}

struct MavlinkFrames(codec::Deframer);

impl FrameCutter for MavlinkFrames {
    fn feed(&mut self, bytes: &[u8], out: &mut dyn FnMut(Result<Vec<u8>, String>)) {
        self.0
            .feed(bytes, &mut |r| out(r.map_err(|e| format!("MAVLink: {e}"))))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use frontseat_actors::proto::frontseat::protobuf::ardupilot::ArdupilotCommand;
    use frontseat_actors::proto::goby::middleware::frontseat::protobuf::DesiredCourse;
    use tokio::sync::mpsc::Receiver;

    type Sink = frontseat_actors::driver::RecordingSink;

    /// Vehicle-side frames encoded by pymavlink (see the file's header).
    const FIXTURE: &str = include_str!("../fixtures/pymavlink_vehicle_frames.hex");

    fn frame(name: &str) -> Vec<u8> {
        let hex = FIXTURE
            .lines()
            .find_map(|l| l.strip_prefix(name).and_then(|r| r.strip_prefix(' ')))
            .unwrap_or_else(|| panic!("no fixture {name}"));
        (0..hex.len())
            .step_by(2)
            .map(|i| u8::from_str_radix(&hex[i..i + 2], 16).unwrap())
            .collect()
    }

    fn driver_with(
        f: impl FnOnce(&mut InterfaceConfig),
    ) -> (ArdupilotDriver, Receiver<Vec<u8>>, Sink) {
        let mut cfg = InterfaceConfig::default();
        f(&mut cfg);
        let mut d = ArdupilotDriver::new(Settings::from_config(&cfg));
        let mut sink = Sink::default();
        let (w, rx) = LineWriter::for_test();
        d.handle_io(DriverIoEvent::Connected(w), Duration::ZERO, &mut sink);
        (d, rx, sink)
    }

    fn driver() -> (ArdupilotDriver, Receiver<Vec<u8>>, Sink) {
        driver_with(|_| {})
    }

    fn feed(d: &mut ArdupilotDriver, sink: &mut Sink, name: &str, t: f64) {
        d.handle_io(
            DriverIoEvent::Frame(frame(name)),
            Duration::from_secs_f64(t),
            sink,
        );
    }

    fn sent(rx: &mut Receiver<Vec<u8>>) -> Vec<MavMessage> {
        let mut v = Vec::new();
        while let Ok(b) = rx.try_recv() {
            let mut d = codec::Deframer::new();
            d.feed(&b, &mut |r| v.push(codec::decode(&r.unwrap()).unwrap().1));
        }
        v
    }

    fn ready(d: &mut ArdupilotDriver, sink: &mut Sink, t: f64) {
        for f in [
            "hb_guided_armed",
            "ekf_ready",
            "gps_3d",
            "attitude",
            "pos_boston",
        ] {
            feed(d, sink, f, t);
        }
    }

    fn course(h: f64, s: f64, id: i32) -> CommandRequest {
        CommandRequest {
            desired_course: Some(DesiredCourse {
                time: 0.0,
                heading: Some(h),
                speed: Some(s),
                ..Default::default()
            }),
            response_requested: Some(true),
            request_id: Some(id),
            ..Default::default()
        }
    }

    /// The state inference from pymavlink-encoded HEARTBEATs, one row per rule.
    #[test]
    fn state_inference_from_heartbeats() {
        let rows = [
            ("hb_manual_disarmed", FrontSeatState::FrontseatIdle),
            (
                "hb_guided_armed",
                FrontSeatState::FrontseatAcceptingCommands,
            ),
            ("hb_auto_armed", FrontSeatState::FrontseatInControl),
            ("hb_hold_armed", FrontSeatState::FrontseatIdle),
            // A failsafe to HOLD is the autopilot taking control: the interface leaves COMMAND.
            ("hb_hold_failsafe", FrontSeatState::FrontseatInControl),
        ];
        let (mut d, _rx, mut sink) = driver();
        assert_eq!(d.frontseat_state(), FrontSeatState::FrontseatNotConnected);
        for (i, (f, want)) in rows.into_iter().enumerate() {
            feed(&mut d, &mut sink, f, i as f64);
            assert_eq!(d.frontseat_state(), want, "{f}");
        }
        // No HEARTBEAT for the timeout: not connected.
        d.do_loop(Duration::from_secs(10), &mut sink);
        assert_eq!(d.frontseat_state(), FrontSeatState::FrontseatNotConnected);
    }

    #[test]
    fn a_gcs_heartbeat_is_not_the_vehicle_and_streams_are_asked_once_found() {
        let (mut d, mut rx, mut sink) = driver();
        sent(&mut rx);
        feed(&mut d, &mut sink, "hb_gcs", 0.0);
        assert_eq!(d.frontseat_state(), FrontSeatState::FrontseatNotConnected);
        assert!(sent(&mut rx).is_empty());
        feed(&mut d, &mut sink, "hb_manual_disarmed", 0.0);
        let asks: Vec<_> = sent(&mut rx)
            .into_iter()
            .filter_map(|m| match m {
                MavMessage::COMMAND_LONG(c)
                    if c.command == MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL =>
                {
                    Some((c.param1 as u32, c.param2, c.target_system))
                }
                _ => None,
            })
            .collect();
        assert!(asks.contains(&(33, 200_000.0, 1)), "{asks:?}");
        assert_eq!(asks.len(), 6);
    }

    #[test]
    fn navigation_only_while_the_estimate_is_usable() {
        let (mut d, _rx, mut sink) = driver();
        // A position before any EKF report may be the backup estimate: not published.
        feed(&mut d, &mut sink, "hb_guided_armed", 0.0);
        feed(&mut d, &mut sink, "pos_boston", 0.0);
        assert!(sink.data.is_empty());
        assert!(d.nav_problem().unwrap().contains("EKF_STATUS_REPORT"));
        for f in ["hb_guided_armed", "ekf_backup", "gps_3d", "pos_boston"] {
            feed(&mut d, &mut sink, f, 0.0);
        }
        assert!(sink.data.is_empty());
        assert!(!d.frontseat_providing_data());
        assert!(
            d.nav_problem().unwrap().contains("EKF"),
            "{:?}",
            d.nav_problem()
        );
        ready(&mut d, &mut sink, 1.0);
        assert!(d.frontseat_providing_data());
        let ns = sink.data.last().unwrap().node_status.clone().unwrap();
        assert!((ns.global_fix.lat - 42.358456).abs() < 1e-7);
        assert_eq!(
            ns.global_fix.depth,
            Some(2.5),
            "relative_alt -2.5 m is 2.5 m deep"
        );
        assert_eq!(ns.pose.heading, Some(90.0));
        assert!((ns.pose.pitch.unwrap() + 5.7296).abs() < 1e-3);
        assert!((ns.speed.over_ground - 1.5).abs() < 1e-9);
        feed(&mut d, &mut sink, "gps_nofix", 2.0);
        feed(&mut d, &mut sink, "pos_boston", 2.0);
        assert!(!d.frontseat_providing_data());
        assert!(d.nav_problem().unwrap().contains("GPS"));
        // SYS_STATUS: the GPS sensor present and enabled but not healthy.
        feed(&mut d, &mut sink, "gps_3d", 3.0);
        let gps = MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_GPS;
        let sick = MavMessage::SYS_STATUS(crate::dialect::SYS_STATUS_DATA {
            onboard_control_sensors_present: gps,
            onboard_control_sensors_enabled: gps,
            onboard_control_sensors_health: MavSysStatusSensor::empty(),
            ..Default::default()
        });
        d.handle_io(
            DriverIoEvent::Frame(codec::encode(1, 1, 0, &sick)),
            Duration::from_secs(3),
            &mut sink,
        );
        let n = sink.data.len();
        feed(&mut d, &mut sink, "pos_boston", 3.0);
        assert_eq!(sink.data.len(), n);
        assert!(
            d.nav_problem().unwrap().contains("SYS_STATUS"),
            "{:?}",
            d.nav_problem()
        );
    }

    #[test]
    fn bad_positions_wrong_systems_bad_crcs_and_floods_are_counted() {
        let (mut d, _rx, mut sink) = driver();
        ready(&mut d, &mut sink, 0.0);
        let published = d.counters.nav_published;
        feed(&mut d, &mut sink, "pos_zero", 0.1);
        feed(&mut d, &mut sink, "pos_out_of_range", 0.1);
        assert_eq!(d.counters.nav_refused, 2);
        assert_eq!(d.counters.nav_published, published);
        // The system id byte changed in place: the CRC no longer matches (bad input).
        let mut other = frame("pos_boston");
        other[5] = 42;
        let (_, msg) = codec::decode(&frame("pos_boston")).unwrap();
        let foreign = codec::encode(42, 1, 0, &msg);
        d.handle_io(DriverIoEvent::Frame(foreign), Duration::ZERO, &mut sink);
        assert_eq!(d.counters.foreign_system, 1);
        d.handle_io(DriverIoEvent::Frame(other), Duration::ZERO, &mut sink);
        let before = d.counters.bad_input;
        d.handle_io(
            DriverIoEvent::BadInput("MAVLink: bad CRC".into()),
            Duration::ZERO,
            &mut sink,
        );
        for _ in 0..10_000 {
            d.handle_io(
                DriverIoEvent::Frame(vec![0xFD, 1, 2]),
                Duration::ZERO,
                &mut sink,
            );
        }
        assert!(d.counters.bad_input >= before + 10_001);
        let nan = MavMessage::ATTITUDE(crate::dialect::ATTITUDE_DATA {
            roll: f32::NAN,
            ..Default::default()
        });
        d.handle_io(
            DriverIoEvent::Frame(codec::encode(1, 1, 0, &nan)),
            Duration::ZERO,
            &mut sink,
        );
        assert!(d.counters.bad_input >= before + 10_002);
        assert_eq!(
            d.frontseat_state(),
            FrontSeatState::FrontseatAcceptingCommands
        );
    }

    #[test]
    fn course_is_resent_at_5_hz_and_stops_when_the_helm_stops() {
        let (mut d, mut rx, mut sink) = driver();
        ready(&mut d, &mut sink, 0.0);
        sent(&mut rx);
        d.send_command_to_frontseat(&course(90.0, 2.0, 1), Duration::ZERO, &mut sink);
        let first = sent(&mut rx);
        let Some(MavMessage::SET_POSITION_TARGET_GLOBAL_INT(t)) = first.first() else {
            panic!("{first:?}")
        };
        assert_eq!(t.type_mask.bits(), 0x09C7);
        assert_eq!((t.vx, t.target_system, t.target_component), (2.0, 1, 1));
        assert!((t.yaw - std::f32::consts::FRAC_PI_2).abs() < 1e-6);
        let mut targets = 0;
        for i in 1..=20 {
            let now = Duration::from_millis(100 * i);
            if i % 10 == 0 {
                feed(&mut d, &mut sink, "hb_guided_armed", now.as_secs_f64());
                // The helm repeats its course (unchanged: no extra frame).
                let mut c = course(90.0, 2.0, 0);
                c.response_requested = None;
                d.send_command_to_frontseat(&c, now, &mut sink);
            }
            d.do_loop(now, &mut sink);
            targets += sent(&mut rx)
                .iter()
                .filter(|m| matches!(m, MavMessage::SET_POSITION_TARGET_GLOBAL_INT(_)))
                .count();
        }
        assert_eq!(targets, 10, "5 Hz for 2 s");
        // No refusal and still GUIDED at the verdict: the course is answered as done.
        assert_eq!(sink.responses.len(), 1);
        assert_eq!(sink.responses[0].request_successful, Some(true));
        // The helm falls silent after t = 2 s: after course_timeout (2 s more) nothing is sent.
        let mut late = 0;
        for i in 21..=50 {
            let now = Duration::from_millis(100 * i);
            if i % 10 == 0 {
                feed(&mut d, &mut sink, "hb_guided_armed", now.as_secs_f64());
            }
            d.do_loop(now, &mut sink);
            let n = sent(&mut rx)
                .iter()
                .filter(|m| matches!(m, MavMessage::SET_POSITION_TARGET_GLOBAL_INT(_)))
                .count();
            if i > 40 {
                late += n;
            }
        }
        assert_eq!(late, 0);
    }

    #[test]
    fn a_target_refused_by_mask_is_a_failed_response_with_the_statustext() {
        let (mut d, _rx, mut sink) = driver();
        ready(&mut d, &mut sink, 0.0);
        d.send_command_to_frontseat(&course(90.0, 2.0, 7), Duration::ZERO, &mut sink);
        feed(&mut d, &mut sink, "text_acc_ignore", 0.1);
        assert_eq!(sink.responses.len(), 1);
        let r = &sink.responses[0];
        assert_eq!((r.request_successful, r.request_id), (Some(false), Some(7)));
        assert!(r.error_string().contains("set ACC_IGNORE in mask"), "{r:?}");
    }

    #[test]
    fn courses_outside_guided_and_failsafe_to_hold_fail() {
        let (mut d, _rx, mut sink) = driver();
        feed(&mut d, &mut sink, "hb_hold_armed", 0.0);
        d.send_command_to_frontseat(&course(0.0, 1.0, 1), Duration::ZERO, &mut sink);
        assert!(
            sink.responses[0].error_string().contains("HOLD"),
            "{:?}",
            sink.responses
        );
        ready(&mut d, &mut sink, 0.0);
        d.send_command_to_frontseat(&course(0.0, 1.0, 2), Duration::ZERO, &mut sink);
        feed(&mut d, &mut sink, "hb_hold_failsafe", 0.2);
        assert_eq!(d.frontseat_state(), FrontSeatState::FrontseatInControl);
        let r = sink.responses.last().unwrap();
        assert_eq!((r.request_successful, r.request_id), (Some(false), Some(2)));
        assert!(r.error_string().contains("failsafe"), "{r:?}");
    }

    fn mode_request(action: Action, id: i32) -> ArdupilotCommandRequest {
        ArdupilotCommandRequest {
            response_requested: Some(true),
            request_id: Some(id),
            ardupilot_command: Some(ArdupilotCommand {
                action: Some(action as i32),
            }),
            ..Default::default()
        }
    }

    #[test]
    fn mode_commands_are_off_by_default_and_never_sent() {
        let (mut d, mut rx, mut sink) = driver();
        ready(&mut d, &mut sink, 0.0);
        sent(&mut rx);
        d.send_ardupilot_command(&mode_request(Action::Arm, 3), Duration::ZERO, &mut sink);
        assert!(sent(&mut rx).is_empty());
        assert_eq!(sink.responses[0].request_successful, Some(false));
        assert!(
            sink.responses[0]
                .error_string()
                .contains("allow_mode_commands")
        );
    }

    #[test]
    fn mode_commands_answered_from_command_ack_with_the_prearm_reason() {
        let (mut d, mut rx, mut sink) =
            driver_with(|c| c.driver.ardupilot.allow_mode_commands = true);
        feed(&mut d, &mut sink, "hb_manual_disarmed", 0.0);
        // GUIDED before the estimate is ready is refused here (README: it ends in an EKF failsafe).
        feed(&mut d, &mut sink, "ekf_backup", 0.0);
        d.send_ardupilot_command(&mode_request(Action::Guided, 1), Duration::ZERO, &mut sink);
        assert!(
            sink.responses[0]
                .error_string()
                .contains("not ready for GUIDED")
        );
        sent(&mut rx);
        d.send_ardupilot_command(&mode_request(Action::Arm, 2), Duration::ZERO, &mut sink);
        let c = sent(&mut rx);
        assert!(matches!(&c[..], [MavMessage::COMMAND_LONG(c)]
            if c.command == MavCmd::MAV_CMD_COMPONENT_ARM_DISARM && c.param1 == 1.0));
        feed(&mut d, &mut sink, "text_prearm", 0.1);
        feed(&mut d, &mut sink, "ack_arm_failed", 0.1);
        let r = sink.responses.last().unwrap();
        assert_eq!((r.request_successful, r.request_id), (Some(false), Some(2)));
        assert!(
            r.error_string().contains("PreArm: Hardware safety switch"),
            "{r:?}"
        );
        ready(&mut d, &mut sink, 1.0);
        d.send_ardupilot_command(
            &mode_request(Action::Guided, 3),
            Duration::from_secs(1),
            &mut sink,
        );
        let c = sent(&mut rx);
        assert!(c.iter().any(|m| matches!(m, MavMessage::COMMAND_LONG(c)
            if c.command == MavCmd::MAV_CMD_DO_SET_MODE && c.param1 == 1.0 && c.param2 == 15.0)));
        feed(&mut d, &mut sink, "ack_mode_accepted", 1.1);
        let r = sink.responses.last().unwrap();
        assert_eq!((r.request_successful, r.request_id), (Some(true), Some(3)));
        // An unanswered one times out.
        d.send_ardupilot_command(
            &mode_request(Action::Hold, 4),
            Duration::from_secs(2),
            &mut sink,
        );
        d.do_loop(Duration::from_secs(6), &mut sink);
        let r = sink.responses.last().unwrap();
        assert_eq!((r.request_successful, r.request_id), (Some(false), Some(4)));
        assert_eq!(d.counters.ack_timeouts, 1);
    }

    #[test]
    fn raw_send_takes_only_whole_checked_frames() {
        let (mut d, mut rx, mut sink) = driver();
        sent(&mut rx);
        let good = Raw {
            raw: Some(frame("hb_gcs")),
            ..Default::default()
        };
        d.send_raw_to_frontseat(&good, Duration::ZERO, &mut sink);
        assert_eq!(sent(&mut rx).len(), 1);
        let mut broken = frame("hb_gcs");
        broken.pop();
        d.send_raw_to_frontseat(
            &Raw {
                raw: Some(broken),
                ..Default::default()
            },
            Duration::ZERO,
            &mut sink,
        );
        assert!(sent(&mut rx).is_empty());
        assert_eq!(d.counters.bad_input, 1);
    }

    #[test]
    fn every_pymavlink_fixture_decodes() {
        for line in FIXTURE.lines().filter(|l| !l.starts_with('#')) {
            let name = line.split(' ').next().unwrap();
            assert!(codec::decode(&frame(name)).is_ok(), "{name}");
        }
    }
}

#[cfg(test)]
#[path = "sub_driver_tests.rs"]
mod sub_tests;
