//! The driver with `vehicle = "sub"` against ArduSub's side of the link as pymavlink encodes it
//! (`fixtures/pymavlink_sub_frames.hex`, carrying the values `ardusub.md` records): one test per
//! fact the driver relies on.

use super::*;
use crate::codec::MavMessage;
use crate::dialect::MavCmd;
use crate::dialect::{MANUAL_CONTROL_DATA, MavFrame};
use crate::infer;
use frontseat_actors::proto::frontseat::protobuf::ardupilot::ardupilot_command::Action;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::DesiredCourse;
use frontseat_config::{ArdupilotVehicle, InterfaceConfig};
use tokio::sync::mpsc::Receiver;

use super::test_link::{Sink, connected, feed_frame, fixture_frame, written};

const FIXTURE: &str = include_str!("../../fixtures/pymavlink_sub_frames.hex");

fn frame(name: &str) -> Vec<u8> {
    fixture_frame(FIXTURE, name)
}

fn driver_with(f: impl FnOnce(&mut InterfaceConfig)) -> (ArdupilotDriver, Receiver<Vec<u8>>, Sink) {
    let mut cfg = InterfaceConfig::default();
    cfg.driver.ardupilot.vehicle = ArdupilotVehicle::Sub;
    f(&mut cfg);
    connected(&cfg)
}

fn feed(d: &mut ArdupilotDriver, sink: &mut Sink, name: &str, t: f64) {
    feed_frame(d, sink, frame(name), t);
}

/// Everything the driver wrote, with the sender's system id.
fn sent(rx: &mut Receiver<Vec<u8>>) -> Vec<(u8, MavMessage)> {
    written(rx)
}

fn msgs(rx: &mut Receiver<Vec<u8>>) -> Vec<MavMessage> {
    sent(rx).into_iter().map(|(_, m)| m).collect()
}

/// No frame the driver sent arms, disarms or changes the mode.
#[allow(deprecated)] // SET_MODE: looked for precisely because it must never be sent.
fn assert_never_arms_or_changes_mode(v: &[MavMessage]) {
    for m in v {
        if let MavMessage::COMMAND_LONG(c) = m {
            assert_eq!(
                c.command,
                MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
                "the driver sent {c:?} on its own"
            );
        }
        assert!(!matches!(m, MavMessage::SET_MODE(_)), "{m:?}");
    }
}

fn course(h: f64, s: f64, depth: Option<f64>, id: i32) -> CommandRequest {
    CommandRequest {
        desired_course: Some(DesiredCourse {
            time: 0.0,
            heading: Some(h),
            speed: Some(s),
            depth,
            ..Default::default()
        }),
        response_requested: Some(true),
        request_id: Some(id),
        ..Default::default()
    }
}

fn ready_guided(d: &mut ArdupilotDriver, sink: &mut Sink, t: f64) {
    for f in [
        "sub_hb_guided_armed",
        "sub_ekf_ready",
        "sub_attitude",
        "sub_local_5m",
        "sub_pos_5m",
    ] {
        feed(d, sink, f, t);
    }
}

/// ardusub.md: mode numbers (GUIDED 4, ALT_HOLD 2, MANUAL 19, STABILIZE 0, SURFACE 9, AUTO 3,
/// POSHOLD 16), disarmed is idle, system_status 5 is a failsafe; the reason carries the
/// vehicle's words.
#[test]
fn state_inference_follows_ardusubs_modes_and_failsafes() {
    let (mut d, mut rx, mut sink) = driver_with(|_| {});
    let rows = [
        ("sub_hb_manual_disarmed", FrontSeatState::FrontseatIdle),
        ("sub_hb_guided_disarmed", FrontSeatState::FrontseatIdle),
        (
            "sub_hb_guided_armed",
            FrontSeatState::FrontseatAcceptingCommands,
        ),
        ("sub_hb_althold_armed", FrontSeatState::FrontseatIdle),
        ("sub_hb_manual_armed", FrontSeatState::FrontseatIdle),
        ("sub_hb_stabilize_armed", FrontSeatState::FrontseatIdle),
        ("sub_hb_poshold_armed", FrontSeatState::FrontseatIdle),
        ("sub_hb_surface_armed", FrontSeatState::FrontseatInControl),
        ("sub_hb_auto_armed", FrontSeatState::FrontseatInControl),
        ("sub_hb_guided_critical", FrontSeatState::FrontseatInControl),
    ];
    for (i, (f, want)) in rows.into_iter().enumerate() {
        feed(&mut d, &mut sink, f, i as f64 * 0.1);
        assert_eq!(d.frontseat_state(), want, "{f}");
    }
    assert!(
        d.state_reason().contains("GUIDED (4)"),
        "{}",
        d.state_reason()
    );
    // A leak: warn-level failsafe, status CRITICAL, the reason quotes the vehicle.
    feed(&mut d, &mut sink, "sub_hb_guided_armed", 2.0);
    feed(&mut d, &mut sink, "sub_text_leak", 2.1);
    feed(&mut d, &mut sink, "sub_hb_guided_critical", 2.2);
    assert_eq!(d.frontseat_state(), FrontSeatState::FrontseatInControl);
    assert!(
        d.state_reason().contains("Leak Detected"),
        "{}",
        d.state_reason()
    );
    // The GCS failsafe: disarmed, mode still GUIDED, status 5.
    feed(&mut d, &mut sink, "sub_hb_guided_armed", 3.0);
    feed(&mut d, &mut sink, "sub_text_gcs_lost", 3.1);
    feed(&mut d, &mut sink, "sub_hb_guided_disarmed_critical", 3.2);
    assert_eq!(d.frontseat_state(), FrontSeatState::FrontseatIdle);
    assert!(
        d.state_reason().contains("disarmed") && d.state_reason().contains("heartbeat lost"),
        "{}",
        d.state_reason()
    );
    // The pilot takes over: MANUAL, with the mode named.
    feed(&mut d, &mut sink, "sub_hb_guided_armed", 4.0);
    feed(&mut d, &mut sink, "sub_hb_manual_armed", 4.1);
    assert!(
        d.state_reason().contains("MANUAL (19)"),
        "{}",
        d.state_reason()
    );
    assert_never_arms_or_changes_mode(&msgs(&mut rx));
}

/// ardusub.md "Recommended": GUIDED + SET_POSITION_TARGET_LOCAL_NED, frame LOCAL_NED, type_mask
/// 0x09C0, x/y = the latest LOCAL_POSITION_NED, z = depth, (vx, vy) = speed along the heading,
/// yaw = heading, at 5 Hz; never a GLOBAL_INT (its yaw is ignored in GUIDED).
#[test]
fn guided_course_is_a_local_ned_position_velocity_yaw_target_at_5_hz() {
    let (mut d, mut rx, mut sink) = driver_with(|_| {});
    ready_guided(&mut d, &mut sink, 0.0);
    assert!(d.frontseat_providing_data(), "{:?}", d.nav_problem());
    msgs(&mut rx);
    d.send_command_to_frontseat(&course(90.0, 0.5, Some(5.0), 1), Duration::ZERO, &mut sink);
    let first = msgs(&mut rx);
    let [MavMessage::SET_POSITION_TARGET_LOCAL_NED(t)] = &first[..] else {
        panic!("{first:?}")
    };
    assert_eq!(t.type_mask.bits(), 0x09C0);
    assert_eq!(t.coordinate_frame, MavFrame::MAV_FRAME_LOCAL_NED);
    assert_eq!((t.x, t.y, t.z), (3.0, 4.0, 5.0));
    assert!(t.vx.abs() < 1e-6 && (t.vy - 0.5).abs() < 1e-6, "{t:?}");
    assert!((t.yaw - std::f32::consts::FRAC_PI_2).abs() < 1e-6);
    assert_eq!((t.target_system, t.target_component), (1, 1));
    let mut all = Vec::new();
    for i in 1..=20 {
        let now = Duration::from_millis(100 * i);
        if i.is_multiple_of(10) {
            feed(&mut d, &mut sink, "sub_hb_guided_armed", now.as_secs_f64());
            let mut c = course(90.0, 0.5, Some(5.0), 0);
            c.response_requested = None;
            d.send_command_to_frontseat(&c, now, &mut sink);
        }
        d.do_loop(now, &mut sink);
        all.extend(msgs(&mut rx));
    }
    let targets = all
        .iter()
        .filter(|m| matches!(m, MavMessage::SET_POSITION_TARGET_LOCAL_NED(_)))
        .count();
    assert_eq!(targets, 10, "5 Hz for 2 s");
    assert!(
        !all.iter()
            .any(|m| matches!(m, MavMessage::SET_POSITION_TARGET_GLOBAL_INT(_))),
        "GUIDED ignores a GLOBAL_INT's yaw: never sent"
    );
    assert_eq!(sink.responses[0].request_successful, Some(true));
    assert_never_arms_or_changes_mode(&all);
}

/// Without a LOCAL_POSITION_NED there is nothing to anchor the target on: refused in words; a
/// course with no depth holds the depth it finds; a negative depth is refused.
#[test]
fn guided_needs_a_local_position_and_a_course_without_depth_holds_depth() {
    let (mut d, mut rx, mut sink) = driver_with(|_| {});
    feed(&mut d, &mut sink, "sub_hb_guided_armed", 0.0);
    d.send_command_to_frontseat(&course(90.0, 0.5, Some(5.0), 1), Duration::ZERO, &mut sink);
    assert_eq!(sink.responses[0].request_successful, Some(false));
    assert!(
        sink.responses[0]
            .error_string()
            .contains("LOCAL_POSITION_NED"),
        "{:?}",
        sink.responses
    );
    ready_guided(&mut d, &mut sink, 0.1);
    msgs(&mut rx);
    d.send_command_to_frontseat(
        &course(180.0, 0.3, None, 2),
        Duration::from_millis(100),
        &mut sink,
    );
    let v = msgs(&mut rx);
    let [MavMessage::SET_POSITION_TARGET_LOCAL_NED(t)] = &v[..] else {
        panic!("{v:?}")
    };
    assert_eq!(t.z, 5.0, "holds the 5 m it is at");
    d.send_command_to_frontseat(
        &course(180.0, 0.3, Some(-1.0), 3),
        Duration::from_millis(200),
        &mut sink,
    );
    assert_eq!(
        sink.responses.last().unwrap().request_successful,
        Some(false)
    );
}

/// ardusub.md, ALT_HOLD path: depth by a z-only SET_POSITION_TARGET_GLOBAL_INT (alt = −depth)
/// once a second, heading by SET_ATTITUDE_TARGET (bit 6 set; re-sent well inside its 5 s) and
/// forward by MANUAL_CONTROL x (z 500, buttons 0); when the pilot switches mode the thrust is
/// zeroed at once and the course dropped.
#[test]
fn alt_hold_course_is_depth_attitude_and_thrust_and_stops_when_the_pilot_takes_over() {
    let (mut d, mut rx, mut sink) =
        driver_with(|c| c.driver.ardupilot.alt_hold_accepts_commands = true);
    for f in [
        "sub_hb_althold_armed",
        "sub_ekf_const_pos",
        "sub_attitude",
        "sub_local_5m",
        "sub_pos_5m",
    ] {
        feed(&mut d, &mut sink, f, 0.0);
    }
    assert_eq!(
        d.frontseat_state(),
        FrontSeatState::FrontseatAcceptingCommands
    );
    assert!(d.frontseat_providing_data(), "{:?}", d.nav_problem());
    msgs(&mut rx);
    d.send_command_to_frontseat(&course(90.0, 0.5, Some(5.0), 1), Duration::ZERO, &mut sink);
    let mut all = sent(&mut rx);
    for i in 1..=20 {
        let now = Duration::from_millis(100 * i);
        if i.is_multiple_of(10) {
            feed(&mut d, &mut sink, "sub_hb_althold_armed", now.as_secs_f64());
            let mut c = course(90.0, 0.5, Some(5.0), 0);
            c.response_requested = None;
            d.send_command_to_frontseat(&c, now, &mut sink);
        }
        d.do_loop(now, &mut sink);
        all.extend(sent(&mut rx));
    }
    let att: Vec<_> = all
        .iter()
        .filter_map(|(_, m)| match m {
            MavMessage::SET_ATTITUDE_TARGET(a) => Some(a.clone()),
            _ => None,
        })
        .collect();
    let mc: Vec<(u8, MANUAL_CONTROL_DATA)> = all
        .iter()
        .filter_map(|(s, m)| match m {
            MavMessage::MANUAL_CONTROL(c) => Some((*s, c.clone())),
            _ => None,
        })
        .collect();
    let depth: Vec<_> = all
        .iter()
        .filter_map(|(_, m)| match m {
            MavMessage::SET_POSITION_TARGET_GLOBAL_INT(t) => Some(t.clone()),
            _ => None,
        })
        .collect();
    assert_eq!(att.len(), 11, "5 Hz for 2 s, plus the first");
    assert_eq!(att[0].type_mask.bits(), 0x47);
    assert!((infer::quaternion_heading(att[0].q).unwrap() - 90.0).abs() < 1e-3);
    assert_eq!(mc.len(), 11);
    let (sysid, m) = &mc[0];
    assert_eq!(
        (*sysid, m.x, m.y, m.z, m.r, m.buttons, m.target),
        (255, 500, 0, 500, 0, 0, 1)
    );
    assert!(
        (2..=4).contains(&depth.len()),
        "about 1 Hz: {}",
        depth.len()
    );
    assert_eq!(depth[0].alt, -5.0);
    assert_eq!(depth[0].type_mask.bits() & 0b100, 0, "z used");
    assert_eq!(depth[0].type_mask.bits() & 0b011, 0b011, "x, y ignored");
    assert!(
        !all.iter()
            .any(|(_, m)| matches!(m, MavMessage::SET_POSITION_TARGET_LOCAL_NED(_)))
    );
    // The pilot switches to MANUAL: one neutral MANUAL_CONTROL at once, nothing more.
    feed(&mut d, &mut sink, "sub_hb_manual_armed", 2.05);
    let after = msgs(&mut rx);
    assert!(
        matches!(&after[..], [MavMessage::MANUAL_CONTROL(m)] if m.x == 0 && m.z == 500),
        "{after:?}"
    );
    assert_eq!(d.frontseat_state(), FrontSeatState::FrontseatIdle);
    for i in 21..=40 {
        d.do_loop(Duration::from_millis(100 * i), &mut sink);
    }
    assert!(
        msgs(&mut rx)
            .iter()
            .all(|m| matches!(m, MavMessage::HEARTBEAT(_)))
    );
    assert_never_arms_or_changes_mode(&all.into_iter().map(|(_, m)| m).collect::<Vec<_>>());
}

/// ardusub.md, depth telemetry: depth is LOCAL_POSITION_NED.z (5.00), not relative_alt (−5.037)
/// nor VFR_HUD alt; pitch and roll come from ATTITUDE; a DVL's relative position is a position.
#[test]
fn navigation_depth_is_local_position_z_with_pitch_and_roll() {
    let (mut d, _rx, mut sink) = driver_with(|_| {});
    feed(&mut d, &mut sink, "sub_hb_guided_armed", 0.0);
    feed(&mut d, &mut sink, "sub_ekf_ready", 0.0);
    feed(&mut d, &mut sink, "sub_pos_5m", 0.0);
    assert!(sink.data.is_empty(), "no depth yet");
    assert!(d.nav_problem().unwrap().contains("LOCAL_POSITION_NED"));
    for f in [
        "sub_attitude",
        "sub_vfr_5m",
        "sub_pressure_5m",
        "sub_local_5m",
        "sub_pos_5m",
    ] {
        feed(&mut d, &mut sink, f, 0.1);
    }
    let ns = sink.data.last().unwrap().node_status.clone().unwrap();
    assert_eq!(ns.global_fix.depth, Some(5.0));
    assert!((ns.pose.pitch.unwrap() - (-0.05f64).to_degrees()).abs() < 1e-3);
    assert!((ns.pose.roll.unwrap() - 0.02f64.to_degrees()).abs() < 1e-3);
    assert_eq!(ns.pose.heading, Some(90.0));
    // A DVL: relative horizontal position, no GPS fix: still navigation.
    feed(&mut d, &mut sink, "sub_ekf_dvl", 0.2);
    feed(&mut d, &mut sink, "sub_gps_none", 0.2);
    let n = sink.data.len();
    feed(&mut d, &mut sink, "sub_pos_5m", 0.2);
    assert_eq!(sink.data.len(), n + 1, "{:?}", d.nav_problem());
    // Constant-position mode (GPS lost, nothing else): not a position for GUIDED.
    feed(&mut d, &mut sink, "sub_ekf_const_pos", 0.3);
    feed(&mut d, &mut sink, "sub_pos_5m", 0.3);
    assert_eq!(sink.data.len(), n + 1);
    assert!(d.nav_problem().unwrap().contains("horizontal position"));
}

/// Bad depths reach the navigation gate as they came (it refuses and counts them; the
/// interface's test shows that); a non-finite one is also counted here as bad input.
#[test]
fn bad_depths_are_passed_on_unclamped_and_nan_is_counted() {
    let (mut d, _rx, mut sink) = driver_with(|_| {});
    ready_guided(&mut d, &mut sink, 0.0);
    let before = d.counters.bad_input;
    for (f, want) in [("sub_local_1e9", 1e9), ("sub_local_above", -200.0)] {
        feed(&mut d, &mut sink, f, 0.1);
        feed(&mut d, &mut sink, "sub_pos_5m", 0.1);
        let ns = sink.data.last().unwrap().node_status.clone().unwrap();
        assert_eq!(ns.global_fix.depth, Some(want), "{f}");
    }
    feed(&mut d, &mut sink, "sub_local_nan", 0.2);
    feed(&mut d, &mut sink, "sub_pos_5m", 0.2);
    let ns = sink.data.last().unwrap().node_status.clone().unwrap();
    assert!(ns.global_fix.depth.unwrap().is_nan());
    assert_eq!(d.counters.bad_input, before + 1);
}

/// ardusub.md, failsafes: our HEARTBEAT (1 Hz) and, when configured, a neutral MANUAL_CONTROL
/// (more often than every 3 s), both from our system id (MAV_GCS_SYSID 255), only while the link
/// is up and the vehicle heard; off by default.
#[test]
fn failsafe_feeding_only_while_alive_and_connected() {
    let (mut d, mut rx, mut sink) =
        driver_with(|c| c.driver.ardupilot.pilot_input_keepalive = true);
    feed(&mut d, &mut sink, "sub_hb_manual_disarmed", 0.0);
    let mut v = Vec::new();
    for i in 1..=30 {
        let now = Duration::from_millis(100 * i);
        if i.is_multiple_of(10) {
            feed(
                &mut d,
                &mut sink,
                "sub_hb_manual_disarmed",
                now.as_secs_f64(),
            );
        }
        d.do_loop(now, &mut sink);
        v.extend(sent(&mut rx));
    }
    let mc: Vec<_> = v
        .iter()
        .filter_map(|(s, m)| match m {
            MavMessage::MANUAL_CONTROL(c) => Some((*s, c.clone())),
            _ => None,
        })
        .collect();
    assert!((6..=7).contains(&mc.len()), "2 Hz for 3 s: {}", mc.len());
    assert!(mc.iter().all(|(s, m)| *s == 255
        && m.x == 0
        && m.z == 500
        && m.buttons == 0
        && m.target == 1));
    let hbs = v
        .iter()
        .filter(|(s, m)| *s == 255 && matches!(m, MavMessage::HEARTBEAT(_)))
        .count();
    assert!((3..=4).contains(&hbs), "1 Hz: {hbs}");
    // The vehicle falls silent: once it counts as lost, no MANUAL_CONTROL (our HEARTBEAT still
    // announces us).
    let mut lost_at = None;
    let mut late = 0;
    for i in 31..=80 {
        d.do_loop(Duration::from_millis(100 * i), &mut sink);
        let n = msgs(&mut rx)
            .iter()
            .filter(|m| matches!(m, MavMessage::MANUAL_CONTROL(_)))
            .count();
        if lost_at.is_some() {
            late += n;
        } else if d.frontseat_state() == FrontSeatState::FrontseatNotConnected {
            lost_at = Some(i);
        }
    }
    assert!(lost_at.is_some());
    assert_eq!(late, 0, "MANUAL_CONTROL after the vehicle went silent");
    // The link drops: nothing at all.
    d.handle_io(
        DriverIoEvent::Disconnected("test".into()),
        Duration::from_secs(8),
        &mut sink,
    );
    for i in 81..=120 {
        d.do_loop(Duration::from_millis(100 * i), &mut sink);
    }
    assert!(msgs(&mut rx).is_empty());
    // Off by default: no MANUAL_CONTROL ever.
    let (mut d, mut rx, mut sink) = driver_with(|_| {});
    feed(&mut d, &mut sink, "sub_hb_guided_armed", 0.0);
    for i in 1..=30 {
        d.do_loop(Duration::from_millis(100 * i), &mut sink);
    }
    assert!(
        !msgs(&mut rx)
            .iter()
            .any(|m| matches!(m, MavMessage::MANUAL_CONTROL(_)))
    );
}

/// ardusub.md: DO_SET_MODE GUIDED without a position is answered FAILED with "Mode change
/// failed: GUIDED requires position" — the extension's answer carries those words; and the
/// driver's GUIDED is mode 4.
#[test]
fn guided_request_is_mode_4_and_its_refusal_carries_the_vehicles_words() {
    let (mut d, mut rx, mut sink) = driver_with(|c| c.driver.ardupilot.allow_mode_commands = true);
    ready_guided(&mut d, &mut sink, 0.0);
    msgs(&mut rx);
    let req = ArdupilotCommandRequest {
        response_requested: Some(true),
        request_id: Some(5),
        ardupilot_command: Some(
            frontseat_actors::proto::frontseat::protobuf::ardupilot::ArdupilotCommand {
                action: Some(Action::Guided as i32),
            },
        ),
        ..Default::default()
    };
    d.send_ardupilot_command(&req, Duration::ZERO, &mut sink);
    let v = msgs(&mut rx);
    assert!(v.iter().any(|m| matches!(m, MavMessage::COMMAND_LONG(c)
        if c.command == MavCmd::MAV_CMD_DO_SET_MODE && c.param1 == 1.0 && c.param2 == 4.0)));
    feed(&mut d, &mut sink, "sub_text_requires_position", 0.1);
    feed(&mut d, &mut sink, "sub_ack_mode_failed", 0.1);
    let r = sink.responses.last().unwrap();
    assert_eq!((r.request_successful, r.request_id), (Some(false), Some(5)));
    assert!(
        r.error_string().contains("GUIDED requires position"),
        "{r:?}"
    );
}

#[test]
fn every_sub_fixture_decodes() {
    for line in FIXTURE.lines().filter(|l| !l.starts_with('#')) {
        let name = line.split(' ').next().unwrap();
        assert!(codec::decode(&frame(name)).is_ok(), "{name}");
    }
}

/// The setpoint lane on a Sub: a GUIDED LOCAL_NED target anchored on the latest
/// LOCAL_POSITION_NED, holding the depth it finds when the course names none; nothing in
/// ALT_HOLD (three messages: the actors' path) or with a negative depth.
#[test]
fn the_lane_writes_the_subs_guided_target_and_nothing_in_alt_hold() {
    let (mut d, mut rx, mut sink) = driver_with(|_| {});
    let lane = d.direct_command().expect("a TCP link offers the lane");
    let bare = |h: f64, depth: Option<f64>| {
        let mut c = course(h, 0.5, depth, 0);
        c.response_requested = None;
        c.request_id = None;
        c
    };
    feed(&mut d, &mut sink, "sub_hb_guided_armed", 0.0);
    assert!(
        lane.send_now(&bare(90.0, Some(5.0))).is_none(),
        "no LOCAL_POSITION_NED to anchor on"
    );
    ready_guided(&mut d, &mut sink, 0.0);
    msgs(&mut rx);
    assert!(lane.send_now(&bare(90.0, Some(-1.0))).is_none());
    assert!(lane.send_now(&bare(90.0, None)).is_some());
    let v = msgs(&mut rx);
    let [MavMessage::SET_POSITION_TARGET_LOCAL_NED(t)] = &v[..] else {
        panic!("{v:?}")
    };
    assert_eq!((t.x, t.y, t.z), (3.0, 4.0, 5.0), "holds the 5 m it is at");
    assert!((t.yaw - std::f32::consts::FRAC_PI_2).abs() < 1e-6);
    // The same course with the depth it held: unchanged, not written.
    assert!(lane.send_now(&bare(90.0, Some(5.0))).is_none());
    assert!(lane.send_now(&bare(100.0, Some(7.0))).is_some());
    let v = msgs(&mut rx);
    let [MavMessage::SET_POSITION_TARGET_LOCAL_NED(t)] = &v[..] else {
        panic!("{v:?}")
    };
    assert_eq!(t.z, 7.0);
    // The driver goes on from it: its 5 Hz re-send is the lane's course.
    for i in 1..=3 {
        d.do_loop(Duration::from_millis(250 * i), &mut sink);
    }
    let v = msgs(&mut rx);
    assert!(
        v.iter()
            .any(|m| matches!(m, MavMessage::SET_POSITION_TARGET_LOCAL_NED(t) if t.z == 7.0)),
        "{v:?}"
    );
    feed(&mut d, &mut sink, "sub_hb_althold_armed", 1.0);
    assert!(lane.send_now(&bare(120.0, Some(2.0))).is_none());
    assert_never_arms_or_changes_mode(&msgs(&mut rx));
}
