//! The DUNE driver's state and I/O. It reads VehicleState (and its liveness) into a frontseat
//! state with a reason, EstimatedState into NodeStatus while it is sane and the navigation
//! entity is healthy, and steers by the backseat path DUNE supports: on entering COMMAND a
//! one-maneuver plan (PlanControl START with FollowReference, control_src = us, a timeout), then
//! a Reference each period toward a point ahead on the helm's heading, ended by a MANDONE
//! Reference and PlanControl STOP when the interface leaves COMMAND. If we die, the maneuver's
//! own timeout stops the vehicle. Everything goes to the vehicle's IMC id exactly.
//!
//! Here: the settings, the counters, the state, writing to the vehicle and the runtime's
//! `Driver` trait (whose loop decides when a plan starts and a Reference is due). What the
//! vehicle says is read in `reading`; the plan and its References are sent by `steering`.

/// Log lines keep the target this module had as one file, whatever part now writes them:
/// operators filter and grep on it.
const LOG_TARGET: &str = "frontseat_dune::driver";

use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use crate::imc::{self, ByteOrder, Header, Message, consts};
use crate::infer::Position;
use frontseat_config::InterfaceConfig;

use frontseat_actors::clock::SimClock;
use frontseat_actors::driver::{DirectCommand, Driver, DriverContext, DriverIoEvent, SignalSink};
use frontseat_actors::drivers::kit::{
    Asker, DataWatch, OwnedTask, config_secs, log_due, raw_binary, refuse, send_bytes,
};
use frontseat_actors::link::LineWriter;
use frontseat_actors::link::byte::{self, ByteLinkConfig, LinkStats, Transport};
use frontseat_actors::link::framing::{FrameCutter, Framing};
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CommandRequest, CommandResponse, FrontSeatState, InterfaceData, InterfaceState,
    InterfaceStatus, Raw,
};
use frontseat_actors::ratelog::RateLimitedLog;

mod reading;
mod steering;

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
/// Where a lane Reference may go, as the driver last left it: our plan running, the vehicle
/// taking a backseat's course, its IMC address and last position, the course in force.
#[derive(Clone, Copy)]
struct Ready {
    dst: u16,
    lat: f64,
    lon: f64,
    course: Option<(f64, f64, Option<f64>)>,
}

/// What the driver shares with the setpoint lane's [`DirectReference`] (ARCHITECTURE.md "The lane
/// per vehicle family"): `ready`, published by the driver after every message (None: the course
/// goes the actors' way), and the course the lane last wrote a Reference for, which the driver
/// takes as its own at the start of its next message — so the Reference's re-sends every
/// `reference_period` and the helm's `course_timeout` go on from it.
#[derive(Default)]
struct SteerState {
    ready: Option<Ready>,
    written: Option<(f64, f64, Option<f64>)>,
}

#[derive(Clone, Default)]
struct Steer(Arc<Mutex<SteerState>>);

impl Steer {
    fn lock(&self) -> MutexGuard<'_, SteerState> {
        self.0.lock().unwrap_or_else(|p| p.into_inner())
    }
}

/// The setpoint lane's way to a DUNE vehicle: a new course's Reference (toward the point ahead
/// on its heading, as the driver computes it) written from the publisher's thread while our
/// FollowReference plan runs. Starting and ending the plan stay the driver's.
struct DirectReference {
    writer: LineWriter,
    steer: Steer,
    own_id: u16,
    lookahead_m: f64,
}

impl DirectCommand for DirectReference {
    fn send_now(&self, req: &CommandRequest) -> Option<Raw> {
        let c = req.desired_course.as_ref()?;
        let (heading, speed, depth) = (c.heading(), c.speed(), c.depth);
        // What the driver's own path would refuse goes there to be refused.
        if !(heading.is_finite()
            && speed.is_finite()
            && speed >= 0.0
            && depth.is_none_or(|d| d.is_finite()))
        {
            return None;
        }
        if !self.writer.writes_at_once() {
            return None;
        }
        let mut st = self.steer.lock();
        let ready = st.ready?;
        let now_course = st.written.or(ready.course);
        // Unchanged: the driver's path renews it without a write.
        if now_course == Some((heading, speed, depth)) {
            return None;
        }
        let r = crate::infer::steering_reference(
            ready.lat,
            ready.lon,
            heading,
            speed,
            depth,
            self.lookahead_m,
        );
        let h = Header::new(self.own_id, ready.dst, SimClock::unix_now());
        let bytes = imc::encode(&h, &r.into(), ByteOrder::Little).ok()?;
        self.writer.write_bytes(bytes.clone()).ok()?;
        st.written = Some((heading, speed, depth));
        Some(raw_binary(bytes))
    }
}

pub struct DuneDriver {
    settings: Settings,
    writer: Option<LineWriter>,
    /// Shared with the lane's [`DirectReference`].
    steer: Steer,
    /// While the link is open: the setpoint lane's way to it.
    direct: Option<Arc<DirectReference>>,
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
            steer: Steer::default(),
            direct: None,
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

    /// At the start of every message: the course the lane wrote a Reference for becomes the
    /// driver's, renewed now, its Reference sent now.
    fn absorb(&mut self, now: Duration) {
        let written = self.steer.lock().written.take();
        if let Some(w) = written {
            self.adopt(w, now);
        }
    }

    /// The lane's course `(heading, speed, depth)`, its Reference written: the driver's own now.
    fn adopt(&mut self, (heading, speed, depth): (f64, f64, Option<f64>), now: Duration) {
        self.course = Some(Course {
            heading,
            speed,
            depth,
            renewed: now,
        });
        self.counters.references_sent += 1;
        if let Some(plan) = &mut self.plan {
            plan.last_reference = Some(now);
        }
    }

    /// At the end of every message: where a lane Reference may go now, if anywhere.
    fn publish_steer(&mut self) {
        let ready = match (
            self.plan,
            self.vehicle_id,
            self.position,
            self.writer.is_some(),
        ) {
            (Some(_), Some(dst), Some(p), true)
                if self.state == FrontSeatState::FrontseatAcceptingCommands
                    && self.interface == InterfaceState::InterfaceCommand =>
            {
                Some(Ready {
                    dst,
                    lat: p.lat,
                    lon: p.lon,
                    course: self.course.map(|c| (c.heading, c.speed, c.depth)),
                })
            }
            _ => None,
        };
        self.steer.lock().ready = ready;
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
            tracing::warn!(target: LOG_TARGET, %what, suppressed, "bad input from the DUNE vehicle");
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
                    tracing::warn!(target: LOG_TARGET, error = %e, suppressed, "IMC packet to the vehicle not sent");
                }
                false
            }
        }
    }

    fn set_state(&mut self, state: FrontSeatState, why: String) {
        if state != self.state || why != self.why {
            tracing::info!(target: LOG_TARGET, ?state, %why, "DUNE vehicle state");
        }
        self.state = state;
        self.why = why;
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

impl Driver for DuneDriver {
    fn name(&self) -> &str {
        "dune"
    }

    fn start(&mut self, ctx: DriverContext) {
        self.link_task.set(byte::spawn_direct(
            self.settings.link.clone(),
            ctx.io,
            self.link_stats.clone(),
        ));
    }

    fn handle_io(&mut self, ev: DriverIoEvent, now: Duration, sig: &mut dyn SignalSink) {
        self.absorb(now);
        self.io_event(ev, now, sig);
        self.publish_steer();
    }

    fn send_command_to_frontseat(
        &mut self,
        req: &CommandRequest,
        now: Duration,
        sig: &mut dyn SignalSink,
    ) {
        self.absorb(now);
        self.take_course(req, now, sig);
        self.publish_steer();
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
        self.on_interface_status(status);
        self.publish_steer();
    }

    fn do_loop(&mut self, now: Duration, sig: &mut dyn SignalSink) {
        self.absorb(now);
        self.tick(now, sig);
        self.publish_steer();
    }

    fn direct_command(&self) -> Option<Arc<dyn DirectCommand>> {
        self.direct.clone().map(|d| d as Arc<dyn DirectCommand>)
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
        self.direct = None;
        self.steer.lock().ready = None;
    }
}

/// The driver's work per message, between [`DuneDriver::absorb`] and
/// [`DuneDriver::publish_steer`].
impl DuneDriver {
    fn io_event(&mut self, ev: DriverIoEvent, now: Duration, sig: &mut dyn SignalSink) {
        match ev {
            DriverIoEvent::Connected(w) => {
                tracing::info!(target: LOG_TARGET, address = %self.settings.address, "IMC BackSeat link open");
                self.direct = Some(Arc::new(DirectReference {
                    writer: w.clone(),
                    steer: self.steer.clone(),
                    own_id: self.settings.own_id,
                    lookahead_m: self.settings.lookahead_m,
                }));
                self.writer = Some(w);
            }
            DriverIoEvent::Frame(b) => self.on_packet(b, now, sig),
            DriverIoEvent::Line(_) => self.bad("text line on an IMC link"),
            DriverIoEvent::BadInput(what) => self.bad(&what),
            DriverIoEvent::Disconnected(reason) => {
                tracing::warn!(target: LOG_TARGET, %reason, "IMC BackSeat link lost; reconnecting");
                self.writer = None;
                self.direct = None;
                self.vehicle_lost("link lost");
            }
        }
    }

    fn take_course(&mut self, req: &CommandRequest, now: Duration, sig: &mut dyn SignalSink) {
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
        Asker::of(req).answer(sig, true, 0, None);
    }

    fn on_interface_status(&mut self, status: &InterfaceStatus) {
        let s = status.state();
        if s == InterfaceState::InterfaceCommand && self.interface != s {
            self.command_entered = true;
        }
        self.interface = s;
    }

    fn tick(&mut self, now: Duration, sig: &mut dyn SignalSink) {
        if let Some(t) = self.last_vs
            && now.saturating_sub(t) > self.settings.vehicle_state_timeout
        {
            tracing::warn!(
                target: LOG_TARGET,
                "no VehicleState from the vehicle for {:?}: not connected",
                self.settings.vehicle_state_timeout
            );
            self.vehicle_lost("VehicleState silent");
        }
        if self.nav.expired(now, self.settings.navigation_timeout) {
            tracing::warn!(target: LOG_TARGET, "no usable EstimatedState from the vehicle: not providing data");
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
