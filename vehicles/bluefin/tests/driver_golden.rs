//! Replays the constructed Huxley golden session (`vehicles/bluefin/fixtures/golden_session.txt`) through
//! the real Bluefin driver, byte for byte: every `<` line is fed at its own timestamp, the 10 Hz
//! loop runs in between, and the lines the driver writes must be exactly the `>` lines, in
//! order (heartbeat timestamps aside, see the fixture's README). The signals the transcript's
//! comments describe (NodeStatus, frontseat states, CommandResponse) are checked too.

use std::time::Duration;

use frontseat_actors::driver::{Driver, DriverIoEvent};
use frontseat_actors::link::LineWriter;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CommandRequest, CommandResponse, DesiredCourse, FrontSeatState, source::Sensor,
};
use frontseat_bluefin::{BluefinDriver, Settings, codec};
use frontseat_config::InterfaceConfig;

/// 2025-11-22 00:00:00 UTC; the session runs from 12:00:00.
const DAY: f64 = 20_414.0 * 86_400.0;
const NOON: f64 = 43_200.0;

type Sink = frontseat_actors::driver::RecordingSink;

/// A sentence line without its trailing `# comment`.
fn sentence(rest: &str) -> &str {
    rest.split_once(" #").map_or(rest, |(s, _)| s).trim()
}

/// The time of day in a `<` line (field 1), in ms after noon.
fn ms_after_noon(tod_text: &str) -> u64 {
    let tod = codec::parse_time(tod_text).expect("time of day");
    ((tod - NOON) * 1000.0).round() as u64
}

/// The heartbeat's timestamp is masked: our cadence differs on purpose.
fn mask_sts(line: &str) -> String {
    if !line.starts_with("$BPSTS,") {
        return line.to_string();
    }
    let s = codec::Sentence::parse(line).expect("BPSTS parses");
    format!("$BPSTS,<t>,{}", s.fields[1..].join(","))
}

struct Replay {
    driver: BluefinDriver,
    sink: Sink,
    rx: tokio::sync::mpsc::Receiver<Vec<u8>>,
    /// Loop ticks run so far (every 100 ms).
    ticks_done: u64,
}

impl Replay {
    fn new() -> Self {
        let mut cfg = InterfaceConfig::default();
        cfg.driver.name = "bluefin".into();
        // The transcript's cadence (Goby3's doubled 1 s).
        cfg.driver.bluefin.heartbeat_interval = 2;
        let driver = BluefinDriver::with_wall_clock(
            Settings::from_config(&cfg),
            Box::new(|now: Duration| DAY + NOON + now.as_secs_f64()),
        );
        let (w, rx) = LineWriter::for_test();
        let mut r = Self {
            driver,
            sink: Sink::default(),
            rx,
            ticks_done: 0,
        };
        r.driver
            .handle_io(DriverIoEvent::Connected(w), Duration::ZERO, &mut r.sink);
        r
    }

    /// Runs every loop tick strictly before `ms`: an event at a tick's instant comes first.
    fn run_until(&mut self, ms: u64) {
        while self.ticks_done * 100 < ms {
            self.ticks_done += 1;
            let now = Duration::from_millis((self.ticks_done - 1) * 100);
            if now.is_zero() {
                continue;
            }
            self.driver.do_loop(now, &mut self.sink);
        }
    }

    fn written(&mut self) -> Vec<String> {
        let mut out = Vec::new();
        while let Ok(b) = self.rx.try_recv() {
            let s = String::from_utf8(b).expect("ASCII");
            let line = s.strip_suffix("\r\n").expect("CRLF-terminated");
            out.push(line.to_string());
        }
        out
    }
}

#[test]
fn golden_session_replays_byte_for_byte() {
    let text = include_str!("../fixtures/golden_session.txt");
    let mut r = Replay::new();
    assert_eq!(r.driver.frontseat_state(), FrontSeatState::FrontseatIdle);
    let mut expected: Vec<String> = Vec::new();
    let mut written: Vec<String> = Vec::new();
    let mut fed = 0;
    for (n, line) in text.lines().enumerate() {
        let n = n + 1;
        if let Some(rest) = line.strip_prefix("> ") {
            expected.push(mask_sts(sentence(rest)));
            // Causality: what the transcript shows written so far has been written by now.
            written.extend(r.written().iter().map(|l| mask_sts(l)));
            assert!(
                written.len() >= expected.len(),
                "line {n}: `{}` not yet written (written so far: {written:#?})",
                expected[expected.len() - 1]
            );
        } else if let Some(rest) = line.strip_prefix("< ") {
            let s = sentence(rest);
            let t = s.split(',').nth(1).expect("timestamp field");
            r.run_until(ms_after_noon(t));
            let now = Duration::from_millis(ms_after_noon(t));
            r.driver
                .handle_io(DriverIoEvent::Line(s.to_string()), now, &mut r.sink);
            fed += 1;
            // The states the transcript's comments name.
            if s.starts_with("$BFMIS") {
                assert_eq!(
                    r.driver.frontseat_state(),
                    FrontSeatState::FrontseatInControl
                );
            }
            if s.starts_with("$BFMSC") {
                assert_eq!(
                    r.driver.frontseat_state(),
                    FrontSeatState::FrontseatAcceptingCommands
                );
            }
            if s.starts_with("$BFNVG") {
                assert!(r.driver.frontseat_providing_data());
            }
        } else if let Some(rest) = line.strip_prefix("@ ") {
            let mut words = rest.split_whitespace();
            let t = words.next().expect("time");
            assert_eq!(words.next(), Some("command"), "line {n}");
            let mut course = DesiredCourse::default();
            let mut req = CommandRequest::default();
            for w in words {
                match w.split_once('=') {
                    Some(("heading", v)) => course.heading = v.parse().ok(),
                    Some(("speed", v)) => course.speed = v.parse().ok(),
                    Some(("depth", v)) => course.depth = v.parse().ok(),
                    Some(("request_id", v)) => req.request_id = v.parse().ok(),
                    None if w == "response_requested" => req.response_requested = Some(true),
                    other => panic!("line {n}: unknown directive word {other:?}"),
                }
            }
            req.desired_course = Some(course);
            let ms = ms_after_noon(t);
            r.run_until(ms);
            r.driver
                .send_command_to_frontseat(&req, Duration::from_millis(ms), &mut r.sink);
        }
    }
    r.run_until(4_400);
    written.extend(r.written().iter().map(|l| mask_sts(l)));
    assert_eq!(written, expected, "the driver's bytes are the transcript's");
    assert_eq!(fed, 24);
    assert_eq!(
        r.sink.raw_in.len(),
        fed,
        "every line from the Huxley on raw_in once"
    );
    assert_eq!(
        r.sink.raw_out.len(),
        expected.len(),
        "every line written on raw_out once"
    );
    assert_eq!(r.driver.queue_lengths(), (0, 0), "everything acknowledged");
    assert_eq!(r.driver.stats.unmatched_acks, 0);
    assert_eq!(r.driver.stats.bad_lines, 0);

    // NVR published the NodeStatus the transcript describes.
    assert_eq!(r.sink.data.len(), 1);
    let ns = r.sink.data[0].node_status.as_ref().expect("node_status");
    assert!((ns.time - (DAY + NOON + 1.95)).abs() < 1e-6, "{}", ns.time);
    assert!((ns.global_fix.lat - 42.3584).abs() < 1e-9);
    assert!((ns.global_fix.lon + 71.0876).abs() < 1e-9);
    assert_eq!(ns.global_fix.depth, Some(0.0));
    assert_eq!(ns.global_fix.altitude, Some(25.3));
    let p = &ns.pose;
    assert_eq!(
        (p.heading, p.roll, p.pitch),
        (Some(90.0), Some(0.5), Some(-1.2))
    );
    assert_eq!(
        (p.pitch_rate, p.roll_rate, p.heading_rate),
        (Some(0.1), Some(0.0), Some(0.2))
    );
    assert_eq!(ns.speed.over_ground, 1.5);
    assert_eq!(ns.source.as_ref().map(|s| s.position()), Some(Sensor::Gps));

    // Pending, then success: exactly one answer, after the final ack.
    assert_eq!(
        r.sink.responses,
        vec![CommandResponse {
            request_successful: Some(true),
            request_id: Some(1),
            error_code: None,
            error_string: None,
        }]
    );
}

#[test]
fn golden_failure_variant_answers_with_the_huxley_text() {
    let mut r = Replay::new();
    // Acknowledge the whole startup, then fly the failure variant of the fact sheet.
    let mut ms = 0;
    loop {
        let lines = r.written();
        if lines.is_empty() {
            break;
        }
        for l in lines {
            ms += 10;
            let s = codec::Sentence::parse(&l).unwrap();
            let ack = format!(
                "$BFACK,{},{},{},,2,0,",
                codec::format_time(NOON + ms as f64 / 1000.0),
                s.id,
                s.field(1).unwrap_or_default()
            );
            let ack = codec::Sentence::parse(&ack).unwrap().format();
            r.driver.handle_io(
                DriverIoEvent::Line(ack),
                Duration::from_millis(ms),
                &mut r.sink,
            );
        }
    }
    assert_eq!(r.driver.queue_lengths(), (0, 0));
    let req = CommandRequest {
        desired_course: Some(DesiredCourse {
            heading: Some(180.0),
            speed: Some(1.5),
            depth: Some(500.0),
            ..Default::default()
        }),
        response_requested: Some(true),
        request_id: Some(9),
        ..Default::default()
    };
    r.driver
        .send_command_to_frontseat(&req, Duration::from_millis(ms), &mut r.sink);
    assert_eq!(r.written().len(), 1);
    r.driver.handle_io(
        DriverIoEvent::Line("$BFACK,120029.000,RMB,120028.000,,1,0,depth too deep*31".into()),
        Duration::from_millis(ms + 50),
        &mut r.sink,
    );
    assert_eq!(
        r.sink.responses,
        vec![CommandResponse {
            request_successful: Some(false),
            request_id: Some(9),
            error_code: Some(1),
            error_string: Some("depth too deep".into()),
        }]
    );
}
