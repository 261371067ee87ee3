//! What the DUNE vehicle says, read: each IMC packet checked for its sender (our own echoes, a
//! vehicle found by its first VehicleState, foreign senders), VehicleState into the frontseat
//! state with its reason, EstimatedState into NodeStatus while it is sane and the navigation
//! entity is healthy, and the plan engine's answers about our plan.

use std::time::Duration;

use super::{DuneDriver, Plan, START_GRACE};
use crate::imc::{self, ImcError, Message, consts};
use crate::infer::{self, Control};
use frontseat_actors::clock::SimClock;
use frontseat_actors::driver::SignalSink;
use frontseat_actors::drivers::kit::{log_due, raw_binary};
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    EulerAngles, FrontSeatState, InterfaceData, NodeStatus, Speed,
};
use frontseat_actors::proto::goby::middleware::protobuf::LatLonPoint;

impl DuneDriver {
    pub(super) fn on_packet(&mut self, bytes: Vec<u8>, now: Duration, sig: &mut dyn SignalSink) {
        let decoded = imc::decode(&bytes);
        sig.raw_from_frontseat(raw_binary(bytes));
        let (h, msg) = match decoded {
            Ok(x) => x,
            Err(e @ ImcError::UnknownMessage(_)) => {
                // DUNE streams many messages a frontseat has no use for: counted, not logged.
                self.counters.unknown_messages += 1;
                let _ = e;
                return;
            }
            Err(e) => return self.bad(&e.to_string()),
        };
        self.counters.packets += 1;
        if h.src == self.settings.own_id {
            // `Loopback Internal Messages`: our PlanControl and References come back.
            self.counters.own_echoes += 1;
            return;
        }
        if self.vehicle_id.is_none() {
            if let Message::VehicleState(_) = msg
                && h.src != imc::NULL_ADDRESS
                && h.src != 0
            {
                tracing::info!(
                    target: super::LOG_TARGET,
                    imc_id = format_args!("{:#06x}", h.src),
                    "DUNE vehicle found"
                );
                self.vehicle_id = Some(h.src);
            } else {
                self.counters.ignored += 1;
                return;
            }
        }
        let vehicle = self.vehicle_id.unwrap_or_default();
        if h.src != vehicle {
            match msg {
                Message::VehicleState(_)
                | Message::EstimatedState(_)
                | Message::PlanControlState(_)
                | Message::FollowRefState(_)
                | Message::GpsFix(_) => {
                    self.counters.foreign += 1;
                    self.bad(&format!(
                        "{} from IMC id {:#06x}, not the vehicle ({vehicle:#06x}): ignored",
                        msg.name(),
                        h.src
                    ));
                }
                _ => self.counters.ignored += 1,
            }
            return;
        }
        match msg {
            Message::VehicleState(vs) => self.on_vehicle_state(vs, now, sig),
            Message::EstimatedState(e) => self.on_estimated_state(&e, now, sig),
            Message::PlanControlState(p) => {
                self.pcs = Some(p);
            }
            Message::PlanControl(p) => self.on_plan_control(&p, h.dst, now),
            Message::FollowRefState(f) => {
                if f.state == consts::follow_ref_state::TIMEOUT
                    && f.control_src == self.settings.own_id
                {
                    tracing::warn!(target: super::LOG_TARGET, "DUNE: FollowReference timed out waiting for our References");
                }
            }
            Message::EntityInfo(e) => {
                if e.label == self.settings.navigation_entity {
                    self.nav_entity = Some(e.id);
                }
            }
            Message::EntityList(l) => {
                if let Some(id) = entity_id(&l.list, &self.settings.navigation_entity) {
                    self.nav_entity = Some(id);
                }
            }
            Message::EntityState(es) => {
                if Some(h.src_ent) == self.nav_entity && !self.settings.navigation_entity.is_empty()
                {
                    let fault = (es.state >= consts::entity_state::ERROR).then(|| {
                        format!(
                            "entity {} in {}: {}",
                            self.settings.navigation_entity,
                            match es.state {
                                consts::entity_state::ERROR => "ERROR",
                                _ => "FAILURE",
                            },
                            es.description
                        )
                    });
                    if fault != self.nav_entity_fault {
                        tracing::warn!(target: super::LOG_TARGET, ?fault, "DUNE navigation entity");
                    }
                    self.nav_entity_fault = fault;
                }
            }
            Message::Abort(_) => {
                tracing::warn!(target: super::LOG_TARGET, "DUNE: an Abort is on the vehicle's bus");
            }
            _ => self.counters.ignored += 1,
        }
    }

    fn on_vehicle_state(&mut self, vs: imc::VehicleState, now: Duration, sig: &mut dyn SignalSink) {
        self.counters.vehicle_states += 1;
        self.last_vs = Some(now);
        let in_followref =
            vs.op_mode == consts::op_mode::MANEUVER && vs.maneuver_type == infer::FOLLOW_REFERENCE;
        let pcs_ours = self
            .pcs
            .as_ref()
            .is_some_and(|p| p.plan_id == self.settings.plan_id);
        // State sent before our own STOP arrived is not a plan to take back.
        let after_stop = self
            .last_stop
            .is_none_or(|t| now.saturating_sub(t) > START_GRACE);
        if self.plan.is_none() && in_followref && pcs_ours && after_stop {
            // Our plan from before a reconnection (or a restart) is still running: take it
            // back, so it is steered, or ended, rather than left to its timeout.
            tracing::info!(target: super::LOG_TARGET, "DUNE: our FollowReference plan is running; taking it back");
            self.plan = Some(Plan {
                started: now,
                request_id: self.request_id,
                confirmed: true,
                last_reference: None,
            });
        }
        if let Some(p) = &mut self.plan {
            if in_followref {
                p.confirmed = true;
            } else if p.confirmed || now.saturating_sub(p.started) > START_GRACE {
                let why = if vs.last_error.is_empty() {
                    format!("vehicle left the maneuver (op_mode {})", vs.op_mode)
                } else {
                    format!(
                        "vehicle left the maneuver (op_mode {}): {}",
                        vs.op_mode, vs.last_error
                    )
                };
                self.plan_ended(&why);
            }
        }
        let blocked = self.pcs.as_ref().is_some_and(|p| {
            p.state == consts::pcs::BLOCKED && vs.op_mode == consts::op_mode::SERVICE
        });
        let (control, why) = infer::control(&vs, blocked, self.ours());
        let state = match control {
            Control::AcceptingCommands => FrontSeatState::FrontseatAcceptingCommands,
            Control::InControl => FrontSeatState::FrontseatInControl,
            Control::Idle => FrontSeatState::FrontseatIdle,
        };
        self.vs = Some(vs);
        self.set_state(state, why);
        if state != FrontSeatState::FrontseatAcceptingCommands && self.course.take().is_some() {
            tracing::warn!(target: super::LOG_TARGET, why = %self.why, "DUNE vehicle no longer takes our course");
        }
        let _ = sig;
    }

    fn on_plan_control(&mut self, p: &imc::PlanControl, dst: u16, _now: Duration) {
        if p.kind == consts::plan_control::REQUEST
            || p.plan_id != self.settings.plan_id
            || (dst != self.settings.own_id && dst != imc::NULL_ADDRESS)
        {
            self.counters.ignored += 1;
            return;
        }
        match p.kind {
            consts::plan_control::FAILURE => {
                let why = format!("vehicle: {}", p.info);
                self.plan_ended(&why);
            }
            consts::plan_control::SUCCESS
                if p.info.contains("completed") || p.op == consts::plan_control::STOP =>
            {
                self.plan.take();
            }
            _ => {
                if let Some(suppressed) = log_due(&mut self.info_log) {
                    tracing::info!(target: super::LOG_TARGET, info = %p.info, suppressed, "DUNE plan engine");
                }
            }
        }
    }

    fn on_estimated_state(
        &mut self,
        e: &imc::EstimatedState,
        now: Duration,
        sig: &mut dyn SignalSink,
    ) {
        let pos = match infer::position(e) {
            Ok(p) => p,
            Err(why) => {
                self.counters.nav_refused += 1;
                self.position = None;
                self.nav.lost();
                return self.bad(&format!("EstimatedState refused: {why}"));
            }
        };
        self.position = Some(pos);
        if let Some(why) = self.nav_entity_fault.clone() {
            if self.nav_problem.as_deref() != Some(why.as_str()) {
                tracing::warn!(target: super::LOG_TARGET, %why, "DUNE navigation not usable: not providing data");
            }
            self.nav_problem = Some(why);
            self.nav.lost();
            self.counters.nav_refused += 1;
            return;
        }
        if self.nav_problem.take().is_some() {
            tracing::info!(target: super::LOG_TARGET, "DUNE navigation usable again");
        }
        let ns = NodeStatus {
            time: SimClock::unix_now(),
            global_fix: LatLonPoint {
                lat: pos.lat,
                lon: pos.lon,
                depth: Some(pos.depth),
                altitude: pos.altitude,
            },
            pose: EulerAngles {
                heading: Some(pos.heading),
                roll: Some(pos.roll),
                pitch: Some(pos.pitch),
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
}

/// `Name=id;Name=id` (EntityList) → the id of `name`.
fn entity_id(list: &str, name: &str) -> Option<u8> {
    list.split(';')
        .filter_map(|kv| kv.split_once('='))
        .find(|(k, _)| *k == name)
        .and_then(|(_, v)| v.trim().parse().ok())
}
