//! FrontSeatInterface: the state machine, the gate between helm and driver, compute_missing, the
//! status publications, and the host of its DriverActor's supervisor.
//!
//! The driver is the one child of a nested [`Supervisor`](crate::supervisor) (`spawn_nested`),
//! which alone decides its restarts, with the same [`Policy`] and decider as every other child:
//! `[supervision]`'s backoff and limit, vehicle side. The interface maps what the supervisor tells
//! it onto Goby3's states: a driver that panics or stops is at once a frontseat NOT_CONNECTED (→
//! FS_ERROR by the ordinary rules) and its pending commands fail with DRIVER_FAILED; the
//! interface climbs back STANDBY → LISTEN → COMMAND by itself once data flows again. When the
//! supervisor gives up (more than `max_restarts` within `restart_window`), the service ends with
//! [`ServiceExit::RestartLimit`] so that systemd restarts the whole process.

use std::collections::HashMap;
use std::sync::Arc;
use std::time::Duration;

use frontseat_config::{InterfaceConfig, RestartPolicy};
use ractor::{Actor, ActorProcessingErr, ActorRef, RpcReplyPort, SupervisionEvent};
use tokio::sync::watch;

use crate::bus::{Bus, Envelope, Subscription, Undeliverable};
use crate::chaos::{FaultPort, FaultTarget};
use crate::clock::SimClock;
use crate::command_gate::{GateContext, Limits, check_course};
use crate::driver::DriverFactory;
use crate::driver_actor::{DriverActor, DriverArgs};
use crate::extensions::{Encoded, Kind as ExtensionKind, Spec as ExtensionSpec};
use crate::nav_gate::{
    DepthContinuity, NavField, NavLimits, NavViolation, OnViolation, check_navigation,
};
use crate::ports::{FrontSeatInterfaceInbox, FrontSeatInterfacePorts};
use crate::proto::frontseat::protobuf::{InterfaceDetail, NavFieldCount};
use crate::proto::goby::middleware::frontseat::protobuf::{
    CartesianCoordinate, CommandRequest, CommandResponse, FrontSeatError, FrontSeatState,
    HelmError, InterfaceData, InterfaceState, InterfaceStatus, NodeStatus, Raw, VehicleType,
};
use crate::proto::goby::middleware::protobuf::LatLonPoint;
use crate::ratelog::{LogDecision, RateLimitedLog, more, summary};
use crate::raw_gate::{RawPolicy, check_raw, source_name, source_of};
use crate::state_machine::{Inputs, StateMachine, StateMachineConfig, Transition, state_words};
use crate::supervisor::{
    ChildDown, ChildFailure, ChildObserver, ChildSpec, Node, Policy, Side, SupervisorMsg,
    spawn_nested,
};
use frontseat_sim::geodesy::LocalGrid;

/// Error codes in CommandResponse.error_code for the failures the interface itself answers.
pub mod error_code {
    pub const NOT_IN_COMMAND: i32 = 2;
    pub const TIMEOUT: i32 = 3;
    pub const DRIVER_FAILED: i32 = 4;
    pub const SHUTTING_DOWN: i32 = 5;
    /// Outside the safety envelope (`[limits]`, non-finite values): see the error string.
    pub const OUTSIDE_ENVELOPE: i32 = 6;
}

/// Everything the interface needs, resolved from the config once.
#[derive(Clone, Debug)]
pub struct InterfaceSettings {
    pub name: String,
    pub vehicle_type: VehicleType,
    pub origin: (f64, f64),
    pub sm: StateMachineConfig,
    /// helm_state not heard for this long (sim time) = helm not running; zero = never.
    pub helm_state_timeout: Duration,
    pub status_period: Duration,
    pub exit_on_error: bool,
    pub warp: f64,
    pub restart_initial: Duration,
    pub restart_max: Duration,
    pub max_restarts: u32,
    pub restart_window: Duration,
    pub queue_capacity: usize,
    /// A command with response_requested that the frontseat has not answered in this long
    /// (sim time) gets a failed CommandResponse.
    pub command_timeout: Duration,
    pub driver_name: String,
    pub limits: Limits,
    /// Physical bounds of navigation from the frontseat (`[limits.navigation]`).
    pub nav_limits: NavLimits,
    /// Who may use raw_send_request and what one may carry (`[raw_send]`).
    pub raw: RawPolicy,
    /// `[chaos] enabled`: the interface and each driver open a fault port (crate::chaos).
    pub fault_ports: bool,
}

impl InterfaceSettings {
    /// The settings of `cfg` for a driver the config alone describes: no acknowledgement budget
    /// beyond the interface's own, and raw requests checked as lines (frames for a plugin).
    /// [`Self::for_driver`] gives the selected driver's word on both.
    pub fn from_config(cfg: &InterfaceConfig) -> Self {
        let secs = |s: f64| Duration::from_secs_f64(s.max(0.0));
        Self {
            name: cfg.name.clone(),
            vehicle_type: VehicleType::try_from(cfg.r#type.proto_value())
                .unwrap_or(VehicleType::Auv),
            origin: (cfg.origin.lat, cfg.origin.lon),
            sm: StateMachineConfig {
                require_helm: cfg.require_helm,
                helm_running_timeout: secs(cfg.helm_running_timeout),
                frontseat_connected_timeout: secs(cfg.frontseat_connected_timeout),
                ..Default::default()
            },
            helm_state_timeout: secs(cfg.helm_state_timeout),
            status_period: secs(cfg.status_period),
            exit_on_error: cfg.exit_on_error,
            warp: cfg.sim_warp_factor,
            restart_initial: Duration::from_millis(cfg.supervision.restart_initial_delay_ms),
            restart_max: Duration::from_millis(cfg.supervision.restart_max_delay_ms),
            max_restarts: cfg.supervision.max_restarts,
            restart_window: secs(cfg.supervision.restart_window_s),
            queue_capacity: cfg.bus.queue_capacity.max(1),
            command_timeout: command_timeout(Duration::ZERO),
            driver_name: cfg.driver.name.clone(),
            limits: Limits::from(&cfg.limits),
            nav_limits: NavLimits::from(&cfg.limits.navigation),
            raw: RawPolicy::from_config(
                cfg,
                if cfg.driver.library.is_some() {
                    crate::raw_gate::RawFraming::Frames
                } else {
                    crate::raw_gate::RawFraming::Lines
                },
            ),
            fault_ports: cfg.chaos.enabled,
        }
    }

    /// With what the selected driver says of its vehicle: how long it may take to answer a
    /// command, and how its wire delimits a raw request.
    pub fn for_driver(mut self, driver: &crate::drivers::SelectedDriver) -> Self {
        self.command_timeout = command_timeout(driver.ack_budget);
        self.raw.framing = driver.raw_framing;
        self
    }

    /// The DriverActor's restart policy (`[supervision]`): restarted however it ends (a panic, a
    /// kill, a stop nobody asked for), after `restart_initial` doubling to `restart_max`; more
    /// than `max_restarts` within `restart_window` and its supervisor gives up.
    pub fn driver_policy(&self) -> Policy {
        Policy {
            side: Side::Vehicle,
            restart: RestartPolicy::Always,
            max_restarts: self.max_restarts,
            window: self.restart_window,
            backoff_initial: self.restart_initial,
            backoff_max: self.restart_max,
        }
    }
}

/// Our own answer to a command waits at least this long for the driver's.
const MIN_COMMAND_TIMEOUT: Duration = Duration::from_secs(5);

/// How long the interface waits before answering a command itself (failed): past the selected
/// driver's own acknowledgement budget (`ack_budget`: Bluefin's nmea_resend_attempts ×
/// nmea_resend_interval, the serial vehicles' link ack_timeout; the driver's word,
/// [`crate::drivers::BuiltIn::ack_budget`]), plus a second, so the driver's real answer (a
/// Bluefin "pending", then its ack) is the one the helm gets, as in Goby3, which forwards every
/// driver answer and never answers on its own (frontseat_interface.cpp:205-208).
pub fn command_timeout(ack_budget: Duration) -> Duration {
    ack_budget
        .saturating_add(Duration::from_secs(1))
        .max(MIN_COMMAND_TIMEOUT)
}

/// Why the service ended (the supervision tree's word; the interface's path kept for its users).
pub use crate::supervisor::ServiceExit;

/// A vehicle extension the interface could not handle: our own bus encoded it (or our driver
/// did), so this is a bug, not vehicle input; logged all the same at a bounded rate (a line at
/// the 1st, 2nd, 4th, … drop).
fn extension_dropped(type_name: &str, why: &str) {
    static DROPPED: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let n = DROPPED.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
    if n.is_power_of_two() {
        tracing::warn!(
            type_name,
            dropped_total = n,
            "vehicle extension dropped: {why}"
        );
    }
}

pub enum FsiMsg {
    Bus(FrontSeatInterfaceInbox),
    Tick,
    StatusTick,
    /// From the driver's start function, before the DriverActor is spawned: statuses from now on
    /// are the new driver's (`restarts`: how many starts came before).
    DriverStarting {
        restarts: u32,
    },
    /// The DriverActor started.
    DriverUp,
    /// From the driver's supervisor: the DriverActor ended (it decides on the restart).
    DriverDown(String),
    /// Orderly shutdown: refuse further commands, stop the driver, publish a last status.
    Shutdown(RpcReplyPort<()>),
    /// A snapshot for tests and the systemd watchdog: answering proves the actor is alive.
    Snapshot(RpcReplyPort<Snapshot>),
}

impl FsiMsg {
    fn kind(&self) -> &'static str {
        match self {
            FsiMsg::Bus(m) => m.group(),
            FsiMsg::Tick => "tick",
            FsiMsg::StatusTick => "status_tick",
            FsiMsg::DriverStarting { .. } => "driver_starting",
            FsiMsg::DriverUp => "driver_up",
            FsiMsg::DriverDown(_) => "driver_down",
            FsiMsg::Shutdown(_) => "shutdown",
            FsiMsg::Snapshot(_) => "snapshot",
        }
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct Snapshot {
    pub status: InterfaceStatus,
    pub providing_data: bool,
    pub driver_restarts: u32,
    pub driver_up: bool,
    /// False when the driver actor is up but has not handled its 10 Hz loop tick for
    /// `DRIVER_HUNG_AFTER`: it is stuck in a handler (a driver that is down is not hung).
    pub driver_responsive: bool,
    pub commands_gated: u64,
    pub setpoints_refused: u64,
    pub nav_refused: u64,
    /// Navigation fields dropped as out of bounds (the message itself was published).
    pub nav_fields_dropped: u64,
    /// Per field (index: [`NavField::index`]), how often it was out of bounds.
    pub nav_field_violations: [u64; NavField::COUNT],
    /// raw_send_requests passed to the driver, and refused by the raw gate.
    pub raw_sent: u64,
    pub raw_refused: u64,
}

/// How long a running driver actor may go without handling its loop tick before the watchdog
/// probe calls it hung (wall time; ticks come every 100 ms / warp).
pub const DRIVER_HUNG_AFTER: Duration = Duration::from_secs(2);

pub use crate::clock::heartbeat_now;

#[derive(Default, Clone, Copy, Debug)]
struct Counters {
    commands_gated: u64,
    data_gated: u64,
    raw_gated: u64,
    late_responses: u64,
    setpoints_refused: u64,
    nav_refused: u64,
    nav_fields_dropped: u64,
    nav_field_violations: [u64; NavField::COUNT],
    raw_sent: u64,
    raw_refused: u64,
}

pub struct FsiState {
    s: InterfaceSettings,
    bus: Bus,
    ports: FrontSeatInterfacePorts,
    factory: DriverFactory,
    clock: SimClock,
    sm: StateMachine,
    inputs: Inputs,
    /// When the last helm_state arrived, and the timeout that makes it stale (zero: never).
    helm_heard: tokio::time::Instant,
    helm_state_timeout: Duration,
    frame: Option<LocalGrid>,
    /// The DriverActor's supervisor (its one child), until the interface stops it.
    drivers: Option<ActorRef<SupervisorMsg>>,
    /// Between a driver's start and its end: its statuses count (a dead driver's must not).
    driver_live: bool,
    /// The DriverActor is running.
    driver_up: bool,
    driver_heartbeat: Arc<std::sync::atomic::AtomicU64>,
    restarts: u32,
    /// request_id → sim-time deadline of commands awaiting the frontseat's answer.
    pending: HashMap<Option<i32>, Duration>,
    counters: Counters,
    /// What the safety envelope needs besides the setpoint (last commanded, current heading).
    gate: GateContext,
    refused_log: RateLimitedLog,
    nav_log: RateLimitedLog,
    nav_drop_log: RateLimitedLog,
    /// The last depth let through, to refuse a depth sensor that jumps.
    depth_continuity: DepthContinuity,
    raw_log: RateLimitedLog,
    raw_refused_log: RateLimitedLog,
    /// The detail's counters for the OTel metrics (crate::metrics): written here, read by the
    /// exporter.
    metrics: Arc<frontseat_telemetry::metrics::VehicleMetrics>,
    shutting_down: bool,
    exit: watch::Sender<Option<ServiceExit>>,
    subs: Vec<Subscription>,
    timers: Vec<tokio::task::JoinHandle<()>>,
    /// Only with `[chaos] enabled`.
    faults: Option<FaultPort>,
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
        // Not linked the other way: the driver (and its frontseat connection) must not outlive
        // an interface that panicked, beside the one its restart starts.
        if let Some(d) = self.drivers.take() {
            d.stop(Some("interface gone".into()));
        }
    }
}

pub struct FrontSeatInterface;

pub struct FsiArgs {
    pub settings: InterfaceSettings,
    pub bus: Bus,
    pub factory: DriverFactory,
    pub exit: watch::Sender<Option<ServiceExit>>,
}

impl FsiState {
    fn now(&self) -> Duration {
        self.clock.now()
    }

    fn status(&self) -> InterfaceStatus {
        self.sm.status(&self.inputs)
    }

    fn publish_status_for(&self, t: &Transition) {
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

    fn publish_status(&self) {
        self.publish(self.status());
    }

    fn publish(&self, status: InterfaceStatus) {
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
    fn evaluate(&mut self, myself: &ActorRef<FsiMsg>) {
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
            tracing::error!("{why}");
            self.finish(myself, ServiceExit::ErrorState(why));
        }
    }

    fn finish(&mut self, myself: &ActorRef<FsiMsg>, exit: ServiceExit) {
        self.exit.send_replace(Some(exit));
        self.shutting_down = true;
        if let Some(d) = self.drivers.take() {
            d.stop(None);
        }
        myself.stop(None);
    }

    fn refuse(&self, req: &CommandRequest, code: i32, why: String) {
        if req.response_requested() {
            self.ports.publish_command_response(CommandResponse {
                request_successful: Some(false),
                request_id: req.request_id,
                error_code: Some(code),
                error_string: Some(why),
            });
        }
    }

    fn handle_command(&mut self, env: Envelope<CommandRequest>) {
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
        self.ports
            .publish_command_request_with(env.msg.clone(), env.meta());
    }

    /// Refuses and counts a request the state gate stops: shutting down, or not in the state(s)
    /// it `needs` ("command", "listen or command"). One wording for every kind of request.
    fn refuse_gated(&mut self, req: &CommandRequest, needs: &str) {
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
        tracing::debug!(state, reason = %why, "command dropped");
        self.refuse(req, code, why);
    }

    /// The safety envelope (command_gate): the request with its course made safe (heading
    /// wrapped or filled in), or None after answering and counting the refusal.
    fn through_envelope(
        &mut self,
        env: Envelope<CommandRequest>,
    ) -> Option<Envelope<CommandRequest>> {
        let Some(course) = env.msg.desired_course.as_ref() else {
            return Some(env);
        };
        match check_course(course, &self.s.limits, &self.gate) {
            Ok(safe) => {
                frontseat_telemetry::metrics::VehicleMetrics::add(&self.metrics.setpoints_sent);
                self.gate.last_commanded_heading = safe.heading;
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

    /// A vehicle extension from a helm (`interface_yaml/vehicles/`), gated by its kind: a
    /// command as command_request, a mode request in listen or command, data as
    /// data_to_frontseat; what passes goes to the driver whole, tagged with its type.
    fn handle_extension_to_frontseat(&mut self, env: Envelope<Encoded>) {
        let spec = env.msg.spec;
        let passed = match spec.kind {
            ExtensionKind::Command => self.gate_extended(env),
            ExtensionKind::Mode => self.gate_mode_command(env),
            ExtensionKind::Data => {
                if self.listen_or_command() {
                    let meta = env.meta();
                    Some((env.msg.bytes.clone(), meta))
                } else {
                    self.counters.data_gated += 1;
                    tracing::debug!(
                        group = spec.group,
                        "{} data_to_frontseat dropped: not in listen or command",
                        spec.vehicle
                    );
                    None
                }
            }
            // Toward the helms: the interface publishes these, it never receives them.
            ExtensionKind::Navigation | ExtensionKind::NavigationCopy => None,
        };
        if let Some((bytes, meta)) = passed {
            let ext = crate::driver::DriverExtension {
                type_name: Some(spec.type_name.to_string()),
                value: Some(bytes),
                vehicle: Some(spec.vehicle.to_string()),
            };
            self.ports
                .publish_extension_to_frontseat_with(Arc::new(ext), meta);
        }
    }

    /// A vehicle-extended CommandRequest (Bluefin's field 1000, Iver3's 1001): the same gate,
    /// pending table and refusals as [`Self::handle_command`]; the request to forward whole
    /// (vehicle fields included, course made safe) to the driver, or None when it was refused.
    fn gate_extended(
        &mut self,
        env: Envelope<Encoded>,
    ) -> Option<(Vec<u8>, crate::bus::PublishMeta)> {
        let base = self.extension_base(&env)?;
        self.gate_extended_base(env, base)
    }

    /// [`Self::gate_extended`] with the base already decoded from the mirror.
    fn gate_extended_base(
        &mut self,
        env: Envelope<Encoded>,
        base: CommandRequest,
    ) -> Option<(Vec<u8>, crate::bus::PublishMeta)> {
        let state = self.sm.state();
        if !self.shutting_down && state == InterfaceState::InterfaceCommand {
            let spec = env.msg.spec;
            let mirror = env.msg.bytes.clone();
            // Its desired_course crosses the same safety envelope as any other setpoint.
            let checked = self.through_envelope(Envelope::rewrap(env, base))?;
            let joined = self.rejoin_or_log(spec, &*checked.msg, &mirror)?;
            if base.response_requested() {
                self.pending
                    .insert(base.request_id, self.now() + self.s.command_timeout);
            }
            return Some((joined, checked.meta()));
        }
        self.refuse_gated(&base, "command");
        None
    }

    /// A vehicle mode/arming request (the ArduPilot extension): GUIDED is how COMMAND is
    /// reached, so it passes in listen as well as command; a course riding along still needs
    /// command and the safety envelope, as everywhere.
    fn gate_mode_command(
        &mut self,
        env: Envelope<Encoded>,
    ) -> Option<(Vec<u8>, crate::bus::PublishMeta)> {
        let base = self.extension_base(&env)?;
        if self.sm.state() == InterfaceState::InterfaceCommand || base.desired_course.is_some() {
            return self.gate_extended_base(env, base);
        }
        if self.listen_or_command() {
            if base.response_requested() {
                self.pending
                    .insert(base.request_id, self.now() + self.s.command_timeout);
            }
            let meta = env.meta();
            return Some((env.msg.bytes.clone(), meta));
        }
        self.refuse_gated(&base, "listen or command");
        None
    }

    /// The Goby3 CommandRequest inside a vehicle's command mirror (same field numbers). The
    /// bytes were encoded from a typed message on our own bus, so a failure is a bug: logged.
    fn extension_base(&self, env: &Envelope<Encoded>) -> Option<CommandRequest> {
        match <CommandRequest as prost::Message>::decode(env.msg.bytes.as_slice()) {
            Ok(base) => Some(base),
            Err(e) => {
                extension_dropped(env.msg.spec.type_name, &e.to_string());
                None
            }
        }
    }

    /// The gated base re-joined with the vehicle's own fields of `mirror`.
    fn rejoin_or_log<B: prost::Message>(
        &self,
        spec: &ExtensionSpec,
        base: &B,
        mirror: &[u8],
    ) -> Option<Vec<u8>> {
        match crate::extension::rejoin(base, mirror, spec.base_fields) {
            Ok(b) => Some(b),
            Err(e) => {
                extension_dropped(spec.type_name, &e.to_string());
                None
            }
        }
    }

    fn listen_or_command(&self) -> bool {
        !self.shutting_down
            && matches!(
                self.sm.state(),
                InterfaceState::InterfaceCommand | InterfaceState::InterfaceListen
            )
    }

    fn compute_missing(&self, ns: &mut NodeStatus) {
        compute_missing(ns, &self.s.name, self.s.vehicle_type, self.frame.as_ref());
    }

    /// The navigation gate (nav_gate) with its counters and logs: `ns` fit for the helm, or
    /// false when it must not be published at all. `count` is false for a second copy of
    /// navigation already counted (the Iver3 driver's extended $OSI).
    fn nav_fit_for_helm(&mut self, ns: &mut NodeStatus, count: bool) -> bool {
        let (refused, dropped) = match check_navigation(ns, &self.s.nav_limits) {
            Ok(dropped) if count => match self.depth_continuity.check(
                ns,
                self.clock.now().as_secs_f64(),
                &self.s.nav_limits,
            ) {
                Ok(()) => (None, dropped),
                Err(r) => (Some(r), Vec::new()),
            },
            Ok(dropped) => (None, dropped),
            Err(r) => (Some(r), Vec::new()),
        };
        if !count {
            return refused.is_none();
        }
        for v in refused.iter().chain(dropped.iter()) {
            self.counters.nav_field_violations[v.field.index()] += 1;
        }
        self.counters.nav_fields_dropped += dropped.len() as u64;
        if let Some(v) = dropped.first()
            && let LogDecision::Log { suppressed_before } = self.nav_drop_log.decide_at(self.now())
        {
            tracing::warn!(
                field = v.field.name(),
                value = v.value,
                fields = dropped.len(),
                "navigation field from the frontseat dropped: {}{}",
                list(&dropped),
                more(
                    suppressed_before,
                    "navigation messages with fields dropped",
                    self.nav_drop_log.window()
                )
            );
        }
        let Some(r) = refused else { return true };
        debug_assert_eq!(r.field.on_violation(), OnViolation::RefuseMessage);
        // Impossible navigation is a frontseat fault: the helm must not steer by it.
        self.counters.nav_refused += 1;
        if let LogDecision::Log { suppressed_before } = self.nav_log.decide_at(self.now()) {
            tracing::warn!(
                field = r.field.name(),
                value = r.value,
                "navigation from the frontseat refused: {r}{}",
                more(
                    suppressed_before,
                    "refused navigation messages",
                    self.nav_log.window()
                )
            );
        }
        false
    }

    fn handle_data_from_frontseat(&mut self, env: Envelope<InterfaceData>) {
        let mut data = (*env.msg).clone();
        if data.node_status.is_some() {
            frontseat_telemetry::metrics::VehicleMetrics::add(&self.metrics.nav_received);
        }
        if let Some(ns) = data.node_status.as_mut()
            && !self.nav_fit_for_helm(ns, true)
        {
            data.node_status = None;
            if data == InterfaceData::default() {
                return;
            }
        }
        if let Some(ns) = data.node_status.as_mut() {
            self.compute_missing(ns);
            if let Some(h) = ns.pose.heading {
                self.gate.current_heading = Some(h);
            }
            self.ports
                .publish_node_status_with(Arc::new(ns.clone()), env.meta());
        }
        self.ports
            .publish_data_from_frontseat_with(Arc::new(data), env.meta());
    }

    /// A vehicle extension's node_status through the navigation gate: completed when fit for a
    /// helm, removed otherwise (`count`: whether its refusals count, or are counted elsewhere).
    fn gate_extension_nav(&mut self, ns: &mut Option<NodeStatus>, count: bool) {
        if let Some(n) = ns.as_mut() {
            if self.nav_fit_for_helm(n, count) {
                self.compute_missing(n);
            } else {
                *ns = None;
            }
        }
    }

    /// A driver's extended data (its type one of `interface_yaml/vehicles/`' groups toward the
    /// helms): its node_status crosses the navigation gate (counted unless the kind says it is a
    /// copy of navigation counted on data_from_frontseat), then it goes out on its group.
    fn handle_extension_data(&mut self, env: Envelope<crate::driver::DriverExtension>) {
        let meta = env.meta();
        let Some(spec) = crate::extensions::to_helm(env.msg.type_name()) else {
            extension_dropped(
                env.msg.type_name(),
                "no vehicle group toward the helms has this type",
            );
            return;
        };
        let mirror = env.msg.value();
        let mut base = match <InterfaceData as prost::Message>::decode(mirror) {
            Ok(b) => b,
            Err(e) => return extension_dropped(spec.type_name, &e.to_string()),
        };
        self.gate_extension_nav(
            &mut base.node_status,
            spec.kind == ExtensionKind::Navigation,
        );
        let Some(joined) = self.rejoin_or_log(spec, &base, mirror) else {
            return;
        };
        if let Err(e) = self.ports.publish_encoded(spec.group, &joined, meta) {
            extension_dropped(spec.type_name, &e.to_string());
        }
    }

    /// Goby3's raw backdoor, through the raw gate (raw_gate): one line or frame, from an allowed
    /// source, in listen or command; every one counted and logged (rate-limited).
    fn handle_raw_send(&mut self, env: Envelope<Raw>) {
        let source = source_of(env.origin);
        let checked = check_raw(&env.msg, source, &self.s.raw);
        let raw = match checked {
            Err(why) => {
                self.counters.raw_refused += 1;
                if let LogDecision::Log { suppressed_before } =
                    self.raw_refused_log.decide_at(self.now())
                {
                    tracing::warn!(
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
            tracing::debug!("raw_send_request dropped: not in listen or command");
            return;
        }
        self.counters.raw_sent += 1;
        if let LogDecision::Log { suppressed_before } = self.raw_log.decide_at(self.now()) {
            tracing::info!(
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
            .publish_raw_send_request_with(Arc::new(raw), env.meta());
    }

    /// Every answer a driver gives reaches the helm, whenever it comes, as in Goby3
    /// (frontseat_interface.cpp:205-208): a Bluefin "pending" and then its ack are two answers.
    /// The pending table only decides whether our own timeout still has to answer.
    fn handle_driver_response(&mut self, env: Envelope<CommandResponse>) {
        let key = env.msg.request_id;
        if self.pending.remove(&key).is_some() {
            self.sm.command_result(env.msg.request_successful());
        } else {
            // After our timeout answered, a restart, or a second answer to the same request.
            self.counters.late_responses += 1;
            tracing::debug!(request_id = ?key, "late or further command response forwarded");
        }
        self.ports
            .publish_command_response_with(env.msg.clone(), env.meta());
    }

    /// A burst's summary once its window has ended, even when no further bad input comes to
    /// carry it (the limiters run on simulated time, so a warp shrinks their window).
    fn log_due_summaries(&mut self) {
        let now = self.now();
        if let Some(n) = self.refused_log.summary_due_at(now) {
            let line = summary(n, "refused setpoints", self.refused_log.window());
            tracing::warn!(
                suppressed = n,
                refused_total = self.counters.setpoints_refused,
                "{line}"
            );
        }
        if let Some(n) = self.raw_log.summary_due_at(now) {
            let line = summary(n, "raw sends", self.raw_log.window());
            tracing::info!(
                suppressed = n,
                raw_sent_total = self.counters.raw_sent,
                "{line}"
            );
        }
        if let Some(n) = self.raw_refused_log.summary_due_at(now) {
            let line = summary(n, "refused raw sends", self.raw_refused_log.window());
            tracing::warn!(
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
                suppressed = n,
                nav_fields_dropped_total = self.counters.nav_fields_dropped,
                "{line}"
            );
        }
        if let Some(n) = self.nav_log.summary_due_at(now) {
            let line = summary(n, "refused navigation messages", self.nav_log.window());
            tracing::warn!(
                suppressed = n,
                nav_refused_total = self.counters.nav_refused,
                "{line}"
            );
        }
    }

    fn fail_pending(&mut self, code: i32, why: &str, only_expired: bool) {
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

    /// The DriverActor as the one child of its supervisor: each start builds a fresh driver from
    /// the factory and tells the interface first, so that no status of the new driver comes
    /// before the interface counts it as live.
    fn driver_child(&self, myself: &ActorRef<FsiMsg>) -> ChildSpec {
        let fsi = myself.clone();
        let starts = Arc::new(std::sync::atomic::AtomicU32::new(0));
        let heartbeat = self.driver_heartbeat.clone();
        let factory = self.factory.clone();
        let bus = self.bus.clone();
        let clock = self.clock;
        let queue_capacity = self.s.queue_capacity;
        let fault_ports = self.s.fault_ports;
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
    fn driver_down(&mut self, myself: &ActorRef<FsiMsg>, why: &str) {
        self.driver_live = false;
        self.driver_up = false;
        self.inputs.frontseat = FrontSeatState::FrontseatNotConnected;
        self.inputs.providing_data = false;
        self.fail_pending(error_code::DRIVER_FAILED, "driver failed", false);
        if self.shutting_down {
            return;
        }
        tracing::error!(%why, "driver failed: frontseat treated as not connected");
        self.evaluate(myself);
    }
}

/// The interface's one supervised child, as its supervisor starts it and the tree shows it.
pub fn driver_node(settings: &InterfaceSettings) -> Node {
    Node::new(
        "DriverActor",
        settings.driver_policy(),
        "[supervision] (restart_initial_delay_ms, restart_max_delay_ms, max_restarts, restart_window_s); down = frontseat not connected",
    )
}

/// "pose.pitch = NaN (not a finite number), …" for a log line.
fn list(violations: &[NavViolation]) -> String {
    violations
        .iter()
        .map(|v| v.to_string())
        .collect::<Vec<_>>()
        .join(", ")
}

/// Goby3's compute_missing: name, type and time when absent, and the local fix (x east, y north,
/// z = −depth) from the global one around the datum — or the global from the local.
pub fn compute_missing(
    ns: &mut NodeStatus,
    name: &str,
    vehicle_type: VehicleType,
    frame: Option<&LocalGrid>,
) {
    if ns.name.is_none() && !name.is_empty() {
        ns.name = Some(name.to_string());
    }
    if ns.r#type.is_none() {
        ns.set_type(vehicle_type);
    }
    if ns.time == 0.0 {
        ns.time = SimClock::unix_now();
    }
    let Some(frame) = frame else { return };
    // global_fix is `required`, so prost always holds one: a zero fix with a local fix present
    // is taken as "global missing", as a C++ message would report !has_global_fix().
    let g = ns.global_fix;
    let global_missing = g.lat == 0.0 && g.lon == 0.0 && ns.local_fix.is_some();
    if global_missing {
        let Some(l) = ns.local_fix else { return };
        match frame.to_global(l.x, l.y) {
            Ok((lat, lon)) => {
                ns.global_fix = LatLonPoint {
                    lat,
                    lon,
                    depth: Some(-l.z()),
                    altitude: None,
                }
            }
            Err(e) => warn_fix("global_fix", &e),
        }
    } else if ns.local_fix.is_none() {
        match frame.to_local(g.lat, g.lon) {
            Ok((x, y)) => {
                ns.local_fix = Some(CartesianCoordinate {
                    x,
                    y,
                    z: Some(-g.depth()),
                })
            }
            Err(e) => warn_fix("local_fix", &e),
        }
    }
}

/// A fix that cannot be converted came from the vehicle (or a helm): one rate-limited WARN, so a
/// vehicle sending positions far off the datum cannot flood the journal (a hostile vehicle made
/// this line hundreds of times a second).
fn warn_fix(what: &str, e: &dyn std::fmt::Display) {
    static LOG: std::sync::LazyLock<std::sync::Mutex<RateLimitedLog>> =
        std::sync::LazyLock::new(|| std::sync::Mutex::new(RateLimitedLog::for_bad_input()));
    let mut log = LOG.lock().unwrap_or_else(|p| p.into_inner());
    if let LogDecision::Log { suppressed_before } = log.decide(tokio::time::Instant::now()) {
        tracing::warn!(
            error = %e,
            "cannot compute {what}{}",
            more(suppressed_before, "fixes not converted", log.window())
        );
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
fn state_name(n: i32) -> &'static str {
    InterfaceState::try_from(n)
        .map(|s| s.as_str_name())
        .unwrap_or("UNKNOWN")
}

fn log_transition(t: &Transition) {
    tracing::info!(
        from = state_words(t.from),
        to = state_words(t.to),
        helm_error = ?t.helm_error,
        frontseat_error = ?t.frontseat_error,
        "{}",
        t.rule
    );
}

impl Actor for FrontSeatInterface {
    type Msg = FsiMsg;
    type State = FsiState;
    type Arguments = FsiArgs;

    async fn pre_start(
        &self,
        myself: ActorRef<FsiMsg>,
        args: FsiArgs,
    ) -> Result<FsiState, ActorProcessingErr> {
        let me = myself.clone();
        let subs = FrontSeatInterfaceInbox::subscribe_all(
            &args.bus,
            "FrontSeatInterface",
            args.settings.queue_capacity,
            move |m| me.cast(FsiMsg::Bus(m)).map_err(|_| Undeliverable),
        );
        let clock = SimClock::new(args.settings.warp);
        let frame = match LocalGrid::new(args.settings.origin.0, args.settings.origin.1) {
            Ok(f) => Some(f),
            Err(e) => {
                tracing::error!(error = %e, "bad origin: local_fix will not be computed");
                None
            }
        };
        let mut timers =
            vec![myself.send_interval(clock.wall(Duration::from_millis(100)), || FsiMsg::Tick)];
        if !args.settings.status_period.is_zero() {
            timers.push(
                myself.send_interval(clock.wall(args.settings.status_period), || {
                    FsiMsg::StatusTick
                }),
            );
        }
        let faults =
            FaultPort::open_if(args.settings.fault_ports, &args.bus, FaultTarget::Interface);
        let mut state = FsiState {
            faults,
            sm: StateMachine::new(args.settings.sm.clone()),
            ports: FrontSeatInterfacePorts::new(&args.bus),
            bus: args.bus,
            factory: args.factory,
            clock,
            inputs: Inputs::default(),
            helm_heard: tokio::time::Instant::now(),
            helm_state_timeout: clock.wall(args.settings.helm_state_timeout),
            frame,
            drivers: None,
            driver_live: false,
            driver_up: false,
            driver_heartbeat: Arc::new(std::sync::atomic::AtomicU64::new(heartbeat_now())),
            restarts: 0,
            pending: HashMap::new(),
            counters: Counters::default(),
            gate: GateContext::default(),
            refused_log: RateLimitedLog::for_bad_input(),
            nav_log: RateLimitedLog::for_bad_input(),
            nav_drop_log: RateLimitedLog::for_bad_input(),
            depth_continuity: DepthContinuity::default(),
            raw_log: RateLimitedLog::for_bad_input(),
            raw_refused_log: RateLimitedLog::for_bad_input(),
            metrics: frontseat_telemetry::metrics::register(&args.settings.name, state_name),
            shutting_down: false,
            exit: args.exit,
            subs,
            timers,
            s: args.settings,
        };
        let me = myself.clone();
        let observer: ChildObserver = Arc::new(move |down: ChildDown| {
            let _ = me.cast(FsiMsg::DriverDown(down.why));
        });
        let child = state.driver_child(&myself);
        state.drivers = Some(
            spawn_nested(
                "FrontSeatInterface",
                vec![child],
                myself.get_cell(),
                Some(observer),
            )
            .await?,
        );
        state.publish_status();
        tracing::info!(state = "standby", "frontseat interface started");
        Ok(state)
    }

    async fn handle(
        &self,
        myself: ActorRef<FsiMsg>,
        msg: FsiMsg,
        st: &mut FsiState,
    ) -> Result<(), ActorProcessingErr> {
        use tracing::Instrument;
        let span = tracing::trace_span!(
            target: "frontseat_actors",
            "actor.handle",
            actor = "FrontSeatInterface",
            message = msg.kind(),
        );
        self.handle_inner(myself, msg, st).instrument(span).await
    }

    async fn handle_supervisor_evt(
        &self,
        myself: ActorRef<FsiMsg>,
        evt: SupervisionEvent,
        st: &mut FsiState,
    ) -> Result<(), ActorProcessingErr> {
        self.supervise(myself, evt, st).await
    }

    async fn post_stop(
        &self,
        myself: ActorRef<FsiMsg>,
        st: &mut FsiState,
    ) -> Result<(), ActorProcessingErr> {
        self.cleanup(myself, st).await
    }
}

impl FrontSeatInterface {
    async fn handle_inner(
        &self,
        myself: ActorRef<FsiMsg>,
        msg: FsiMsg,
        st: &mut FsiState,
    ) -> Result<(), ActorProcessingErr> {
        use FrontSeatInterfaceInbox as I;
        if crate::chaos::take(&st.faults).is_some() {
            tracing::warn!("chaos: making the FrontSeatInterface panic");
            panic!("chaos: FrontSeatInterface panic injected");
        }
        match msg {
            FsiMsg::Bus(inbox) => match inbox {
                I::CommandRequest(env) => st.handle_command(env),
                I::DesiredCourse(env) => {
                    let req = CommandRequest {
                        desired_course: Some(*env.msg),
                        ..Default::default()
                    };
                    let env2 = Envelope::rewrap(env, req);
                    st.handle_command(env2);
                }
                I::DataToFrontseat(env) => {
                    if st.listen_or_command() {
                        st.ports
                            .publish_data_to_frontseat_with(env.msg.clone(), env.meta());
                    } else {
                        st.counters.data_gated += 1;
                        tracing::debug!("data_to_frontseat dropped: not in listen or command");
                    }
                }
                I::VehicleExtension(env) => st.handle_extension_to_frontseat(env),
                I::RawSendRequest(env) => st.handle_raw_send(env),
                I::HelmState(env) => {
                    let helm = env.msg.state();
                    if helm != st.inputs.helm {
                        tracing::info!(?helm, "helm state");
                    }
                    st.inputs.helm = helm;
                    st.helm_heard = tokio::time::Instant::now();
                    st.evaluate(&myself);
                }
                I::DatumUpdate(env) => {
                    let d = env.msg.datum;
                    match LocalGrid::new(d.lat, d.lon) {
                        Ok(f) => {
                            tracing::info!(lat = d.lat, lon = d.lon, "datum updated");
                            st.frame = Some(f);
                        }
                        Err(e) => tracing::warn!(error = %e, "datum_update refused"),
                    }
                }
                I::CommandResponse(env) => st.handle_driver_response(env),
                I::DataFromFrontseat(env) => st.handle_data_from_frontseat(env),
                I::ExtensionFromFrontseat(env) => st.handle_extension_data(env),
                I::RawFromFrontseat(env) => {
                    st.ports.publish_raw_in_with(env.msg.clone(), env.meta());
                }
                I::RawToFrontseat(env) => {
                    st.ports.publish_raw_out_with(env.msg.clone(), env.meta());
                }
                I::Status(env) => {
                    // A status from a driver we already consider dead must not revive it.
                    if st.driver_live {
                        st.inputs.frontseat = env.msg.frontseat_state();
                        st.inputs.providing_data = env.msg.providing_data();
                        st.evaluate(&myself);
                    }
                }
            },
            FsiMsg::Tick => {
                if !st.helm_state_timeout.is_zero()
                    && st.inputs.helm != crate::proto::goby::middleware::frontseat::protobuf::HelmState::HelmNotRunning
                    && st.helm_heard.elapsed() > st.helm_state_timeout
                {
                    tracing::warn!(
                        timeout = ?st.helm_state_timeout,
                        "helm_state not heard within helm_state_timeout: helm treated as not running"
                    );
                    st.inputs.helm =
                        crate::proto::goby::middleware::frontseat::protobuf::HelmState::HelmNotRunning;
                }
                st.fail_pending(
                    error_code::TIMEOUT,
                    "no answer from the frontseat in time",
                    true,
                );
                st.log_due_summaries();
                st.evaluate(&myself);
            }
            FsiMsg::StatusTick => st.publish_status(),
            FsiMsg::DriverStarting { restarts } => {
                st.driver_live = true;
                st.restarts = restarts;
            }
            FsiMsg::DriverUp => st.driver_up = st.driver_live,
            FsiMsg::DriverDown(why) => st.driver_down(&myself, &why),
            FsiMsg::Shutdown(reply) => {
                tracing::info!(
                    "orderly shutdown: refusing commands, closing the frontseat connection"
                );
                st.shutting_down = true;
                st.fail_pending(error_code::SHUTTING_DOWN, "interface shutting down", false);
                st.publish_status();
                if let Some(d) = st.drivers.take() {
                    // The driver's supervisor stops it (an orderly stop: the driver closes its
                    // frontseat connection) and restarts nothing. Give it a moment to flush.
                    let _ = d
                        .stop_and_wait(
                            Some("orderly shutdown".into()),
                            Some(Duration::from_millis(500)),
                        )
                        .await;
                }
                st.exit.send_replace(Some(ServiceExit::Clean));
                let _ = reply.send(());
                myself.stop(Some("orderly shutdown".into()));
            }
            FsiMsg::Snapshot(reply) => {
                let _ = reply.send(Snapshot {
                    status: st.status(),
                    providing_data: st.inputs.providing_data,
                    driver_restarts: st.restarts,
                    driver_up: st.driver_up,
                    driver_responsive: !st.driver_up
                        || heartbeat_now().saturating_sub(
                            st.driver_heartbeat
                                .load(std::sync::atomic::Ordering::Relaxed),
                        ) < DRIVER_HUNG_AFTER.as_millis() as u64,
                    commands_gated: st.counters.commands_gated,
                    setpoints_refused: st.counters.setpoints_refused,
                    nav_refused: st.counters.nav_refused,
                    nav_fields_dropped: st.counters.nav_fields_dropped,
                    nav_field_violations: st.counters.nav_field_violations,
                    raw_sent: st.counters.raw_sent,
                    raw_refused: st.counters.raw_refused,
                });
            }
        }
        Ok(())
    }

    async fn supervise(
        &self,
        myself: ActorRef<FsiMsg>,
        evt: SupervisionEvent,
        st: &mut FsiState,
    ) -> Result<(), ActorProcessingErr> {
        // ractor's default would stop us with the child. The driver's supervisor ends only when
        // it gave up (its failure carries the restart limit's reason) or when we stopped it.
        let is_drivers = |cell: &ractor::ActorCell| {
            st.drivers.as_ref().map(|d| d.get_id()) == Some(cell.get_id())
        };
        let exit = match evt {
            SupervisionEvent::ActorFailed(cell, err) if is_drivers(&cell) => {
                match err.downcast_ref::<ChildFailure>() {
                    Some(ChildFailure {
                        exit: Some(ServiceExit::RestartLimit(reason)),
                        ..
                    }) => ServiceExit::RestartLimit(reason.clone()),
                    _ => ServiceExit::Failed(format!("driver supervisor failed: {err}")),
                }
            }
            SupervisionEvent::ActorTerminated(cell, _, reason) if is_drivers(&cell) => {
                ServiceExit::Failed(format!(
                    "driver supervisor stopped: {}",
                    reason.unwrap_or_default()
                ))
            }
            _ => return Ok(()),
        };
        st.drivers = None;
        let why = match &exit {
            ServiceExit::RestartLimit(w) | ServiceExit::Failed(w) => w.clone(),
            _ => String::new(),
        };
        // This may come before the supervisor's word that the driver is down.
        st.driver_down(&myself, &why);
        if !st.shutting_down {
            tracing::error!("{why}");
            st.finish(&myself, exit);
        }
        Ok(())
    }

    async fn cleanup(
        &self,
        _myself: ActorRef<FsiMsg>,
        st: &mut FsiState,
    ) -> Result<(), ActorProcessingErr> {
        for t in st.timers.drain(..) {
            t.abort();
        }
        for s in st.subs.drain(..) {
            s.cancel();
        }
        if st.exit.borrow().is_none() {
            st.exit.send_replace(Some(ServiceExit::Clean));
        }
        Ok(())
    }
}

/// The running interface: the actor, and how it ended.
pub struct InterfaceService {
    actor: ActorRef<FsiMsg>,
    join: tokio::task::JoinHandle<()>,
    exit: watch::Receiver<Option<ServiceExit>>,
}

#[derive(Debug, thiserror::Error)]
pub enum StartError {
    #[error("driver: {0}")]
    Driver(#[from] crate::drivers::DriverSelectError),
    #[error("could not start the interface actor: {0}")]
    Spawn(String),
}

impl InterfaceService {
    /// Starts the interface with the driver the config names, a plugin or one of `built_in`
    /// (the registry's list, `frontseat_drivers::BUILT_IN`).
    pub async fn start(
        cfg: &InterfaceConfig,
        bus: &Bus,
        built_in: &[crate::drivers::BuiltIn],
    ) -> Result<Self, StartError> {
        let driver = crate::drivers::select(cfg, built_in)?;
        let settings = InterfaceSettings::from_config(cfg).for_driver(&driver);
        Self::start_with(settings, bus, driver.factory).await
    }

    pub async fn start_with(
        settings: InterfaceSettings,
        bus: &Bus,
        factory: DriverFactory,
    ) -> Result<Self, StartError> {
        let (tx, rx) = watch::channel(None);
        let (actor, join) = Actor::spawn(
            None,
            FrontSeatInterface,
            FsiArgs {
                settings,
                bus: bus.clone(),
                factory,
                exit: tx,
            },
        )
        .await
        .map_err(|e| StartError::Spawn(e.to_string()))?;
        Ok(Self {
            actor,
            join,
            exit: rx,
        })
    }

    pub fn actor(&self) -> &ActorRef<FsiMsg> {
        &self.actor
    }

    /// A snapshot, or None if the actor did not answer within `within` (a hung actor).
    pub async fn snapshot(&self, within: Duration) -> Option<Snapshot> {
        let call = self.actor.call(FsiMsg::Snapshot, Some(within));
        match call.await {
            Ok(ractor::rpc::CallResult::Success(s)) => Some(s),
            _ => None,
        }
    }

    /// Resolves when the service ends by itself (error exit, restart limit, actor failure).
    pub async fn wait(&mut self) -> ServiceExit {
        loop {
            if let Some(e) = self.exit.borrow().clone() {
                return e;
            }
            if self.join.is_finished() {
                return self
                    .exit
                    .borrow()
                    .clone()
                    .unwrap_or(ServiceExit::Failed("interface actor ended".into()));
            }
            tokio::select! {
                r = self.exit.changed() => if r.is_err() {
                    return ServiceExit::Failed("interface actor ended".into());
                },
                _ = &mut self.join => {}
            }
        }
    }

    /// Orderly shutdown within `within`: stop accepting commands, publish a last status, close
    /// the frontseat connection.
    pub async fn shutdown(mut self, within: Duration) -> ServiceExit {
        let _ = self.actor.call(FsiMsg::Shutdown, Some(within)).await;
        // `wait` may have consumed the join already (a JoinHandle must not be polled twice).
        if !self.join.is_finished() {
            let _ = tokio::time::timeout(within, &mut self.join).await;
        }
        // An interface actor that was killed ran no cleanup: its DriverActor (and so the
        // frontseat connection) would outlive it, beside the one a restart starts.
        self.actor
            .stop_children_and_wait(Some("interface stopped".into()), Some(within))
            .await;
        self.exit.borrow().clone().unwrap_or(ServiceExit::Clean)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame() -> LocalGrid {
        LocalGrid::new(42.358456, -71.087589).unwrap()
    }

    #[test]
    fn fills_name_type_time_and_local_fix_from_global() {
        let f = frame();
        let (lat, lon) = f.to_global(100.0, -50.0).unwrap();
        let mut ns = NodeStatus {
            global_fix: LatLonPoint {
                lat,
                lon,
                depth: Some(12.5),
                altitude: None,
            },
            ..Default::default()
        };
        compute_missing(&mut ns, "auv1", VehicleType::Auv, Some(&f));
        assert_eq!(ns.name.as_deref(), Some("auv1"));
        assert_eq!(ns.r#type(), VehicleType::Auv);
        assert!(ns.time > 1.0e9, "unix time filled");
        let l = ns.local_fix.unwrap();
        assert!(
            (l.x - 100.0).abs() < 1e-3 && (l.y + 50.0).abs() < 1e-3,
            "{l:?}"
        );
        assert_eq!(l.z(), -12.5);
    }

    #[test]
    fn fills_global_fix_from_local_and_keeps_what_is_given() {
        let f = frame();
        let mut ns = NodeStatus {
            name: Some("given".into()),
            local_fix: Some(CartesianCoordinate {
                x: 0.0,
                y: 1000.0,
                z: Some(-3.0),
            }),
            ..Default::default()
        };
        ns.set_type(VehicleType::Glider);
        compute_missing(&mut ns, "auv1", VehicleType::Auv, Some(&f));
        assert_eq!(ns.name.as_deref(), Some("given"));
        assert_eq!(ns.r#type(), VehicleType::Glider);
        let g = ns.global_fix;
        assert!((g.lat - 42.367459).abs() < 1e-4, "{g:?}");
        // Goby3's grid: grid north leans west of true north at this datum.
        assert!(g.lon < -71.087589 - 1e-4, "{g:?}");
        let (x, y) = f.to_local(g.lat, g.lon).unwrap();
        assert!(x.abs() < 1e-6 && (y - 1000.0).abs() < 1e-6);
        assert_eq!(g.depth(), 3.0);
    }

    #[test]
    fn a_moved_datum_moves_the_local_fix() {
        let f = frame();
        let (lat, lon) = f.to_global(0.0, 0.0).unwrap();
        let moved = LocalGrid::new(lat - 0.001, lon).unwrap();
        let mut ns = NodeStatus {
            global_fix: LatLonPoint {
                lat,
                lon,
                depth: Some(0.0),
                altitude: None,
            },
            ..Default::default()
        };
        compute_missing(&mut ns, "", VehicleType::Auv, Some(&moved));
        let l = ns.local_fix.unwrap();
        assert!(
            (l.y - 111.07).abs() < 0.5,
            "0.001° north of the new datum: {l:?}"
        );
    }
}
