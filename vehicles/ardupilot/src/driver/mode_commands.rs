//! The ArduPilot CommandRequest extension: GUIDED, HOLD, arm and disarm as COMMAND_LONGs, sent
//! only with `allow_mode_commands` (the driver never arms or changes mode on its own), GUIDED only
//! once navigation is usable, a course riding along passed on to the course path.

use std::time::Duration;

use crate::dialect::MavCmd;

use super::state::ArdupilotDriver;
use frontseat_actors::driver::{Driver, SignalSink};
use frontseat_actors::drivers::kit::{Asker, Awaiting, base_command, refuse};
use frontseat_actors::proto::frontseat::protobuf::ardupilot::{
    CommandRequest as ArdupilotCommandRequest, ardupilot_command::Action,
};

/// The type of our ArduPilot extension (field 1002), as its group declares it.
pub const COMMAND: &str =
    frontseat_actors::groups::FRONTSEAT_ARDUPILOT_ARDUPILOT_COMMAND_REQUEST.type_name();

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
