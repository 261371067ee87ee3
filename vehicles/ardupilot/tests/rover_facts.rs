//! One test per fact of ArduPilot Rover's MAVLink face (the README of this crate lists them, as
//! checked against the real autopilot in SITL), run against the emulator session directly:
//! frames in, frames out, sim time stepped by hand — no sockets, no clocks.

use frontseat_ardupilot::codec::{Deframer, MavMessage, Sender, decode};
use frontseat_ardupilot::dialect::*;
use frontseat_ardupilot::emulator::{RoverOptions, RoverSession};
use frontseat_ardupilot::infer::TARGET_TIMEOUT_TEXT;
use frontseat_ardupilot::modes::rover;
use frontseat_sim::emulator::Session;

struct Gcs {
    rover: RoverSession,
    tx: Sender,
    rx: Deframer,
    heard: Vec<MavMessage>,
}

impl Gcs {
    fn new(opts: RoverOptions) -> Self {
        Self {
            rover: RoverSession::new(opts),
            tx: Sender::new(255, 190),
            rx: Deframer::new(),
            heard: Vec::new(),
        }
    }

    fn take(&mut self, out: Vec<u8>) {
        let mut frames = Vec::new();
        self.rx.feed(&out, &mut |r| {
            frames.push(r.expect("the emulator sends good frames"))
        });
        for f in frames {
            self.heard.push(decode(&f).expect("decodes").1);
        }
    }

    fn send(&mut self, msg: MavMessage) {
        let mut out = Vec::new();
        let f = self.tx.frame(&msg);
        self.rover.on_bytes(&f, &mut out);
        self.take(out);
    }

    fn run(&mut self, seconds: f64) {
        let n = (seconds / 0.1).round() as usize;
        for _ in 0..n {
            let mut out = Vec::new();
            self.rover.step(0.1, &mut out);
            self.take(out);
        }
    }

    fn command(&mut self, command: MavCmd, p1: f32, p2: f32) -> MavResult {
        self.heard.clear();
        self.send(MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
            command,
            param1: p1,
            param2: p2,
            target_system: 1,
            target_component: 1,
            ..Default::default()
        }));
        self.heard
            .iter()
            .find_map(|m| match m {
                MavMessage::COMMAND_ACK(a) if a.command == command => Some(a.result),
                _ => None,
            })
            .expect("every COMMAND_LONG is answered by a COMMAND_ACK")
    }

    fn texts(&self) -> Vec<String> {
        self.heard
            .iter()
            .filter_map(|m| match m {
                MavMessage::STATUSTEXT(t) => t.text.to_str().ok().map(|s| s.to_string()),
                _ => None,
            })
            .collect()
    }

    fn last_heartbeat(&self) -> HEARTBEAT_DATA {
        self.heard
            .iter()
            .rev()
            .find_map(|m| match m {
                MavMessage::HEARTBEAT(h) => Some(h.clone()),
                _ => None,
            })
            .expect("a heartbeat")
    }

    fn target(&mut self, mask: u16, vx: f32, vy: f32, yaw_deg: f32) {
        self.send(MavMessage::SET_POSITION_TARGET_GLOBAL_INT(
            SET_POSITION_TARGET_GLOBAL_INT_DATA {
                vx,
                vy,
                yaw: yaw_deg.to_radians(),
                type_mask: PositionTargetTypemask::from_bits_retain(mask),
                target_system: 1,
                target_component: 1,
                coordinate_frame: MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT,
                ..Default::default()
            },
        ));
    }

    /// Ready (past init and EKF), GUIDED, armed.
    fn guided_and_armed() -> Self {
        let mut g = Gcs::new(RoverOptions::default());
        g.run(6.0);
        assert_eq!(
            g.command(MavCmd::MAV_CMD_DO_SET_MODE, 1.0, 15.0),
            MavResult::MAV_RESULT_ACCEPTED
        );
        assert_eq!(
            g.command(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, 1.0, 0.0),
            MavResult::MAV_RESULT_ACCEPTED
        );
        g
    }

    /// Keeps a target coming at 5 Hz for `seconds`.
    fn steer(&mut self, mask: u16, vx: f32, vy: f32, yaw: f32, seconds: f64) {
        for _ in 0..(seconds / 0.2).round() as usize {
            self.target(mask, vx, vy, yaw);
            self.run(0.2);
        }
    }
}

#[test]
fn heartbeat_is_an_ardupilot_boat_initialising_then_manual() {
    let mut g = Gcs::new(RoverOptions::default());
    g.run(0.5);
    let hb = g.last_heartbeat();
    assert_eq!(hb.mavtype, MavType::MAV_TYPE_SURFACE_BOAT);
    assert_eq!(hb.autopilot, MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA);
    assert_eq!(hb.custom_mode, rover::INITIALISING);
    assert_eq!(hb.system_status as u8, 2, "initialising");
    g.run(1.5);
    let hb = g.last_heartbeat();
    assert_eq!(hb.custom_mode, rover::MANUAL);
    assert_eq!(hb.system_status, MavState::MAV_STATE_STANDBY);
    assert!(
        !hb.base_mode
            .contains(MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED)
    );
}

#[test]
fn arming_and_mode_are_answered_by_command_ack_and_prearm_refuses_in_words() {
    let mut g = Gcs::new(RoverOptions::default());
    assert_eq!(
        g.command(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, 1.0, 0.0),
        MavResult::MAV_RESULT_FAILED
    );
    assert!(
        g.texts().iter().any(|t| t.starts_with("PreArm")),
        "{:?}",
        g.texts()
    );
    g.run(1.5);
    assert_eq!(
        g.command(MavCmd::MAV_CMD_DO_SET_MODE, 1.0, 99.0),
        MavResult::MAV_RESULT_FAILED
    );
    assert_eq!(
        g.command(MavCmd::MAV_CMD_DO_SET_MODE, 1.0, 4.0),
        MavResult::MAV_RESULT_ACCEPTED
    );
    assert_eq!(g.rover.mode(), rover::HOLD);
    assert_eq!(
        g.command(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, 1.0, 0.0),
        MavResult::MAV_RESULT_ACCEPTED
    );
    g.run(1.0);
    assert!(
        g.last_heartbeat()
            .base_mode
            .contains(MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED)
    );
    // README: MAV_CMD_DO_CHANGE_SPEED answers FAILED in heading/speed mode.
    assert_eq!(
        g.command(MavCmd::MAV_CMD_DO_CHANGE_SPEED, 1.0, 2.0),
        MavResult::MAV_RESULT_FAILED
    );
}

#[test]
fn streams_come_at_the_rate_set_message_interval_asks_for() {
    let mut g = Gcs::new(RoverOptions::default());
    g.run(2.0);
    let count = |g: &Gcs| {
        g.heard
            .iter()
            .filter(|m| matches!(m, MavMessage::GLOBAL_POSITION_INT(_)))
            .count()
    };
    assert_eq!(count(&g), 0, "nothing but HEARTBEAT until asked");
    assert_eq!(
        g.command(MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL, 33.0, 200_000.0),
        MavResult::MAV_RESULT_ACCEPTED
    );
    g.heard.clear();
    g.run(2.0);
    assert!((9..=11).contains(&count(&g)), "5 Hz for 2 s: {}", count(&g));
    assert_eq!(
        g.command(MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL, 33.0, -1.0),
        MavResult::MAV_RESULT_ACCEPTED
    );
    g.heard.clear();
    g.run(1.0);
    assert_eq!(count(&g), 0, "-1 stops it");
}

#[test]
fn targets_outside_guided_are_silently_ignored() {
    let mut g = Gcs::new(RoverOptions::default());
    g.run(6.0);
    g.command(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, 1.0, 0.0);
    g.heard.clear();
    g.steer(0x09C7, 2.0, 0.0, 90.0, 3.0);
    assert!(g.texts().is_empty());
    assert!(
        !g.heard
            .iter()
            .any(|m| matches!(m, MavMessage::COMMAND_ACK(_)))
    );
    assert_eq!(g.rover.vehicle().speed, 0.0);
    assert!(g.rover.stats.targets_ignored >= 15);
}

#[test]
fn velocity_and_yaw_0x09c7_steers_heading_90_at_2_mps() {
    let mut g = Gcs::guided_and_armed();
    g.steer(0x09C7, 2.0, 0.0, 90.0, 8.0);
    let v = g.rover.vehicle();
    assert!((v.heading - 90.0).abs() < 1.0, "{}", v.heading);
    assert!((v.speed - 2.0).abs() < 1e-6, "{}", v.speed);
}

#[test]
fn velocity_only_0x0dc7_steers_heading_225_at_3_mps() {
    let mut g = Gcs::guided_and_armed();
    let c = -3.0 * std::f32::consts::FRAC_1_SQRT_2;
    g.steer(0x0DC7, c, c, 0.0, 12.0);
    let v = g.rover.vehicle();
    assert!((v.heading - 225.0).abs() < 1.0, "{}", v.heading);
    assert!((v.speed - 3.0).abs() < 1e-3, "{}", v.speed);
}

#[test]
fn acceleration_bits_clear_is_refused_with_statustext() {
    let mut g = Gcs::guided_and_armed();
    g.heard.clear();
    g.target(0x0907, 2.0, 0.0, 90.0);
    assert!(
        g.texts()
            .iter()
            .any(|t| t.contains("set ACC_IGNORE in mask")),
        "{:?}",
        g.texts()
    );
    g.run(2.0);
    assert_eq!(g.rover.vehicle().speed, 0.0);
}

#[test]
fn target_times_out_after_3_s_of_sim_time_and_a_new_one_resumes() {
    let mut g = Gcs::guided_and_armed();
    g.steer(0x09C7, 2.0, 0.0, 0.0, 5.0);
    assert!(g.rover.vehicle().speed > 1.0);
    g.heard.clear();
    // The last target went out 0.2 s ago.
    g.run(2.7);
    assert!(g.texts().is_empty(), "not before 3 s");
    g.run(0.2);
    assert_eq!(g.texts(), vec![TARGET_TIMEOUT_TEXT.to_string()]);
    assert_eq!(g.rover.mode(), rover::GUIDED, "the mode stays GUIDED");
    g.run(6.0);
    assert_eq!(g.rover.vehicle().speed, 0.0, "a boat loiters where it is");
    g.steer(0x09C7, 1.0, 0.0, 0.0, 3.0);
    assert!(g.rover.vehicle().speed > 0.5, "a new target resumes");
}

#[test]
fn speed_is_capped_at_wp_speed() {
    let mut g = Gcs::guided_and_armed();
    g.steer(0x09C7, 9.0, 0.0, 0.0, 15.0);
    assert_eq!(g.rover.vehicle().speed, RoverOptions::default().wp_speed);
}

#[test]
fn guided_before_the_ekf_is_ready_ends_in_an_ekf_failsafe_to_hold() {
    let mut g = Gcs::new(RoverOptions::default());
    g.run(1.5);
    assert!(!g.rover.ekf_ready());
    assert_eq!(
        g.command(MavCmd::MAV_CMD_DO_SET_MODE, 1.0, 15.0),
        MavResult::MAV_RESULT_ACCEPTED
    );
    g.command(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, 1.0, 0.0);
    g.heard.clear();
    g.steer(0x09C7, 2.0, 0.0, 0.0, 3.0);
    assert_eq!(
        g.rover.mode(),
        rover::HOLD,
        "the autopilot switched by itself"
    );
    assert!(
        g.texts().iter().any(|t| t.contains("EKF failsafe")),
        "{:?}",
        g.texts()
    );
    let hb = g.last_heartbeat();
    assert_eq!(hb.system_status, MavState::MAV_STATE_CRITICAL);
    assert_eq!(hb.custom_mode, rover::HOLD);
    let before = g.rover.stats.targets_ignored;
    g.steer(0x09C7, 2.0, 0.0, 0.0, 1.0);
    assert!(
        g.rover.stats.targets_ignored > before,
        "setpoints now silently ignored"
    );
}

#[test]
fn ekf_report_reads_ready_as_0x033f_after_the_estimate_settles() {
    let mut g = Gcs::new(RoverOptions::default());
    g.run(1.5);
    g.command(MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL, 193.0, 500_000.0);
    g.command(MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL, 24.0, 500_000.0);
    g.heard.clear();
    g.run(1.0);
    let flags = |g: &Gcs| {
        g.heard.iter().rev().find_map(|m| match m {
            MavMessage::EKF_STATUS_REPORT(e) => Some(e.flags.bits()),
            _ => None,
        })
    };
    assert_ne!(flags(&g).map(|f| f & 0x033f), Some(0x033f));
    g.run(4.0);
    assert_eq!(flags(&g).map(|f| f & 0x033f), Some(0x033f));
    let fix = g.heard.iter().rev().find_map(|m| match m {
        MavMessage::GPS_RAW_INT(p) => Some(p.fix_type),
        _ => None,
    });
    assert_eq!(fix, Some(GpsFixType::GPS_FIX_TYPE_3D_FIX));
}

#[test]
fn local_ned_targets_are_dropped_until_the_ekf_origin_is_set() {
    let mut g = Gcs::new(RoverOptions {
        ekf_ready_s: 1000.0,
        ..Default::default()
    });
    g.run(1.5);
    g.command(MavCmd::MAV_CMD_DO_SET_MODE, 1.0, 15.0);
    g.command(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, 1.0, 0.0);
    g.heard.clear();
    g.send(MavMessage::SET_POSITION_TARGET_LOCAL_NED(
        SET_POSITION_TARGET_LOCAL_NED_DATA {
            vx: 1.0,
            type_mask: PositionTargetTypemask::from_bits_retain(0x0DC7),
            target_system: 1,
            target_component: 1,
            coordinate_frame: MavFrame::MAV_FRAME_LOCAL_NED,
            ..Default::default()
        },
    ));
    assert!(g.texts().is_empty());
    assert_eq!(g.rover.stats.targets_ignored, 1);
    assert_eq!(g.rover.stats.targets_followed, 0);
}

#[test]
fn noise_bad_crc_and_floods_are_counted_never_fatal() {
    let mut g = Gcs::guided_and_armed();
    let mut out = Vec::new();
    let mut bad =
        g.tx.frame(&MavMessage::HEARTBEAT(HEARTBEAT_DATA::default()));
    let n = bad.len();
    bad[n - 2] ^= 0x5A;
    g.rover.on_bytes(&bad, &mut out);
    g.rover.on_bytes(&[0xFD; 5000], &mut out);
    g.rover.on_bytes(b"garbage\r\n", &mut out);
    assert!(g.rover.stats.bad_input >= 3, "{:?}", g.rover.stats);
    g.steer(0x09C7, 2.0, 0.0, 45.0, 4.0);
    assert!(
        g.rover.vehicle().speed > 1.0,
        "still steering after the noise"
    );
}

#[test]
fn no_gcs_failsafe_by_default_when_the_backseat_falls_silent() {
    // README: FS_GCS_ENABLE 0 — a silent backseat changes nothing; only the target times out.
    let mut g = Gcs::guided_and_armed();
    g.send(MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        mavtype: MavType::MAV_TYPE_ONBOARD_CONTROLLER,
        autopilot: MavAutopilot::MAV_AUTOPILOT_INVALID,
        ..Default::default()
    }));
    assert_eq!(g.rover.stats.gcs_heartbeats, 1);
    g.run(30.0);
    assert_eq!(g.rover.mode(), rover::GUIDED);
    assert!(g.rover.armed());
    assert_eq!(g.last_heartbeat().system_status, MavState::MAV_STATE_ACTIVE);
}
