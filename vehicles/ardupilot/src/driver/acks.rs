//! Requests awaiting a verdict: a mode or arming command waits for its COMMAND_ACK (with the
//! vehicle's STATUSTEXT as the reason of a refusal) or times out; a course is judged at its
//! deadline by whether the vehicle still accepts commands, and fails at once when the vehicle
//! leaves its commanded mode or refuses the target in words.

use std::time::Duration;

use crate::dialect::{MavCmd, MavResult};

use super::state::{ArdupilotDriver, Pending};
use frontseat_actors::driver::SignalSink;
use frontseat_actors::drivers::kit::{Awaiting, TIMED_OUT};
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::FrontSeatState;

impl ArdupilotDriver {
    pub(super) fn push_pending(&mut self, p: Awaiting<Pending>, sig: &mut dyn SignalSink) {
        self.pending
            .push(p, "too many requests awaiting a verdict", sig);
    }

    pub(super) fn fail_course_verdicts(&mut self, why: &str, sig: &mut dyn SignalSink) {
        for p in self.pending.take_all(|command| command.is_none()) {
            p.asker.fail(sig, 4, why);
        }
    }

    pub(super) fn on_ack(
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
                tracing::debug!(target: super::LOG_TARGET, ?command, ?result, "COMMAND_ACK not accepted");
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

    /// Each loop tick: the verdicts whose deadline came.
    pub(super) fn judge_due(&mut self, now: Duration, sig: &mut dyn SignalSink) {
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
}
