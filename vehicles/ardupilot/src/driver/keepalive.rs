//! What the driver sends without a helm asking, so the vehicle knows we are alive and talks to
//! us: our own HEARTBEAT (at once on connecting, then every second while the link is open), the
//! stream requests once the vehicle is heard, and the Sub's neutral MANUAL_CONTROL that feeds its
//! pilot-input failsafe. None of it goes out while we are gone: the vehicle's failsafes stay its
//! watchdog on us.

use std::time::Duration;

use crate::codec::MavMessage;
use crate::dialect::{HEARTBEAT_DATA, MavAutopilot, MavCmd, MavModeFlag, MavState, MavType};
use crate::infer;

use super::state::{ArdupilotDriver, LOOP_SLACK};
use frontseat_actors::driver::SignalSink;

/// How often the Sub's neutral MANUAL_CONTROL goes out (ArduSub disarms 3 s after the last).
const KEEPALIVE_PERIOD: Duration = Duration::from_millis(500);

impl ArdupilotDriver {
    pub(super) fn own_heartbeat(&mut self, now: Duration, sig: &mut dyn SignalSink) {
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

    pub(super) fn request_streams(&mut self, sig: &mut dyn SignalSink) {
        self.streams_requested = true;
        for (id, hz) in self.settings.streams.clone() {
            let us = (1e6 / hz).round() as f32;
            self.command_long(MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL, id as f32, us, sig);
        }
    }

    /// The neutral MANUAL_CONTROL that feeds ArduSub's pilot-input failsafe, while the link is
    /// up and the vehicle heard (so if we die or lose it, the vehicle's failsafe acts).
    pub(super) fn keepalive(&mut self, now: Duration, sig: &mut dyn SignalSink) {
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
}
