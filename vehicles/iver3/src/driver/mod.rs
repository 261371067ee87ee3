//! The Iver3 driver: Goby3's `IverFrontSeat` over a serial port (or serial-over-IP TCP), with
//! its gaps closed — the state drops to NOT_CONNECTED when the port goes away, `$OSI` counts as
//! data, `$ACK` becomes a CommandResponse, `$C` before any `$OSI` publishes nothing, and the
//! `Mp` manual-parking mode is recognised. Polls with `$OSD` on every loop tick.

/// Log lines keep the target this module had as one file, whatever part now writes them:
/// operators filter and grep on it.
const LOG_TARGET: &str = "frontseat_iver3::driver";

use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use frontseat_config::{InterfaceConfig, IverModeAssignments};

use crate::edge::{self as codec, IverMode, Sentence, ack_type};
use frontseat_actors::clock::SimClock;
use frontseat_actors::driver::{
    DirectCommand, Driver, DriverContext, DriverExtension, DriverIoEvent, SignalSink, raw_ascii,
};
use frontseat_actors::drivers::kit::{
    AckQueue, Asker, Awaiting, LinkState, OwnedTask, TIMED_OUT, base_command, config_secs, log_due,
    own_extension, refuse, send_line, state_of,
};
use frontseat_actors::drivers::vehicle_link;
use frontseat_actors::link::LineWriter;
use frontseat_actors::link::byte::{self, ByteLinkConfig, LinkStats, Transport};
use frontseat_actors::link::framing::Framing;
use frontseat_actors::link::serial::SerialSettings;
use frontseat_actors::proto::frontseat::protobuf::iver::{
    CommandRequest as IverCommandRequest, InterfaceData as IverInterfaceData,
};
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::IverState;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::iver_extra_commands::IverCommand;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CommandRequest, FrontSeatState, InterfaceData, NodeStatus, Raw,
};
use frontseat_actors::ratelog::RateLimitedLog;

/// The types of Goby3's Iver3 extension (field 1001), as its groups declare them.
pub const COMMAND: &str = frontseat_actors::groups::FRONTSEAT_IVER_IVER_COMMAND_REQUEST.type_name();
pub const DATA: &str =
    frontseat_actors::groups::FRONTSEAT_IVER_IVER_DATA_FROM_FRONTSEAT.type_name();

/// Goby3's fixed baud of the NTP copy port.
const NTP_BAUD: u32 = 4800;

/// Commands waiting for an `$ACK` at most (older ones are answered as failed).
const MAX_PENDING: usize = 64;

#[derive(Clone, Debug)]
pub struct Settings {
    pub link: ByteLinkConfig,
    /// Where RMC sentences are copied for NTP (4800 8N1), if anywhere.
    pub ntp_link: Option<ByteLinkConfig>,
    pub max_pitch_angle_degrees: i32,
    pub remote_helm_version_major: i32,
    pub oms_timeout: u32,
    pub modes: ModeTable,
    pub providing_data_timeout: Duration,
    pub ack_timeout: Duration,
}

/// FrontSeatState per UVC mode.
#[derive(Clone, Debug, PartialEq)]
pub struct ModeTable(pub IverModeAssignments);

impl ModeTable {
    pub fn state(&self, m: IverMode) -> FrontSeatState {
        let a = &self.0;
        state_of(match m {
            IverMode::Unknown => a.unknown,
            IverMode::Normal => a.normal,
            IverMode::Stopped => a.stopped,
            IverMode::Parking => a.parking,
            IverMode::ManualOverride => a.manual_override,
            IverMode::ManualParking => a.manual_parking,
            IverMode::Servo => a.servo_mode,
            IverMode::Mission => a.mission_mode,
        })
    }
}

impl Settings {
    pub fn from_config(cfg: &InterfaceConfig) -> Self {
        let c = &cfg.driver.iver3;
        Self {
            link: vehicle_link(
                &c.link,
                &c.serial_port,
                c.serial_baud,
                Framing::Lines {
                    max_line_bytes: codec::MAX_SENTENCE,
                },
            ),
            ntp_link: c.ntp_serial_port.as_ref().map(|p| ByteLinkConfig {
                transport: Transport::Serial(SerialSettings::new_8n1(p.clone(), NTP_BAUD)),
                framing: Framing::Lines {
                    max_line_bytes: codec::MAX_SENTENCE,
                },
                backoff_initial: Duration::from_millis(c.link.reconnect_initial_ms.max(1)),
                backoff_max: Duration::from_millis(c.link.reconnect_max_ms.max(1)),
            }),
            max_pitch_angle_degrees: c.max_pitch_angle_degrees,
            // Validation requires it; 5 (metres) only if a caller skipped validation.
            remote_helm_version_major: c.remote_helm_version_major.unwrap_or(5),
            oms_timeout: c.oms_timeout.min(120),
            modes: ModeTable(c.mode_assignments.clone()),
            providing_data_timeout: config_secs(c.providing_data_timeout),
            ack_timeout: config_secs(c.link.ack_timeout),
        }
    }
}

/// What the driver counted (read by tests and the logs).
#[derive(Debug, Default, Clone, PartialEq)]
pub struct IverCounters {
    pub osi: u64,
    pub compass: u64,
    pub acks: u64,
    pub unmatched_acks: u64,
    pub bad_lines: u64,
    pub ignored: u64,
    pub write_failures: u64,
    pub ack_timeouts: u64,
}

pub struct Iver3Driver {
    settings: Settings,
    link: LinkState,
    link_task: OwnedTask,
    pub link_stats: Arc<LinkStats>,
    /// The NTP copy port's writer while it is open (filled by its own link task).
    ntp: Arc<std::sync::Mutex<Option<LineWriter>>>,
    ntp_task: OwnedTask,
    mode: IverMode,
    /// The latest `$OSI` navigation, so `$C` can republish it with new pitch and roll.
    status: Option<NodeStatus>,
    /// Commands written, each waiting for the `$ACK` of its type; shared with the lane's
    /// [`DirectOms`].
    pending: Pending,
    /// The sim clock (from `start`): the lane's `$OMS` gets its `$ACK` deadline from it.
    clock: Option<SimClock>,
    /// While the link is open: the setpoint lane's way to it.
    direct: Option<Arc<DirectOms>>,
    bad_log: RateLimitedLog,
    pub counters: IverCounters,
}

impl Iver3Driver {
    pub fn new(settings: Settings) -> Self {
        Self {
            settings,
            link: LinkState::default(),
            link_task: OwnedTask::default(),
            link_stats: Arc::new(LinkStats::default()),
            ntp: Arc::new(std::sync::Mutex::new(None)),
            ntp_task: OwnedTask::default(),
            mode: IverMode::Unknown,
            status: None,
            pending: Pending(Arc::new(Mutex::new(AckQueue::new(MAX_PENDING)))),
            clock: None,
            direct: None,
            bad_log: RateLimitedLog::for_bad_input(),
            counters: IverCounters::default(),
        }
    }

    pub fn mode(&self) -> IverMode {
        self.mode
    }

    fn write(&mut self, line: &str, sig: &mut dyn SignalSink) -> bool {
        let Some(w) = self.link.writer() else {
            self.counters.write_failures += 1;
            return false;
        };
        match send_line(w, line, sig) {
            Ok(()) => true,
            Err(e) => {
                self.counters.write_failures += 1;
                if let Some(suppressed) = log_due(&mut self.bad_log) {
                    tracing::warn!(target: LOG_TARGET, line, error = %e, suppressed, "line to the Iver not sent");
                }
                false
            }
        }
    }

    fn bad(&mut self, what: &str) {
        self.counters.bad_lines += 1;
        frontseat_actors::drivers::kit::bad_line();
        if let Some(suppressed) = log_due(&mut self.bad_log) {
            tracing::warn!(target: LOG_TARGET, %what, suppressed, "bad input from the Iver");
        }
    }

    fn fresh_data(&mut self, now: Duration) {
        self.link.data.fresh(now);
    }

    fn handle_line(&mut self, line: &str, now: Duration, sig: &mut dyn SignalSink) {
        sig.raw_from_frontseat(raw_ascii(line, ""));
        let s = match Sentence::parse(line) {
            Ok(s) => s,
            Err(e) => {
                self.bad(&format!(
                    "{e}: {}",
                    frontseat_actors::drivers::kit::truncate(line)
                ));
                return;
            }
        };
        match s {
            Sentence::Osi(o) => {
                self.counters.osi += 1;
                self.mode = IverMode::from_field(&o.mode);
                self.link.state = self.settings.modes.state(self.mode);
                let mut ns = codec::osi_to_node_status(&o, SimClock::unix_now());
                if let Some(prev) = &self.status {
                    ns.pose.pitch = prev.pose.pitch;
                    ns.pose.roll = prev.pose.roll;
                }
                self.status = Some(ns.clone());
                self.fresh_data(now);
                // Goby3 publishes one InterfaceData with the iver_state extension; the same
                // bytes go on frontseat::iver::iver_data_from_frontseat, and the plain one (the
                // base fields Goby3's subscribers decode) on data_from_frontseat.
                emit(
                    sig,
                    IverInterfaceData {
                        node_status: Some(ns.clone()),
                        iver_state: Some(IverState {
                            mode: Some(codec::mode_proto(self.mode) as i32),
                        }),
                        ..Default::default()
                    },
                );
                sig.data_from_frontseat(InterfaceData {
                    node_status: Some(ns),
                    ..Default::default()
                });
            }
            Sentence::Compass(c) => {
                self.counters.compass += 1;
                self.fresh_data(now);
                if let Some(ns) = &mut self.status {
                    ns.pose.pitch = Some(c.pitch);
                    ns.pose.roll = Some(c.roll);
                    ns.time = SimClock::unix_now();
                    let ns = ns.clone();
                    sig.data_from_frontseat(InterfaceData {
                        node_status: Some(ns),
                        ..Default::default()
                    });
                }
            }
            Sentence::Ack(a) => {
                self.counters.acks += 1;
                let taken = self.pending.lock().take(|t| *t == a.msg_type);
                match taken {
                    Some(p) => {
                        let ok = a.status == 0;
                        p.asker.answer(
                            sig,
                            ok,
                            a.err as i32,
                            (!ok).then(|| {
                                format!("UVC answered $ACK status {} error {}", a.status, a.err)
                            }),
                        );
                    }
                    None => {
                        // $ACK of $OSD polls, or of raw commands: nothing to answer.
                        if a.msg_type != ack_type::OSD {
                            self.counters.unmatched_acks += 1;
                        }
                    }
                }
            }
            Sentence::Rmc { .. } => {
                // Copied verbatim (checksum and all) for the NTP reference clock, as Goby3.
                let w = self.ntp.lock().unwrap_or_else(|p| p.into_inner()).clone();
                if let Some(w) = w
                    && w.write_line(line).is_err()
                {
                    self.counters.write_failures += 1;
                }
            }
            _ => {
                self.counters.ignored += 1;
                tracing::trace!(target: LOG_TARGET, line, "ignoring sentence from the Iver");
            }
        }
    }

    /// A command written: its `$ACK` (of `ack` type) answers it, or the timeout does.
    fn await_ack(
        &mut self,
        ack: u32,
        request_id: Option<i32>,
        respond: bool,
        now: Duration,
        sig: &mut dyn SignalSink,
    ) {
        self.pending.lock().push(
            Awaiting {
                asker: Asker {
                    request_id,
                    respond,
                },
                deadline: now + self.settings.ack_timeout,
                what: ack,
            },
            "too many commands awaiting $ACK",
            sig,
        );
    }
}

impl Iver3Driver {
    /// Goby3's iver_command: START_MISSION with a mission → `$OMSTART`, STOP_MISSION →
    /// `$OMSTOP,0`, each awaiting its `$ACK` like `$OMS`; a desired_course in the same request is
    /// sent after it (as Goby3). START_MISSION without a mission is refused (Goby3 only logs).
    pub fn send_iver_command(
        &mut self,
        req: &IverCommandRequest,
        now: Duration,
        sig: &mut dyn SignalSink,
    ) {
        let base = base_command!(req);
        let extra = req.iver_command.as_ref();
        let sentence = match extra.map(|c| (c.command(), c.mission.as_deref().unwrap_or(""))) {
            Some((IverCommand::StartMission, "")) => {
                tracing::warn!(target: LOG_TARGET, "iver_command START_MISSION without a mission name: refused");
                refuse(&base, "START_MISSION needs a mission name", sig);
                return;
            }
            Some((IverCommand::StartMission, m)) if !codec::is_field_safe(m) => {
                self.bad("iver_command mission name is not a plain NMEA field");
                refuse(
                    &base,
                    "mission name must be printable ASCII without , * $",
                    sig,
                );
                return;
            }
            Some((IverCommand::StartMission, m)) => Some((
                Sentence::OmStart {
                    mission: m.to_string(),
                },
                ack_type::OMSTART,
            )),
            Some((IverCommand::StopMission, _)) => Some((Sentence::OmStop, ack_type::OMSTOP)),
            Some((IverCommand::UnknownCommand, _)) | None => None,
        };
        let Some((sentence, ack)) = sentence else {
            // Nothing for the extension: the course alone, if any.
            if base.desired_course.is_some() {
                self.send_command_to_frontseat(&base, now, sig);
            } else {
                refuse(&base, "iver_command without a command", sig);
            }
            return;
        };
        let line = sentence.to_line();
        if !self.write(&line, sig) {
            refuse(
                &base,
                "not connected to the Iver: mission command not sent",
                sig,
            );
            return;
        }
        // With a course as well, the response answers the course's $ACK (as one request).
        let respond = base.response_requested() && base.desired_course.is_none();
        self.await_ack(ack, base.request_id, respond, now, sig);
        if base.desired_course.is_some() {
            self.send_command_to_frontseat(&base, now, sig);
        }
    }
}

/// The commands awaiting their `$ACK`, shared by the driver and the lane's [`DirectOms`]: a
/// lane `$OMS` is entered under this lock before its bytes can reach the UVC, so the `$ACK` read
/// on the vehicle thread finds it (and never answers an older request in its place).
#[derive(Clone)]
struct Pending(Arc<Mutex<AckQueue<u32>>>);

impl Pending {
    fn lock(&self) -> MutexGuard<'_, AckQueue<u32>> {
        self.0.lock().unwrap_or_else(|p| p.into_inner())
    }
}

/// `$OMS` for a course, in the units and limits the settings give.
fn oms_line(
    s: &Settings,
    c: &frontseat_actors::proto::goby::middleware::frontseat::protobuf::DesiredCourse,
) -> String {
    let oms = codec::course_to_oms(
        c,
        s.remote_helm_version_major,
        s.max_pitch_angle_degrees,
        s.oms_timeout,
    );
    Sentence::Oms(oms).to_line()
}

/// The setpoint lane's way to the UVC (`frontseat_actors::setpoint_lane`, ARCHITECTURE.md "The
/// lane per vehicle family"): a course's `$OMS` written at once from the publisher's thread,
/// awaiting its `$ACK` like any other (no answer wanted: a lane course asks for none).
struct DirectOms {
    writer: LineWriter,
    pending: Pending,
    clock: SimClock,
    settings: Settings,
}

impl DirectCommand for DirectOms {
    fn send_now(&self, req: &CommandRequest) -> Option<Raw> {
        let c = req.desired_course.as_ref()?;
        // Something queued before it: the course queues behind it on the driver's path.
        if !self.writer.writes_at_once() {
            return None;
        }
        let line = oms_line(&self.settings, c);
        let mut q = self.pending.lock();
        // Full: the driver's path gives up the oldest and answers it (one place does that).
        if q.len() >= MAX_PENDING {
            return None;
        }
        let mut unheard = frontseat_actors::driver::RecordingSink::default();
        q.push(
            Awaiting {
                asker: Asker {
                    request_id: req.request_id,
                    respond: false,
                },
                deadline: self.clock.now() + self.settings.ack_timeout,
                what: ack_type::OMS,
            },
            "too many commands awaiting $ACK",
            &mut unheard,
        );
        if self.writer.write_line(&line).is_err() {
            let last = q.len().checked_sub(1)?;
            q.remove(last);
            return None;
        }
        Some(raw_ascii(&line, ""))
    }
}

/// Extension data to the interface, tagged with its type.
fn emit(sig: &mut dyn SignalSink, data: IverInterfaceData) {
    sig.extension_from_frontseat(DriverExtension::encode(DATA, "Iver3", &data));
}

impl Driver for Iver3Driver {
    fn send_extension(&mut self, ext: &DriverExtension, now: Duration, sig: &mut dyn SignalSink) {
        if let Some(r) = own_extension::<IverCommandRequest>(ext, COMMAND, sig, self.name()) {
            self.send_iver_command(&r, now, sig);
        }
    }

    fn name(&self) -> &str {
        "iver3"
    }

    fn start(&mut self, ctx: DriverContext) {
        self.clock = Some(ctx.clock);
        self.link_task.set(byte::spawn_direct(
            self.settings.link.clone(),
            ctx.io,
            self.link_stats.clone(),
        ));
        if let Some(ntp) = self.settings.ntp_link.clone() {
            // Write-only: what the NTP side sends back is discarded (as Goby3), so its events
            // stay on its own task instead of the driver's mailbox.
            let slot = self.ntp.clone();
            let io = frontseat_actors::driver::IoSender::new(move |ev| {
                let mut s = slot.lock().unwrap_or_else(|p| p.into_inner());
                match ev {
                    DriverIoEvent::Connected(w) => *s = Some(w),
                    DriverIoEvent::Disconnected(_) => *s = None,
                    _ => {}
                }
                true
            });
            self.ntp_task
                .set(byte::spawn(ntp, io, Arc::new(LinkStats::default())));
        }
    }

    fn handle_io(&mut self, ev: DriverIoEvent, now: Duration, sig: &mut dyn SignalSink) {
        match ev {
            DriverIoEvent::Connected(w) => {
                tracing::info!(target: LOG_TARGET, link = %self.settings.link.transport.describe(), "connected to the Iver");
                // Open but not yet told its mode: Goby3's "unknown" until the first $OSI.
                self.direct = self.clock.map(|clock| {
                    Arc::new(DirectOms {
                        writer: w.clone(),
                        pending: self.pending.clone(),
                        clock,
                        settings: self.settings.clone(),
                    })
                });
                self.link.opened(w, FrontSeatState::FrontseatNotConnected);
            }
            DriverIoEvent::Line(line) => self.handle_line(&line, now, sig),
            DriverIoEvent::Frame(_) => self.bad("binary frame on a Remote Helm link"),
            DriverIoEvent::BadInput(what) => self.bad(&what),
            DriverIoEvent::Disconnected(reason) => {
                tracing::warn!(target: LOG_TARGET, %reason, "Iver link lost; reopening");
                self.link.lost();
                self.direct = None;
                self.mode = IverMode::Unknown;
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
            refuse(
                req,
                "the Iver3 driver sends only desired_course ($OMS)",
                sig,
            );
            return;
        };
        let line = oms_line(&self.settings, c);
        if !self.write(&line, sig) {
            refuse(req, "not connected to the Iver: $OMS not sent", sig);
            return;
        }
        self.await_ack(
            ack_type::OMS,
            req.request_id,
            req.response_requested(),
            now,
            sig,
        );
    }

    fn send_data_to_frontseat(
        &mut self,
        _data: &InterfaceData,
        _now: Duration,
        _sig: &mut dyn SignalSink,
    ) {
        // Remote Helm has no data channel (Goby3: "no data yet to send").
    }

    fn send_raw_to_frontseat(&mut self, raw: &Raw, _now: Duration, sig: &mut dyn SignalSink) {
        let bytes = raw.raw.as_deref().unwrap_or_default();
        match std::str::from_utf8(bytes) {
            Ok(s) if s.len() <= codec::MAX_SENTENCE => {
                let line = s.trim_end_matches(['\r', '\n']).to_string();
                self.write(&line, sig);
            }
            _ => self.bad("raw_send_request is not a text line of at most 512 bytes"),
        }
    }

    fn do_loop(&mut self, now: Duration, sig: &mut dyn SignalSink) {
        if self.link.is_open() {
            let osd = Sentence::Osd {
                gps: true,
                compass: true,
                state: true,
                power: true,
            }
            .to_line();
            self.write(&osd, sig);
        }
        if self
            .link
            .data
            .expired(now, self.settings.providing_data_timeout)
        {
            tracing::warn!(
                target: LOG_TARGET,
                "no $OSI or $C from the Iver for {:?}: not providing data",
                self.settings.providing_data_timeout
            );
        }
        loop {
            let Some(p) = self.pending.lock().due(now) else {
                break;
            };
            self.counters.ack_timeouts += 1;
            p.asker.fail(
                sig,
                TIMED_OUT,
                format!(
                    "no $ACK from the UVC within {:?}",
                    self.settings.ack_timeout
                ),
            );
        }
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
        self.direct = None;
        self.link.close();
        *self.ntp.lock().unwrap_or_else(|p| p.into_inner()) = None;
    }
}

#[cfg(test)]
mod tests;
