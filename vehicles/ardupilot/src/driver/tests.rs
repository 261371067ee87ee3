//! The driver with `vehicle = "rover"` against the vehicle's side of the link as pymavlink
//! encodes it (`fixtures/pymavlink_vehicle_frames.hex`): one test per rule the driver keeps.

use super::*;
use crate::codec::MavMessage;
use crate::dialect::{MavCmd, MavSysStatusSensor};
use frontseat_actors::proto::frontseat::protobuf::ardupilot::ArdupilotCommand;
use frontseat_actors::proto::frontseat::protobuf::ardupilot::ardupilot_command::Action;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::DesiredCourse;
use frontseat_config::InterfaceConfig;
use tokio::sync::mpsc::Receiver;

use super::test_link::{Sink, connected, feed_frame, fixture_frame, written};

/// Vehicle-side frames encoded by pymavlink (see the file's header).
const FIXTURE: &str = include_str!("../../fixtures/pymavlink_vehicle_frames.hex");

fn frame(name: &str) -> Vec<u8> {
    fixture_frame(FIXTURE, name)
}

fn driver_with(f: impl FnOnce(&mut InterfaceConfig)) -> (ArdupilotDriver, Receiver<Vec<u8>>, Sink) {
    let mut cfg = InterfaceConfig::default();
    f(&mut cfg);
    connected(&cfg)
}

fn driver() -> (ArdupilotDriver, Receiver<Vec<u8>>, Sink) {
    driver_with(|_| {})
}

fn feed(d: &mut ArdupilotDriver, sink: &mut Sink, name: &str, t: f64) {
    feed_frame(d, sink, frame(name), t);
}

fn sent(rx: &mut Receiver<Vec<u8>>) -> Vec<MavMessage> {
    written(rx).into_iter().map(|(_, m)| m).collect()
}

fn ready(d: &mut ArdupilotDriver, sink: &mut Sink, t: f64) {
    for f in [
        "hb_guided_armed",
        "ekf_ready",
        "gps_3d",
        "attitude",
        "pos_boston",
    ] {
        feed(d, sink, f, t);
    }
}

fn course(h: f64, s: f64, id: i32) -> CommandRequest {
    CommandRequest {
        desired_course: Some(DesiredCourse {
            time: 0.0,
            heading: Some(h),
            speed: Some(s),
            ..Default::default()
        }),
        response_requested: Some(true),
        request_id: Some(id),
        ..Default::default()
    }
}

/// The state inference from pymavlink-encoded HEARTBEATs, one row per rule.
#[test]
fn state_inference_from_heartbeats() {
    let rows = [
        ("hb_manual_disarmed", FrontSeatState::FrontseatIdle),
        (
            "hb_guided_armed",
            FrontSeatState::FrontseatAcceptingCommands,
        ),
        ("hb_auto_armed", FrontSeatState::FrontseatInControl),
        ("hb_hold_armed", FrontSeatState::FrontseatIdle),
        // A failsafe to HOLD is the autopilot taking control: the interface leaves COMMAND.
        ("hb_hold_failsafe", FrontSeatState::FrontseatInControl),
    ];
    let (mut d, _rx, mut sink) = driver();
    assert_eq!(d.frontseat_state(), FrontSeatState::FrontseatNotConnected);
    for (i, (f, want)) in rows.into_iter().enumerate() {
        feed(&mut d, &mut sink, f, i as f64);
        assert_eq!(d.frontseat_state(), want, "{f}");
    }
    // No HEARTBEAT for the timeout: not connected.
    d.do_loop(Duration::from_secs(10), &mut sink);
    assert_eq!(d.frontseat_state(), FrontSeatState::FrontseatNotConnected);
}

#[test]
fn a_gcs_heartbeat_is_not_the_vehicle_and_streams_are_asked_once_found() {
    let (mut d, mut rx, mut sink) = driver();
    sent(&mut rx);
    feed(&mut d, &mut sink, "hb_gcs", 0.0);
    assert_eq!(d.frontseat_state(), FrontSeatState::FrontseatNotConnected);
    assert!(sent(&mut rx).is_empty());
    feed(&mut d, &mut sink, "hb_manual_disarmed", 0.0);
    let asks: Vec<_> = sent(&mut rx)
        .into_iter()
        .filter_map(|m| match m {
            MavMessage::COMMAND_LONG(c) if c.command == MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL => {
                Some((c.param1 as u32, c.param2, c.target_system))
            }
            _ => None,
        })
        .collect();
    assert!(asks.contains(&(33, 200_000.0, 1)), "{asks:?}");
    assert_eq!(asks.len(), 6);
}

#[test]
fn navigation_only_while_the_estimate_is_usable() {
    let (mut d, _rx, mut sink) = driver();
    // A position before any EKF report may be the backup estimate: not published.
    feed(&mut d, &mut sink, "hb_guided_armed", 0.0);
    feed(&mut d, &mut sink, "pos_boston", 0.0);
    assert!(sink.data.is_empty());
    assert!(d.nav_problem().unwrap().contains("EKF_STATUS_REPORT"));
    for f in ["hb_guided_armed", "ekf_backup", "gps_3d", "pos_boston"] {
        feed(&mut d, &mut sink, f, 0.0);
    }
    assert!(sink.data.is_empty());
    assert!(!d.frontseat_providing_data());
    assert!(
        d.nav_problem().unwrap().contains("EKF"),
        "{:?}",
        d.nav_problem()
    );
    ready(&mut d, &mut sink, 1.0);
    assert!(d.frontseat_providing_data());
    let ns = sink.data.last().unwrap().node_status.clone().unwrap();
    assert!((ns.global_fix.lat - 42.358456).abs() < 1e-7);
    assert_eq!(
        ns.global_fix.depth,
        Some(2.5),
        "relative_alt -2.5 m is 2.5 m deep"
    );
    assert_eq!(ns.pose.heading, Some(90.0));
    assert!((ns.pose.pitch.unwrap() + 5.7296).abs() < 1e-3);
    assert!((ns.speed.over_ground - 1.5).abs() < 1e-9);
    feed(&mut d, &mut sink, "gps_nofix", 2.0);
    feed(&mut d, &mut sink, "pos_boston", 2.0);
    assert!(!d.frontseat_providing_data());
    assert!(d.nav_problem().unwrap().contains("GPS"));
    // SYS_STATUS: the GPS sensor present and enabled but not healthy.
    feed(&mut d, &mut sink, "gps_3d", 3.0);
    let gps = MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_GPS;
    let sick = MavMessage::SYS_STATUS(crate::dialect::SYS_STATUS_DATA {
        onboard_control_sensors_present: gps,
        onboard_control_sensors_enabled: gps,
        onboard_control_sensors_health: MavSysStatusSensor::empty(),
        ..Default::default()
    });
    d.handle_io(
        DriverIoEvent::Frame(codec::encode(1, 1, 0, &sick)),
        Duration::from_secs(3),
        &mut sink,
    );
    let n = sink.data.len();
    feed(&mut d, &mut sink, "pos_boston", 3.0);
    assert_eq!(sink.data.len(), n);
    assert!(
        d.nav_problem().unwrap().contains("SYS_STATUS"),
        "{:?}",
        d.nav_problem()
    );
}

#[test]
fn bad_positions_wrong_systems_bad_crcs_and_floods_are_counted() {
    let (mut d, _rx, mut sink) = driver();
    ready(&mut d, &mut sink, 0.0);
    let published = d.counters.nav_published;
    feed(&mut d, &mut sink, "pos_zero", 0.1);
    feed(&mut d, &mut sink, "pos_out_of_range", 0.1);
    assert_eq!(d.counters.nav_refused, 2);
    assert_eq!(d.counters.nav_published, published);
    // The system id byte changed in place: the CRC no longer matches (bad input).
    let mut other = frame("pos_boston");
    other[5] = 42;
    let (_, msg) = codec::decode(&frame("pos_boston")).unwrap();
    let foreign = codec::encode(42, 1, 0, &msg);
    d.handle_io(DriverIoEvent::Frame(foreign), Duration::ZERO, &mut sink);
    assert_eq!(d.counters.foreign_system, 1);
    d.handle_io(DriverIoEvent::Frame(other), Duration::ZERO, &mut sink);
    let before = d.counters.bad_input;
    d.handle_io(
        DriverIoEvent::BadInput("MAVLink: bad CRC".into()),
        Duration::ZERO,
        &mut sink,
    );
    for _ in 0..10_000 {
        d.handle_io(
            DriverIoEvent::Frame(vec![0xFD, 1, 2]),
            Duration::ZERO,
            &mut sink,
        );
    }
    assert!(d.counters.bad_input >= before + 10_001);
    let nan = MavMessage::ATTITUDE(crate::dialect::ATTITUDE_DATA {
        roll: f32::NAN,
        ..Default::default()
    });
    d.handle_io(
        DriverIoEvent::Frame(codec::encode(1, 1, 0, &nan)),
        Duration::ZERO,
        &mut sink,
    );
    assert!(d.counters.bad_input >= before + 10_002);
    assert_eq!(
        d.frontseat_state(),
        FrontSeatState::FrontseatAcceptingCommands
    );
}

#[test]
fn course_is_resent_at_5_hz_and_stops_when_the_helm_stops() {
    let (mut d, mut rx, mut sink) = driver();
    ready(&mut d, &mut sink, 0.0);
    sent(&mut rx);
    d.send_command_to_frontseat(&course(90.0, 2.0, 1), Duration::ZERO, &mut sink);
    let first = sent(&mut rx);
    let Some(MavMessage::SET_POSITION_TARGET_GLOBAL_INT(t)) = first.first() else {
        panic!("{first:?}")
    };
    assert_eq!(t.type_mask.bits(), 0x09C7);
    assert_eq!((t.vx, t.target_system, t.target_component), (2.0, 1, 1));
    assert!((t.yaw - std::f32::consts::FRAC_PI_2).abs() < 1e-6);
    let mut targets = 0;
    for i in 1..=20 {
        let now = Duration::from_millis(100 * i);
        if i % 10 == 0 {
            feed(&mut d, &mut sink, "hb_guided_armed", now.as_secs_f64());
            // The helm repeats its course (unchanged: no extra frame).
            let mut c = course(90.0, 2.0, 0);
            c.response_requested = None;
            d.send_command_to_frontseat(&c, now, &mut sink);
        }
        d.do_loop(now, &mut sink);
        targets += sent(&mut rx)
            .iter()
            .filter(|m| matches!(m, MavMessage::SET_POSITION_TARGET_GLOBAL_INT(_)))
            .count();
    }
    assert_eq!(targets, 10, "5 Hz for 2 s");
    // No refusal and still GUIDED at the verdict: the course is answered as done.
    assert_eq!(sink.responses.len(), 1);
    assert_eq!(sink.responses[0].request_successful, Some(true));
    // The helm falls silent after t = 2 s: after course_timeout (2 s more) nothing is sent.
    let mut late = 0;
    for i in 21..=50 {
        let now = Duration::from_millis(100 * i);
        if i % 10 == 0 {
            feed(&mut d, &mut sink, "hb_guided_armed", now.as_secs_f64());
        }
        d.do_loop(now, &mut sink);
        let n = sent(&mut rx)
            .iter()
            .filter(|m| matches!(m, MavMessage::SET_POSITION_TARGET_GLOBAL_INT(_)))
            .count();
        if i > 40 {
            late += n;
        }
    }
    assert_eq!(late, 0);
}

#[test]
fn a_target_refused_by_mask_is_a_failed_response_with_the_statustext() {
    let (mut d, _rx, mut sink) = driver();
    ready(&mut d, &mut sink, 0.0);
    d.send_command_to_frontseat(&course(90.0, 2.0, 7), Duration::ZERO, &mut sink);
    feed(&mut d, &mut sink, "text_acc_ignore", 0.1);
    assert_eq!(sink.responses.len(), 1);
    let r = &sink.responses[0];
    assert_eq!((r.request_successful, r.request_id), (Some(false), Some(7)));
    assert!(r.error_string().contains("set ACC_IGNORE in mask"), "{r:?}");
}

#[test]
fn courses_outside_guided_and_failsafe_to_hold_fail() {
    let (mut d, _rx, mut sink) = driver();
    feed(&mut d, &mut sink, "hb_hold_armed", 0.0);
    d.send_command_to_frontseat(&course(0.0, 1.0, 1), Duration::ZERO, &mut sink);
    assert!(
        sink.responses[0].error_string().contains("HOLD"),
        "{:?}",
        sink.responses
    );
    ready(&mut d, &mut sink, 0.0);
    d.send_command_to_frontseat(&course(0.0, 1.0, 2), Duration::ZERO, &mut sink);
    feed(&mut d, &mut sink, "hb_hold_failsafe", 0.2);
    assert_eq!(d.frontseat_state(), FrontSeatState::FrontseatInControl);
    let r = sink.responses.last().unwrap();
    assert_eq!((r.request_successful, r.request_id), (Some(false), Some(2)));
    assert!(r.error_string().contains("failsafe"), "{r:?}");
}

fn mode_request(action: Action, id: i32) -> ArdupilotCommandRequest {
    ArdupilotCommandRequest {
        response_requested: Some(true),
        request_id: Some(id),
        ardupilot_command: Some(ArdupilotCommand {
            action: Some(action as i32),
        }),
        ..Default::default()
    }
}

#[test]
fn mode_commands_are_off_by_default_and_never_sent() {
    let (mut d, mut rx, mut sink) = driver();
    ready(&mut d, &mut sink, 0.0);
    sent(&mut rx);
    d.send_ardupilot_command(&mode_request(Action::Arm, 3), Duration::ZERO, &mut sink);
    assert!(sent(&mut rx).is_empty());
    assert_eq!(sink.responses[0].request_successful, Some(false));
    assert!(
        sink.responses[0]
            .error_string()
            .contains("allow_mode_commands")
    );
}

#[test]
fn mode_commands_answered_from_command_ack_with_the_prearm_reason() {
    let (mut d, mut rx, mut sink) = driver_with(|c| c.driver.ardupilot.allow_mode_commands = true);
    feed(&mut d, &mut sink, "hb_manual_disarmed", 0.0);
    // GUIDED before the estimate is ready is refused here (README: it ends in an EKF failsafe).
    feed(&mut d, &mut sink, "ekf_backup", 0.0);
    d.send_ardupilot_command(&mode_request(Action::Guided, 1), Duration::ZERO, &mut sink);
    assert!(
        sink.responses[0]
            .error_string()
            .contains("not ready for GUIDED")
    );
    sent(&mut rx);
    d.send_ardupilot_command(&mode_request(Action::Arm, 2), Duration::ZERO, &mut sink);
    let c = sent(&mut rx);
    assert!(matches!(&c[..], [MavMessage::COMMAND_LONG(c)]
        if c.command == MavCmd::MAV_CMD_COMPONENT_ARM_DISARM && c.param1 == 1.0));
    feed(&mut d, &mut sink, "text_prearm", 0.1);
    feed(&mut d, &mut sink, "ack_arm_failed", 0.1);
    let r = sink.responses.last().unwrap();
    assert_eq!((r.request_successful, r.request_id), (Some(false), Some(2)));
    assert!(
        r.error_string().contains("PreArm: Hardware safety switch"),
        "{r:?}"
    );
    ready(&mut d, &mut sink, 1.0);
    d.send_ardupilot_command(
        &mode_request(Action::Guided, 3),
        Duration::from_secs(1),
        &mut sink,
    );
    let c = sent(&mut rx);
    assert!(c.iter().any(|m| matches!(m, MavMessage::COMMAND_LONG(c)
        if c.command == MavCmd::MAV_CMD_DO_SET_MODE && c.param1 == 1.0 && c.param2 == 15.0)));
    feed(&mut d, &mut sink, "ack_mode_accepted", 1.1);
    let r = sink.responses.last().unwrap();
    assert_eq!((r.request_successful, r.request_id), (Some(true), Some(3)));
    // An unanswered one times out.
    d.send_ardupilot_command(
        &mode_request(Action::Hold, 4),
        Duration::from_secs(2),
        &mut sink,
    );
    d.do_loop(Duration::from_secs(6), &mut sink);
    let r = sink.responses.last().unwrap();
    assert_eq!((r.request_successful, r.request_id), (Some(false), Some(4)));
    assert_eq!(d.counters.ack_timeouts, 1);
}

#[test]
fn raw_send_takes_only_whole_checked_frames() {
    let (mut d, mut rx, mut sink) = driver();
    sent(&mut rx);
    let good = Raw {
        raw: Some(frame("hb_gcs")),
        ..Default::default()
    };
    d.send_raw_to_frontseat(&good, Duration::ZERO, &mut sink);
    assert_eq!(sent(&mut rx).len(), 1);
    let mut broken = frame("hb_gcs");
    broken.pop();
    d.send_raw_to_frontseat(
        &Raw {
            raw: Some(broken),
            ..Default::default()
        },
        Duration::ZERO,
        &mut sink,
    );
    assert!(sent(&mut rx).is_empty());
    assert_eq!(d.counters.bad_input, 1);
}

#[test]
fn every_pymavlink_fixture_decodes() {
    for line in FIXTURE.lines().filter(|l| !l.starts_with('#')) {
        let name = line.split(' ').next().unwrap();
        assert!(codec::decode(&frame(name)).is_ok(), "{name}");
    }
}

/// A course as the setpoint lane hands it: bare, no answer asked.
fn lane_course(h: f64, s: f64) -> CommandRequest {
    CommandRequest {
        desired_course: Some(DesiredCourse {
            time: 0.0,
            heading: Some(h),
            speed: Some(s),
            ..Default::default()
        }),
        ..Default::default()
    }
}

/// Every frame the driver (or the lane) handed to the link, with its MAVLink sequence number.
fn sequenced(rx: &mut Receiver<Vec<u8>>) -> Vec<(u8, MavMessage)> {
    let mut v = Vec::new();
    while let Ok(b) = rx.try_recv() {
        let (h, m) = crate::codec::decode(&b).unwrap();
        v.push((h.sequence, m));
    }
    v
}

/// ARCHITECTURE.md "The lane per vehicle family": the lane writes a new course's GUIDED target
/// only armed in GUIDED, never an unchanged one, in the driver's own sequence; the driver takes
/// its course in and re-sends it at 5 Hz until the helm stops; a mode change the driver has
/// handled closes the way at once.
#[test]
fn the_lane_writes_a_new_course_armed_in_guided_and_the_driver_goes_on_from_it() {
    let (mut d, mut rx, mut sink) = driver();
    let lane = d.direct_command().expect("a TCP link offers the lane");
    assert!(
        lane.send_now(&lane_course(90.0, 2.0)).is_none(),
        "no HEARTBEAT yet"
    );
    feed(&mut d, &mut sink, "hb_hold_armed", 0.0);
    assert!(lane.send_now(&lane_course(90.0, 2.0)).is_none(), "HOLD");
    feed(&mut d, &mut sink, "hb_manual_disarmed", 0.0);
    assert!(lane.send_now(&lane_course(90.0, 2.0)).is_none(), "disarmed");
    ready(&mut d, &mut sink, 0.0);
    let before = sequenced(&mut rx);
    let last_seq = before.last().map(|(s, _)| *s).unwrap();

    let raw = lane
        .send_now(&lane_course(90.0, 2.0))
        .expect("armed in GUIDED");
    let v = sequenced(&mut rx);
    let [(seq, MavMessage::SET_POSITION_TARGET_GLOBAL_INT(t))] = &v[..] else {
        panic!("{v:?}")
    };
    assert_eq!(*seq, last_seq.wrapping_add(1), "the driver's own sequence");
    assert_eq!(t.type_mask.bits(), 0x09C7);
    assert_eq!((t.vx, t.target_system, t.target_component), (2.0, 1, 1));
    assert!((t.yaw - std::f32::consts::FRAC_PI_2).abs() < 1e-6);
    let (_, m) = crate::codec::decode(raw.raw.as_deref().unwrap()).unwrap();
    assert!(matches!(m, MavMessage::SET_POSITION_TARGET_GLOBAL_INT(_)));
    // The same course again: not written (the driver's path renews it).
    assert!(lane.send_now(&lane_course(90.0, 2.0)).is_none());
    assert!(sequenced(&mut rx).is_empty());
    // The driver's next message takes the course in: the helm's renewal through the actors is
    // unchanged (no frame), and the re-sends go on at 5 Hz with the lane's heading and the
    // sequence unbroken.
    let mut c = lane_course(90.0, 2.0);
    c.response_requested = None;
    d.send_command_to_frontseat(&c, Duration::from_millis(50), &mut sink);
    assert!(
        sequenced(&mut rx).is_empty(),
        "an unchanged course is not written"
    );
    assert_eq!(d.counters.targets_sent, 1);
    let mut seqs = vec![*seq];
    for i in 1..=10 {
        let now = Duration::from_millis(50 + 100 * i);
        d.do_loop(now, &mut sink);
        for (s, m) in sequenced(&mut rx) {
            seqs.push(s);
            if let MavMessage::SET_POSITION_TARGET_GLOBAL_INT(t) = m {
                assert!((t.yaw - std::f32::consts::FRAC_PI_2).abs() < 1e-6);
            }
        }
    }
    assert!(d.counters.targets_sent >= 5, "{:?}", d.counters);
    assert!(
        seqs.windows(2).all(|w| w[1] == w[0].wrapping_add(1)),
        "{seqs:?}"
    );
    // The helm stops renewing: after course_timeout the re-sends stop, as on the actors' path.
    for i in 11..=50 {
        let now = Duration::from_millis(50 + 100 * i);
        if i % 10 == 0 {
            feed(&mut d, &mut sink, "hb_guided_armed", now.as_secs_f64());
        }
        d.do_loop(now, &mut sink);
        let late = sequenced(&mut rx)
            .into_iter()
            .filter(|(_, m)| matches!(m, MavMessage::SET_POSITION_TARGET_GLOBAL_INT(_)))
            .count();
        if i > 40 {
            assert_eq!(late, 0, "re-sent after the helm stopped");
        }
    }
    // A mode change the driver has handled closes the way before the lane is asked again.
    let t = 5.5;
    feed(&mut d, &mut sink, "hb_hold_failsafe", t);
    assert!(lane.send_now(&lane_course(180.0, 1.0)).is_none());
    assert!(
        sequenced(&mut rx)
            .iter()
            .all(|(_, m)| !matches!(m, MavMessage::SET_POSITION_TARGET_GLOBAL_INT(_)))
    );
    // The link lost: no lane; a UDP link never offers one.
    d.handle_io(
        frontseat_actors::driver::DriverIoEvent::Disconnected("test".into()),
        Duration::from_secs(6),
        &mut sink,
    );
    assert!(d.direct_command().is_none());
    assert!(lane.send_now(&lane_course(270.0, 1.0)).is_none());
    let (udp, _rx, _sink) =
        driver_with(|c| c.driver.ardupilot.address = "udpin:127.0.0.1:0".into());
    assert!(udp.direct_command().is_none());
}

/// A course the driver would refuse, or a queue that cannot take the frame now, is not the
/// lane's: it goes the actors' way.
#[test]
fn the_lane_refuses_what_it_cannot_write_at_once() {
    let (mut d, mut rx, mut sink) = driver();
    let lane = d.direct_command().unwrap();
    ready(&mut d, &mut sink, 0.0);
    assert!(lane.send_now(&lane_course(f64::NAN, 1.0)).is_none());
    assert!(lane.send_now(&lane_course(90.0, -1.0)).is_none());
    assert!(lane.send_now(&CommandRequest::default()).is_none());
    // Fill the link's queue: the lane refuses instead of waiting.
    let mut n = 0;
    while lane
        .send_now(&lane_course(f64::from(n % 300), 1.0))
        .is_some()
    {
        n += 1;
        assert!(n < 100_000);
    }
    assert!(n > 0);
    drop(rx.try_recv());
    assert!(lane.send_now(&lane_course(301.0, 1.0)).is_some());
}
