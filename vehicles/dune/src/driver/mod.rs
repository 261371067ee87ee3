//! The DUNE driver's state and I/O. It reads VehicleState (and its liveness) into a frontseat
//! state with a reason, EstimatedState into NodeStatus while it is sane and the navigation
//! entity is healthy, and steers by the backseat path DUNE supports: on entering COMMAND a
//! one-maneuver plan (PlanControl START with FollowReference, control_src = us, a timeout), then
//! a Reference each period toward a point ahead on the helm's heading, ended by a MANDONE
//! Reference and PlanControl STOP when the interface leaves COMMAND. If we die, the maneuver's
//! own timeout stops the vehicle. Everything goes to the vehicle's IMC id exactly.

use std::sync::Arc;
use std::time::Duration;

use crate::imc::{self, ByteOrder, Header, ImcError, Message, consts};
use crate::infer::{self, Control, Position};
use frontseat_config::InterfaceConfig;

use frontseat_actors::clock::SimClock;
use frontseat_actors::driver::{Driver, DriverContext, DriverIoEvent, SignalSink};
use frontseat_actors::drivers::kit::{
    DataWatch, OwnedTask, config_secs, log_due, raw_binary, refuse, send_bytes,
};
use frontseat_actors::link::LineWriter;
use frontseat_actors::link::byte::{self, ByteLinkConfig, LinkStats, Transport};
use frontseat_actors::link::framing::{FrameCutter, Framing};
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CommandRequest, CommandResponse, EulerAngles, FrontSeatState, InterfaceData, InterfaceState,
    InterfaceStatus, NodeStatus, Raw, Speed,
};
use frontseat_actors::proto::goby::middleware::protobuf::LatLonPoint;
use frontseat_actors::ratelog::RateLimitedLog;

/// A raw_send_request larger than this is not a handful of IMC packets.
const MAX_RAW_BYTES: usize = 4 * imc::MAX_FRAME;
/// A START the vehicle did not act on is sent again after this long.
const START_RETRY: Duration = Duration::from_secs(3);
/// After our START the vehicle needs a moment to report MANEUVER; until then SERVICE is not
/// taken for the end of our plan.
const START_GRACE: Duration = Duration::from_secs(3);
/// Half the driver loop's period.
const LOOP_SLACK: Duration = Duration::from_millis(50);

#[derive(Clone, Debug)]
pub struct Settings {
    pub link: ByteLinkConfig,
    pub address: String,
    pub own_id: u16,
    /// 0: the src of the first VehicleState.
    pub vehicle_id: u16,
    pub navigation_entity: String,
    pub plan_id: String,
    pub reference_period: Duration,
    pub maneuver_timeout: f32,
    pub lookahead_m: f64,
    pub course_timeout: Duration,
    pub vehicle_state_timeout: Duration,
    pub navigation_timeout: Duration,
}

impl Settings {
    pub fn from_config(cfg: &InterfaceConfig) -> Self {
        let c = &cfg.driver.dune;
        Self {
            link: ByteLinkConfig {
                transport: Transport::Tcp {
                    host: c.address.clone(),
                    port: c.port,
                },
                framing: Framing::Frames(imc_frames),
                backoff_initial: Duration::from_millis(c.reconnect_initial_ms.max(1)),
                backoff_max: Duration::from_millis(
                    c.reconnect_max_ms.max(c.reconnect_initial_ms).max(1),
                ),
            },
            address: format!("{}:{}", c.address, c.port),
            own_id: c.own_imc_id,
            vehicle_id: c.vehicle_imc_id,
            navigation_entity: c.navigation_entity.clone(),
            plan_id: c.plan_id.clone(),
            reference_period: config_secs(1.0 / c.reference_rate.clamp(0.2, 10.0)),
            maneuver_timeout: c.maneuver_timeout.clamp(0.0, 600.0) as f32,
            lookahead_m: c.lookahead_m.clamp(50.0, 1000.0),
            course_timeout: config_secs(c.course_timeout),
            vehicle_state_timeout: config_secs(c.vehicle_state_timeout),
            navigation_timeout: config_secs(c.navigation_timeout),
        }
    }
}

/// What the driver counted (read by tests and logs).
#[derive(Debug, Default, Clone, PartialEq)]
pub struct DuneCounters {
    pub packets: u64,
    pub bad_input: u64,
    pub unknown_messages: u64,
    /// State or navigation from another src than the vehicle's id.
    pub foreign: u64,
    /// Our own messages looped back by DUNE.
    pub own_echoes: u64,
    pub vehicle_states: u64,
    pub nav_published: u64,
    pub nav_refused: u64,
    pub plan_starts: u64,
    pub plan_stops: u64,
    pub references_sent: u64,
    pub maneuver_failures: u64,
    pub write_failures: u64,
    pub ignored: u64,
}

#[derive(Debug, Clone, Copy)]
struct Course {
    heading: f64,
    speed: f64,
    depth: Option<f64>,
    renewed: Duration,
}

/// Our one-maneuver plan, from its START to its end.
#[derive(Debug, Clone, Copy)]
struct Plan {
    started: Duration,
    request_id: u16,
    /// The vehicle said MANEUVER FollowReference since the START.
    confirmed: bool,
    last_reference: Option<Duration>,
}

pub struct DuneDriver {
    settings: Settings,
    writer: Option<LineWriter>,
    link_task: OwnedTask,
    pub link_stats: Arc<LinkStats>,
    vehicle_id: Option<u16>,
    state: FrontSeatState,
    why: String,
    last_vs: Option<Duration>,
    vs: Option<imc::VehicleState>,
    pcs: Option<imc::PlanControlState>,
    nav_entity: Option<u8>,
    nav_entity_fault: Option<String>,
    position: Option<Position>,
    nav: DataWatch,
    nav_problem: Option<String>,
    interface: InterfaceState,
    /// The interface entered COMMAND and no plan was started for it yet.
    command_entered: bool,
    course: Option<Course>,
    plan: Option<Plan>,
    last_start: Option<Duration>,
    last_stop: Option<Duration>,
    request_id: u16,
    bad_log: RateLimitedLog,
    info_log: RateLimitedLog,
    pub counters: DuneCounters,
}

impl DuneDriver {
    pub fn new(settings: Settings) -> Self {
        let vehicle_id = (settings.vehicle_id != 0).then_some(settings.vehicle_id);
        Self {
            settings,
            writer: None,
            link_task: OwnedTask::default(),
            link_stats: Arc::new(LinkStats::default()),
            vehicle_id,
            state: FrontSeatState::FrontseatNotConnected,
            why: "no VehicleState yet".into(),
            last_vs: None,
            vs: None,
            pcs: None,
            nav_entity: None,
            nav_entity_fault: None,
            position: None,
            nav: DataWatch::default(),
            nav_problem: None,
            interface: InterfaceState::InterfaceStandby,
            command_entered: false,
            course: None,
            plan: None,
            last_start: None,
            last_stop: None,
            request_id: 0,
            bad_log: RateLimitedLog::for_bad_input(),
            info_log: RateLimitedLog::for_bad_input(),
            counters: DuneCounters::default(),
        }
    }

    /// Why the frontseat state is what it is.
    pub fn state_reason(&self) -> &str {
        &self.why
    }

    /// The vehicle's IMC id, once known.
    pub fn vehicle_id(&self) -> Option<u16> {
        self.vehicle_id
    }

    /// Whether our FollowReference plan is running (started and not ended).
    pub fn plan_running(&self) -> bool {
        self.plan.is_some()
    }

    /// Why navigation is not published, if it is not.
    pub fn nav_problem(&self) -> Option<&str> {
        self.nav_problem.as_deref()
    }

    fn bad(&mut self, what: &str) {
        self.counters.bad_input += 1;
        frontseat_actors::drivers::kit::bad_line();
        if let Some(suppressed) = log_due(&mut self.bad_log) {
            tracing::warn!(%what, suppressed, "bad input from the DUNE vehicle");
        }
    }

    fn send(&mut self, msg: Message, sig: &mut dyn SignalSink) -> bool {
        let Some(dst) = self.vehicle_id else {
            return false;
        };
        let h = Header::new(self.settings.own_id, dst, SimClock::unix_now());
        let Ok(bytes) = imc::encode(&h, &msg, ByteOrder::Little) else {
            return false;
        };
        self.write_bytes(bytes, sig)
    }

    fn write_bytes(&mut self, bytes: Vec<u8>, sig: &mut dyn SignalSink) -> bool {
        let Some(w) = &self.writer else {
            self.counters.write_failures += 1;
            return false;
        };
        match send_bytes(w, bytes, sig) {
            Ok(()) => true,
            Err(e) => {
                self.counters.write_failures += 1;
                if let Some(suppressed) = log_due(&mut self.bad_log) {
                    tracing::warn!(error = %e, suppressed, "IMC packet to the vehicle not sent");
                }
                false
            }
        }
    }

    fn set_state(&mut self, state: FrontSeatState, why: String) {
        if state != self.state || why != self.why {
            tracing::info!(?state, %why, "DUNE vehicle state");
        }
        self.state = state;
        self.why = why;
    }

    fn ours(&self) -> bool {
        self.plan.is_some()
            || self
                .pcs
                .as_ref()
                .is_some_and(|p| p.plan_id == self.settings.plan_id)
    }

    fn on_packet(&mut self, bytes: Vec<u8>, now: Duration, sig: &mut dyn SignalSink) {
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
                    tracing::warn!("DUNE: FollowReference timed out waiting for our References");
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
                        tracing::warn!(?fault, "DUNE navigation entity");
                    }
                    self.nav_entity_fault = fault;
                }
            }
            Message::Abort(_) => {
                tracing::warn!("DUNE: an Abort is on the vehicle's bus");
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
            tracing::info!("DUNE: our FollowReference plan is running; taking it back");
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
            tracing::warn!(why = %self.why, "DUNE vehicle no longer takes our course");
        }
        let _ = sig;
    }

    fn plan_ended(&mut self, why: &str) {
        if self.plan.take().is_some() {
            self.counters.maneuver_failures += 1;
            tracing::warn!(%why, "DUNE: our FollowReference plan ended");
        }
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
                    tracing::info!(info = %p.info, suppressed, "DUNE plan engine");
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
                tracing::warn!(%why, "DUNE navigation not usable: not providing data");
            }
            self.nav_problem = Some(why);
            self.nav.lost();
            self.counters.nav_refused += 1;
            return;
        }
        if self.nav_problem.take().is_some() {
            tracing::info!("DUNE navigation usable again");
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

    fn start_plan(&mut self, now: Duration, sig: &mut dyn SignalSink) {
        self.request_id = self.request_id.wrapping_add(1);
        let msg = imc::PlanControl {
            kind: consts::plan_control::REQUEST,
            op: consts::plan_control::START,
            request_id: self.request_id,
            plan_id: self.settings.plan_id.clone(),
            flags: 0,
            arg: Some(Box::new(
                imc::FollowReference {
                    control_src: self.settings.own_id,
                    control_ent: imc::ANY_ENTITY,
                    timeout: self.settings.maneuver_timeout,
                    loiter_radius: 0.0,
                    altitude_interval: 0.0,
                }
                .into(),
            )),
            info: String::new(),
        };
        self.last_start = Some(now);
        if self.send(msg.into(), sig) {
            self.counters.plan_starts += 1;
            self.command_entered = false;
            tracing::info!(
                timeout_s = self.settings.maneuver_timeout,
                "DUNE: PlanControl START FollowReference"
            );
            self.plan = Some(Plan {
                started: now,
                request_id: self.request_id,
                confirmed: false,
                last_reference: None,
            });
            self.send_reference(now, sig);
        }
    }

    fn stop_plan(&mut self, why: &str, now: Duration, sig: &mut dyn SignalSink) {
        let Some(plan) = self.plan.take() else {
            return;
        };
        self.last_stop = Some(now);
        tracing::info!(%why, "DUNE: ending our FollowReference plan (MANDONE, STOP)");
        let (lat, lon) = self
            .position
            .map(|p| (p.lat.to_radians(), p.lon.to_radians()))
            .unwrap_or_default();
        self.send(
            imc::Reference {
                flags: consts::reference::MANDONE,
                speed: None,
                z: None,
                lat,
                lon,
                radius: 0.0,
            }
            .into(),
            sig,
        );
        self.send(
            imc::PlanControl {
                kind: consts::plan_control::REQUEST,
                op: consts::plan_control::STOP,
                request_id: plan.request_id,
                plan_id: self.settings.plan_id.clone(),
                flags: 0,
                arg: None,
                info: String::new(),
            }
            .into(),
            sig,
        );
        self.counters.plan_stops += 1;
    }

    fn send_reference(&mut self, now: Duration, sig: &mut dyn SignalSink) {
        let (Some(c), Some(p)) = (self.course, self.position) else {
            return;
        };
        if now.saturating_sub(c.renewed) > self.settings.course_timeout {
            return;
        }
        let r = infer::steering_reference(
            p.lat,
            p.lon,
            c.heading,
            c.speed,
            c.depth,
            self.settings.lookahead_m,
        );
        if self.send(r.into(), sig) {
            self.counters.references_sent += 1;
            if let Some(plan) = &mut self.plan {
                plan.last_reference = Some(now);
            }
        }
    }

    fn vehicle_lost(&mut self, why: &str) {
        self.set_state(FrontSeatState::FrontseatNotConnected, why.into());
        self.nav.lost();
        self.last_vs = None;
        self.vs = None;
        self.pcs = None;
        self.course = None;
        // Without a link nothing can be ended; the maneuver's own timeout ends it.
        self.plan = None;
    }
}

/// `Name=id;Name=id` (EntityList) → the id of `name`.
fn entity_id(list: &str, name: &str) -> Option<u8> {
    list.split(';')
        .filter_map(|kv| kv.split_once('='))
        .find(|(k, _)| *k == name)
        .and_then(|(_, v)| v.trim().parse().ok())
}

impl Driver for DuneDriver {
    fn name(&self) -> &str {
        "dune"
    }

    fn start(&mut self, ctx: DriverContext) {
        self.link_task.set(byte::spawn(
            self.settings.link.clone(),
            ctx.io,
            self.link_stats.clone(),
        ));
    }

    fn handle_io(&mut self, ev: DriverIoEvent, now: Duration, sig: &mut dyn SignalSink) {
        match ev {
            DriverIoEvent::Connected(w) => {
                tracing::info!(address = %self.settings.address, "IMC BackSeat link open");
                self.writer = Some(w);
            }
            DriverIoEvent::Frame(b) => self.on_packet(b, now, sig),
            DriverIoEvent::Line(_) => self.bad("text line on an IMC link"),
            DriverIoEvent::BadInput(what) => self.bad(&what),
            DriverIoEvent::Disconnected(reason) => {
                tracing::warn!(%reason, "IMC BackSeat link lost; reconnecting");
                self.writer = None;
                self.vehicle_lost("link lost");
            }
        }
    }

    fn send_command_to_frontseat(
        &mut self,
        req: &CommandRequest,
        now: Duration,
        sig: &mut dyn SignalSink,
    ) {
        let Some(c) = &req.desired_course else {
            refuse(req, "the DUNE driver takes desired_course only", sig);
            return;
        };
        let (heading, speed) = (c.heading(), c.speed());
        let depth = c.depth;
        if !(heading.is_finite()
            && speed.is_finite()
            && speed >= 0.0
            && depth.is_none_or(|d| d.is_finite()))
        {
            refuse(
                req,
                "desired_course needs a finite heading, a finite non-negative speed and a finite depth",
                sig,
            );
            return;
        }
        if self.state != FrontSeatState::FrontseatAcceptingCommands {
            refuse(
                req,
                format!("DUNE vehicle not taking a backseat's course: {}", self.why),
                sig,
            );
            return;
        }
        let changed = self
            .course
            .is_none_or(|o| o.heading != heading || o.speed != speed || o.depth != depth);
        self.course = Some(Course {
            heading,
            speed,
            depth,
            renewed: now,
        });
        if self.plan.is_some() && changed {
            self.send_reference(now, sig);
        }
        if req.response_requested() {
            sig.command_response(CommandResponse {
                request_successful: Some(true),
                request_id: req.request_id,
                error_code: Some(0),
                error_string: None,
            });
        }
    }

    fn send_data_to_frontseat(
        &mut self,
        _data: &InterfaceData,
        _now: Duration,
        _sig: &mut dyn SignalSink,
    ) {
        // No data channel to DUNE.
    }

    fn send_raw_to_frontseat(&mut self, raw: &Raw, _now: Duration, sig: &mut dyn SignalSink) {
        let bytes = raw.raw.as_deref().unwrap_or_default();
        if bytes.is_empty() || bytes.len() > MAX_RAW_BYTES {
            return self.bad("raw_send_request is not 1 to 16384 bytes of IMC packets");
        }
        // Whole, checked packets only: a broken one would cost the vehicle's parser a resync.
        let mut d = imc::Deframer::new();
        let mut ok = true;
        d.feed(bytes, &mut |r| ok &= r.is_ok());
        if !ok || d.buffered() != 0 {
            return self.bad("raw_send_request is not whole IMC packets with good CRCs");
        }
        self.write_bytes(bytes.to_vec(), sig);
    }

    fn interface_status(&mut self, status: &InterfaceStatus) {
        let s = status.state();
        if s == InterfaceState::InterfaceCommand && self.interface != s {
            self.command_entered = true;
        }
        self.interface = s;
    }

    fn do_loop(&mut self, now: Duration, sig: &mut dyn SignalSink) {
        if let Some(t) = self.last_vs
            && now.saturating_sub(t) > self.settings.vehicle_state_timeout
        {
            tracing::warn!(
                "no VehicleState from the vehicle for {:?}: not connected",
                self.settings.vehicle_state_timeout
            );
            self.vehicle_lost("VehicleState silent");
        }
        if self.nav.expired(now, self.settings.navigation_timeout) {
            tracing::warn!("no usable EstimatedState from the vehicle: not providing data");
        }
        let commanding = self.interface == InterfaceState::InterfaceCommand;
        if !commanding {
            self.command_entered = false;
            self.stop_plan("the interface left COMMAND", now, sig);
            return;
        }
        let fresh_course = self
            .course
            .is_some_and(|c| now.saturating_sub(c.renewed) <= self.settings.course_timeout);
        match self.plan {
            None => {
                let ready = self.state == FrontSeatState::FrontseatAcceptingCommands
                    && self.vs.as_ref().map(|v| v.op_mode) == Some(consts::op_mode::SERVICE);
                let retry_ok = self
                    .last_start
                    .is_none_or(|t| now.saturating_sub(t) >= START_RETRY);
                if ready && retry_ok && (self.command_entered || fresh_course) {
                    self.start_plan(now, sig);
                }
            }
            Some(p) => {
                let due = p.last_reference.is_none_or(|t| {
                    now.saturating_sub(t) + LOOP_SLACK >= self.settings.reference_period
                });
                if due && fresh_course {
                    self.send_reference(now, sig);
                }
            }
        }
    }

    fn frontseat_state(&self) -> FrontSeatState {
        self.state
    }

    fn frontseat_providing_data(&self) -> bool {
        self.nav.providing()
    }

    fn stop(&mut self) {
        // An orderly stop ends our plan rather than leaving it to the maneuver's timeout.
        let mut sink = NullSink;
        self.stop_plan("the interface is stopping", Duration::ZERO, &mut sink);
        self.writer = None;
    }
}

/// Signals nobody will read (an orderly stop).
struct NullSink;

impl SignalSink for NullSink {
    fn command_response(&mut self, _: CommandResponse) {}
    fn data_from_frontseat(&mut self, _: InterfaceData) {}
    fn raw_from_frontseat(&mut self, _: Raw) {}
    fn raw_to_frontseat(&mut self, _: Raw) {}
}

/// IMC packets on a byte link, CRC-checked by the codec's bounded deframer.
pub fn imc_frames() -> Box<dyn FrameCutter> {
    Box::new(ImcFrames(imc::Deframer::new()))
}

struct ImcFrames(imc::Deframer);

impl FrameCutter for ImcFrames {
    fn feed(&mut self, bytes: &[u8], out: &mut dyn FnMut(Result<Vec<u8>, String>)) {
        self.0
            .feed(bytes, &mut |r| out(r.map_err(|e| format!("IMC: {e}"))))
    }
}
