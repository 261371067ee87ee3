//! The driver for the basic frontseat simulator protocol (sim/PROTOCOL.md), as Goby3's
//! `BasicSimulatorFrontSeatInterface` but: connecting never blocks, reconnects back off to a
//! cap of about a second, START goes out on every (re)connect at full precision, and every line
//! becomes a signal the moment it is read.
//!
//! Bad input is counted always and logged through `ratelog`: five WARNs per 10 s (simulated),
//! then one summary ("…and 95 more bad lines in the last 10 s"), so a broken or hostile
//! frontseat cannot flood the journal.

use std::collections::VecDeque;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use frontseat_config::InterfaceConfig;
use frontseat_sim::codec::{self, FieldError, LineError, Outbound};

use frontseat_actors::clock::SimClock;
use frontseat_actors::driver::{
    DirectCommand, Driver, DriverContext, DriverIoEvent, SignalSink, raw_ascii,
};
use frontseat_actors::drivers::kit::{LinkState, OwnedTask, config_secs, refuse, send_line};
use frontseat_actors::link::{self, LineWriter, LinkConfig};
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CommandRequest, CommandResponse, EulerAngles, FrontSeatState, InterfaceData, NodeStatus, Raw,
    Speed,
};
use frontseat_actors::proto::goby::middleware::protobuf::LatLonPoint;
use frontseat_actors::ratelog::{LogDecision, RateLimitedLog, more, summary};

#[derive(Clone, Debug)]
pub struct Settings {
    pub link: LinkConfig,
    pub start_line: String,
    pub nav_timeout: Duration,
}

impl Settings {
    pub fn from_config(cfg: &InterfaceConfig) -> Self {
        let b = &cfg.driver.basic_simulator;
        let s = &b.start;
        // `{}` prints the shortest string that reads back as the same f64: full precision.
        let start_line = format!(
            "START,LAT:{},LON:{},DURATION:{},FREQ:{},ACCEL:{},HDG_RATE:{},Z_RATE:{},WARP:{}",
            s.lat,
            s.lon,
            s.duration,
            s.control_freq,
            s.vehicle.accel,
            s.vehicle.hdg_rate,
            s.vehicle.z_rate,
            cfg.sim_warp_factor
        );
        Self {
            link: LinkConfig {
                host: b.tcp_address.clone(),
                port: b.tcp_port,
                backoff_initial: Duration::from_millis(b.reconnect_initial_ms),
                backoff_max: Duration::from_millis(b.reconnect_max_ms),
                max_line_bytes: 4096,
            },
            start_line,
            nav_timeout: config_secs(b.nav_timeout),
        }
    }
}

/// Commands awaiting their CMD,RESULT at most (a frontseat that stopped answering cannot make
/// the queue grow without end).
const MAX_IN_FLIGHT: usize = 256;

/// The requests whose CMD lines are on their way, oldest first; shared with the [`DirectCmd`]
/// that writes courses from the helm's thread.
#[derive(Clone, Default)]
struct InFlight(Arc<Mutex<VecDeque<CommandRequest>>>);

impl InFlight {
    fn lock(&self) -> MutexGuard<'_, VecDeque<CommandRequest>> {
        self.0.lock().unwrap_or_else(|p| p.into_inner())
    }
}

/// Queues `req` to be matched with the next CMD,RESULT, writes its line with `write`, and takes
/// it back if the line was not sent. The queue is held locked throughout, so an answer read on
/// another thread cannot look for the request before it is there. A frontseat that stopped
/// answering loses the oldest (the interface answers it when its own timeout passes).
fn write_in_flight(
    in_flight: &InFlight,
    req: &CommandRequest,
    write: impl FnOnce() -> bool,
) -> bool {
    let mut q = in_flight.lock();
    q.push_back(*req);
    if !write() {
        q.pop_back();
        return false;
    }
    while q.len() > MAX_IN_FLIGHT {
        q.pop_front();
    }
    true
}

/// The setpoint lane's way to this connection (`frontseat_actors::setpoint_lane`): a course's
/// CMD line written at once from the publisher's thread. Its request is queued for the answer
/// under the lock answers are matched under, before the line can reach the frontseat, so a
/// CMD,RESULT always finds it.
struct DirectCmd {
    writer: LineWriter,
    in_flight: InFlight,
}

impl DirectCommand for DirectCmd {
    fn send_now(&self, req: &CommandRequest) -> Option<Raw> {
        let line = command_line(req)?;
        // A link with a backlog: the course queues behind it on the driver's own path.
        if !self.writer.writes_at_once() {
            return None;
        }
        let _span = tracing::trace_span!(
            target: "frontseat_actors",
            "frontseat.socket_write",
            bytes = line.len() + 2,
            line = frontseat_actors::drivers::kit::truncate(&line),
        )
        .entered();
        write_in_flight(&self.in_flight, req, || {
            self.writer.write_line(&line).is_ok()
        })
        .then(|| raw_ascii(&line, ""))
    }
}

pub struct BasicSimulatorDriver {
    settings: Settings,
    /// Its data watch: NAV lines.
    link: LinkState,
    link_task: OwnedTask,
    /// The requests whose CMD lines are on their way, oldest first: the simulator answers every
    /// CMD in order, so each CMD,RESULT belongs to the oldest (Goby3 answers with its last
    /// request instead, so a burst got one request answered several times and the rest never).
    in_flight: InFlight,
    /// While connected: the lane's way to the connection.
    direct: Option<Arc<DirectCmd>>,
    /// CMD,RESULT lines with no CMD of ours in flight (a reconnect in between).
    pub unmatched_results: u64,
    pub bad_lines: u64,
    pub unknown_lines: u64,
    pub write_failures: u64,
    bad_log: RateLimitedLog,
    unknown_log: RateLimitedLog,
}

impl BasicSimulatorDriver {
    pub fn new(settings: Settings) -> Self {
        Self {
            settings,
            link: LinkState::default(),
            link_task: OwnedTask::default(),
            in_flight: InFlight::default(),
            direct: None,
            unmatched_results: 0,
            bad_lines: 0,
            unknown_lines: 0,
            write_failures: 0,
            bad_log: RateLimitedLog::for_bad_input(),
            unknown_log: RateLimitedLog::for_bad_input(),
        }
    }

    /// Input the driver cannot use: counted, and logged as the rate limiter allows.
    fn bad_input(&mut self, now: Duration, what: &str, line: &str, error: &str) {
        self.bad_lines += 1;
        frontseat_actors::drivers::kit::bad_line();
        if let LogDecision::Log { suppressed_before } = self.bad_log.decide_at(now) {
            let line = frontseat_actors::drivers::kit::truncate(line);
            let window = self.bad_log.window();
            tracing::warn!(
                line,
                error,
                "{what}{}",
                more(suppressed_before, "bad lines", window)
            );
        }
    }

    /// Writes one line; whether it was handed to the connection.
    fn write(&mut self, line: &str, sig: &mut dyn SignalSink) -> bool {
        let Some(w) = self.link.writer() else {
            self.write_failures += 1;
            tracing::debug!(line, "not connected to the frontseat; line not sent");
            return false;
        };
        let _span = tracing::trace_span!(
            target: "frontseat_actors",
            "frontseat.socket_write",
            bytes = line.len() + 2,
            line = frontseat_actors::drivers::kit::truncate(line),
        )
        .entered();
        match send_line(w, line, sig) {
            Ok(()) => true,
            Err(e) => {
                self.write_failures += 1;
                tracing::warn!(line, error = %e, "line to the frontseat not sent");
                false
            }
        }
    }

    fn handle_line(&mut self, line: &str, now: Duration, sig: &mut dyn SignalSink) {
        sig.raw_from_frontseat(raw_ascii(line, ""));
        let (kind, fields) = match line.split_once(',') {
            Some((k, rest)) => (k, rest),
            None => (line, ""),
        };
        let _span = tracing::trace_span!(
            target: "frontseat_actors",
            "frontseat.decode",
            kind,
            bytes = line.len(),
        )
        .entered();
        match kind {
            "NAV" => match parse_nav(line) {
                Ok(ns) => {
                    self.link.data.fresh(now);
                    sig.data_from_frontseat(InterfaceData {
                        node_status: Some(ns),
                        ..Default::default()
                    });
                }
                Err(e) => {
                    self.bad_input(now, "bad NAV line from the frontseat", line, &e.to_string());
                }
            },
            "CTRL" => {
                let state = field(fields, "STATE").unwrap_or("");
                self.link.state = match state {
                    "PAYLOAD" => FrontSeatState::FrontseatAcceptingCommands,
                    "AUV" => FrontSeatState::FrontseatInControl,
                    _ => FrontSeatState::FrontseatIdle,
                };
            }
            "CMD" => {
                let ok = field(fields, "RESULT") == Some("OK");
                let popped = self.in_flight.lock().pop_front();
                let Some(req) = popped else {
                    self.unmatched_results += 1;
                    tracing::debug!(line, "CMD,RESULT with no command in flight");
                    return;
                };
                if req.response_requested() {
                    sig.command_response(CommandResponse {
                        request_successful: Some(ok),
                        request_id: req.request_id,
                        error_string: (!ok)
                            .then(|| "frontseat answered CMD,RESULT:ERROR".to_string()),
                        ..Default::default()
                    });
                }
            }
            _ => {
                self.unknown_lines += 1;
                if let LogDecision::Log { suppressed_before } = self.unknown_log.decide_at(now) {
                    let window = self.unknown_log.window();
                    tracing::info!(
                        line = frontseat_actors::drivers::kit::truncate(line),
                        "unknown line from the frontseat{}",
                        more(suppressed_before, "unknown lines", window)
                    );
                }
            }
        }
    }
}

/// The value of `KEY:` in a comma-separated field list.
fn field<'a>(fields: &'a str, key: &str) -> Option<&'a str> {
    fields.split(',').find_map(|kv| {
        let (k, v) = kv.split_once(':')?;
        (k == key).then_some(v)
    })
}

/// Why a NAV line gave no navigation.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum NavError {
    /// A field is missing, not a number or not finite (the simulator codec's own words).
    #[error("{0}")]
    Field(FieldError),
    #[error("not a NAV line")]
    NotNav,
}

/// A whole `NAV,LAT:..,LON:..,DEPTH:..,HEADING:..,SPEED:..` line → NodeStatus (time and local
/// fix filled later by compute_missing). The fields are read by the simulator's own codec
/// (`frontseat_sim::codec`), so the driver and the simulator agree on what a NAV line is.
pub fn parse_nav(line: &str) -> Result<NodeStatus, NavError> {
    let n = match codec::parse_outbound(line) {
        Ok(Outbound::Nav(n)) => n,
        // parse_outbound files a bad NAV field under its CMD variant; only the field matters.
        Err(LineError::Cmd(e)) => return Err(NavError::Field(e)),
        _ => return Err(NavError::NotNav),
    };
    Ok(NodeStatus {
        time: SimClock::unix_now(),
        global_fix: LatLonPoint {
            lat: n.lat,
            lon: n.lon,
            depth: Some(n.depth),
            altitude: None,
        },
        pose: EulerAngles {
            heading: Some(n.heading),
            ..Default::default()
        },
        speed: Speed {
            over_ground: n.speed,
            over_water: None,
        },
        ..Default::default()
    })
}

/// `CMD,HEADING:h,SPEED:s,DEPTH:d` for a desired course; None for a request without one.
pub fn command_line(req: &CommandRequest) -> Option<String> {
    let c = req.desired_course.as_ref()?;
    Some(format!(
        "CMD,HEADING:{},SPEED:{},DEPTH:{}",
        c.heading(),
        c.speed(),
        c.depth()
    ))
}

impl Driver for BasicSimulatorDriver {
    fn name(&self) -> &str {
        "basic_simulator"
    }

    fn start(&mut self, ctx: DriverContext) {
        self.link_task
            .set(link::spawn(self.settings.link.clone(), ctx.io));
    }

    fn handle_io(&mut self, ev: DriverIoEvent, now: Duration, sig: &mut dyn SignalSink) {
        match ev {
            DriverIoEvent::Connected(w) => {
                tracing::info!(
                    host = %self.settings.link.host,
                    port = self.settings.link.port,
                    "connected to the frontseat; sending START"
                );
                // Connected but not yet told its state: IDLE until CTRL says otherwise.
                self.direct = Some(Arc::new(DirectCmd {
                    writer: w.clone(),
                    in_flight: self.in_flight.clone(),
                }));
                self.link.opened(w, FrontSeatState::FrontseatIdle);
                let start = self.settings.start_line.clone();
                let _ = self.write(&start, sig);
            }
            DriverIoEvent::Line(line) => self.handle_line(&line, now, sig),
            DriverIoEvent::Frame(_) => self.bad_input(
                now,
                "binary frame on the basic simulator's line link; ignored",
                "",
                "",
            ),
            DriverIoEvent::BadInput(what) => {
                self.bad_input(now, "bad input from the frontseat", "", &what)
            }
            DriverIoEvent::Disconnected(reason) => {
                tracing::warn!(%reason, "frontseat connection lost; reconnecting");
                self.link.lost();
                self.direct = None;
                // Their answers will not come on a new connection (the interface answers them).
                self.in_flight.lock().clear();
            }
        }
    }

    fn send_command_to_frontseat(
        &mut self,
        req: &CommandRequest,
        _now: Duration,
        sig: &mut dyn SignalSink,
    ) {
        match command_line(req) {
            Some(line) => {
                let in_flight = self.in_flight.clone();
                write_in_flight(&in_flight, req, || self.write(&line, sig));
            }
            None => refuse(
                req,
                "the basic simulator accepts only desired_course commands",
                sig,
            ),
        }
    }

    fn send_data_to_frontseat(
        &mut self,
        _data: &InterfaceData,
        _now: Duration,
        _sig: &mut dyn SignalSink,
    ) {
        // The basic simulator protocol has no data channel to the frontseat (as in Goby3).
    }

    fn send_raw_to_frontseat(&mut self, raw: &Raw, now: Duration, sig: &mut dyn SignalSink) {
        let bytes = raw.raw.as_deref().unwrap_or_default();
        match std::str::from_utf8(bytes) {
            Ok(s) => {
                let line = s.trim_end_matches(['\r', '\n']).to_string();
                let _ = self.write(&line, sig);
            }
            Err(_) => self.bad_input(
                now,
                "raw_send_request is not text; the basic simulator protocol is ASCII",
                "",
                "",
            ),
        }
    }

    fn do_loop(&mut self, now: Duration, _sig: &mut dyn SignalSink) {
        // A burst's summary, even when no further bad line comes to carry it.
        if let Some(n) = self.bad_log.summary_due_at(now) {
            let line = summary(n, "bad lines", self.bad_log.window());
            tracing::warn!(suppressed = n, "{line}");
        }
        if let Some(n) = self.unknown_log.summary_due_at(now) {
            let line = summary(n, "unknown lines", self.unknown_log.window());
            tracing::info!(suppressed = n, "{line}");
        }
        if self.link.data.expired(now, self.settings.nav_timeout) {
            tracing::warn!(
                "no NAV for {:?} (sim time): frontseat not providing data",
                self.settings.nav_timeout
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
        // Dropping the writers lets the link flush and shut the socket down cleanly.
        self.direct = None;
        self.link.close();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use frontseat_actors::link::LineWriter;
    use frontseat_actors::proto::goby::middleware::frontseat::protobuf::DesiredCourse;
    use frontseat_sim::codec::Problem;

    type Sink = frontseat_actors::driver::RecordingSink;

    fn driver() -> BasicSimulatorDriver {
        BasicSimulatorDriver::new(Settings::from_config(&InterfaceConfig::default()))
    }

    #[test]
    fn nav_parses_with_fields_in_any_order() {
        let ns = parse_nav("NAV,SPEED:1.4,HEADING:223,DEPTH:200,LON:-72.5435,LAT:42.1234").unwrap();
        let g = ns.global_fix;
        assert_eq!((g.lat, g.lon, g.depth()), (42.1234, -72.5435, 200.0));
        assert_eq!(ns.pose.heading(), 223.0);
        assert_eq!(ns.speed.over_ground, 1.4);
        assert_eq!(
            parse_nav("NAV,LAT:1,LON:2,DEPTH:3,HEADING:4"),
            Err(NavError::Field(FieldError {
                field: "SPEED",
                problem: Problem::Missing
            }))
        );
        assert!(matches!(
            parse_nav("NAV,LAT:nan,LON:2,DEPTH:3,HEADING:4,SPEED:1"),
            Err(NavError::Field(FieldError {
                field: "LAT",
                problem: Problem::NotFinite(_)
            }))
        ));
        assert!(matches!(
            parse_nav("NAV,LAT:x,LON:2,DEPTH:3,HEADING:4,SPEED:1"),
            Err(NavError::Field(FieldError {
                field: "LAT",
                problem: Problem::NotANumber(_)
            }))
        ));
        // The simulator's codec reads the fields: white space around names and values is not
        // part of them (docs/goby3-differences.md, basic-simulator NAV row).
        let ns = parse_nav("NAV,LAT: 42, LON:-71 ,DEPTH:0,HEADING:90,SPEED:1").unwrap();
        assert_eq!((ns.global_fix.lat, ns.global_fix.lon), (42.0, -71.0));
        assert_eq!(
            parse_nav("CTRL,STATE:PAYLOAD"),
            Err(NavError::NotNav),
            "only NAV lines carry navigation"
        );
    }

    #[test]
    fn start_line_has_full_precision() {
        let mut cfg = InterfaceConfig::default();
        cfg.driver.basic_simulator.start.lat = 42.358456123;
        cfg.driver.basic_simulator.start.lon = -71.087589987;
        cfg.sim_warp_factor = 4.0;
        let s = Settings::from_config(&cfg);
        assert!(
            s.start_line
                .starts_with("START,LAT:42.358456123,LON:-71.087589987,"),
            "{}",
            s.start_line
        );
        assert!(s.start_line.ends_with(",WARP:4"), "{}", s.start_line);
    }

    #[test]
    fn ctrl_maps_to_frontseat_state_and_disconnect_to_not_connected() {
        let mut d = driver();
        let mut sink = Sink::default();
        let (w, mut rx) = LineWriter::for_test();
        let now = Duration::ZERO;
        d.handle_io(DriverIoEvent::Connected(w), now, &mut sink);
        assert!(rx.try_recv().unwrap().starts_with(b"START,LAT:"));
        for (line, want) in [
            (
                "CTRL,STATE:PAYLOAD",
                FrontSeatState::FrontseatAcceptingCommands,
            ),
            ("CTRL,STATE:AUV", FrontSeatState::FrontseatInControl),
            ("CTRL,STATE:IDLE", FrontSeatState::FrontseatIdle),
            ("CTRL,STATE:WHATEVER", FrontSeatState::FrontseatIdle),
        ] {
            d.handle_io(DriverIoEvent::Line(line.into()), now, &mut sink);
            assert_eq!(d.frontseat_state(), want, "{line}");
        }
        d.handle_io(DriverIoEvent::Disconnected("x".into()), now, &mut sink);
        assert_eq!(d.frontseat_state(), FrontSeatState::FrontseatNotConnected);
        assert_eq!(sink.raw_in.len(), 4);
        assert_eq!(sink.raw_out.len(), 1);
    }

    #[test]
    fn command_round_trip_answers_only_when_requested() {
        let mut d = driver();
        let mut sink = Sink::default();
        let (w, mut rx) = LineWriter::for_test();
        let now = Duration::ZERO;
        d.handle_io(DriverIoEvent::Connected(w), now, &mut sink);
        let _start = rx.try_recv().unwrap();
        let mut req = CommandRequest {
            desired_course: Some(DesiredCourse {
                time: 0.0,
                heading: Some(260.0),
                speed: Some(1.5),
                depth: Some(100.0),
                ..Default::default()
            }),
            response_requested: Some(true),
            request_id: Some(7),
            ..Default::default()
        };
        d.send_command_to_frontseat(&req, now, &mut sink);
        assert_eq!(
            rx.try_recv().unwrap(),
            b"CMD,HEADING:260,SPEED:1.5,DEPTH:100\r\n"
        );
        d.handle_io(DriverIoEvent::Line("CMD,RESULT:OK".into()), now, &mut sink);
        assert_eq!(sink.responses.len(), 1);
        assert_eq!(sink.responses[0].request_successful, Some(true));
        assert_eq!(sink.responses[0].request_id, Some(7));
        d.handle_io(DriverIoEvent::Line("CMD,RESULT:OK".into()), now, &mut sink);
        assert_eq!(sink.responses.len(), 1, "a request is answered once");
        req.response_requested = Some(false);
        d.send_command_to_frontseat(&req, now, &mut sink);
        d.handle_io(
            DriverIoEvent::Line("CMD,RESULT:ERROR".into()),
            now,
            &mut sink,
        );
        assert_eq!(sink.responses.len(), 1);
    }

    #[test]
    fn a_burst_of_commands_gets_one_answer_each_in_order() {
        let mut d = driver();
        let mut sink = Sink::default();
        let (w, mut rx) = LineWriter::for_test();
        let now = Duration::ZERO;
        d.handle_io(DriverIoEvent::Connected(w), now, &mut sink);
        let _start = rx.try_recv().unwrap();
        for (id, respond) in [(1, true), (2, false), (3, true)] {
            let req = CommandRequest {
                desired_course: Some(DesiredCourse {
                    heading: Some(90.0),
                    speed: Some(1.0),
                    ..Default::default()
                }),
                response_requested: Some(respond),
                request_id: Some(id),
                ..Default::default()
            };
            d.send_command_to_frontseat(&req, now, &mut sink);
        }
        for result in ["OK", "OK", "ERROR"] {
            d.handle_io(
                DriverIoEvent::Line(format!("CMD,RESULT:{result}")),
                now,
                &mut sink,
            );
        }
        let answers: Vec<(Option<i32>, Option<bool>)> = sink
            .responses
            .iter()
            .map(|r| (r.request_id, r.request_successful))
            .collect();
        assert_eq!(answers, vec![(Some(1), Some(true)), (Some(3), Some(false))]);
        // A result with nothing in flight answers nobody.
        d.handle_io(DriverIoEvent::Line("CMD,RESULT:OK".into()), now, &mut sink);
        assert_eq!(sink.responses.len(), 2);
        assert_eq!(d.unmatched_results, 1);
    }

    #[test]
    fn providing_data_times_out_after_nav_stops() {
        let mut d = driver();
        let mut sink = Sink::default();
        let (w, _rx) = LineWriter::for_test();
        d.handle_io(DriverIoEvent::Connected(w), Duration::ZERO, &mut sink);
        d.handle_io(
            DriverIoEvent::Line("NAV,LAT:1,LON:2,DEPTH:0,HEADING:0,SPEED:0".into()),
            Duration::from_secs(1),
            &mut sink,
        );
        assert!(d.frontseat_providing_data());
        d.do_loop(Duration::from_secs(10), &mut sink);
        assert!(d.frontseat_providing_data());
        d.do_loop(Duration::from_millis(11_100), &mut sink);
        assert!(!d.frontseat_providing_data());
        assert_eq!(sink.data.len(), 1);
    }
}
