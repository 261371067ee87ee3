//! The Bluefin driver's state: what the Huxley told us (frontseat state, providing data, the
//! last navigation fix), the stop-and-wait write queue with its acknowledgements, resends and
//! demerits, and the `$BPSTS` heartbeat. Everything the Huxley sends arrives as a line through
//! [`Driver::handle_io`]; timers run in [`Driver::do_loop`] at 10 Hz of simulated time.
//!
//! Goby3's behaviour is the reference (see `docs/goby3-differences.md` for where this differs):
//! requests are answered per request (not per command type), every command sentence gets an
//! answer (including cancel, abort and the mission confirms), an ack for a pending command never
//! releases another sentence's wait, an unmatched ack clears nothing, the heartbeat runs at its
//! configured period, and an unresponsive Huxley gets its connection re-opened.
//!
//! Here: the settings, the counters, the state and the runtime's `Driver` trait. The parts of
//! the work each own a file, all on this one state: `inbound` (what the Huxley's sentences
//! become), `outbound` (what we send, as sentences) and `queue` (how a sentence is delivered:
//! stop-and-wait with acknowledgements, resends and demerits).

/// Log lines keep the target this module had as one file, whatever part now writes them:
/// operators filter and grep on it.
const LOG_TARGET: &str = "frontseat_bluefin::driver";

use std::collections::VecDeque;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use frontseat_config::{AcceptingCommandsHook, InterfaceConfig};

use crate::codec::{self, FromPayload, Nvg, Sentence};
use frontseat_actors::clock::SimClock;
use frontseat_actors::driver::{
    DirectCommand, Driver, DriverContext, DriverExtension, DriverIoEvent, IoSender, SignalSink,
    raw_ascii, refuse_extension,
};
use frontseat_actors::drivers::kit::{LinkState, OwnedTask, decoded};
use frontseat_actors::link::{self, LineWriter, LinkConfig};
use frontseat_actors::proto::frontseat::protobuf::bluefin as bf;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CommandRequest, CommandResponse, DesiredCourse, FrontSeatState, InterfaceData, Raw,
    bluefin_extra_data::PayloadStatus,
};
use frontseat_actors::ratelog::{LogDecision, RateLimitedLog};

mod inbound;
mod outbound;
mod queue;

/// The types of the Bluefin extension (Goby3's field 1000), as its groups declare them.
pub const COMMAND: &str =
    frontseat_actors::groups::FRONTSEAT_BLUEFIN_BLUEFIN_COMMAND_REQUEST.type_name();
pub const DATA: &str =
    frontseat_actors::groups::FRONTSEAT_BLUEFIN_BLUEFIN_DATA_FROM_FRONTSEAT.type_name();

/// Sentences waiting to be written before new ones are refused: a Huxley that stops acking
/// must not grow our memory.
pub const MAX_QUEUE: usize = 256;
/// Sentences the Huxley answered "pending" (status 3) and not yet finally: a Huxley that answers
/// pending to everything must not grow our memory either. Past this the oldest is given up.
pub const MAX_PENDING: usize = 256;
/// Payload statuses kept for the heartbeat (they expire by themselves).
const MAX_PAYLOAD_STATUSES: usize = 64;
/// Longest line accepted from the Huxley.
pub const MAX_LINE_BYTES: usize = 2048;

/// CommandResponse error codes of ours (Goby3 uses the BFACK status, 0 or 1).
pub mod error_code {
    /// Huxley: invalid request (BFACK status 0).
    pub const INVALID: i32 = 0;
    /// Huxley: request unsuccessfully processed (BFACK status 1).
    pub const FAILED: i32 = 1;
    /// Written `nmea_resend_attempts` times without an acknowledgement.
    pub const NOT_ACKNOWLEDGED: i32 = 10;
    /// The connection closed (or was re-opened) before the Huxley answered.
    pub const CONNECTION_LOST: i32 = 11;
    /// Nothing in the request this driver can send, or a value it cannot write.
    pub const BAD_REQUEST: i32 = 12;
    /// The write queue is full.
    pub const QUEUE_FULL: i32 = 13;
    /// Cancelled by a later request's cancel_request_id.
    pub const CANCELLED: i32 = 14;
    /// Answered "pending" and then crowded out by `MAX_PENDING` newer pending sentences before
    /// the Huxley gave its final answer.
    pub const PENDING_OVERFLOW: i32 = 15;
}

#[derive(Clone, Debug)]
pub struct Settings {
    pub link: LinkConfig,
    pub resend_attempts: u32,
    pub resend_interval: Duration,
    pub allowed_demerits: u32,
    pub missing_nav: Duration,
    pub heartbeat: Duration,
    /// `$BPLOG,<id>,ON` at every connect, in order.
    pub bplog: Vec<String>,
    pub send_tmr: bool,
    pub disable_ack: bool,
    pub hook: AcceptingCommandsHook,
    /// (speed m/s, rpm) sorted by speed, when commanding RPM.
    pub rpm_table: Option<Vec<(f64, f64)>>,
}

impl Settings {
    pub fn from_config(cfg: &InterfaceConfig) -> Self {
        let b = &cfg.driver.bluefin;
        let mut bplog: Vec<String> = Vec::new();
        if !b.disable_ack {
            // First, so that every other sentence is acknowledged.
            bplog.push("ACK".into());
        }
        for id in [
            "NVG", "MIS", "MSC", "NVR", "SVS", "RVL", "SHT", "TOP", "MBS", "MBE", "CTD", "DVL",
            "BOY", "TRM",
        ] {
            bplog.push(id.into());
        }
        if b.accepting_commands_hook == AcceptingCommandsHook::BfctlTrigger {
            bplog.push("CTL".into());
        }
        bplog.extend(b.extra_bplog.iter().map(|s| s.to_ascii_uppercase()));
        let rpm_table = b.use_rpm_table_for_speed.then(|| {
            let mut t: Vec<(f64, f64)> = b
                .rpm_table
                .iter()
                .filter(|e| e.speed.is_finite())
                .map(|e| (e.speed, f64::from(e.rpm)))
                .collect();
            t.sort_by(|a, b| a.0.total_cmp(&b.0));
            t
        });
        Self {
            link: LinkConfig {
                host: b.huxley_tcp_address.clone(),
                port: b.huxley_tcp_port,
                backoff_initial: Duration::from_millis(50),
                backoff_max: Duration::from_secs(u64::from(b.reconnect_interval.max(1))),
                max_line_bytes: MAX_LINE_BYTES,
            },
            resend_attempts: b.nmea_resend_attempts.max(1),
            resend_interval: Duration::from_secs(u64::from(b.nmea_resend_interval.max(1))),
            allowed_demerits: b.allowed_nmea_demerits,
            missing_nav: Duration::from_secs(u64::from(b.allow_missing_nav_interval.max(1))),
            heartbeat: Duration::from_secs(u64::from(b.heartbeat_interval.max(1))),
            bplog,
            send_tmr: b.send_tmr_messages,
            disable_ack: b.disable_ack,
            hook: b.accepting_commands_hook,
            rpm_table,
        }
    }
}

/// Counters since the driver started.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct BluefinStats {
    /// Lines that are not sentences, fail their checksum, or have malformed fields.
    pub bad_lines: u64,
    /// Well-formed sentences of an id the driver does not act on.
    pub ignored_sentences: u64,
    /// `$BFACK`s that match nothing in flight or pending.
    pub unmatched_acks: u64,
    /// Sentences dropped after `nmea_resend_attempts` writes without an ack.
    pub dropped_unacked: u64,
    /// Sentences rewritten after `nmea_resend_interval`.
    pub resends: u64,
    /// Sentences refused because the queue was full.
    pub queue_full: u64,
    /// Lines that could not be handed to the socket.
    pub write_failures: u64,
    /// Pending sentences given up because `MAX_PENDING` newer ones were pending too.
    pub pending_overflow: u64,
    /// Connections re-opened because the Huxley stopped acknowledging.
    pub unresponsive_resets: u64,
}

/// One sentence on its way to the Huxley.
#[derive(Clone, Debug)]
struct Outgoing {
    /// The 3-letter id the Huxley acknowledges it by.
    ack_id: String,
    line: String,
    /// The request to answer when the Huxley answers this sentence.
    request: Option<Option<i32>>,
    written_at: Option<Duration>,
    writes: u32,
}

/// What the driver shares with the setpoint lane's [`DirectRmb`], under one lock (ARCHITECTURE.md
/// "The lane per vehicle family"): whether a sentence of the driver's is queued or in flight
/// (`busy`: set before the driver writes a head, cleared after a message only when its queue is
/// empty), and the lane's `$BPRMB` in flight until the driver takes it in as its queue's head at
/// the start of its next message — before the `$BFACK` that answers it can be handled. So the
/// lane writes only when nothing is in flight, and stop-and-wait holds whichever thread wrote.
#[derive(Default)]
struct Wire {
    busy: bool,
    lane_head: Option<Outgoing>,
}

#[derive(Clone, Default)]
struct SharedWire(Arc<Mutex<Wire>>);

impl SharedWire {
    fn lock(&self) -> MutexGuard<'_, Wire> {
        self.0.lock().unwrap_or_else(|p| p.into_inner())
    }
}

/// The setpoint lane's way to the Huxley: a course's `$BPRMB` written from the publisher's
/// thread when nothing of the driver's is queued or in flight, then tracked as the in-flight
/// head (its `$BFACK`, resends after `nmea_resend_interval`, the drop and its demerit) like any
/// sentence. A lane course asks for no answer.
struct DirectRmb {
    writer: LineWriter,
    wire: SharedWire,
    clock: SimClock,
    settings: Settings,
}

impl DirectCommand for DirectRmb {
    fn send_now(&self, req: &CommandRequest) -> Option<Raw> {
        let c = req.desired_course.as_ref()?;
        if !self.writer.writes_at_once() {
            return None;
        }
        // The driver's wall clock is the system's outside its unit tests.
        let tod = codec::seconds_of_day(SimClock::unix_now());
        let msg = FromPayload::Rmb(outbound::rmb(&self.settings, c, tod).ok()?);
        let line = msg.to_sentence().format();
        let mut w = self.wire.lock();
        if w.busy || w.lane_head.is_some() {
            return None;
        }
        if !self.settings.disable_ack {
            w.lane_head = Some(Outgoing {
                ack_id: msg.id().to_string(),
                line: line.clone(),
                request: None,
                written_at: Some(self.clock.now()),
                writes: 1,
            });
            w.busy = true;
        }
        if self.writer.write_line(&line).is_err() {
            w.lane_head = None;
            w.busy = false;
            return None;
        }
        Some(raw_ascii(&line, ""))
    }
}

/// Wall clock (Unix seconds) used for sentence timestamps and NodeStatus dates; a test fixes it.
pub type WallClock = Box<dyn Fn(Duration) -> f64 + Send>;

pub struct BluefinDriver {
    settings: Settings,
    wall: WallClock,
    io: Option<IoSender>,
    /// Its data watch: `$BFNVG`.
    link: LinkState,
    link_task: OwnedTask,
    nvg: Option<Nvg>,
    /// Head may be in flight (written, waiting for its ack).
    queue: VecDeque<Outgoing>,
    /// Acknowledged "pending" (status 3), waiting for the final answer.
    pending: VecDeque<Outgoing>,
    /// Shared with the lane's [`DirectRmb`].
    wire: SharedWire,
    /// The sim clock (from `start`): the lane's `$BPRMB` is stamped written by it.
    clock: Option<SimClock>,
    /// While connected: the setpoint lane's way to the Huxley.
    direct: Option<Arc<DirectRmb>>,
    demerits: u32,
    last_heartbeat: Option<Duration>,
    payload_status: Vec<PayloadStatus>,
    /// The interface is in HELM_ERROR or FS_ERROR: the heartbeat says not all ok.
    interface_in_error: bool,
    /// Bad input is logged a few times per window, then summarised (a garbage stream must not
    /// flood the journal); the counters keep counting.
    problems: RateLimitedLog,
    pub stats: BluefinStats,
}

impl BluefinDriver {
    pub fn new(settings: Settings) -> Self {
        Self::with_wall_clock(settings, Box::new(|_| SimClock::unix_now()))
    }

    /// A driver whose timestamps come from `wall` (given the driver's simulated time).
    pub fn with_wall_clock(settings: Settings, wall: WallClock) -> Self {
        Self {
            settings,
            wall,
            io: None,
            link: LinkState::default(),
            link_task: OwnedTask::default(),
            nvg: None,
            queue: VecDeque::new(),
            pending: VecDeque::new(),
            wire: SharedWire::default(),
            clock: None,
            direct: None,
            demerits: 0,
            last_heartbeat: None,
            payload_status: Vec::new(),
            interface_in_error: false,
            problems: RateLimitedLog::for_bad_input(),
            stats: BluefinStats::default(),
        }
    }

    /// Sentences queued or in flight, and pending a final answer.
    pub fn queue_lengths(&self) -> (usize, usize) {
        (self.queue.len(), self.pending.len())
    }

    /// At the start of every message: the lane's `$BPRMB` in flight (if any) becomes the queue's
    /// head, before anything of this message can look for it or write.
    fn absorb(&mut self) {
        if let Some(o) = self.wire.lock().lane_head.take() {
            self.queue.push_front(o);
        }
    }

    /// At the end of every message: whether the lane may write (nothing queued or in flight).
    fn settle(&mut self) {
        let mut w = self.wire.lock();
        w.busy = !self.queue.is_empty() || w.lane_head.is_some();
    }

    /// The link is gone or being re-opened: no more lane writes to it.
    fn drop_direct(&mut self) {
        self.direct = None;
    }

    fn tod(&self, now: Duration) -> f64 {
        codec::seconds_of_day((self.wall)(now))
    }

    fn problem(&mut self, what: &str, line: &str) {
        let line: String = line.chars().take(120).collect();
        match self.problems.decide(tokio::time::Instant::now()) {
            LogDecision::Log { suppressed_before } if suppressed_before > 0 => tracing::warn!(
                target: LOG_TARGET,
                %line,
                "{what} (…and {suppressed_before} more Bluefin input problems in the last {}s)",
                self.problems.window().as_secs()
            ),
            LogDecision::Log { .. } => tracing::warn!(target: LOG_TARGET, %line, "{what}"),
            LogDecision::Suppress => tracing::debug!(target: LOG_TARGET, %line, "{what}"),
        }
    }

    fn answer(
        sig: &mut dyn SignalSink,
        request_id: Option<i32>,
        ok: bool,
        code: i32,
        why: impl Into<String>,
    ) {
        sig.command_response(CommandResponse {
            request_successful: Some(ok),
            request_id,
            error_code: (!ok).then_some(code),
            error_string: (!ok).then(|| why.into()),
        });
    }

    fn initialise(&mut self, now: Duration, sig: &mut dyn SignalSink) {
        self.fail_all("connection to the Huxley re-opened", sig);
        self.demerits = 0;
        for id in self.settings.bplog.clone() {
            self.enqueue(FromPayload::Log { id, on: true }, None, now, sig);
        }
        self.heartbeat(now, sig);
    }
}

/// The fields of a CommandRequest, plain or Bluefin-extended.
struct Cmd<'a> {
    desired: Option<&'a DesiredCourse>,
    ext: Option<
        &'a frontseat_actors::proto::goby::middleware::frontseat::protobuf::BluefinExtraCommands,
    >,
    response_requested: bool,
    request_id: Option<i32>,
    cancel_request_id: Option<i32>,
}

impl Driver for BluefinDriver {
    fn send_extension(&mut self, ext: &DriverExtension, now: Duration, sig: &mut dyn SignalSink) {
        self.absorb();
        self.extension(ext, now, sig);
        self.settle();
    }

    fn name(&self) -> &str {
        "bluefin"
    }

    fn start(&mut self, ctx: DriverContext) {
        self.io = Some(ctx.io.clone());
        self.clock = Some(ctx.clock);
        self.link_task
            .set(link::spawn(self.settings.link.clone(), ctx.io));
    }

    fn handle_io(&mut self, ev: DriverIoEvent, now: Duration, sig: &mut dyn SignalSink) {
        self.absorb();
        self.io_event(ev, now, sig);
        self.settle();
    }

    fn send_command_to_frontseat(
        &mut self,
        req: &CommandRequest,
        now: Duration,
        sig: &mut dyn SignalSink,
    ) {
        self.absorb();
        let c = Cmd {
            desired: req.desired_course.as_ref(),
            ext: None,
            response_requested: req.response_requested(),
            request_id: req.request_id,
            cancel_request_id: req.cancel_request_id,
        };
        self.command(c, now, sig);
        self.settle();
    }

    fn send_data_to_frontseat(
        &mut self,
        data: &InterfaceData,
        now: Duration,
        sig: &mut dyn SignalSink,
    ) {
        self.absorb();
        self.data(data, now, sig);
        self.settle();
    }

    fn send_raw_to_frontseat(&mut self, raw: &Raw, now: Duration, sig: &mut dyn SignalSink) {
        self.absorb();
        self.raw(raw, now, sig);
        self.settle();
    }

    fn do_loop(&mut self, now: Duration, sig: &mut dyn SignalSink) {
        self.absorb();
        self.tick(now, sig);
        self.settle();
    }

    fn interface_status(
        &mut self,
        status: &frontseat_actors::proto::goby::middleware::frontseat::protobuf::InterfaceStatus,
    ) {
        use frontseat_actors::proto::goby::middleware::frontseat::protobuf::InterfaceState;
        self.interface_in_error = matches!(
            status.state(),
            InterfaceState::InterfaceHelmError | InterfaceState::InterfaceFsError
        );
    }

    fn frontseat_state(&self) -> FrontSeatState {
        self.link.state
    }

    fn frontseat_providing_data(&self) -> bool {
        self.link.data.providing()
    }

    fn direct_command(&self) -> Option<Arc<dyn DirectCommand>> {
        self.direct.clone().map(|d| d as Arc<dyn DirectCommand>)
    }

    fn stop(&mut self) {
        self.drop_direct();
        self.link.close();
    }
}

/// The driver's work per message, between [`BluefinDriver::absorb`] and
/// [`BluefinDriver::settle`].
impl BluefinDriver {
    fn extension(&mut self, ext: &DriverExtension, now: Duration, sig: &mut dyn SignalSink) {
        match ext.type_name() {
            COMMAND => {
                if let Some(r) = decoded::<bf::CommandRequest>(ext, sig, self.name()) {
                    self.send_bluefin_command(&r, now, sig);
                }
            }
            DATA => {
                if let Some(d) = decoded::<bf::InterfaceData>(ext, sig, self.name()) {
                    self.send_bluefin_data(&d, now, sig);
                }
            }
            _ => refuse_extension(sig, ext, self.name()),
        }
    }

    fn io_event(&mut self, ev: DriverIoEvent, now: Duration, sig: &mut dyn SignalSink) {
        match ev {
            DriverIoEvent::Connected(w) => {
                tracing::info!(
                    target: LOG_TARGET,
                    host = %self.settings.link.host,
                    port = self.settings.link.port,
                    "connected to the Huxley; enabling its sentences"
                );
                self.direct = self.clock.map(|clock| {
                    Arc::new(DirectRmb {
                        writer: w.clone(),
                        wire: self.wire.clone(),
                        clock,
                        settings: self.settings.clone(),
                    })
                });
                self.link.opened(w, FrontSeatState::FrontseatIdle);
                self.initialise(now, sig);
            }
            DriverIoEvent::Line(line) => self.handle_line(&line, now, sig),
            DriverIoEvent::BadInput(what) => {
                self.stats.bad_lines += 1;
                frontseat_actors::drivers::kit::bad_line();
                self.problem("bad input from the Huxley", &what);
            }
            DriverIoEvent::Frame(_) => {
                self.stats.bad_lines += 1;
                frontseat_actors::drivers::kit::bad_line();
                self.problem("binary frame on a Huxley link", "");
            }
            DriverIoEvent::Disconnected(reason) => {
                tracing::warn!(target: LOG_TARGET, %reason, "Huxley connection lost; reconnecting");
                self.drop_direct();
                self.link.lost();
                self.fail_all("connection to the Huxley lost", sig);
            }
        }
    }

    fn raw(&mut self, raw: &Raw, now: Duration, sig: &mut dyn SignalSink) {
        let bytes = raw.raw.as_deref().unwrap_or_default();
        let Ok(text) = std::str::from_utf8(bytes) else {
            self.stats.bad_lines += 1;
            frontseat_actors::drivers::kit::bad_line();
            self.problem(
                "raw_send_request is not text; Huxley sentences are ASCII",
                "",
            );
            return;
        };
        // A supplied checksum is replaced by a fresh one, as Goby3 does.
        let text = text.trim();
        let body = match text.len().checked_sub(3).map(|i| text.split_at(i)) {
            Some((b, cs)) if cs.starts_with('*') => b,
            _ => text,
        };
        match Sentence::parse(body) {
            Ok(s) => self.enqueue(FromPayload::Other(s), None, now, sig),
            Err(e) => {
                self.stats.bad_lines += 1;
                frontseat_actors::drivers::kit::bad_line();
                self.problem(&format!("raw_send_request is not a sentence: {e}"), text);
            }
        }
    }

    fn tick(&mut self, now: Duration, sig: &mut dyn SignalSink) {
        if self.link.data.expired(now, self.settings.missing_nav) {
            tracing::warn!(
                target: LOG_TARGET,
                "no $BFNVG for {:?} (sim time): Huxley not providing data",
                self.settings.missing_nav
            );
        }
        if !self.link.is_open() {
            return;
        }
        if self
            .last_heartbeat
            .is_none_or(|t| now.saturating_sub(t) >= self.settings.heartbeat)
        {
            self.heartbeat(now, sig);
        }
        self.resend_or_drop(now, sig);
        self.try_send(now, sig);
    }
}
