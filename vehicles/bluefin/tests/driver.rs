//! The Bluefin driver's rules, one test per rule, through its public `Driver` interface with a
//! channel standing in for the socket: state inference, the acknowledgement queue (and each
//! Goby3 bug it does not copy), heartbeats, commands and extensions, bad input. The extension
//! bytes are checked against a Goby3-style `extend` through reflection.

use std::time::Duration;

use frontseat_actors::driver::{Driver, DriverIoEvent};
use frontseat_actors::link::LineWriter;
use frontseat_actors::proto;
use frontseat_actors::proto::frontseat::protobuf::bluefin as bf;
use frontseat_actors::proto::goby::acomms::protobuf::ModemRaw;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    BluefinExtraCommands, BluefinExtraData, CommandRequest, DesiredCourse, FrontSeatState, Raw,
    bluefin_extra_commands::BluefinCommand, bluefin_extra_data::PayloadStatus,
};
use frontseat_bluefin::driver::error_code;
use frontseat_bluefin::{BluefinDriver, Settings, codec};
use frontseat_config::{AcceptingCommandsHook, InterfaceConfig, RpmTableEntry};
use prost::Message;

const DAY: f64 = 20_414.0 * 86_400.0;
const NOON: f64 = 43_200.0;

type Sink = frontseat_actors::driver::RecordingSink;

struct H {
    d: BluefinDriver,
    sink: Sink,
    rx: tokio::sync::mpsc::Receiver<Vec<u8>>,
    now: Duration,
}

impl H {
    fn with(cfg: impl FnOnce(&mut InterfaceConfig)) -> Self {
        let mut c = InterfaceConfig::default();
        c.driver.name = "bluefin".into();
        cfg(&mut c);
        let d = BluefinDriver::with_wall_clock(
            Settings::from_config(&c),
            Box::new(|now: Duration| DAY + NOON + now.as_secs_f64()),
        );
        let (w, rx) = LineWriter::for_test();
        let mut h = Self {
            d,
            sink: Sink::default(),
            rx,
            now: Duration::ZERO,
        };
        h.d.handle_io(DriverIoEvent::Connected(w), h.now, &mut h.sink);
        h
    }

    fn new() -> Self {
        Self::with(|_| {})
    }

    fn written(&mut self) -> Vec<String> {
        let mut out = Vec::new();
        while let Ok(b) = self.rx.try_recv() {
            let s = String::from_utf8(b).unwrap();
            out.push(s.trim_end().to_string());
        }
        out
    }

    fn feed(&mut self, line: &str) {
        self.d
            .handle_io(DriverIoEvent::Line(line.into()), self.now, &mut self.sink);
    }

    fn ack(&mut self, id: &str, status: u8, text: &str) {
        let s = codec::Sentence::parse(&format!(
            "$BFACK,{},{id},,,{status},0,{text}",
            codec::format_time(NOON + self.now.as_secs_f64())
        ))
        .unwrap();
        self.feed(&s.format());
    }

    /// Acknowledges everything written, one at a time, as a prompt Huxley would.
    fn ack_everything(&mut self) -> Vec<String> {
        let mut all = Vec::new();
        loop {
            let w = self.written();
            if w.is_empty() {
                return all;
            }
            for l in w {
                let s = codec::Sentence::parse(&l).unwrap();
                self.ack(&s.id.clone(), 2, "");
                all.push(l);
            }
        }
    }

    fn tick_to(&mut self, secs: f64) {
        let target = Duration::from_secs_f64(secs);
        while self.now + Duration::from_millis(100) <= target {
            self.now += Duration::from_millis(100);
            self.d.do_loop(self.now, &mut self.sink);
        }
    }

    fn command(&mut self, req: &CommandRequest) {
        self.d
            .send_command_to_frontseat(req, self.now, &mut self.sink);
    }

    fn bluefin(&mut self, req: &bf::CommandRequest) {
        self.d.send_bluefin_command(req, self.now, &mut self.sink);
    }
}

fn course(heading: f64, speed: f64, depth: f64, id: i32) -> CommandRequest {
    CommandRequest {
        desired_course: Some(DesiredCourse {
            heading: Some(heading),
            speed: Some(speed),
            depth: Some(depth),
            ..Default::default()
        }),
        response_requested: Some(true),
        request_id: Some(id),
        ..Default::default()
    }
}

fn ext(cmd: BluefinCommand, id: i32) -> bf::CommandRequest {
    let mut e = BluefinExtraCommands::default();
    e.set_command(cmd);
    bf::CommandRequest {
        response_requested: Some(true),
        request_id: Some(id),
        bluefin_command: Some(e),
        ..Default::default()
    }
}

fn fields(line: &str) -> Vec<String> {
    codec::Sentence::parse(line).unwrap().fields
}

#[test]
fn connect_enables_logging_ack_first_then_heartbeat() {
    let mut h = H::with(|c| c.driver.bluefin.extra_bplog = vec!["svs".into(), "xyz".into()]);
    assert_eq!(h.d.frontseat_state(), FrontSeatState::FrontseatIdle);
    let lines = h.ack_everything();
    let ids: Vec<String> = lines
        .iter()
        .map(|l| {
            let f = fields(l);
            if l.starts_with("$BPLOG") {
                f[0].clone()
            } else {
                l[1..6].to_string()
            }
        })
        .collect();
    assert_eq!(
        ids,
        [
            "ACK", "NVG", "MIS", "MSC", "NVR", "SVS", "RVL", "SHT", "TOP", "MBS", "MBE", "CTD",
            "DVL", "BOY", "TRM", "SVS", "XYZ", "BPSTS"
        ]
    );
    assert_eq!(lines.last().unwrap(), "$BPSTS,120000.000,1,Deploy*6D");

    let mut h = H::with(|c| {
        c.driver.bluefin.disable_ack = true;
        c.driver.bluefin.accepting_commands_hook = AcceptingCommandsHook::BfctlTrigger;
    });
    let lines = h.written();
    assert_eq!(
        lines[0], "$BPLOG,NVG,ON*08",
        "no ACK request with acks disabled"
    );
    assert!(lines.iter().any(|l| l.starts_with("$BPLOG,CTL,ON")));
    assert_eq!(lines.len(), 16, "all written at once without acks");
}

#[test]
fn heartbeat_runs_at_its_interval_not_twice_it() {
    let mut h = H::new();
    h.ack_everything();
    let mut beats = Vec::new();
    for t in 1..=6 {
        h.tick_to(f64::from(t));
        for l in h.ack_everything() {
            if l.starts_with("$BPSTS") {
                beats.push(fields(&l)[0].clone());
            }
        }
    }
    assert_eq!(
        beats,
        [
            "120001.000",
            "120002.000",
            "120003.000",
            "120004.000",
            "120005.000",
            "120006.000"
        ]
    );
}

#[test]
fn payload_statuses_fold_into_the_heartbeat_until_they_expire() {
    let mut h = H::new();
    h.ack_everything();
    let now_us = |s: f64| ((DAY + NOON + s) * 1e6) as u64;
    let data = bf::InterfaceData {
        bluefin_data: Some(BluefinExtraData {
            payload_status: vec![
                PayloadStatus {
                    id: 2,
                    expire_time: now_us(1.5),
                    msg: "camera: FAULT".into(),
                    all_ok: false,
                },
                PayloadStatus {
                    id: 1,
                    expire_time: now_us(10.0),
                    msg: "sonar: ok".into(),
                    all_ok: true,
                },
            ],
            ..Default::default()
        }),
        ..Default::default()
    };
    h.d.send_bluefin_data(&data, h.now, &mut h.sink);
    h.tick_to(1.0);
    let beat = h.ack_everything();
    assert_eq!(beat.len(), 1);
    let f = fields(&beat[0]);
    assert_eq!(f[1], "0", "one payload is not ok");
    assert_eq!(
        f[2],
        "2025-Nov-22 12:00:01.000000; sonar: ok; camera: FAULT"
    );
    h.tick_to(2.0);
    let f = fields(&h.ack_everything()[0]);
    assert_eq!(f[1], "1", "the faulty status expired");
    assert_eq!(f[2], "2025-Nov-22 12:00:02.000000; sonar: ok");
}

#[test]
fn the_heartbeat_reports_an_interface_error() {
    use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
        InterfaceState, InterfaceStatus,
    };
    let mut h = H::new();
    h.ack_everything();
    let mut s = InterfaceStatus::default();
    s.set_state(InterfaceState::InterfaceHelmError);
    h.d.interface_status(&s);
    h.tick_to(1.0);
    assert_eq!(fields(&h.ack_everything()[0])[1], "0");
    s.set_state(InterfaceState::InterfaceCommand);
    h.d.interface_status(&s);
    h.tick_to(2.0);
    assert_eq!(fields(&h.ack_everything()[0])[1], "1");
}

#[test]
fn state_follows_the_accepting_commands_hook() {
    use FrontSeatState::*;
    let mis_run = "$BFMIS,120003.000,demo.dive,Running*15";
    let mis_stop = "$BFMIS,120020.000,demo.dive,Stopped*1A";
    let msc = "$BFMSC,120003.500,backseat control enabled*48";
    let ctl_on = "$BFCTL,120021.000,1*70";
    let ctl_off = "$BFCTL,120022.000,0*72";
    let cases: &[(AcceptingCommandsHook, &[(&str, FrontSeatState)])] = &[
        (
            AcceptingCommandsHook::BfmscTrigger,
            &[
                (mis_run, FrontseatInControl),
                (msc, FrontseatAcceptingCommands),
                (mis_run, FrontseatAcceptingCommands),
                (ctl_off, FrontseatAcceptingCommands),
                (mis_stop, FrontseatIdle),
            ],
        ),
        (
            AcceptingCommandsHook::BfmisRunningTrigger,
            &[
                (msc, FrontseatIdle),
                (mis_run, FrontseatAcceptingCommands),
                (mis_stop, FrontseatIdle),
            ],
        ),
        (
            AcceptingCommandsHook::BfctlTrigger,
            &[
                (ctl_off, FrontseatIdle),
                (ctl_on, FrontseatAcceptingCommands),
                (mis_run, FrontseatAcceptingCommands),
                (ctl_off, FrontseatInControl),
                (msc, FrontseatInControl),
            ],
        ),
    ];
    for (hook, steps) in cases {
        let mut h = H::with(|c| c.driver.bluefin.accepting_commands_hook = *hook);
        for (line, want) in *steps {
            h.feed(line);
            assert_eq!(h.d.frontseat_state(), *want, "{hook:?}: {line}");
        }
    }
}

#[test]
fn providing_data_comes_from_navigation_only_and_times_out() {
    let mut h = H::new();
    h.ack_everything();
    assert!(!h.d.frontseat_providing_data(), "acks are not navigation");
    h.feed("$BFNVG,120002.000,4221.5040,N,07105.2560,W,1,25.3,0.0,90.0,0.5,-1.2,120001.950*42");
    assert!(h.d.frontseat_providing_data());
    h.tick_to(5.0);
    assert!(h.d.frontseat_providing_data());
    h.tick_to(5.2);
    assert!(!h.d.frontseat_providing_data());
    // NVR without a new NVG republishes the last fix (as Goby3 does).
    h.feed("$BFNVR,120002.010,1.50,0.00,0.00,0.10,0.00,0.20*7B");
    h.feed("$BFNVR,120002.010,1.50,0.00,0.00,0.10,0.00,0.20*7B");
    assert_eq!(h.sink.data.len(), 2);
}

#[test]
fn a_final_ack_for_a_pending_command_does_not_release_the_sentence_in_flight() {
    let mut h = H::new();
    h.ack_everything();
    h.command(&course(180.0, 1.5, 10.0, 1));
    h.bluefin(&ext(BluefinCommand::BuoyancyAdjust, 2));
    assert_eq!(h.written().len(), 1, "stop-and-wait: RMB only");
    h.ack("RMB", 3, "");
    let w = h.written();
    assert_eq!(w.len(), 1, "pending frees the line: BOY goes out");
    assert!(w[0].starts_with("$BPBOY"));
    h.ack("RMB", 2, "");
    assert!(
        h.written().is_empty(),
        "Goby3 writes BOY a second time here; we keep waiting for its own ack"
    );
    h.tick_to(1.0);
    h.ack("BOY", 2, "");
    h.ack_everything();
    assert_eq!(h.d.queue_lengths(), (0, 0));
    assert_eq!(h.d.stats.unmatched_acks, 0);
    let ids: Vec<_> = h.sink.responses.iter().map(|r| r.request_id).collect();
    assert_eq!(ids, [Some(1), Some(2)]);
    assert!(
        h.sink
            .responses
            .iter()
            .all(|r| r.request_successful == Some(true))
    );
}

#[test]
fn a_huxley_that_answers_only_pending_cannot_grow_the_pending_list() {
    // Goby3 keeps every pending sentence until its final answer (`pending_`, unbounded); we keep
    // MAX_PENDING and fail the oldest, so the helm hears that request will get no answer.
    use frontseat_bluefin::driver::MAX_PENDING;
    let mut h = H::new();
    h.ack_everything();
    let n = i32::try_from(MAX_PENDING).unwrap() + 10;
    for id in 1..=n {
        h.command(&course(180.0, 1.5, 10.0, id));
        let w = h.written();
        assert_eq!(w.len(), 1, "request {id}");
        assert!(w[0].starts_with("$BPRMB"), "{w:?}");
        h.ack("RMB", 3, "");
    }
    assert_eq!(h.d.queue_lengths(), (0, MAX_PENDING));
    assert_eq!(h.d.stats.pending_overflow, 10);
    let failed: Vec<_> = h
        .sink
        .responses
        .iter()
        .filter(|r| r.request_successful == Some(false))
        .map(|r| (r.request_id, r.error_code))
        .collect();
    let want: Vec<_> = (1..=10)
        .map(|id| (Some(id), Some(error_code::PENDING_OVERFLOW)))
        .collect();
    assert_eq!(failed, want, "the oldest ten, in order, and nothing else");
    // The next final answer belongs to the oldest request still pending.
    h.ack("RMB", 2, "");
    let last = h.sink.responses.last().unwrap();
    assert_eq!(
        (last.request_id, last.request_successful),
        (Some(11), Some(true))
    );
    assert_eq!(h.d.queue_lengths(), (0, MAX_PENDING - 1));
}

#[test]
fn an_unmatched_ack_is_counted_and_clears_nothing() {
    let mut h = H::new();
    h.ack_everything();
    h.command(&course(180.0, 1.5, 10.0, 1));
    h.command(&course(90.0, 1.5, 10.0, 2));
    assert_eq!(h.written().len(), 1);
    h.ack("TRM", 2, "");
    assert_eq!(h.d.stats.unmatched_acks, 1);
    assert_eq!(
        h.d.queue_lengths(),
        (2, 0),
        "Goby3 would clear both queues here"
    );
    h.ack("RMB", 2, "");
    h.ack_everything();
    // Two requests of the same type: both answered (Goby3 keeps only the newest).
    let ids: Vec<_> = h.sink.responses.iter().map(|r| r.request_id).collect();
    assert_eq!(ids, [Some(1), Some(2)]);
}

#[test]
fn every_bluefin_command_maps_to_its_sentence_and_gets_an_answer() {
    let mut h = H::new();
    h.ack_everything();
    let cases = [
        (BluefinCommand::TrimAdjust, "$BPTRM,"),
        (BluefinCommand::BuoyancyAdjust, "$BPBOY,"),
        (BluefinCommand::SilentMode, "$BPSIL,"),
        (BluefinCommand::CancelCurrentBehavior, "$BPRCE,"),
        (BluefinCommand::AbortMission, "$BPABT,"),
        (BluefinCommand::MissionStartConfirm, "$BPSMC,"),
        (BluefinCommand::MissionEndConfirm, "$BPRCE,"),
    ];
    for (i, (cmd, prefix)) in cases.iter().enumerate() {
        let id = i as i32 + 10;
        let mut req = ext(*cmd, id);
        if *cmd == BluefinCommand::SilentMode {
            req.bluefin_command.as_mut().unwrap().silent_mode = Some(1);
        }
        h.bluefin(&req);
        let w = h.ack_everything();
        assert_eq!(w.len(), 1, "{cmd:?}");
        assert!(w[0].starts_with(prefix), "{cmd:?}: {}", w[0]);
        let r = h.sink.responses.last().unwrap();
        assert_eq!(
            (r.request_id, r.request_successful),
            (Some(id), Some(true)),
            "{cmd:?} answered"
        );
    }
    let w: Vec<_> = h.sink.responses.iter().map(|r| r.request_id).collect();
    assert_eq!(w.len(), cases.len());
    // The silent flag and the abort reason reach the wire.
    let mut h = H::new();
    h.ack_everything();
    let mut req = ext(BluefinCommand::SilentMode, 1);
    req.bluefin_command.as_mut().unwrap().silent_mode = Some(1);
    h.bluefin(&req);
    assert_eq!(fields(&h.written()[0])[1], "1");
    h.ack("SIL", 2, "");
    let mut req = ext(BluefinCommand::AbortMission, 2);
    req.bluefin_command.as_mut().unwrap().abort_reason = Some(0);
    h.bluefin(&req);
    assert_eq!(fields(&h.written()[0])[1..], ["backseat abort", "0"]);
}

#[test]
fn desired_course_stops_only_below_a_centimetre_per_second() {
    let mut h = H::new();
    h.ack_everything();
    // Goby3 truncates depth and speed to int and sends the stop line for this slow surface transit.
    h.command(&course(90.0, 0.8, 0.5, 1));
    let w = h.ack_everything();
    assert_eq!(fields(&w[0])[1..], ["90", "0.5", "0", "0.8", "1", "0"]);
    h.command(&course(90.0, 0.0, 5.0, 2));
    let w = h.ack_everything();
    assert_eq!(fields(&w[0])[1..], ["0", "0", "2", "0", "0", "1"]);
    // Non-finite values are refused with an answer, not written.
    h.command(&course(f64::NAN, 1.0, 5.0, 3));
    assert!(h.written().is_empty());
    let r = h.sink.responses.last().unwrap();
    assert_eq!(r.request_id, Some(3));
    assert_eq!(r.error_code, Some(error_code::BAD_REQUEST));
}

#[test]
fn rpm_table_interpolates_speed() {
    let mut h = H::with(|c| {
        c.driver.bluefin.use_rpm_table_for_speed = true;
        c.driver.bluefin.rpm_table = vec![
            RpmTableEntry {
                speed: 2.0,
                rpm: 1000,
            },
            RpmTableEntry {
                speed: 1.0,
                rpm: 500,
            },
        ];
    });
    h.ack_everything();
    for (speed, rpm) in [(1.5, "750"), (0.5, "500"), (3.0, "1000")] {
        h.command(&course(90.0, speed, 5.0, 1));
        let w = h.ack_everything();
        let f = fields(&w[0]);
        assert_eq!((f[4].as_str(), f[5].as_str()), (rpm, "0"), "speed {speed}");
    }
}

#[test]
fn unacknowledged_sentences_are_resent_dropped_answered_and_finally_reset_the_link() {
    let mut h = H::new();
    // Acknowledge nothing: ACK request written at 0, 5, 10; dropped at 15.
    assert_eq!(h.written().len(), 1);
    h.tick_to(4.9);
    assert!(h.written().is_empty());
    h.tick_to(5.0);
    assert_eq!(h.written(), ["$BPLOG,ACK,ON*1E"]);
    h.tick_to(10.0);
    assert_eq!(h.written(), ["$BPLOG,ACK,ON*1E"]);
    h.tick_to(15.0);
    assert_eq!(h.written(), ["$BPLOG,NVG,ON*08"], "dropped, next one goes");
    assert_eq!(h.d.stats.dropped_unacked, 1);
    // Any valid sentence proves the Huxley alive: demerits restart.
    h.tick_to(30.0);
    h.feed("$BFSHT,120028.000*70");
    h.tick_to(45.0);
    h.tick_to(60.0);
    h.tick_to(75.0);
    assert_eq!(h.d.frontseat_state(), FrontSeatState::FrontseatIdle);
    // A request in flight that is never answered gets a failure, not silence.
    h.written();
    let mut h = H::new();
    h.ack_everything();
    h.command(&course(180.0, 1.5, 10.0, 7));
    h.tick_to(15.0);
    let r = h.sink.responses.last().expect("answered");
    assert_eq!(
        (r.request_id, r.request_successful, r.error_code),
        (Some(7), Some(false), Some(error_code::NOT_ACKNOWLEDGED))
    );
    // The fourth dropped sentence in a row: the Huxley is unresponsive.
    h.tick_to(59.0);
    assert_eq!(h.d.frontseat_state(), FrontSeatState::FrontseatIdle);
    h.tick_to(60.0);
    assert_eq!(h.d.frontseat_state(), FrontSeatState::FrontseatNotConnected);
    assert_eq!(h.d.stats.unresponsive_resets, 1);
    assert_eq!(h.d.queue_lengths(), (0, 0));
}

#[test]
fn cancel_request_id_answers_the_cancelled_request() {
    let mut h = H::new();
    h.ack_everything();
    h.command(&course(180.0, 1.5, 10.0, 1));
    h.command(&course(90.0, 1.5, 10.0, 2));
    h.command(&CommandRequest {
        cancel_request_id: Some(2),
        response_requested: Some(true),
        request_id: Some(3),
        ..Default::default()
    });
    let rs: Vec<_> = h
        .sink
        .responses
        .iter()
        .map(|r| (r.request_id, r.request_successful, r.error_code))
        .collect();
    assert_eq!(
        rs,
        [
            (Some(2), Some(false), Some(error_code::CANCELLED)),
            (Some(3), Some(true), None)
        ]
    );
    let w = h.ack_everything();
    assert_eq!(w.len(), 1, "the cancelled RMB was never written");
}

#[test]
fn disconnect_answers_outstanding_requests() {
    let mut h = H::new();
    h.ack_everything();
    h.command(&course(180.0, 1.5, 10.0, 4));
    h.d.handle_io(
        DriverIoEvent::Disconnected("test".into()),
        h.now,
        &mut h.sink,
    );
    assert_eq!(h.d.frontseat_state(), FrontSeatState::FrontseatNotConnected);
    let r = h.sink.responses.last().unwrap();
    assert_eq!(
        (r.request_id, r.error_code),
        (Some(4), Some(error_code::CONNECTION_LOST))
    );
}

#[test]
fn bad_input_is_counted_published_raw_and_never_fatal() {
    let mut h = H::new();
    h.ack_everything();
    let before = h.sink.raw_in.len();
    for line in [
        "$BFNVG,120002.000,4221.5040,N,07105.2560,W,1,25.3,0.0,90.0,0.5,-1.2,120001.950*43",
        "garbage",
        "$BFNVG,120002.000,4221.5040,N,07105.2560,W,1,25.3,nan,90.0,0.5,-1.2,120001.950",
        "$BFACK,120000.000,RMB,,,9,0,",
        "$BFNV,1",
        "\u{0}\u{1}$$$***",
    ] {
        h.feed(line);
    }
    h.d.handle_io(
        DriverIoEvent::BadInput("line over 2048 bytes".into()),
        h.now,
        &mut h.sink,
    );
    assert_eq!(h.d.stats.bad_lines, 7);
    assert!(!h.d.frontseat_providing_data());
    assert!(h.sink.data.is_empty());
    h.feed("$BFSVS,120000.000,1500");
    h.feed("$BFXYZ,120000.000");
    assert_eq!(h.d.stats.ignored_sentences, 2);
    assert_eq!(h.sink.raw_in.len() - before, 8, "every line on raw_in once");
}

#[test]
fn huxley_extension_data_is_published_with_goby3_fields() {
    let mut h = H::new();
    h.ack_everything();
    h.feed("$BFBOY,120023.000,2,0,done,-1.5*65");
    h.feed("$BFTRM,120024.000,2,0,done,1.2,0.3*56");
    h.feed("$BFRVL,120025.000,1200,1.5*53");
    h.feed("$BFDVL,120026.000,1.5,0.01,-0.02,10.1,10.2,10.3,10.4,12.5,120025.900*48");
    assert_eq!(h.sink.extensions.len(), 4);
    let d: Vec<_> = h
        .sink
        .extensions_of::<bf::InterfaceData>(frontseat_bluefin::driver::DATA)
        .into_iter()
        .map(|d| d.bluefin_data.unwrap())
        .collect();
    assert_eq!(d.len(), 4, "every one of the Bluefin's type, and decodes");
    assert!(h.sink.extensions.iter().all(|e| e.vehicle() == "Bluefin"));
    let b = d[0].buoyancy_status.as_ref().unwrap();
    assert_eq!((b.status, b.buoyancy_newtons), (Some(2), Some(-1.5)));
    let t = d[1].trim_status.as_ref().unwrap();
    assert_eq!(
        (t.pitch_trim_degrees, t.roll_trim_degrees),
        (Some(1.2), Some(0.3))
    );
    let th = d[2].thruster.as_ref().unwrap();
    assert_eq!(
        (th.rotation, th.speed_from_lookup_table),
        (1200.0, Some(1.5))
    );
    let dvl = d[3].dvl.as_ref().unwrap();
    assert_eq!(
        (dvl.u, dvl.beam4_range, dvl.temperature),
        (Some(1.5), Some(10.4), Some(12.5))
    );
    assert_eq!(dvl.dvl_time, Some(DAY + NOON + 25.9));
    // CTD: µS/cm → S/m, kPa → Pa.
    h.feed("$BFCTD,120027.000,42000,12.5,201.325,120026.900*74");
    let c = h.sink.data[0].ctd_sample.as_ref().unwrap();
    assert_eq!(c.conductivity, Some(4.2));
    assert_eq!((c.temperature, c.pressure), (12.5, 201_325.0));
    // Completed as Goby3's compute_missing: PSS-78 salinity, Mackenzie sound speed, EOS-80.
    let sal = frontseat_bluefin::seawater::salinity_pss78(4.2 / 4.2914, 12.5, 20.1325);
    assert_eq!(c.salinity, sal);
    assert!((35.0..38.0).contains(&c.salinity), "{}", c.salinity);
    assert!(
        (1490.0..1510.0).contains(&c.sound_speed),
        "{}",
        c.sound_speed
    );
    assert!((1026.0..1030.0).contains(&c.density), "{}", c.density);
    assert_eq!(c.density_algorithm, Some(1));
}

#[test]
fn data_to_the_huxley_ctd_dccl_and_modem_lines() {
    let mut h = H::new();
    h.ack_everything();
    h.tick_to(0.9);
    let mut data = bf::InterfaceData {
        dccl_message: Some(vec![0x0a, 0x04, 0x08, 0x01, 0x10, 0x02]),
        bluefin_data: Some(BluefinExtraData {
            micro_modem_raw_in: Some(ModemRaw {
                raw: b"$CARXD,1,0,0,1,1*51\r\n".to_vec(),
                description: None,
            }),
            ..Default::default()
        }),
        ..Default::default()
    };
    h.d.send_bluefin_data(&data, h.now, &mut h.sink);
    let w = h.ack_everything();
    assert_eq!(fields(&w[0])[1], "CgQIARAC");
    assert_eq!(fields(&w[1])[1..], ["3", "$CARXD:1:0:0:1:1/51  "]);
    let mut h2 = H::with(|c| c.driver.bluefin.send_tmr_messages = false);
    h2.ack_everything();
    data.dccl_message = None;
    h2.d.send_bluefin_data(&data, h2.now, &mut h2.sink);
    assert!(h2.written().is_empty());
}

#[test]
fn raw_sentences_get_a_fresh_checksum() {
    let mut h = H::new();
    h.ack_everything();
    let raw = Raw {
        raw: Some(b"$BPVER,1*00\r\n".to_vec()),
        ..Default::default()
    };
    h.d.send_raw_to_frontseat(&raw, h.now, &mut h.sink);
    assert_eq!(h.written(), ["$BPVER,1*4E"]);
    h.ack("VER", 2, "");
    let raw = Raw {
        raw: Some(b"not a sentence".to_vec()),
        ..Default::default()
    };
    h.d.send_raw_to_frontseat(&raw, h.now, &mut h.sink);
    assert!(h.written().is_empty());
}

#[test]
fn a_goby3_extended_command_request_decodes_into_the_mirror_and_back() {
    use prost_reflect::{DescriptorPool, DynamicMessage, Value};
    let pool = DescriptorPool::decode(proto::FILE_DESCRIPTOR_SET).unwrap();
    let base = pool
        .get_message_by_name("goby.middleware.frontseat.protobuf.CommandRequest")
        .unwrap();
    let ext_field = pool
        .get_extension_by_name("goby.middleware.frontseat.protobuf.bluefin_command")
        .unwrap();
    assert_eq!(ext_field.number(), 1000);
    let cmds = pool
        .get_message_by_name("goby.middleware.frontseat.protobuf.BluefinExtraCommands")
        .unwrap();
    let mut c = DynamicMessage::new(cmds);
    c.set_field_by_name("command", Value::EnumNumber(4));
    let mut goby = DynamicMessage::new(base.clone());
    goby.set_field_by_name("request_id", Value::I32(5));
    goby.set_field_by_name("response_requested", Value::Bool(true));
    goby.set_extension(&ext_field, Value::Message(c));
    let bytes = goby.encode_to_vec();

    let ours = bf::CommandRequest::decode(bytes.as_slice()).unwrap();
    assert_eq!(ours.request_id, Some(5));
    assert_eq!(
        ours.bluefin_command.as_ref().map(|c| c.command()),
        Some(BluefinCommand::BuoyancyAdjust)
    );
    assert_eq!(ours.encode_to_vec(), bytes, "we write what Goby3 wrote");

    // And bluefin_data the other way: what we publish, Goby3 reads as its extension.
    let data = bf::InterfaceData {
        bluefin_data: Some(BluefinExtraData {
            thruster: Some(
                proto::goby::middleware::frontseat::protobuf::bluefin_extra_data::RawThrusterRotation {
                    rotation: 1200.0,
                    speed_from_lookup_table: Some(1.5),
                },
            ),
            ..Default::default()
        }),
        ..Default::default()
    };
    let base = pool
        .get_message_by_name("goby.middleware.frontseat.protobuf.InterfaceData")
        .unwrap();
    let ext_data = pool
        .get_extension_by_name("goby.middleware.frontseat.protobuf.bluefin_data")
        .unwrap();
    let read = DynamicMessage::decode(base, data.encode_to_vec().as_slice()).unwrap();
    let v = read.get_extension(&ext_data);
    let m = v.as_message().unwrap();
    let th = m.get_field_by_name("thruster").unwrap();
    assert_eq!(
        th.as_message()
            .unwrap()
            .get_field_by_name("rotation")
            .unwrap()
            .as_f64(),
        Some(1200.0)
    );
}
