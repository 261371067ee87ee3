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
//!
//! One state (`state`) and the modules that act on it, each owning one part: `settings` (the
//! config, the framing), `inbound` (frame → the part that owns the message), `heartbeat`
//! (state inference), `navigation` (NodeStatus), `keepalive` (what goes out unasked),
//! `course` and `sub_course` (the helm's course: Rover, Sub), `lane` (the setpoint lane's course
//! taken in before each message, its snapshot published after; what the lane shares and writes
//! with: `steer`), `mode_commands` (the extension), `acks` (verdicts). This file is the runtime's
//! `Driver` trait over them.

/// Log lines keep the target this module had as one file, whatever part now writes them:
/// operators filter and grep on it.
const LOG_TARGET: &str = "frontseat_ardupilot::driver";

use std::sync::Arc;
use std::time::Duration;

use crate::codec;
use frontseat_actors::driver::{
    DirectCommand, Driver, DriverContext, DriverExtension, DriverIoEvent, SignalSink,
};
use frontseat_actors::drivers::kit::own_extension;
use frontseat_actors::link::byte;
use frontseat_actors::proto::frontseat::protobuf::ardupilot::CommandRequest as ArdupilotCommandRequest;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CommandRequest, FrontSeatState, InterfaceData, Raw,
};

mod acks;
mod course;
mod heartbeat;
mod inbound;
mod keepalive;
mod lane;
mod mode_commands;
mod navigation;
mod settings;
mod state;
mod steer;
mod sub_course;

pub use mode_commands::COMMAND;
pub use settings::{Settings, mavlink_frames};
pub use state::{ArdupilotCounters, ArdupilotDriver};

/// A raw_send_request larger than this is not a handful of MAVLink frames.
const MAX_RAW_BYTES: usize = 16 * codec::MAX_FRAME;

impl Driver for ArdupilotDriver {
    fn send_extension(&mut self, ext: &DriverExtension, now: Duration, sig: &mut dyn SignalSink) {
        self.absorb(now);
        if let Some(r) = own_extension::<ArdupilotCommandRequest>(ext, COMMAND, sig, self.name()) {
            self.send_ardupilot_command(&r, now, sig);
        }
        self.publish_steer(now);
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
                target: LOG_TARGET,
                address = %self.settings.address,
                "ArduPilot address does not parse (tcpout:HOST:PORT, udpin:ADDR:PORT, udpout:HOST:PORT, serial:PATH:BAUD); not connecting"
            ),
        }
    }

    fn handle_io(&mut self, ev: DriverIoEvent, now: Duration, sig: &mut dyn SignalSink) {
        self.absorb(now);
        self.io_event(ev, now, sig);
        self.publish_steer(now);
    }

    fn send_command_to_frontseat(
        &mut self,
        req: &CommandRequest,
        now: Duration,
        sig: &mut dyn SignalSink,
    ) {
        self.absorb(now);
        self.take_course(req, now, sig);
        self.publish_steer(now);
    }

    fn send_data_to_frontseat(
        &mut self,
        _data: &InterfaceData,
        _now: Duration,
        _sig: &mut dyn SignalSink,
    ) {
        // No data channel to the autopilot.
    }

    fn send_raw_to_frontseat(&mut self, raw: &Raw, now: Duration, sig: &mut dyn SignalSink) {
        self.absorb(now);
        self.raw_send(raw, sig);
        self.publish_steer(now);
    }

    fn do_loop(&mut self, now: Duration, sig: &mut dyn SignalSink) {
        self.absorb(now);
        self.tick(now, sig);
        self.publish_steer(now);
    }

    fn direct_command(&self) -> Option<Arc<dyn DirectCommand>> {
        self.direct()
    }

    fn frontseat_state(&self) -> FrontSeatState {
        self.state
    }

    fn frontseat_providing_data(&self) -> bool {
        self.nav.providing()
    }

    fn stop(&mut self) {
        self.writer = None;
        self.close_lane();
    }
}

/// The driver's work per message, between [`ArdupilotDriver::absorb`] (the lane's course taken
/// in) and [`ArdupilotDriver::publish_steer`] (the lane's snapshot).
impl ArdupilotDriver {
    fn io_event(&mut self, ev: DriverIoEvent, now: Duration, sig: &mut dyn SignalSink) {
        match ev {
            DriverIoEvent::Connected(w) => {
                tracing::info!(target: LOG_TARGET, address = %self.settings.address, "MAVLink link open");
                self.open_lane(&w);
                self.writer = Some(w);
                self.streams_requested = false;
                // A companion announces itself; SITL's first serial port starts talking on it.
                self.own_heartbeat(now, sig);
            }
            DriverIoEvent::Frame(b) => self.on_frame(b, now, sig),
            DriverIoEvent::Line(_) => self.bad("text line on a MAVLink link"),
            DriverIoEvent::BadInput(what) => self.bad(&what),
            DriverIoEvent::Disconnected(reason) => {
                tracing::warn!(target: LOG_TARGET, %reason, "MAVLink link lost; reopening");
                self.writer = None;
                self.close_lane();
                self.heartbeat_lost(sig);
            }
        }
    }

    fn raw_send(&mut self, raw: &Raw, sig: &mut dyn SignalSink) {
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

    fn tick(&mut self, now: Duration, sig: &mut dyn SignalSink) {
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
                target: LOG_TARGET,
                "no HEARTBEAT from the vehicle for {:?}: not connected",
                self.settings.heartbeat_timeout
            );
            self.heartbeat_lost(sig);
        }
        if self.nav.expired(now, self.settings.heartbeat_timeout) {
            tracing::warn!(target: LOG_TARGET, "no usable position from the vehicle: not providing data");
        }
        self.resend_course(now, sig);
        if self.is_sub() {
            self.keepalive(now, sig);
        }
        self.judge_due(now, sig);
    }
}

#[cfg(test)]
mod test_link;

#[cfg(test)]
mod tests;

#[cfg(test)]
mod sub_tests;
