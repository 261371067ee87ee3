//! The driver's one state, which every other module of the driver acts on: the
//! [`ArdupilotDriver`] value and its counters, the helm's course and the Sub's local position as
//! kept, and the few things all of them do alike (write a frame, count bad input, say the mode in
//! words).

use std::sync::Arc;
use std::time::Duration;

use crate::codec::{MavMessage, Sender};

use super::steer::{DirectTarget, Steer};
use crate::dialect::{
    COMMAND_LONG_DATA, EkfStatusFlags, GpsFixType, LOCAL_POSITION_NED_DATA, MavCmd,
};
use crate::infer::Beat;
use crate::modes::Firmware;

use super::settings::Settings;
use frontseat_actors::driver::SignalSink;
use frontseat_actors::drivers::kit::{
    AckQueue, DataWatch, OwnedTask, log_due, raw_binary, send_bytes,
};
use frontseat_actors::link::LineWriter;
use frontseat_actors::link::byte::LinkStats;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::FrontSeatState;
use frontseat_actors::ratelog::RateLimitedLog;

/// Requests awaiting a verdict at most (older ones are answered as failed).
pub(super) const MAX_PENDING: usize = 64;
/// Half of the driver loop's 10 Hz period.
pub(super) const LOOP_SLACK: Duration = Duration::from_millis(50);

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
pub(super) struct Course {
    pub(super) heading: f64,
    pub(super) speed: f64,
    pub(super) depth: Option<f64>,
    /// When the helm last gave it.
    pub(super) renewed: Duration,
    pub(super) sent: Option<Duration>,
}

/// LOCAL_POSITION_NED's position: north, east, down (m).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Local {
    pub(super) x: f32,
    pub(super) y: f32,
    pub(super) z: f32,
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
pub(super) type Pending = Option<MavCmd>;

pub struct ArdupilotDriver {
    pub(super) settings: Settings,
    pub(super) writer: Option<LineWriter>,
    pub(super) link_task: OwnedTask,
    pub link_stats: Arc<LinkStats>,
    /// The MAVLink framer and the steering snapshot, shared with the lane's [`DirectTarget`].
    pub(super) steer: Steer,
    /// While a (non-UDP) link is open: the setpoint lane's way to it.
    pub(super) direct: Option<Arc<DirectTarget>>,
    /// The autopilot (system, component) spoken to: configured, or the first heard.
    pub(super) vehicle: Option<(u8, u8)>,
    pub(super) beat: Option<Beat>,
    pub(super) last_heartbeat: Option<Duration>,
    pub(super) state: FrontSeatState,
    pub(super) streams_requested: bool,
    pub(super) own_heartbeat_at: Option<Duration>,
    pub(super) ekf: Option<EkfStatusFlags>,
    pub(super) gps_fix: Option<GpsFixType>,
    /// SYS_STATUS says the GPS is present and enabled but unhealthy.
    pub(super) gps_unhealthy: bool,
    pub(super) attitude: Option<(f64, f64, f64)>,
    /// Usable positions.
    pub(super) nav: DataWatch,
    pub(super) nav_problem: Option<String>,
    pub(super) course: Option<Course>,
    pub(super) pending: AckQueue<Pending>,
    pub(super) last_text: Option<(Duration, String)>,
    /// The latest warning-or-worse STATUSTEXT ("Leak Detected", "… heartbeat lost").
    pub(super) serious_text: Option<(Duration, String)>,
    /// Why the frontseat state is what it is, in words (mode, arming, failsafe and its text).
    pub(super) reason: String,
    /// Sub: the latest LOCAL_POSITION_NED (north, east, down m; as sent, unchecked).
    pub(super) local: Option<Local>,
    /// Sub: when the last MANUAL_CONTROL went out, and whether it carried thrust.
    pub(super) manual_at: Option<Duration>,
    pub(super) thrusting: bool,
    /// Sub in ALT_HOLD: when the depth target last went out, and which.
    pub(super) depth_sent: Option<(Duration, f64)>,
    pub(super) bad_log: RateLimitedLog,
    pub(super) text_log: RateLimitedLog,
    pub counters: ArdupilotCounters,
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
            steer: Steer::new(tx),
            direct: None,
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

    pub(super) fn mode_words(&self) -> String {
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

    pub(super) fn bad(&mut self, what: &str) {
        self.counters.bad_input += 1;
        frontseat_actors::drivers::kit::bad_line();
        if let Some(suppressed) = log_due(&mut self.bad_log) {
            tracing::warn!(target: super::LOG_TARGET, %what, suppressed, "bad input from the ArduPilot vehicle");
        }
    }

    /// Frames `msg` and hands it to the link under the framer's lock, which the lane's writes
    /// take too: sequence numbers enter the link in order.
    pub(super) fn write(&mut self, msg: &MavMessage, sig: &mut dyn SignalSink) -> bool {
        let Some(w) = &self.writer else {
            self.counters.write_failures += 1;
            return false;
        };
        let sent = {
            let mut st = self.steer.lock();
            let frame = st.tx.frame(msg);
            w.write_bytes(frame.clone()).map(|()| frame)
        };
        match sent {
            Ok(frame) => {
                sig.raw_to_frontseat(raw_binary(frame));
                true
            }
            Err(e) => {
                self.counters.write_failures += 1;
                if let Some(suppressed) = log_due(&mut self.bad_log) {
                    tracing::warn!(target: super::LOG_TARGET, error = %e, suppressed, "MAVLink frame to the vehicle not sent");
                }
                false
            }
        }
    }

    pub(super) fn write_bytes(&mut self, frame: Vec<u8>, sig: &mut dyn SignalSink) -> bool {
        let Some(w) = &self.writer else {
            self.counters.write_failures += 1;
            return false;
        };
        match send_bytes(w, frame, sig) {
            Ok(()) => true,
            Err(e) => {
                self.counters.write_failures += 1;
                if let Some(suppressed) = log_due(&mut self.bad_log) {
                    tracing::warn!(target: super::LOG_TARGET, error = %e, suppressed, "MAVLink frame to the vehicle not sent");
                }
                false
            }
        }
    }

    pub(super) fn command_long(
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

    pub(super) fn is_sub(&self) -> bool {
        self.settings.firmware == Firmware::Sub
    }
}
