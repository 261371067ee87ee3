//! What a helm asks of the vehicle: a command (desired_course, command_request) through the state
//! gate and the safety envelope (`command_gate`), the pending table of commands awaiting the
//! frontseat's answer and our own answers when none comes, the driver's answers forwarded, and
//! Goby3's raw backdoor through the raw gate.

use std::sync::Arc;

use crate::bus::Envelope;
use crate::command_gate::check_course;
use crate::proto::goby::middleware::frontseat::protobuf::{
    CommandRequest, CommandResponse, InterfaceState, Raw,
};
use crate::ratelog::{LogDecision, more};
use crate::raw_gate::{check_raw, source_name, source_of};
use crate::state_machine::state_words;

use super::messages::error_code;
use super::state::FsiState;

impl FsiState {
    pub(super) fn refuse(&self, req: &CommandRequest, code: i32, why: String) {
        if req.response_requested() {
            self.ports.publish_command_response(CommandResponse {
                request_successful: Some(false),
                request_id: req.request_id,
                error_code: Some(code),
                error_string: Some(why),
            });
        }
    }

    pub(super) fn handle_command(&mut self, env: Envelope<CommandRequest>) {
        if self.shutting_down || self.sm.state() != InterfaceState::InterfaceCommand {
            self.refuse_gated(&env.msg, "command");
            return;
        }
        let Some(env) = self.through_envelope(env) else {
            return;
        };
        if env.msg.response_requested() {
            self.pending
                .insert(env.msg.request_id, self.now() + self.s.command_timeout);
        }
        // The lane's fence rides on to the driver (crate::setpoint_lane).
        self.ports
            .publish_command_request_held(env.msg.clone(), env.meta(), env.held());
    }

    /// Refuses and counts a request the state gate stops: shutting down, or not in the state(s)
    /// it `needs` ("command", "listen or command"). One wording for every kind of request.
    pub(super) fn refuse_gated(&mut self, req: &CommandRequest, needs: &str) {
        self.counters.commands_gated += 1;
        let state = state_words(self.sm.state());
        let (code, why) = if self.shutting_down {
            (
                error_code::SHUTTING_DOWN,
                "interface shutting down".to_string(),
            )
        } else {
            (
                error_code::NOT_IN_COMMAND,
                format!("not in {needs} state (state: {state})"),
            )
        };
        tracing::debug!(target: super::LOG_TARGET, state, reason = %why, "command dropped");
        self.refuse(req, code, why);
    }

    /// The safety envelope (command_gate): the request with its course made safe (heading
    /// wrapped or filled in), or None after answering and counting the refusal.
    pub(super) fn through_envelope(
        &mut self,
        env: Envelope<CommandRequest>,
    ) -> Option<Envelope<CommandRequest>> {
        let Some(course) = env.msg.desired_course.as_ref() else {
            return Some(env);
        };
        match check_course(course, &self.s.limits, &self.lane.gate()) {
            Ok(safe) => {
                frontseat_telemetry::metrics::VehicleMetrics::add(&self.metrics.setpoints_sent);
                self.lane.commanded(safe.heading);
                if safe == *course {
                    return Some(env);
                }
                let mut req = *env.msg;
                req.desired_course = Some(safe);
                Some(Envelope::rewrap(env, req))
            }
            Err(r) => {
                self.counters.setpoints_refused += 1;
                match self.refused_log.decide_at(self.now()) {
                    LogDecision::Log { suppressed_before } => tracing::warn!(
                        target: super::LOG_TARGET,
                        field = r.field,
                        value = r.value,
                        refused_total = self.counters.setpoints_refused,
                        "setpoint refused by the safety envelope: {r}{}",
                        more(
                            suppressed_before,
                            "refused setpoints",
                            self.refused_log.window()
                        )
                    ),
                    LogDecision::Suppress => {}
                }
                self.refuse(
                    &env.msg,
                    error_code::OUTSIDE_ENVELOPE,
                    format!("refused by the safety envelope: {r}"),
                );
                None
            }
        }
    }

    /// Goby3's raw backdoor, through the raw gate (raw_gate): one line or frame, from an allowed
    /// source, in listen or command; every one counted and logged (rate-limited).
    pub(super) fn handle_raw_send(&mut self, env: Envelope<Raw>) {
        let source = source_of(env.origin);
        let checked = check_raw(&env.msg, source, &self.s.raw);
        let raw = match checked {
            Err(why) => {
                self.counters.raw_refused += 1;
                if let LogDecision::Log { suppressed_before } =
                    self.raw_refused_log.decide_at(self.now())
                {
                    tracing::warn!(
                        target: super::LOG_TARGET,
                        source = source_name(source),
                        raw_refused_total = self.counters.raw_refused,
                        "raw_send_request refused: {why}: {:?}{}",
                        frontseat_telemetry::truncate(&String::from_utf8_lossy(
                            env.msg.raw.as_deref().unwrap_or_default()
                        )),
                        more(
                            suppressed_before,
                            "refused raw sends",
                            self.raw_refused_log.window()
                        )
                    );
                }
                return;
            }
            Ok(raw) => raw,
        };
        if !self.listen_or_command() {
            self.counters.raw_gated += 1;
            tracing::debug!(target: super::LOG_TARGET, "raw_send_request dropped: not in listen or command");
            return;
        }
        self.counters.raw_sent += 1;
        if let LogDecision::Log { suppressed_before } = self.raw_log.decide_at(self.now()) {
            tracing::info!(
                target: super::LOG_TARGET,
                source = source_name(source),
                raw_sent_total = self.counters.raw_sent,
                "raw_send_request to the frontseat: {:?}{}",
                frontseat_telemetry::truncate(&String::from_utf8_lossy(
                    raw.raw.as_deref().unwrap_or_default()
                )),
                more(suppressed_before, "raw sends", self.raw_log.window())
            );
        }
        self.ports
            .publish_raw_send_request_held(Arc::new(raw), env.meta(), env.held());
    }

    /// Every answer a driver gives reaches the helm, whenever it comes, as in Goby3
    /// (frontseat_interface.cpp:205-208): a Bluefin "pending" and then its ack are two answers.
    /// The pending table only decides whether our own timeout still has to answer.
    pub(super) fn handle_driver_response(&mut self, env: Envelope<CommandResponse>) {
        let key = env.msg.request_id;
        if self.pending.remove(&key).is_some() {
            self.sm.command_result(env.msg.request_successful());
        } else {
            // After our timeout answered, a restart, or a second answer to the same request.
            self.counters.late_responses += 1;
            tracing::debug!(target: super::LOG_TARGET, request_id = ?key, "late or further command response forwarded");
        }
        self.ports
            .publish_command_response_with(env.msg.clone(), env.meta());
    }

    pub(super) fn fail_pending(&mut self, code: i32, why: &str, only_expired: bool) {
        let now = self.now();
        let expired: Vec<Option<i32>> = self
            .pending
            .iter()
            .filter(|(_, deadline)| !only_expired || **deadline <= now)
            .map(|(k, _)| *k)
            .collect();
        for k in expired {
            self.pending.remove(&k);
            self.ports.publish_command_response(CommandResponse {
                request_successful: Some(false),
                request_id: k,
                error_code: Some(code),
                error_string: Some(why.to_string()),
            });
        }
    }
}
