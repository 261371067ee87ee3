//! What the vehicle's HEARTBEATs make of the frontseat state: the mode table (and the Sub's
//! ALT_HOLD switch) to control, the reason in words (with the vehicle's recent warning), what a
//! change of mode ends (the course, its verdicts, the Sub's thrust), and silence as not
//! connected.

use std::time::Duration;

use crate::infer::{self, Beat};
use crate::modes::{Control, sub};

use super::state::ArdupilotDriver;
use frontseat_actors::driver::SignalSink;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::FrontSeatState;

/// A STATUSTEXT this recent explains a failsafe or a disarm.
const REASON_TEXT_AGE: Duration = Duration::from_secs(10);

impl ArdupilotDriver {
    pub(super) fn control_of(&self, mode: u32) -> Control {
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

    /// The vehicle's recent warning-or-worse words, to explain a failsafe or a disarm.
    pub(super) fn recent_serious_text(&self, now: Duration) -> Option<&str> {
        self.serious_text
            .as_ref()
            .filter(|(t, _)| now.saturating_sub(*t) <= REASON_TEXT_AGE)
            .map(|(_, s)| s.as_str())
    }

    pub(super) fn on_heartbeat(&mut self, beat: Beat, now: Duration, sig: &mut dyn SignalSink) {
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
                tracing::warn!(target: super::LOG_TARGET, reason = %self.reason, state = ?state, "ArduPilot vehicle no longer accepts commands");
            } else {
                tracing::info!(target: super::LOG_TARGET, reason = %self.reason, state = ?state, "ArduPilot vehicle state");
            }
        }
        // Another commanded mode (GUIDED ↔ ALT_HOLD) takes other messages: start afresh.
        let mode_changed = previous.is_some_and(|p| p.mode != beat.mode);
        self.state = state;
        if (control != Control::AcceptingCommands || mode_changed) && self.course.take().is_some() {
            // Targets are ignored outside the commanded modes: stop sending them, and say so to
            // whoever waits.
            tracing::warn!(target: super::LOG_TARGET, reason = %self.reason, "no longer sending the helm's course");
            let why = format!("vehicle left its commanded mode: {}", self.reason);
            self.fail_course_verdicts(&why, sig);
            self.stop_thrust(now, sig);
        }
        if !self.streams_requested {
            self.request_streams(sig);
        }
    }

    pub(super) fn heartbeat_lost(&mut self, sig: &mut dyn SignalSink) {
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
