//! One test per fact of the DUNE facts file (see README.md's table), on the real driver and the
//! emulator joined byte for byte without sockets (the emulator's 10 Hz steps are the clock), and
//! on imcpy's packets (`fixtures/imcpy_packets.hex`) for what the vehicle says.

use std::time::Duration;

use frontseat_actors::driver::{Driver, DriverIoEvent, RecordingSink};
use frontseat_actors::link::LineWriter;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CommandRequest, DesiredCourse, FrontSeatState, InterfaceState, InterfaceStatus,
};
use frontseat_config::InterfaceConfig;
use frontseat_dune::emulator::{DuneOptions, DuneSession};
use frontseat_dune::imc::{self, ByteOrder, Header, Message, consts};
use frontseat_dune::{DuneDriver, Settings};
use frontseat_sim::emulator::Session;
use tokio::sync::mpsc::Receiver;

const FIXTURE: &str = include_str!("../fixtures/imcpy_packets.hex");
const US: u16 = 0x4F0A;
const VEHICLE: u16 = 0x00D1;

fn fixture(name: &str) -> Vec<u8> {
    let hex = FIXTURE
        .lines()
        .find_map(|l| l.strip_prefix(name).and_then(|r| r.strip_prefix(' ')))
        .unwrap_or_else(|| panic!("no fixture {name}"));
    (0..hex.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&hex[i..i + 2], 16).unwrap())
        .collect()
}

struct Rig {
    d: DuneDriver,
    rx: Receiver<Vec<u8>>,
    sink: RecordingSink,
    emu: DuneSession,
    t: f64,
    /// Every packet the driver wrote, decoded.
    sent: Vec<(Header, Message)>,
    course: Option<(f64, f64, f64)>,
}

impl Rig {
    fn new(f: impl FnOnce(&mut InterfaceConfig)) -> Self {
        let mut cfg = InterfaceConfig::default();
        cfg.driver.name = "dune".into();
        cfg.driver.dune.own_imc_id = US;
        f(&mut cfg);
        let mut d = DuneDriver::new(Settings::from_config(&cfg));
        let mut sink = RecordingSink::default();
        let (w, rx) = LineWriter::for_test();
        d.handle_io(DriverIoEvent::Connected(w), Duration::ZERO, &mut sink);
        Self {
            d,
            rx,
            sink,
            emu: DuneSession::new(DuneOptions::default()),
            t: 0.0,
            sent: Vec::new(),
            course: None,
        }
    }

    fn now(&self) -> Duration {
        Duration::from_secs_f64(self.t)
    }

    fn feed_driver(&mut self, bytes: &[u8]) {
        let mut frames = Vec::new();
        imc::Deframer::new().feed(bytes, &mut |r| frames.push(r));
        let now = self.now();
        for f in frames {
            let ev = match f {
                Ok(f) => DriverIoEvent::Frame(f),
                Err(e) => DriverIoEvent::BadInput(e.to_string()),
            };
            self.d.handle_io(ev, now, &mut self.sink);
        }
    }

    fn interface(&mut self, s: InterfaceState) {
        self.d.interface_status(&InterfaceStatus {
            state: Some(s as i32),
            ..Default::default()
        });
    }

    fn command(&mut self, heading: f64, speed: f64, depth: f64) {
        let now = self.now();
        self.d.send_command_to_frontseat(
            &CommandRequest {
                desired_course: Some(DesiredCourse {
                    heading: Some(heading),
                    speed: Some(speed),
                    depth: Some(depth),
                    ..Default::default()
                }),
                ..Default::default()
            },
            now,
            &mut self.sink,
        );
    }

    /// One 0.1 s step of both sides; the helm renews its course each step while it has one.
    fn step(&mut self) {
        let mut out = Vec::new();
        self.emu.step(0.1, &mut out);
        self.t += 0.1;
        self.feed_driver(&out);
        if let Some((h, s, z)) = self.course {
            self.command(h, s, z);
        }
        let now = self.now();
        self.d.do_loop(now, &mut self.sink);
        while let Ok(b) = self.rx.try_recv() {
            if let Ok(x) = imc::decode(&b) {
                self.sent.push(x);
            }
            let mut back = Vec::new();
            self.emu.on_bytes(&b, &mut back);
            self.feed_driver(&back);
        }
    }

    fn run(&mut self, secs: f64) {
        for _ in 0..(secs * 10.0).round() as usize {
            self.step();
        }
    }

    fn run_until(&mut self, max_s: f64, mut done: impl FnMut(&Self) -> bool) -> f64 {
        let t0 = self.t;
        while self.t - t0 < max_s {
            self.step();
            if done(self) {
                return self.t - t0;
            }
        }
        panic!("not done within {max_s} s (t = {})", self.t);
    }

    fn sent_of(&self, pred: impl Fn(&Message) -> bool) -> Vec<(Header, Message)> {
        self.sent.iter().filter(|(_, m)| pred(m)).cloned().collect()
    }
}

fn heading_error(a: f64, b: f64) -> f64 {
    frontseat_sim::vehicle::short_turn(a, b).abs()
}

/// Fact 3/4: DUNE streams VehicleState and EstimatedState unasked on the BackSeat server; the
/// vehicle id is learned from the first VehicleState (imc4j), SERVICE accepts a backseat.
#[test]
fn backseat_server_streams_state_and_the_vehicle_id_is_learned() {
    let mut r = Rig::new(|_| {});
    assert_eq!(r.d.frontseat_state(), FrontSeatState::FrontseatNotConnected);
    r.run(2.0);
    assert_eq!(r.d.vehicle_id(), Some(VEHICLE));
    assert_eq!(
        r.d.frontseat_state(),
        FrontSeatState::FrontseatAcceptingCommands
    );
    assert!(r.d.frontseat_providing_data());
    // 20 Hz EstimatedState: ~40 in 2 s, each a NodeStatus.
    let n = r.sink.data.len();
    assert!((35..=42).contains(&n), "{n} NodeStatus in 2 s");
    assert!(
        r.sent.is_empty(),
        "nothing is sent before COMMAND (no announce needed)"
    );
}

/// EstimatedState → NodeStatus: lat/lon displaced by x (north) and y (east), depth, altitude,
/// heading, pitch, roll, speed over ground (imcpy's packet).
#[test]
fn estimated_state_is_the_reference_displaced_by_x_and_y() {
    let mut r = Rig::new(|c| c.driver.dune.vehicle_imc_id = VEHICLE);
    r.feed_driver(&fixture("estimated_state"));
    let ns = r.sink.data.last().unwrap().node_status.clone().unwrap();
    // 100 m north, 50 m west of 41.185 N, 8.7062 W.
    assert!((ns.global_fix.lat - (41.185 + 100.0 / 111_052.0)).abs() < 2e-6);
    let m_per_deg_lon = 111_320.0 * 41.185f64.to_radians().cos();
    assert!((ns.global_fix.lon - (-8.7062 - 50.0 / m_per_deg_lon)).abs() < 5e-6);
    assert_eq!(ns.global_fix.depth, Some(2.0));
    assert_eq!(ns.global_fix.altitude, Some(18.5));
    assert!((ns.pose.heading.unwrap() - 90.0).abs() < 1e-4);
    assert!((ns.pose.roll.unwrap() - 0.01f64.to_degrees()).abs() < 1e-4);
    assert!((ns.pose.pitch.unwrap() + 0.02f64.to_degrees()).abs() < 1e-4);
    assert!((ns.speed.over_ground - 1.5).abs() < 1e-6);
}

/// VehicleState op_mode → Goby3's frontseat states, with reasons (imcpy's packets).
#[test]
fn vehicle_state_modes_map_to_frontseat_states_with_reasons() {
    let rows = [
        (
            "vs_service",
            FrontSeatState::FrontseatAcceptingCommands,
            "SERVICE",
        ),
        ("vs_boot", FrontSeatState::FrontseatIdle, "BOOT"),
        (
            "vs_calibration",
            FrontSeatState::FrontseatInControl,
            "CALIBRATION",
        ),
        ("vs_error", FrontSeatState::FrontseatIdle, "GPS: no fix"),
        (
            "vs_maneuver_goto",
            FrontSeatState::FrontseatInControl,
            "own",
        ),
        (
            "vs_external",
            FrontSeatState::FrontseatInControl,
            "EXTERNAL",
        ),
        // A FollowReference that is not ours (no START of ours, no plan id of ours).
        (
            "vs_maneuver_followref",
            FrontSeatState::FrontseatInControl,
            "own",
        ),
    ];
    for (name, want, why) in rows {
        let mut r = Rig::new(|c| c.driver.dune.vehicle_imc_id = VEHICLE);
        r.feed_driver(&fixture(name));
        assert_eq!(r.d.frontseat_state(), want, "{name}");
        assert!(
            r.d.state_reason().contains(why),
            "{name}: {}",
            r.d.state_reason()
        );
    }
    // Our plan id in PlanControlState makes a FollowReference ours.
    let mut r = Rig::new(|c| c.driver.dune.vehicle_imc_id = VEHICLE);
    r.feed_driver(&fixture("pcs_executing"));
    r.feed_driver(&fixture("vs_maneuver_followref"));
    assert_eq!(
        r.d.frontseat_state(),
        FrontSeatState::FrontseatAcceptingCommands
    );
    // Silence: NOT_CONNECTED after vehicle_state_timeout.
    r.t = 10.0;
    let now = r.now();
    r.d.do_loop(now, &mut r.sink);
    assert_eq!(r.d.frontseat_state(), FrontSeatState::FrontseatNotConnected);
}

/// The backseat path: entering COMMAND starts PlanControl START + FollowReference (control_src
/// = us, the timeout), dst = the vehicle id exactly, then a Reference per second toward a point
/// ahead; the vehicle reaches the heading and the depth. Measured and printed.
#[test]
fn follow_reference_steers_heading_speed_and_depth() {
    let mut r = Rig::new(|_| {});
    r.run(2.0);
    r.interface(InterfaceState::InterfaceCommand);
    r.course = Some((90.0, 1.5, 2.0));
    let (mut t_heading, mut t_depth) = (None, None);
    r.run_until(120.0, |r| {
        let v = r.emu.vehicle();
        if t_heading.is_none() && heading_error(v.heading, 90.0) < 0.1 && v.speed > 1.4 {
            t_heading = Some(r.t - 2.0);
        }
        if t_depth.is_none() && (v.depth - 2.0).abs() < 0.3 {
            t_depth = Some(r.t - 2.0);
        }
        t_heading.is_some() && t_depth.is_some()
    });
    println!(
        "DUNE emulator from COMMAND: heading 90 ± 0.1 and 1.5 m/s after {:.1} s, depth 2 ± 0.3 after {:.1} s",
        t_heading.unwrap_or_default(),
        t_depth.unwrap_or_default()
    );
    let starts =
        r.sent_of(|m| matches!(m, Message::PlanControl(p) if p.op == consts::plan_control::START));
    assert_eq!(starts.len(), 1);
    let Message::PlanControl(p) = &starts[0].1 else {
        unreachable!()
    };
    let Some(Message::FollowReference(f)) = p.arg.as_deref() else {
        panic!()
    };
    assert_eq!((f.control_src, f.timeout), (US, 10.0));
    assert!(r.sent.iter().all(|(h, _)| h.dst == VEHICLE && h.src == US));
    let refs = r.sent_of(|m| matches!(m, Message::Reference(_)));
    let secs = r.t - 2.0;
    assert!(
        refs.len() as f64 >= secs * 0.9 && refs.len() as f64 <= secs * 1.2 + 2.0,
        "{} References in {secs} s",
        refs.len()
    );
    let Message::Reference(last) = &refs.last().unwrap().1 else {
        unreachable!()
    };
    assert_eq!(last.flags, 0x27);
    assert!(r.d.plan_running());
    assert_eq!(
        r.d.frontseat_state(),
        FrontSeatState::FrontseatAcceptingCommands
    );
    // Turn to 200°.
    r.course = Some((200.0, 1.5, 2.0));
    let t_turn = r.run_until(120.0, |r| {
        heading_error(r.emu.vehicle().heading, 200.0) < 0.1
    });
    println!("DUNE emulator: 90 → 200 ± 0.1 after {t_turn:.1} s");
}

/// References stop → after the maneuver's timeout the vehicle fails it, SERVICE, loops 0; the
/// driver sees its plan ended and stays ready to start again.
#[test]
fn references_stop_and_the_maneuver_timeout_is_the_watchdog() {
    let mut r = Rig::new(|c| c.driver.dune.maneuver_timeout = 5.0);
    r.run(2.0);
    r.interface(InterfaceState::InterfaceCommand);
    r.course = Some((90.0, 1.5, 2.0));
    r.run(10.0);
    assert!(r.emu.maneuver_running());
    r.course = None; // the helm falls silent; its course goes stale after course_timeout (3 s)
    let t = r.run_until(30.0, |r| !r.emu.maneuver_running());
    assert!((7.0..=9.5).contains(&t), "timed out after {t} s");
    assert_eq!(r.emu.stats.timeouts, 1);
    r.run(1.0);
    assert!(!r.d.plan_running());
    assert_eq!(
        r.d.frontseat_state(),
        FrontSeatState::FrontseatAcceptingCommands
    );
    // Thrust off: it slows down.
    r.run(10.0);
    assert!(r.emu.vehicle().speed < 0.1);
}

/// Leaving COMMAND ends the plan with a MANDONE Reference and PlanControl STOP.
#[test]
fn leaving_command_ends_the_plan_with_mandone_and_stop() {
    let mut r = Rig::new(|_| {});
    r.run(2.0);
    r.interface(InterfaceState::InterfaceCommand);
    r.course = Some((45.0, 1.0, 1.0));
    r.run(5.0);
    r.course = None;
    r.interface(InterfaceState::InterfaceListen);
    r.run(1.0);
    assert!(!r.emu.maneuver_running());
    assert_eq!(r.emu.stats.mandone, 1);
    let tail: Vec<_> = r
        .sent
        .iter()
        .rev()
        .take(2)
        .map(|(_, m)| m.clone())
        .collect();
    assert!(matches!(&tail[1], Message::Reference(x) if x.flags == consts::reference::MANDONE));
    assert!(matches!(&tail[0], Message::PlanControl(p) if p.op == consts::plan_control::STOP));
    assert!(!r.d.plan_running());
}

/// DUNE loops our own PlanControl back (`Loopback Internal Messages`): never taken as a reply.
#[test]
fn our_own_looped_back_requests_are_ignored() {
    let mut r = Rig::new(|_| {});
    r.run(2.0);
    r.interface(InterfaceState::InterfaceCommand);
    r.course = Some((0.0, 1.0, 0.0));
    r.run(3.0);
    assert!(r.d.counters.own_echoes >= 1);
    assert!(r.d.plan_running());
}

/// dst must be the vehicle's id: a START to 0xFFFF and an Abort to 0xFFF0 are silently dropped;
/// an Abort to the id stops the maneuver (ERROR then SERVICE).
#[test]
fn dst_must_be_the_vehicle_id_exactly() {
    let mut emu = DuneSession::new(DuneOptions::default());
    let mut out = Vec::new();
    emu.step(2.0, &mut out);
    let start = |dst| {
        imc::encode(
            &Header::new(US, dst, 0.0),
            &imc::PlanControl {
                kind: 0,
                op: 0,
                request_id: 1,
                plan_id: "p".into(),
                flags: 0,
                arg: Some(Box::new(
                    imc::FollowReference {
                        control_src: US,
                        control_ent: 0xFF,
                        timeout: 10.0,
                        ..Default::default()
                    }
                    .into(),
                )),
                info: String::new(),
            }
            .into(),
            ByteOrder::Little,
        )
        .unwrap()
    };
    emu.on_bytes(&start(0xFFFF), &mut out);
    assert!(!emu.maneuver_running());
    assert_eq!(emu.stats.not_for_us, 1);
    emu.on_bytes(&start(VEHICLE), &mut out);
    assert!(emu.maneuver_running());
    let abort = |dst| {
        imc::encode(
            &Header::new(US, dst, 0.0),
            &imc::Abort {}.into(),
            ByteOrder::Little,
        )
        .unwrap()
    };
    emu.on_bytes(&abort(0xFFF0), &mut out);
    assert!(emu.maneuver_running());
    out.clear();
    emu.on_bytes(&abort(VEHICLE), &mut out);
    assert!(!emu.maneuver_running());
    let mut modes = Vec::new();
    imc::Deframer::new().feed(&out, &mut |r| {
        if let Ok((_, Message::VehicleState(v))) = imc::decode(&r.unwrap()) {
            modes.push(v.op_mode);
        }
    });
    assert_eq!(
        modes,
        vec![consts::op_mode::ERROR, consts::op_mode::SERVICE]
    );
}

/// A PlanSpecification holding the FollowReference starts it too (imcpy's packet).
#[test]
fn a_plan_specification_with_follow_reference_starts_it() {
    let mut emu = DuneSession::new(DuneOptions::default());
    let mut out = Vec::new();
    emu.step(2.0, &mut out);
    emu.on_bytes(&fixture("pc_start_spec"), &mut out);
    assert!(emu.maneuver_running());
    emu.on_bytes(&fixture("reference_mandone"), &mut out);
    assert!(!emu.maneuver_running());
}

/// Bad input and a foreign id claiming to be the vehicle: counted, never a panic, never a
/// NodeStatus or a state from it, never steers.
#[test]
fn bad_input_and_foreign_ids_are_counted_and_steer_nothing() {
    let mut r = Rig::new(|c| c.driver.dune.vehicle_imc_id = VEHICLE);
    r.feed_driver(&fixture("vs_service"));
    let before = r.sink.data.len();
    for name in [
        "estimated_state_nan",
        "estimated_state_absurd_depth",
        "estimated_state_foreign",
    ] {
        r.feed_driver(&fixture(name));
    }
    assert_eq!(r.sink.data.len(), before, "nothing published");
    assert_eq!(r.d.counters.foreign, 1);
    assert_eq!(r.d.counters.nav_refused, 2);
    // A foreign VehicleState claiming ERROR changes nothing.
    let mut foreign = imc::decode(&fixture("vs_error")).unwrap();
    foreign.0.src = 0x0777;
    r.feed_driver(&imc::encode(&foreign.0, &foreign.1, ByteOrder::Little).unwrap());
    assert_eq!(
        r.d.frontseat_state(),
        FrontSeatState::FrontseatAcceptingCommands
    );
    // Broken packets: bad CRC, truncated, noise, an unknown id, a flood.
    let mut bad = fixture("estimated_state");
    let n = bad.len();
    bad[n - 1] ^= 0xFF;
    r.feed_driver(&bad);
    r.feed_driver(&fixture("estimated_state")[..50]);
    r.feed_driver(b"\x00\x01garbage\x54");
    let unknown = {
        let mut p = fixture("heartbeat");
        p[2] = 0x39; // message id 0x0039: not one we know
        p[3] = 0x30;
        let crc = imc::crc16(&p[..p.len() - 2]).to_le_bytes();
        let l = p.len();
        p[l - 2..].copy_from_slice(&crc);
        p
    };
    r.feed_driver(&unknown);
    assert!(r.d.counters.bad_input >= 4, "{:?}", r.d.counters);
    assert_eq!(r.d.counters.unknown_messages, 1);
    let flood: Vec<u8> = (0..200_000u32).map(|i| (i * 7919 % 251) as u8).collect();
    r.feed_driver(&flood);
    assert_eq!(r.sink.data.len(), before);
    assert!(r.rx.try_recv().is_err(), "nothing was sent to the vehicle");
}

/// A big-endian vehicle (sync FE 54) is read the same.
#[test]
fn a_big_endian_vehicle_is_read_the_same() {
    let mut r = Rig::new(|c| c.driver.dune.vehicle_imc_id = VEHICLE);
    let (h, m) = imc::decode(&fixture("estimated_state")).unwrap();
    r.feed_driver(&imc::encode(&h, &m, ByteOrder::Big).unwrap());
    r.feed_driver(&fixture("estimated_state"));
    let mut a = r.sink.data[0].node_status.clone().unwrap();
    let mut b = r.sink.data[1].node_status.clone().unwrap();
    // Stamped when published; everything read from the packet is the same.
    (a.time, b.time) = (0.0, 0.0);
    assert_eq!(a, b);
}

/// Direct control (ControlLoops + Desired*) is a config choice refused by validation.
#[test]
fn direct_control_is_refused_by_config_validation() {
    use frontseat_config::ServiceConfig;
    let mut cfg = InterfaceConfig::default();
    cfg.driver.name = "dune".into();
    assert!(cfg.validate().is_empty(), "{:?}", cfg.validate());
    cfg.driver.dune.control = frontseat_config::DuneControl::Direct;
    let errs = cfg.validate();
    assert!(
        errs.iter().any(|e| e.to_string().contains("control")),
        "{errs:?}"
    );
}

/// DUNE re-centres EstimatedState's reference beyond 1 km (x, y back to 0): the driver always
/// recomputes, so the published track stays continuous across it.
#[test]
fn the_reference_point_re_centres_and_the_track_stays_continuous() {
    let mut r = Rig::new(|_| {});
    r.run(2.0);
    r.interface(InterfaceState::InterfaceCommand);
    r.course = Some((45.0, 3.0, 0.0));
    r.run(500.0);
    let refs: std::collections::BTreeSet<(i64, i64)> = r
        .sink
        .raw_in
        .iter()
        .filter_map(|raw| match imc::decode(raw.raw()) {
            Ok((_, Message::EstimatedState(e))) => {
                Some(((e.lat * 1e9) as i64, (e.lon * 1e9) as i64))
            }
            _ => None,
        })
        .collect();
    assert!(refs.len() >= 2, "the reference never moved: {refs:?}");
    let fixes: Vec<(f64, f64)> = r
        .sink
        .data
        .iter()
        .filter_map(|d| d.node_status.as_ref())
        .map(|n| (n.global_fix.lat, n.global_fix.lon))
        .collect();
    let worst = fixes
        .windows(2)
        .map(|w| {
            let (n, e) = frontseat_dune::infer::offset(
                w[0].0.to_radians(),
                w[0].1.to_radians(),
                w[1].0.to_radians(),
                w[1].1.to_radians(),
            );
            n.hypot(e)
        })
        .fold(0.0, f64::max);
    // The model steps at 10 Hz: 3 m/s is 0.3 m per step; a re-centring error would be metres.
    assert!(worst < 0.35, "a jump of {worst} m between fixes");
}

/// A Reference's source is checked against the maneuver's control_src; speed 0 turns the loops
/// off while the maneuver goes on.
#[test]
fn references_from_another_source_are_refused_and_speed_zero_stops_the_loops() {
    let mut emu = DuneSession::new(DuneOptions::default());
    let mut out = Vec::new();
    emu.step(2.0, &mut out);
    emu.on_bytes(&fixture("pc_start_followref"), &mut out);
    assert!(emu.maneuver_running());
    let (mut h, m) = imc::decode(&fixture("reference_full")).unwrap();
    h.src = 0x0777;
    emu.on_bytes(&imc::encode(&h, &m, ByteOrder::Little).unwrap(), &mut out);
    assert_eq!(emu.stats.references_refused, 1);
    assert_eq!(emu.stats.references, 0);
    emu.on_bytes(&fixture("reference_full"), &mut out);
    assert_eq!(emu.stats.references, 1);
    let Message::Reference(mut r) = m else {
        unreachable!()
    };
    r.speed = Some(Box::new(
        imc::DesiredSpeed {
            value: 0.0,
            speed_units: consts::METERS_PS,
        }
        .into(),
    ));
    out.clear();
    let h = Header::new(US, VEHICLE, 0.0);
    emu.on_bytes(
        &imc::encode(&h, &r.into(), ByteOrder::Little).unwrap(),
        &mut out,
    );
    emu.step(0.5, &mut out);
    let mut loops = Vec::new();
    imc::Deframer::new().feed(&out, &mut |f| {
        if let Ok((_, Message::VehicleState(v))) = imc::decode(&f.unwrap()) {
            loops.push((v.op_mode, v.control_loops));
        }
    });
    assert_eq!(
        loops.last(),
        Some(&(consts::op_mode::MANEUVER, 0)),
        "{loops:?}"
    );
    assert!(emu.maneuver_running());
}

/// After a reconnection our plan may still run (PlanControlState names it): the driver takes it
/// back, and ends it (MANDONE, STOP) when the interface is not in COMMAND.
#[test]
fn a_plan_of_ours_still_running_after_a_reconnection_is_taken_back() {
    let mut r = Rig::new(|c| c.driver.dune.vehicle_imc_id = VEHICLE);
    r.feed_driver(&fixture("pcs_executing"));
    r.feed_driver(&fixture("vs_maneuver_followref"));
    assert!(r.d.plan_running());
    assert_eq!(
        r.d.frontseat_state(),
        FrontSeatState::FrontseatAcceptingCommands
    );
    let now = r.now();
    r.d.do_loop(now, &mut r.sink);
    let mut sent = Vec::new();
    while let Ok(b) = r.rx.try_recv() {
        sent.push(imc::decode(&b).unwrap());
    }
    assert_eq!(sent.len(), 2, "{sent:?}");
    assert!(matches!(&sent[0].1, Message::Reference(x) if x.flags == consts::reference::MANDONE));
    assert!(matches!(&sent[1].1, Message::PlanControl(p) if p.op == consts::plan_control::STOP));
    assert!(sent.iter().all(|(h, _)| h.dst == VEHICLE));
    assert!(!r.d.plan_running());
}
