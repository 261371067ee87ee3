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

use std::collections::{BTreeMap, VecDeque};
use std::time::Duration;

use base64::Engine as _;
use frontseat_config::{AcceptingCommandsHook, InterfaceConfig};

use crate::codec::{
    self, Ack, AckStatus, AdjustStatus, CtdOut, FromHuxley, FromPayload, HorizontalMode, Nvg, Nvr,
    Rmb, Sentence, SpeedMode, VerticalMode,
};
use frontseat_actors::clock::SimClock;
use frontseat_actors::driver::{
    Driver, DriverContext, DriverExtension, DriverIoEvent, IoSender, SignalSink, raw_ascii,
    refuse_extension,
};
use frontseat_actors::drivers::kit::{LinkState, OwnedTask, decoded, send_line};
use frontseat_actors::link::{self, LinkConfig};
use frontseat_actors::proto::frontseat::protobuf::bluefin as bf;
use frontseat_actors::proto::goby::acomms::protobuf::ModemRaw;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    BluefinExtraData, BuoyancyStatus, CommandRequest, CommandResponse, CtdSample, DesiredCourse,
    EulerAngles, FrontSeatState, InterfaceData, NodeStatus, Raw, Source, Speed, TrimStatus,
    bluefin_extra_commands::{AbortReason, BluefinCommand, SilentMode},
    bluefin_extra_data::{PayloadStatus, RawDvl, RawThrusterRotation},
    source::Sensor,
};
use frontseat_actors::proto::goby::middleware::protobuf::LatLonPoint;
use frontseat_actors::ratelog::{LogDecision, RateLimitedLog};

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

    fn tod(&self, now: Duration) -> f64 {
        codec::seconds_of_day((self.wall)(now))
    }

    fn problem(&mut self, what: &str, line: &str) {
        let line: String = line.chars().take(120).collect();
        match self.problems.decide(tokio::time::Instant::now()) {
            LogDecision::Log { suppressed_before } if suppressed_before > 0 => tracing::warn!(
                %line,
                "{what} (…and {suppressed_before} more Bluefin input problems in the last {}s)",
                self.problems.window().as_secs()
            ),
            LogDecision::Log { .. } => tracing::warn!(%line, "{what}"),
            LogDecision::Suppress => tracing::debug!(%line, "{what}"),
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

    /// Queues a sentence, answering its request at once if it cannot be queued.
    fn enqueue(
        &mut self,
        msg: FromPayload,
        request: Option<Option<i32>>,
        now: Duration,
        sig: &mut dyn SignalSink,
    ) {
        if self.queue.len() >= MAX_QUEUE {
            self.stats.queue_full += 1;
            self.problem("Bluefin write queue full; sentence refused", msg.id());
            if let Some(id) = request {
                Self::answer(sig, id, false, error_code::QUEUE_FULL, "write queue full");
            }
            return;
        }
        let line = msg.to_sentence().format();
        self.queue.push_back(Outgoing {
            ack_id: msg.id().to_string(),
            line,
            request,
            written_at: None,
            writes: 0,
        });
        self.try_send(now, sig);
    }

    fn write(&mut self, line: &str, sig: &mut dyn SignalSink) -> bool {
        let Some(w) = self.link.writer() else {
            return false;
        };
        match send_line(w, line, sig) {
            Ok(()) => true,
            Err(e) => {
                self.stats.write_failures += 1;
                tracing::warn!(line, error = %e, "line to the Huxley not sent");
                false
            }
        }
    }

    /// Writes the head of the queue if nothing is in flight (stop-and-wait); with acks disabled,
    /// writes everything.
    fn try_send(&mut self, now: Duration, sig: &mut dyn SignalSink) {
        if !self.link.is_open() {
            return;
        }
        if self.settings.disable_ack {
            while let Some(o) = self.queue.pop_front() {
                let sent = self.write(&o.line, sig);
                if let Some(id) = o.request {
                    if sent {
                        Self::answer(sig, id, true, 0, "");
                    } else {
                        Self::answer(sig, id, false, error_code::CONNECTION_LOST, "not written");
                    }
                }
            }
            return;
        }
        let line = match self.queue.front_mut() {
            Some(head) if head.written_at.is_none() => {
                head.written_at = Some(now);
                head.writes = 1;
                head.line.clone()
            }
            _ => return,
        };
        self.write(&line, sig);
    }

    /// Answers (as failed) every request still queued or pending, and empties both queues.
    fn fail_all(&mut self, why: &str, sig: &mut dyn SignalSink) {
        for o in self.queue.drain(..).chain(self.pending.drain(..)) {
            if let Some(id) = o.request {
                Self::answer(sig, id, false, error_code::CONNECTION_LOST, why);
            }
        }
    }

    fn initialise(&mut self, now: Duration, sig: &mut dyn SignalSink) {
        self.fail_all("connection to the Huxley re-opened", sig);
        self.demerits = 0;
        for id in self.settings.bplog.clone() {
            self.enqueue(FromPayload::Log { id, on: true }, None, now, sig);
        }
        self.heartbeat(now, sig);
    }

    fn heartbeat(&mut self, now: Duration, sig: &mut dyn SignalSink) {
        self.last_heartbeat = Some(now);
        let unix = (self.wall)(now);
        let now_us = (unix * 1e6).max(0.0) as u64;
        self.payload_status.retain(|p| p.expire_time > now_us);
        // One entry per payload id: the one that expires first (Goby3's choice).
        let mut by_id: BTreeMap<i32, &PayloadStatus> = BTreeMap::new();
        for p in &self.payload_status {
            by_id
                .entry(p.id)
                .and_modify(|e| {
                    if p.expire_time < e.expire_time {
                        *e = p;
                    }
                })
                .or_insert(p);
        }
        let ok = !self.interface_in_error && by_id.values().all(|p| p.all_ok);
        let text = if by_id.is_empty() {
            "Deploy".to_string()
        } else {
            let mut t = goby_time_text(unix);
            for p in by_id.values() {
                t.push_str("; ");
                t.push_str(&p.msg);
            }
            t
        };
        let msg = FromPayload::Sts {
            time: codec::seconds_of_day(unix),
            ok,
            text,
        };
        self.enqueue(msg, None, now, sig);
    }

    fn handle_line(&mut self, line: &str, now: Duration, sig: &mut dyn SignalSink) {
        sig.raw_from_frontseat(raw_ascii(line, ""));
        let sentence = match Sentence::parse(line) {
            Ok(s) => s,
            Err(codec::CodecError::Empty) => return,
            Err(e) => {
                self.stats.bad_lines += 1;
                frontseat_actors::drivers::kit::bad_line();
                self.problem(&format!("bad line from the Huxley: {e}"), line);
                return;
            }
        };
        // Anything well-formed proves the Huxley is alive.
        self.demerits = 0;
        let msg = match FromHuxley::from_sentence(&sentence) {
            Ok(m) => m,
            Err(e) => {
                self.stats.bad_lines += 1;
                frontseat_actors::drivers::kit::bad_line();
                self.problem(&format!("bad sentence from the Huxley: {e}"), line);
                return;
            }
        };
        match msg {
            FromHuxley::Nvg(n) => {
                self.nvg = Some(n);
                self.link.data.fresh(now);
            }
            FromHuxley::Nvr(r) => {
                if let Some(ns) = self.node_status(&r, now) {
                    sig.data_from_frontseat(InterfaceData {
                        node_status: Some(ns),
                        ..Default::default()
                    });
                }
            }
            FromHuxley::Ack(a) => self.handle_ack(a, now, sig),
            FromHuxley::Msc { .. } => {
                if self.settings.hook == AcceptingCommandsHook::BfmscTrigger {
                    self.link.state = FrontSeatState::FrontseatAcceptingCommands;
                }
            }
            FromHuxley::Mis { status, .. } => {
                if status.contains("Running") {
                    if self.settings.hook == AcceptingCommandsHook::BfmisRunningTrigger {
                        self.link.state = FrontSeatState::FrontseatAcceptingCommands;
                    } else if self.link.state != FrontSeatState::FrontseatAcceptingCommands {
                        self.link.state = FrontSeatState::FrontseatInControl;
                    }
                } else {
                    self.link.state = FrontSeatState::FrontseatIdle;
                }
            }
            FromHuxley::Ctl { control, .. } => {
                if self.settings.hook == AcceptingCommandsHook::BfctlTrigger {
                    if control {
                        self.link.state = FrontSeatState::FrontseatAcceptingCommands;
                    } else if self.link.state == FrontSeatState::FrontseatAcceptingCommands {
                        self.link.state = FrontSeatState::FrontseatInControl;
                    }
                }
            }
            FromHuxley::Boy(b) => emit(
                sig,
                extra(BluefinExtraData {
                    buoyancy_status: Some(buoyancy(&b)),
                    ..Default::default()
                }),
            ),
            FromHuxley::Trm(t) => emit(
                sig,
                extra(BluefinExtraData {
                    trim_status: Some(trim(&t)),
                    ..Default::default()
                }),
            ),
            FromHuxley::Dvl(d) => emit(
                sig,
                extra(BluefinExtraData {
                    dvl: Some(RawDvl {
                        dvl_time: d
                            .dvl_time
                            .map(|t| codec::unix_of_time_of_day(t, (self.wall)(now))),
                        u: d.u,
                        v: d.v,
                        w: d.w,
                        beam1_range: d.beams[0],
                        beam2_range: d.beams[1],
                        beam3_range: d.beams[2],
                        beam4_range: d.beams[3],
                        temperature: d.temperature,
                    }),
                    ..Default::default()
                }),
            ),
            FromHuxley::Rvl { rpm, speed, .. } => emit(
                sig,
                extra(BluefinExtraData {
                    thruster: Some(RawThrusterRotation {
                        rotation: rpm,
                        speed_from_lookup_table: speed,
                    }),
                    ..Default::default()
                }),
            ),
            FromHuxley::Ctd(c) => {
                let fix = self.nvg.as_ref().map(|n| (n.lat, n.lon, n.depth));
                let (Some(t), Some(p)) = (c.temperature, c.pressure_kpa) else {
                    self.stats.bad_lines += 1;
                    frontseat_actors::drivers::kit::bad_line();
                    self.problem("BFCTD without temperature or pressure", line);
                    return;
                };
                let nan = f64::NAN;
                let mut sample = CtdSample {
                    time: (self.wall)(now),
                    conductivity: c.conductivity_us_cm.map(|us| us / 1e4),
                    temperature: t,
                    pressure: p * 1000.0,
                    global_fix: LatLonPoint {
                        lat: fix.map_or(nan, |f| f.0),
                        lon: fix.map_or(nan, |f| f.1),
                        depth: fix.and_then(|f| f.2),
                        altitude: None,
                    },
                    ..Default::default()
                };
                // Salinity, sound speed, density (and depth without a $BFNVG), as Goby3.
                crate::seawater::fill_ctd(&mut sample);
                sig.data_from_frontseat(InterfaceData {
                    ctd_sample: Some(sample),
                    ..Default::default()
                });
            }
            FromHuxley::Sht { .. } => {
                tracing::warn!("the Huxley says it is shutting down ($BFSHT)");
            }
            FromHuxley::Other(id) => {
                self.stats.ignored_sentences += 1;
                tracing::debug!(%id, "Huxley sentence not acted on");
            }
        }
    }

    fn node_status(&self, r: &Nvr, now: Duration) -> Option<NodeStatus> {
        let n = self.nvg.as_ref()?;
        let unix = (self.wall)(now);
        let tod = n.fix_time.unwrap_or(n.time);
        let speed = match (r.east, r.north) {
            (Some(e), Some(no)) => e.hypot(no),
            _ => 0.0,
        };
        Some(NodeStatus {
            time: codec::unix_of_time_of_day(tod, unix),
            global_fix: LatLonPoint {
                lat: n.lat,
                lon: n.lon,
                depth: Some(n.depth.unwrap_or(0.0)),
                altitude: n.altitude,
            },
            pose: EulerAngles {
                roll: n.roll,
                pitch: n.pitch,
                heading: n.heading,
                pitch_rate: r.pitch_rate,
                roll_rate: r.roll_rate,
                heading_rate: r.yaw_rate,
                ..Default::default()
            },
            speed: Speed {
                over_ground: speed,
                over_water: None,
            },
            source: (n.quality == Some(1)).then(|| {
                let mut s = Source::default();
                s.set_position(Sensor::Gps);
                s
            }),
            ..Default::default()
        })
    }

    fn handle_ack(&mut self, a: Ack, now: Duration, sig: &mut dyn SignalSink) {
        let head_in_flight = self
            .queue
            .front()
            .is_some_and(|h| h.written_at.is_some() && h.ack_id.eq_ignore_ascii_case(&a.command));
        if a.status == AckStatus::Pending {
            if head_in_flight && let Some(h) = self.queue.pop_front() {
                if self.pending.len() >= MAX_PENDING
                    && let Some(old) = self.pending.pop_front()
                {
                    self.stats.pending_overflow += 1;
                    let what = format!(
                        "{MAX_PENDING} sentences are pending at the Huxley; giving up the oldest ({}) without its final answer",
                        old.ack_id
                    );
                    self.problem(&what, &old.line);
                    if let Some(id) = old.request {
                        Self::answer(sig, id, false, error_code::PENDING_OVERFLOW, what);
                    }
                }
                self.pending.push_back(h);
            } else {
                self.unmatched(&a);
            }
            self.try_send(now, sig);
            return;
        }
        let done = if head_in_flight {
            self.queue.pop_front()
        } else if let Some(i) = self
            .pending
            .iter()
            .position(|p| p.ack_id.eq_ignore_ascii_case(&a.command))
        {
            // The final answer to a pending command: the sentence in flight (if any) keeps
            // waiting for its own ack.
            self.pending.remove(i)
        } else {
            None
        };
        let Some(done) = done else {
            self.unmatched(&a);
            return;
        };
        if let Some(id) = done.request {
            let ok = a.status == AckStatus::Success;
            let code = match a.status {
                AckStatus::Invalid => error_code::INVALID,
                _ => error_code::FAILED,
            };
            let why = if a.text.is_empty() {
                format!(
                    "Huxley answered {} with status {}",
                    done.ack_id, a.status as i32
                )
            } else {
                a.text.clone()
            };
            Self::answer(sig, id, ok, code, why);
        }
        self.try_send(now, sig);
    }

    fn unmatched(&mut self, a: &Ack) {
        self.stats.unmatched_acks += 1;
        let what = format!(
            "$BFACK for {} (status {}) matches nothing in flight or pending; ignored",
            a.command, a.status as i32
        );
        self.problem(&what, &a.command);
    }

    /// Drops the connection and opens a new one: the Huxley stopped acknowledging.
    fn reset_connection(&mut self, sig: &mut dyn SignalSink) {
        self.stats.unresponsive_resets += 1;
        tracing::warn!(
            demerits = self.demerits,
            "the Huxley is ignoring our sentences; re-opening the connection"
        );
        // Not lost: the navigation received stays fresh until its own timeout.
        self.link.close();
        self.link.state = FrontSeatState::FrontseatNotConnected;
        self.fail_all("the Huxley stopped acknowledging", sig);
        self.demerits = 0;
        if self.link_task.is_running()
            && let Some(io) = self.io.clone()
        {
            self.link_task
                .set(link::spawn(self.settings.link.clone(), io));
        }
    }

    fn resend_or_drop(&mut self, now: Duration, sig: &mut dyn SignalSink) {
        let Some(head) = self.queue.front_mut() else {
            return;
        };
        let Some(at) = head.written_at else {
            return;
        };
        if now.saturating_sub(at) < self.settings.resend_interval {
            return;
        }
        if head.writes < self.settings.resend_attempts {
            head.writes += 1;
            head.written_at = Some(now);
            let line = head.line.clone();
            self.stats.resends += 1;
            self.write(&line, sig);
            return;
        }
        let Some(dropped) = self.queue.pop_front() else {
            return;
        };
        self.stats.dropped_unacked += 1;
        self.demerits += 1;
        tracing::warn!(
            line = %dropped.line,
            writes = dropped.writes,
            demerits = self.demerits,
            "no $BFACK for a sentence; dropped"
        );
        if let Some(id) = dropped.request {
            Self::answer(
                sig,
                id,
                false,
                error_code::NOT_ACKNOWLEDGED,
                format!("no acknowledgement after {} writes", dropped.writes),
            );
        }
        if self.demerits > self.settings.allowed_demerits {
            self.reset_connection(sig);
        } else {
            self.try_send(now, sig);
        }
    }

    fn rpm_for(&self, speed: f64) -> Option<f64> {
        let t = self.settings.rpm_table.as_ref()?;
        let (first, last) = (t.first()?, t.last()?);
        if t.len() < 2 || speed <= first.0 {
            return Some(first.1);
        }
        if speed >= last.0 {
            return Some(last.1);
        }
        let i = t.iter().position(|p| p.0 >= speed)?;
        let (a, b) = (t[i - 1], t[i]);
        let f = if b.0 > a.0 {
            (speed - a.0) / (b.0 - a.0)
        } else {
            0.0
        };
        Some((a.1 + f * (b.1 - a.1)).round())
    }

    /// `$BPRMB` for a desired course; an error text when a value cannot be written.
    fn rmb(&self, c: &DesiredCourse, tod: f64) -> Result<Rmb, String> {
        let (heading, depth, speed) = (c.heading(), c.depth(), c.speed());
        if !(heading.is_finite() && depth.is_finite() && speed.is_finite()) {
            return Err(format!(
                "desired_course has a non-finite value (heading {heading}, depth {depth}, speed {speed})"
            ));
        }
        if speed < 0.01 {
            return Ok(Rmb::stop(tod));
        }
        let (translational, speed_mode) = match self.rpm_for(speed) {
            Some(rpm) => (rpm, SpeedMode::Rpm),
            None => (speed, SpeedMode::Speed),
        };
        Ok(Rmb {
            time: tod,
            horizontal: heading,
            vertical: depth,
            vertical_mode: VerticalMode::Depth,
            translational,
            speed_mode,
            horizontal_mode: HorizontalMode::Heading,
        })
    }

    /// The common path of plain and Bluefin-extended CommandRequests.
    fn command(&mut self, c: Cmd<'_>, now: Duration, sig: &mut dyn SignalSink) {
        let Cmd {
            desired,
            ext,
            response_requested,
            request_id,
            cancel_request_id,
        } = c;
        let request = response_requested.then_some(request_id);
        let mut cancelled = false;
        if let Some(cancel) = cancel_request_id {
            cancelled = self.cancel(cancel, sig);
        }
        let tod = self.tod(now);
        let ext_cmd = ext.map(|e| e.command()).filter(|c| {
            !matches!(
                c,
                BluefinCommand::UnknownCommand | BluefinCommand::DesiredCourse
            )
        });
        let msg = match (ext_cmd, ext) {
            (Some(cmd), Some(e)) => {
                if desired.is_some() {
                    tracing::warn!(
                        ?cmd,
                        "a Bluefin command and a desired_course in one request: only the command is sent"
                    );
                }
                match cmd {
                    BluefinCommand::TrimAdjust => FromPayload::Trm { time: tod },
                    BluefinCommand::BuoyancyAdjust => FromPayload::Boy { time: tod },
                    BluefinCommand::SilentMode => FromPayload::Sil {
                        time: tod,
                        silent: e.silent_mode() == SilentMode::Silent,
                    },
                    BluefinCommand::CancelCurrentBehavior | BluefinCommand::MissionEndConfirm => {
                        FromPayload::Rce { time: tod }
                    }
                    BluefinCommand::AbortMission => FromPayload::Abt {
                        time: tod,
                        with_errors: e.abort_reason() != AbortReason::SuccessfulMission,
                    },
                    BluefinCommand::MissionStartConfirm => FromPayload::Smc { time: tod },
                    BluefinCommand::UnknownCommand | BluefinCommand::DesiredCourse => return,
                }
            }
            _ => match desired {
                Some(c) => match self.rmb(c, tod) {
                    Ok(r) => FromPayload::Rmb(r),
                    Err(why) => {
                        self.problem("desired_course not sent", &why);
                        if let Some(id) = request {
                            Self::answer(sig, id, false, error_code::BAD_REQUEST, why);
                        }
                        return;
                    }
                },
                None => {
                    if let Some(id) = request {
                        if cancel_request_id.is_some() {
                            Self::answer(
                                sig,
                                id,
                                cancelled,
                                error_code::BAD_REQUEST,
                                "no such outstanding request",
                            );
                        } else {
                            Self::answer(
                                sig,
                                id,
                                false,
                                error_code::BAD_REQUEST,
                                "nothing to send: no desired_course and no Bluefin command",
                            );
                        }
                    }
                    return;
                }
            },
        };
        self.enqueue(msg, request, now, sig);
    }

    /// Forgets the request `id`: a sentence not yet written is removed, one in flight or pending
    /// stays but will not answer. The cancelled request is answered as cancelled.
    fn cancel(&mut self, id: i32, sig: &mut dyn SignalSink) -> bool {
        let mut found = false;
        let mut keep = VecDeque::with_capacity(self.queue.len());
        for mut o in self.queue.drain(..) {
            if o.request == Some(Some(id)) {
                found = true;
                o.request = None;
                if o.written_at.is_none() {
                    continue;
                }
            }
            keep.push_back(o);
        }
        self.queue = keep;
        for p in self.pending.iter_mut() {
            if p.request == Some(Some(id)) {
                found = true;
                p.request = None;
            }
        }
        if found {
            Self::answer(
                sig,
                Some(id),
                false,
                error_code::CANCELLED,
                "cancelled by cancel_request_id",
            );
        }
        found
    }

    fn data(&mut self, base: &InterfaceData, now: Duration, sig: &mut dyn SignalSink) {
        let unix = (self.wall)(now);
        let tod = codec::seconds_of_day(unix);
        if let Some(c) = &base.ctd_sample {
            let finite = |x: f64| x.is_finite().then_some(x);
            self.enqueue(
                FromPayload::Ctd(CtdOut {
                    time: tod,
                    conductivity: c.conductivity.and_then(finite),
                    temperature: finite(c.temperature),
                    pressure_kpa: finite(c.pressure).map(|p| p / 1000.0),
                    sample_time: codec::seconds_of_day(c.time),
                }),
                None,
                now,
                sig,
            );
        }
        if let Some(d) = &base.dccl_message {
            let b64 = base64::engine::general_purpose::STANDARD.encode(d);
            self.enqueue(
                FromPayload::Dcl {
                    time: tod,
                    base64: b64,
                },
                None,
                now,
                sig,
            );
        }
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

/// Goby3's payload-status time text, `2024-Oct-10 12:00:31.000000`.
pub fn goby_time_text(unix: f64) -> String {
    let unix = if unix.is_finite() { unix.max(0.0) } else { 0.0 };
    let days = (unix / 86_400.0).floor() as i64;
    let tod = unix - days as f64 * 86_400.0;
    // Civil from days (Howard Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    const MONTHS: [&str; 12] = [
        "Jan", "Feb", "Mar", "Apr", "May", "Jun", "Jul", "Aug", "Sep", "Oct", "Nov", "Dec",
    ];
    let us = (tod * 1e6).round() as u64;
    let (h, rest) = (us / 3_600_000_000, us % 3_600_000_000);
    let (mi, rest) = (rest / 60_000_000, rest % 60_000_000);
    format!(
        "{y}-{}-{d:02} {h:02}:{mi:02}:{:02}.{:06}",
        MONTHS[(m - 1).clamp(0, 11) as usize],
        rest / 1_000_000,
        rest % 1_000_000
    )
}

fn extra(data: BluefinExtraData) -> bf::InterfaceData {
    bf::InterfaceData {
        bluefin_data: Some(data),
        ..Default::default()
    }
}

fn buoyancy(b: &AdjustStatus) -> BuoyancyStatus {
    BuoyancyStatus {
        status: Some(b.status),
        error: Some(b.error),
        debug_string: Some(b.text.clone()),
        buoyancy_newtons: b.value,
    }
}

fn trim(t: &AdjustStatus) -> TrimStatus {
    TrimStatus {
        status: Some(t.status),
        error: Some(t.error.min(2)),
        debug_string: Some(t.text.clone()),
        pitch_trim_degrees: t.value,
        roll_trim_degrees: t.value2,
    }
}

impl BluefinDriver {
    pub fn send_bluefin_command(
        &mut self,
        req: &bf::CommandRequest,
        now: Duration,
        sig: &mut dyn SignalSink,
    ) {
        let c = Cmd {
            desired: req.desired_course.as_ref(),
            ext: req.bluefin_command.as_ref(),
            response_requested: req.response_requested(),
            request_id: req.request_id,
            cancel_request_id: req.cancel_request_id,
        };
        self.command(c, now, sig);
    }

    pub fn send_bluefin_data(
        &mut self,
        data: &bf::InterfaceData,
        now: Duration,
        sig: &mut dyn SignalSink,
    ) {
        let base = InterfaceData {
            node_status: None,
            ctd_sample: data.ctd_sample,
            dccl_message: data.dccl_message.clone(),
        };
        self.data(&base, now, sig);
        let Some(extra) = &data.bluefin_data else {
            return;
        };
        for p in &extra.payload_status {
            if self.payload_status.len() >= MAX_PAYLOAD_STATUSES {
                self.payload_status.remove(0);
            }
            self.payload_status.push(p.clone());
        }
        if self.settings.send_tmr
            && let Some(ModemRaw { raw, .. }) = &extra.micro_modem_raw_in
        {
            let line = String::from_utf8_lossy(raw).to_string();
            let tod = self.tod(now);
            self.enqueue(FromPayload::Tmr { time: tod, line }, None, now, sig);
        }
    }
}

/// Extension data to the interface, tagged with its type.
fn emit(sig: &mut dyn SignalSink, data: bf::InterfaceData) {
    sig.extension_from_frontseat(DriverExtension::encode(DATA, "Bluefin", &data));
}

impl Driver for BluefinDriver {
    fn send_extension(&mut self, ext: &DriverExtension, now: Duration, sig: &mut dyn SignalSink) {
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

    fn name(&self) -> &str {
        "bluefin"
    }

    fn start(&mut self, ctx: DriverContext) {
        self.io = Some(ctx.io.clone());
        self.link_task
            .set(link::spawn(self.settings.link.clone(), ctx.io));
    }

    fn handle_io(&mut self, ev: DriverIoEvent, now: Duration, sig: &mut dyn SignalSink) {
        match ev {
            DriverIoEvent::Connected(w) => {
                tracing::info!(
                    host = %self.settings.link.host,
                    port = self.settings.link.port,
                    "connected to the Huxley; enabling its sentences"
                );
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
                tracing::warn!(%reason, "Huxley connection lost; reconnecting");
                self.link.lost();
                self.fail_all("connection to the Huxley lost", sig);
            }
        }
    }

    fn send_command_to_frontseat(
        &mut self,
        req: &CommandRequest,
        now: Duration,
        sig: &mut dyn SignalSink,
    ) {
        let c = Cmd {
            desired: req.desired_course.as_ref(),
            ext: None,
            response_requested: req.response_requested(),
            request_id: req.request_id,
            cancel_request_id: req.cancel_request_id,
        };
        self.command(c, now, sig);
    }

    fn send_data_to_frontseat(
        &mut self,
        data: &InterfaceData,
        now: Duration,
        sig: &mut dyn SignalSink,
    ) {
        self.data(data, now, sig);
    }

    fn send_raw_to_frontseat(&mut self, raw: &Raw, now: Duration, sig: &mut dyn SignalSink) {
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

    fn do_loop(&mut self, now: Duration, sig: &mut dyn SignalSink) {
        if self.link.data.expired(now, self.settings.missing_nav) {
            tracing::warn!(
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

    fn stop(&mut self) {
        self.link.close();
    }
}
