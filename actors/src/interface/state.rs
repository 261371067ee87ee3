//! The interface's state: [`FsiState`] and what keeps it — the state machine run on every input
//! and a status published for each transition, the status and detail publications, the
//! DriverActor as the one child of its nested supervisor (a driver down is a frontseat not
//! connected), and the due summaries of the rate-limited logs.

use std::collections::HashMap;
use std::sync::Arc;
use std::time::Duration;

use ractor::{Actor, ActorRef};
use tokio::sync::watch;

use crate::bus::{Bus, Subscription};
use crate::chaos::{FaultPort, FaultTarget};
use crate::clock::{SimClock, heartbeat_now};
use crate::driver::DriverFactory;
use crate::driver_actor::{DriverActor, DriverArgs};
use crate::nav_gate::{DepthContinuity, NavField};
use crate::ports::FrontSeatInterfacePorts;
use crate::proto::frontseat::protobuf::{InterfaceDetail, NavFieldCount};
use crate::proto::goby::middleware::frontseat::protobuf::{
    FrontSeatError, FrontSeatState, HelmError, InterfaceState, InterfaceStatus,
};
use crate::ratelog::{RateLimitedLog, summary};
use crate::setpoint_lane::SetpointLane;
use crate::state_machine::{Inputs, StateMachine, Transition, state_words};
use crate::supervisor::{ChildSpec, ServiceExit, SupervisorMsg};
use frontseat_sim::geodesy::LocalGrid;

use super::messages::{FsiMsg, error_code};
use super::settings::{InterfaceSettings, driver_node};

#[derive(Default, Clone, Copy, Debug)]
pub(super) struct Counters {
    pub(super) commands_gated: u64,
    pub(super) data_gated: u64,
    pub(super) raw_gated: u64,
    pub(super) late_responses: u64,
    pub(super) setpoints_refused: u64,
    pub(super) nav_refused: u64,
    pub(super) nav_fields_dropped: u64,
    pub(super) nav_field_violations: [u64; NavField::COUNT],
    pub(super) raw_sent: u64,
    pub(super) raw_refused: u64,
}

pub struct FsiState {
    pub(super) s: InterfaceSettings,
    pub(super) bus: Bus,
    pub(super) ports: FrontSeatInterfacePorts,
    pub(super) factory: DriverFactory,
    pub(super) clock: SimClock,
    pub(super) sm: StateMachine,
    pub(super) inputs: Inputs,
    /// When the last helm_state arrived, and the timeout that makes it stale (zero: never).
    pub(super) helm_heard: tokio::time::Instant,
    pub(super) helm_state_timeout: Duration,
    pub(super) frame: Option<LocalGrid>,
    /// The DriverActor's supervisor (its one child), until the interface stops it.
    pub(super) drivers: Option<ActorRef<SupervisorMsg>>,
    /// Between a driver's start and its end: its statuses count (a dead driver's must not).
    pub(super) driver_live: bool,
    /// The DriverActor is running.
    pub(super) driver_up: bool,
    pub(super) driver_heartbeat: Arc<std::sync::atomic::AtomicU64>,
    pub(super) restarts: u32,
    /// request_id → sim-time deadline of commands awaiting the frontseat's answer.
    pub(super) pending: HashMap<Option<i32>, Duration>,
    pub(super) counters: Counters,
    /// The desired_course path that needs no actor hop, and the safety envelope's context
    /// (last commanded, current heading) it shares with this actor's own path.
    pub(super) lane: SetpointLane,
    pub(super) refused_log: RateLimitedLog,
    pub(super) nav_log: RateLimitedLog,
    pub(super) nav_drop_log: RateLimitedLog,
    /// The last depth let through, to refuse a depth sensor that jumps.
    pub(super) depth_continuity: DepthContinuity,
    pub(super) raw_log: RateLimitedLog,
    pub(super) raw_refused_log: RateLimitedLog,
    /// The detail's counters for the OTel metrics (crate::metrics): written here, read by the
    /// exporter.
    pub(super) metrics: Arc<frontseat_telemetry::metrics::VehicleMetrics>,
    pub(super) shutting_down: bool,
    pub(super) exit: watch::Sender<Option<ServiceExit>>,
    pub(super) subs: Vec<Subscription>,
    pub(super) timers: Vec<tokio::task::JoinHandle<()>>,
    /// Only with `[chaos] enabled`.
    pub(super) faults: Option<FaultPort>,
}

/// As the DriverActor's: an interface that panics or is killed (its supervisor restarts it) runs
/// no `cleanup`, so its subscriptions and timers go when its state is dropped.
impl Drop for FsiState {
    fn drop(&mut self) {
        for t in self.timers.drain(..) {
            t.abort();
        }
        for s in self.subs.drain(..) {
            s.cancel();
        }
        // No course goes to the vehicle without a live interface's gate.
        self.lane.close();
        // Not linked the other way: the driver (and its frontseat connection) must not outlive
        // an interface that panicked, beside the one its restart starts.
        if let Some(d) = self.drivers.take() {
            d.stop(Some("interface gone".into()));
        }
    }
}

impl FsiState {
    pub(super) fn now(&self) -> Duration {
        self.clock.now()
    }

    pub(super) fn status(&self) -> InterfaceStatus {
        self.sm.status(&self.inputs)
    }

    pub(super) fn publish_status_for(&self, t: &Transition) {
        let mut status = self.status();
        status.set_state(t.to);
        status.helm_error = None;
        status.frontseat_error = None;
        if t.helm_error != HelmError::ErrorHelmNone {
            status.set_helm_error(t.helm_error);
        }
        if t.frontseat_error != FrontSeatError::ErrorFrontseatNone {
            status.set_frontseat_error(t.frontseat_error);
        }
        self.publish(status);
    }

    pub(super) fn publish_status(&self) {
        self.publish(self.status());
    }

    pub(super) fn publish(&self, status: InterfaceStatus) {
        self.ports.publish_status(status);
        self.ports.publish_interface_status(status);
        let detail = InterfaceDetail {
            status: Some(status),
            frontseat_providing_data: Some(self.inputs.providing_data),
            driver_restarts: Some(self.restarts),
            commands_gated: Some(self.counters.commands_gated),
            data_gated: Some(self.counters.data_gated),
            raw_gated: Some(self.counters.raw_gated),
            bus_dropped: Some(self.bus.total_dropped()),
            uptime_s: Some(self.now().as_secs_f64()),
            driver: Some(self.s.driver_name.clone()),
            setpoints_refused: Some(self.counters.setpoints_refused),
            nav_refused: Some(self.counters.nav_refused),
            goby3_link_up: self.bus.link_up(crate::bus::GOBY3_LINK),
            spans_dropped: None,
            spans_exported: None,
            nav_field_violations: NavField::ALL
                .iter()
                .filter(|f| self.counters.nav_field_violations[f.index()] > 0)
                .map(|f| NavFieldCount {
                    field: Some(f.name().to_string()),
                    count: Some(self.counters.nav_field_violations[f.index()]),
                })
                .collect(),
            nav_fields_dropped: Some(self.counters.nav_fields_dropped),
            raw_sent: Some(self.counters.raw_sent),
            raw_refused: Some(self.counters.raw_refused),
            record_dropped: frontseat_telemetry::metrics::recorder_drops_if_recording(),
        };
        let detail = with_telemetry(detail, &self.metrics);
        self.ports.publish_detail(detail);
    }

    /// Runs the state machine; publishes status on every change.
    pub(super) fn evaluate(&mut self, myself: &ActorRef<FsiMsg>) {
        let transitions = self.sm.step(&self.inputs, self.now());
        if transitions.is_empty() {
            return;
        }
        // One status per transition, so every state the interface passes through is published
        // (STANDBY → LISTEN → COMMAND in one evaluation gives three statuses, not one).
        for t in &transitions {
            log_transition(t);
            self.publish_status_for(t);
        }
        if self.s.exit_on_error
            && matches!(
                self.sm.state(),
                InterfaceState::InterfaceHelmError | InterfaceState::InterfaceFsError
            )
        {
            let why = format!("exit_on_error: entered {}", state_words(self.sm.state()));
            tracing::error!(target: super::LOG_TARGET, "{why}");
            self.finish(myself, ServiceExit::ErrorState(why));
        }
    }

    pub(super) fn finish(&mut self, myself: &ActorRef<FsiMsg>, exit: ServiceExit) {
        self.exit.send_replace(Some(exit));
        self.shutting_down = true;
        self.sync_lane();
        if let Some(d) = self.drivers.take() {
            d.stop(None);
        }
        myself.stop(None);
    }

    /// Tells the setpoint lane whether a course may go to the vehicle now: after every message
    /// this actor handles, so the lane's gate is never behind the state machine's by more than
    /// the message that changed it.
    pub(super) fn sync_lane(&self) {
        self.lane
            .set_open(!self.shutting_down && self.sm.state() == InterfaceState::InterfaceCommand);
    }

    pub(super) fn listen_or_command(&self) -> bool {
        !self.shutting_down
            && matches!(
                self.sm.state(),
                InterfaceState::InterfaceCommand | InterfaceState::InterfaceListen
            )
    }

    /// A burst's summary once its window has ended, even when no further bad input comes to
    /// carry it (the limiters run on simulated time, so a warp shrinks their window).
    pub(super) fn log_due_summaries(&mut self) {
        let now = self.now();
        if let Some(n) = self.refused_log.summary_due_at(now) {
            let line = summary(n, "refused setpoints", self.refused_log.window());
            tracing::warn!(
                target: super::LOG_TARGET,
                suppressed = n,
                refused_total = self.counters.setpoints_refused,
                "{line}"
            );
        }
        if let Some(n) = self.raw_log.summary_due_at(now) {
            let line = summary(n, "raw sends", self.raw_log.window());
            tracing::info!(
                target: super::LOG_TARGET,
                suppressed = n,
                raw_sent_total = self.counters.raw_sent,
                "{line}"
            );
        }
        if let Some(n) = self.raw_refused_log.summary_due_at(now) {
            let line = summary(n, "refused raw sends", self.raw_refused_log.window());
            tracing::warn!(
                target: super::LOG_TARGET,
                suppressed = n,
                raw_refused_total = self.counters.raw_refused,
                "{line}"
            );
        }
        if let Some(n) = self.nav_drop_log.summary_due_at(now) {
            let line = summary(
                n,
                "navigation messages with fields dropped",
                self.nav_drop_log.window(),
            );
            tracing::warn!(
                target: super::LOG_TARGET,
                suppressed = n,
                nav_fields_dropped_total = self.counters.nav_fields_dropped,
                "{line}"
            );
        }
        if let Some(n) = self.nav_log.summary_due_at(now) {
            let line = summary(n, "refused navigation messages", self.nav_log.window());
            tracing::warn!(
                target: super::LOG_TARGET,
                suppressed = n,
                nav_refused_total = self.counters.nav_refused,
                "{line}"
            );
        }
    }

    /// The DriverActor as the one child of its supervisor: each start builds a fresh driver from
    /// the factory and tells the interface first, so that no status of the new driver comes
    /// before the interface counts it as live.
    pub(super) fn driver_child(&self, myself: &ActorRef<FsiMsg>) -> ChildSpec {
        let fsi = myself.clone();
        let starts = Arc::new(std::sync::atomic::AtomicU32::new(0));
        let heartbeat = self.driver_heartbeat.clone();
        let factory = self.factory.clone();
        let bus = self.bus.clone();
        let clock = self.clock;
        let queue_capacity = self.s.queue_capacity;
        let fault_ports = self.s.fault_ports;
        let lane = self.lane.clone();
        driver_node(&self.s).spec(Arc::new(move |sup| {
            let restarts = starts.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            // A fresh driver counts as alive from its start.
            heartbeat.store(heartbeat_now(), std::sync::atomic::Ordering::Relaxed);
            let _ = fsi.cast(FsiMsg::DriverStarting { restarts });
            let args = DriverArgs {
                heartbeat: heartbeat.clone(),
                factory: factory.clone(),
                bus: bus.clone(),
                clock,
                restarts,
                queue_capacity,
                faults: FaultPort::open_if(fault_ports, &bus, FaultTarget::Driver),
                lane: lane.clone(),
            };
            let fsi = fsi.clone();
            Box::pin(async move {
                let (actor, _join) = Actor::spawn_linked(None, DriverActor, args, sup)
                    .await
                    .map_err(|e| e.to_string())?;
                let _ = fsi.cast(FsiMsg::DriverUp);
                Ok(actor.get_cell())
            })
        }))
    }

    /// The driver ended (its supervisor restarts it, or gives up): the frontseat is not
    /// connected, and no answer to a pending command can come any more.
    pub(super) fn driver_down(&mut self, myself: &ActorRef<FsiMsg>, why: &str) {
        self.driver_live = false;
        self.driver_up = false;
        self.inputs.frontseat = FrontSeatState::FrontseatNotConnected;
        self.inputs.providing_data = false;
        self.fail_pending(error_code::DRIVER_FAILED, "driver failed", false);
        if self.shutting_down {
            return;
        }
        tracing::error!(target: super::LOG_TARGET, %why, "driver failed: frontseat treated as not connected");
        self.evaluate(myself);
    }
}

/// The detail's counters copied for the OTel metrics, and the process's span counts added to it:
/// the metrics and the status say the same thing.
fn with_telemetry(
    mut d: InterfaceDetail,
    m: &frontseat_telemetry::metrics::VehicleMetrics,
) -> InterfaceDetail {
    use frontseat_telemetry::metrics::VehicleMetrics as M;
    M::set(&m.setpoints_refused, d.setpoints_refused());
    M::set(&m.nav_refused, d.nav_refused());
    M::set(&m.nav_fields_dropped, d.nav_fields_dropped());
    M::set(&m.raw_sent, d.raw_sent());
    M::set(&m.raw_refused, d.raw_refused());
    M::set(&m.commands_gated, d.commands_gated());
    M::set(&m.bus_dropped, d.bus_dropped());
    M::set(&m.driver_restarts, u64::from(d.driver_restarts()));
    let state = d.status.map(|s| s.state() as i32).unwrap_or_default();
    m.state.store(state, std::sync::atomic::Ordering::Relaxed);
    if let Some(c) = frontseat_telemetry::span_counts_if_exporting() {
        d.spans_dropped = Some(c.dropped());
        d.spans_exported = Some(c.exported);
    }
    d
}

/// Goby3's name of an InterfaceState number, for the metrics.
pub(super) fn state_name(n: i32) -> &'static str {
    InterfaceState::try_from(n)
        .map(|s| s.as_str_name())
        .unwrap_or("UNKNOWN")
}

fn log_transition(t: &Transition) {
    tracing::info!(
        target: super::LOG_TARGET,
        from = state_words(t.from),
        to = state_words(t.to),
        helm_error = ?t.helm_error,
        frontseat_error = ?t.frontseat_error,
        "{}",
        t.rule
    );
}
