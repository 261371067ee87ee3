//! One test per fact of ArduSub's MAVLink face (`shared/protocol/ardupilot/ardusub.md`, checked
//! there against ArduSub SITL; this crate's README lists them), run against the Sub emulator
//! session directly: frames in, frames out, sim time stepped by hand — no sockets, no clocks.
//! The backseat here is a companion as the facts file describes one: sysid 255, HEARTBEAT at
//! 1 Hz and (unless a test stops it) a neutral MANUAL_CONTROL at 2 Hz.

use frontseat_ardupilot::codec::{Deframer, MavMessage, Sender, decode};
use frontseat_ardupilot::dialect::*;
use frontseat_ardupilot::infer;
use frontseat_ardupilot::modes::sub;
use frontseat_ardupilot::sub_emulator::{SubOptions, SubSession, heading_error};
use frontseat_sim::emulator::Session;

/// Message ids (common.xml) the tests ask streams of.
const LOCAL_POSITION_NED_ID: u32 = 32;
const GLOBAL_POSITION_INT_ID: u32 = 33;
const VFR_HUD_ID: u32 = 74;
const SCALED_PRESSURE2_ID: u32 = 137;

struct Gcs {
    sub: SubSession,
    tx: Sender,
    rx: Deframer,
    heard: Vec<MavMessage>,
    feed_heartbeat: bool,
    feed_manual: bool,
    ticks: u64,
}

impl Gcs {
    fn new(opts: SubOptions) -> Self {
        Self {
            sub: SubSession::new(opts),
            tx: Sender::new(255, 191),
            rx: Deframer::new(),
            heard: Vec::new(),
            feed_heartbeat: true,
            feed_manual: true,
            ticks: 0,
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
        self.sub.on_bytes(&f, &mut out);
        self.take(out);
    }

    fn send_as(&mut self, sysid: u8, msg: MavMessage) {
        let mut out = Vec::new();
        let f = Sender::new(sysid, 191).frame(&msg);
        self.sub.on_bytes(&f, &mut out);
        self.take(out);
    }

    /// Steps sim time by 0.1 s, feeding the failsafes as configured, calling `each` every tick.
    fn run_with(&mut self, seconds: f64, mut each: impl FnMut(&mut Self)) {
        let n = (seconds / 0.1).round() as usize;
        for _ in 0..n {
            self.ticks += 1;
            if self.feed_heartbeat && self.ticks.is_multiple_of(10) {
                self.send(MavMessage::HEARTBEAT(HEARTBEAT_DATA {
                    mavtype: MavType::MAV_TYPE_ONBOARD_CONTROLLER,
                    autopilot: MavAutopilot::MAV_AUTOPILOT_INVALID,
                    ..Default::default()
                }));
            }
            if self.feed_manual && self.ticks.is_multiple_of(5) {
                self.send(MavMessage::MANUAL_CONTROL(infer::manual_control(0, 1)));
            }
            each(self);
            let mut out = Vec::new();
            self.sub.step(0.1, &mut out);
            self.take(out);
        }
    }

    fn run(&mut self, seconds: f64) {
        self.run_with(seconds, |_| {});
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

    fn set_mode(&mut self, mode: u32) -> MavResult {
        self.command(MavCmd::MAV_CMD_DO_SET_MODE, 1.0, mode as f32)
    }

    fn arm(&mut self) -> MavResult {
        self.command(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, 1.0, 0.0)
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
            .expect("a HEARTBEAT")
    }

    fn stream(&mut self, id: u32, hz: f32) {
        assert_eq!(
            self.command(MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL, id as f32, 1e6 / hz),
            MavResult::MAV_RESULT_ACCEPTED
        );
    }

    /// Booted, estimate ready, armed in `mode`.
    fn armed_in(mode: u32) -> Self {
        let mut g = Gcs::new(SubOptions::default());
        g.run(6.0);
        assert_eq!(g.set_mode(mode), MavResult::MAV_RESULT_ACCEPTED);
        assert_eq!(g.arm(), MavResult::MAV_RESULT_ACCEPTED);
        g
    }

    fn posvel(&mut self, heading: f64, speed: f64, depth: f64) {
        let (n, e) = (self.sub.vehicle().y, self.sub.vehicle().x);
        let t = infer::sub_guided_target(heading, speed, depth, n, e, 1, 1, 0);
        self.send(MavMessage::SET_POSITION_TARGET_LOCAL_NED(t));
    }

    fn local(&mut self, mask: u16, pos: (f32, f32, f32), vel: (f32, f32, f32), yaw_deg: f32) {
        self.send(MavMessage::SET_POSITION_TARGET_LOCAL_NED(
            SET_POSITION_TARGET_LOCAL_NED_DATA {
                x: pos.0,
                y: pos.1,
                z: pos.2,
                vx: vel.0,
                vy: vel.1,
                vz: vel.2,
                yaw: yaw_deg.to_radians(),
                type_mask: PositionTargetTypemask::from_bits_retain(mask),
                target_system: 1,
                target_component: 1,
                coordinate_frame: MavFrame::MAV_FRAME_LOCAL_NED,
                ..Default::default()
            },
        ));
    }
}

fn herr(g: &Gcs, want: f64) -> f64 {
    heading_error(g.sub.vehicle().heading, want).abs()
}

/// HEARTBEAT type 12 MAV_TYPE_SUBMARINE, autopilot 3, base_mode 0x51 disarmed (+0x80 armed),
/// boots in MANUAL 19, system_status 3 disarmed and 4 armed.
#[test]
fn heartbeat_is_a_submarine_booting_in_manual() {
    let mut g = Gcs::new(SubOptions::default());
    g.run(2.0);
    let h = g.last_heartbeat();
    assert_eq!(h.mavtype, MavType::MAV_TYPE_SUBMARINE);
    assert_eq!(h.mavtype as u8, 12);
    assert_eq!(h.autopilot, MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA);
    assert_eq!(h.base_mode.bits(), 0x51);
    assert_eq!(h.custom_mode, 19);
    assert_eq!(h.system_status as u8, 3);
    g.run(4.0);
    assert_eq!(g.set_mode(sub::GUIDED), MavResult::MAV_RESULT_ACCEPTED);
    assert_eq!(g.arm(), MavResult::MAV_RESULT_ACCEPTED);
    g.run(1.1);
    let h = g.last_heartbeat();
    assert_eq!(h.base_mode.bits(), 0xD1);
    assert_eq!((h.custom_mode, h.system_status as u8), (4, 4));
}

/// Mode numbers (mode.h:42-53); other numbers refused (mode.cpp:83-87). DO_SET_MODE is
/// accepted while disarmed.
#[test]
fn mode_numbers_and_others_refused() {
    let mut g = Gcs::new(SubOptions::default());
    g.run(6.0);
    for m in [0, 1, 2, 3, 4, 7, 9, 16, 19, 20, 21] {
        assert_eq!(g.set_mode(m), MavResult::MAV_RESULT_ACCEPTED, "mode {m}");
        g.run(0.2);
        assert_eq!(g.last_heartbeat().custom_mode, m);
    }
    for m in [5, 6, 15, 30, 99] {
        assert_eq!(g.set_mode(m), MavResult::MAV_RESULT_FAILED, "mode {m}");
    }
}

/// GUIDED, AUTO, POSHOLD and CIRCLE need a position estimate: FAILED with "Mode change failed:
/// GUIDED requires position"; ALT_HOLD, MANUAL, STABILIZE need none.
#[test]
fn position_modes_need_a_position_estimate() {
    let mut g = Gcs::new(SubOptions {
        position_estimate: false,
        ..Default::default()
    });
    g.run(6.0);
    assert_eq!(g.set_mode(sub::GUIDED), MavResult::MAV_RESULT_FAILED);
    assert!(
        g.texts()
            .contains(&"Mode change failed: GUIDED requires position".to_string()),
        "{:?}",
        g.texts()
    );
    for m in [sub::AUTO, sub::POSHOLD, sub::CIRCLE] {
        assert_eq!(g.set_mode(m), MavResult::MAV_RESULT_FAILED, "{m}");
    }
    for m in [sub::ALT_HOLD, sub::STABILIZE, sub::MANUAL] {
        assert_eq!(g.set_mode(m), MavResult::MAV_RESULT_ACCEPTED, "{m}");
    }
}

/// The recommended method: 0x09C0 LOCAL_NED at 5 Hz from 0.34 m, heading 0, at rest, asking
/// 5 m / 90° / 0.5 m/s: heading within 5°, depth within 0.3 m, then 0.50 m/s on course at 5.00 m
/// (SITL: 2.1 s, 4.5 s). Depth is LOCAL_POSITION_NED.z, the same frame as the target.
#[test]
fn guided_local_ned_pos_vel_yaw_reaches_depth_heading_and_speed() {
    let mut g = Gcs::armed_in(sub::GUIDED);
    g.sub.set_depth(0.34);
    g.stream(LOCAL_POSITION_NED_ID, 5.0);
    let (mut heading_at, mut depth_at) = (None, None);
    let t0 = g.sub.sim_time();
    g.run_with(30.0, |g| {
        if g.ticks.is_multiple_of(2) {
            g.posvel(90.0, 0.5, 5.0);
        }
        let t = g.sub.sim_time() - t0;
        if heading_at.is_none() && herr(g, 90.0) <= 5.0 {
            heading_at = Some(t);
        }
        if depth_at.is_none() && (g.sub.depth() - 5.0).abs() <= 0.3 {
            depth_at = Some(t);
        }
    });
    let (h, d) = (heading_at.unwrap(), depth_at.unwrap());
    assert!(h < 4.0 && d < 8.0, "heading {h} s, depth {d} s");
    assert!((g.sub.vehicle().speed - 0.5).abs() < 0.01);
    assert!(herr(&g, 90.0) < 0.5);
    let z = g
        .heard
        .iter()
        .rev()
        .find_map(|m| match m {
            MavMessage::LOCAL_POSITION_NED(l) => Some(l.z),
            _ => None,
        })
        .unwrap();
    assert!((z - 5.0).abs() < 0.01, "LOCAL_POSITION_NED.z {z}");
}

/// A non-ignored acceleration group drops the whole message with no STATUSTEXT (SITL: 0x0807).
#[test]
fn acceleration_not_ignored_drops_the_whole_target_silently() {
    let mut g = Gcs::armed_in(sub::GUIDED);
    g.heard.clear();
    let dropped = g.sub.stats.targets_dropped;
    g.run_with(5.0, |g| {
        if g.ticks.is_multiple_of(2) {
            g.local(0x0807, (0.0, 0.0, 0.0), (0.0, 1.0, 0.0), 90.0);
        }
    });
    assert!(g.sub.stats.targets_dropped >= dropped + 20);
    assert_eq!(g.sub.stats.targets_followed, 0);
    assert!(g.sub.vehicle().speed.abs() < 1e-9);
    assert!(g.texts().is_empty(), "{:?}", g.texts());
}

/// SET_POSITION_TARGET_GLOBAL_INT in GUIDED: alt = −depth is followed, yaw ignored — the issue's
/// SITL run: depth 4.98 m, heading stayed 0° while the vehicle moved east.
#[test]
fn guided_global_int_follows_depth_but_ignores_yaw() {
    let mut g = Gcs::armed_in(sub::GUIDED);
    let (lat, lon) = (g.sub.vehicle().origin().0, g.sub.vehicle().origin().1);
    g.run_with(20.0, |g| {
        if g.ticks.is_multiple_of(2) {
            g.send(MavMessage::SET_POSITION_TARGET_GLOBAL_INT(
                SET_POSITION_TARGET_GLOBAL_INT_DATA {
                    lat_int: (lat * 1e7) as i32,
                    lon_int: (lon * 1e7) as i32,
                    alt: -5.0,
                    vx: 0.0,
                    vy: 0.5,
                    yaw: std::f32::consts::FRAC_PI_2,
                    type_mask: PositionTargetTypemask::from_bits_retain(0x09C0),
                    target_system: 1,
                    target_component: 1,
                    coordinate_frame: MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT,
                    ..Default::default()
                },
            ));
        }
    });
    assert!((g.sub.depth() - 5.0).abs() < 0.1, "{}", g.sub.depth());
    assert!(herr(&g, 0.0) < 1.0, "heading {}", g.sub.vehicle().heading);
    assert!(g.sub.stats.yaw_ignored > 0);
}

/// Position-only (WP) targets restart the trajectory every time one arrives: sent once, a 3.7 m
/// depth change is done; re-sent at 5 Hz, it hardly moves (SITL: 0.36 m in 20 s).
#[test]
fn position_only_targets_restart_their_trajectory() {
    let change = |resend: bool| {
        let mut g = Gcs::armed_in(sub::GUIDED);
        g.sub.set_depth(1.3);
        g.local(0x0DF8, (0.0, 0.0, 5.0), (0.0, 0.0, 0.0), 0.0);
        g.run_with(20.0, |g| {
            if resend && g.ticks.is_multiple_of(2) {
                g.local(0x0DF8, (0.0, 0.0, 5.0), (0.0, 0.0, 0.0), 0.0);
            }
        });
        g.sub.depth() - 1.3
    };
    let once = change(false);
    let streamed = change(true);
    assert!((once - 3.7).abs() < 0.1, "once: {once}");
    assert!(
        streamed < 1.0 && streamed < once / 3.0,
        "re-sent at 5 Hz: {streamed}"
    );
}

/// 3 s after the last velocity / PosVel target the velocity is zeroed; depth and heading are
/// held; no STATUSTEXT; the mode stays GUIDED; targets are never acknowledged.
#[test]
fn three_seconds_after_the_last_target_velocity_is_zeroed_depth_and_heading_held() {
    let mut g = Gcs::armed_in(sub::GUIDED);
    g.run_with(15.0, |g| {
        if g.ticks.is_multiple_of(2) {
            g.posvel(90.0, 0.5, 3.0);
        }
    });
    assert!((g.sub.vehicle().speed - 0.5).abs() < 0.01);
    g.heard.clear();
    g.run(2.5);
    assert!(g.sub.vehicle().speed > 0.4, "still going before 3 s");
    g.run(5.0);
    assert!(g.sub.vehicle().speed < 0.01);
    assert!((g.sub.depth() - 3.0).abs() < 0.05);
    assert!(herr(&g, 90.0) < 0.5);
    assert_eq!(g.sub.mode(), sub::GUIDED);
    assert!(g.texts().is_empty(), "{:?}", g.texts());
    assert!(
        !g.heard
            .iter()
            .any(|m| matches!(m, MavMessage::COMMAND_ACK(_)))
    );
}

/// LOCAL_NED targets are used only in GUIDED; elsewhere dropped without a word.
#[test]
fn targets_outside_guided_are_dropped() {
    let mut g = Gcs::armed_in(sub::MANUAL);
    g.heard.clear();
    g.posvel(90.0, 0.5, 5.0);
    g.run(3.0);
    assert_eq!(g.sub.stats.targets_followed, 0);
    assert!(g.sub.stats.targets_dropped >= 1);
    assert!(g.sub.depth() < 0.01);
    assert!(g.texts().is_empty());
}

/// ALT_HOLD (no position needed): depth by a z-only GLOBAL_INT (alt = −depth), heading by
/// SET_ATTITUDE_TARGET obeyed 5 s after each, then back to the heading held on entry; forward by
/// MANUAL_CONTROL x (x = 500: 0.49–0.53 m/s), only from MAV_GCS_SYSID.
#[test]
fn alt_hold_depth_heading_and_pilot_thrust() {
    let mut g = Gcs::new(SubOptions {
        position_estimate: false,
        ..Default::default()
    });
    g.run(2.0);
    assert_eq!(g.set_mode(sub::ALT_HOLD), MavResult::MAV_RESULT_ACCEPTED);
    assert_eq!(g.arm(), MavResult::MAV_RESULT_ACCEPTED);
    g.feed_manual = false;
    g.run_with(20.0, |g| {
        if g.ticks.is_multiple_of(10) {
            g.send(MavMessage::SET_POSITION_TARGET_GLOBAL_INT(
                infer::sub_depth_target(5.0, 1, 1, 0),
            ));
        }
        if g.ticks.is_multiple_of(2) {
            g.send(MavMessage::SET_ATTITUDE_TARGET(infer::sub_attitude_target(
                90.0, 1, 1, 0,
            )));
            g.send(MavMessage::MANUAL_CONTROL(infer::manual_control(500, 1)));
        }
    });
    assert!((g.sub.depth() - 5.0).abs() < 0.05, "{}", g.sub.depth());
    assert!(herr(&g, 90.0) < 0.5);
    let v = g.sub.vehicle().speed;
    assert!((0.49..=0.53).contains(&v), "{v}");
    // MANUAL_CONTROL from another system id is not the pilot's.
    let before = g.sub.stats.manual_controls;
    g.send_as(
        1,
        MavMessage::MANUAL_CONTROL(infer::manual_control(1000, 1)),
    );
    assert_eq!(g.sub.stats.manual_controls, before);
    // Attitude stops: obeyed for 5 s, then back to the heading held on entering ALT_HOLD (0°).
    g.feed_manual = true;
    g.run(4.5);
    assert!(herr(&g, 90.0) < 0.5);
    g.run(5.0);
    assert!(herr(&g, 0.0) < 0.5, "{}", g.sub.vehicle().heading);
}

/// GCS failsafe (FS_GCS_ENABLE 2, 5 s): only HEARTBEAT / MANUAL_CONTROL from sysid 255 count,
/// setpoints do not; armed, after the sysid was seen once: "MYGCS: 255, heartbeat lost", disarm,
/// mode stays GUIDED, status 5; "GCS Failsafe Cleared" when heartbeats resume, still disarmed.
#[test]
fn gcs_failsafe_disarms_five_seconds_after_the_last_heartbeat() {
    let mut g = Gcs::armed_in(sub::GUIDED);
    g.sub = SubSession::new(SubOptions {
        pilot_failsafe_s: None,
        ..Default::default()
    });
    g.run(6.0);
    g.set_mode(sub::GUIDED);
    g.arm();
    g.feed_heartbeat = false;
    g.feed_manual = false;
    g.heard.clear();
    // The last HEARTBEAT from 255, now.
    g.send(MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        mavtype: MavType::MAV_TYPE_ONBOARD_CONTROLLER,
        autopilot: MavAutopilot::MAV_AUTOPILOT_INVALID,
        ..Default::default()
    }));
    let t0 = g.sub.sim_time();
    let mut disarmed_at = None;
    g.run_with(8.0, |g| {
        if g.ticks.is_multiple_of(2) {
            g.posvel(90.0, 0.5, 2.0);
        }
        if disarmed_at.is_none() && !g.sub.armed() {
            disarmed_at = Some(g.sub.sim_time() - t0);
        }
    });
    let at = disarmed_at.expect("disarmed");
    assert!((5.0..=5.6).contains(&at), "{at}");
    assert!(
        g.texts()
            .contains(&"MYGCS: 255, heartbeat lost".to_string())
    );
    let h = g.last_heartbeat();
    assert_eq!((h.custom_mode, h.system_status as u8), (4, 5));
    g.feed_heartbeat = true;
    g.run(1.5);
    assert!(g.texts().contains(&"GCS Failsafe Cleared".to_string()));
    assert!(!g.sub.armed());
    // Never seen: no GCS failsafe at all.
    let mut quiet = Gcs::new(SubOptions {
        pilot_failsafe_s: None,
        ..Default::default()
    });
    quiet.feed_heartbeat = false;
    quiet.feed_manual = false;
    quiet.run(6.0);
    quiet.set_mode(sub::GUIDED);
    quiet.arm();
    quiet.run(10.0);
    assert!(quiet.sub.armed());
}

/// Pilot-input failsafe (FS_PILOT_INPUT 2, 3 s, no RC as on a BlueROV2): "Lost manual control"
/// and disarm 3 s after the last MANUAL_CONTROL; HEARTBEATs and setpoints do not feed it; neutral
/// MANUAL_CONTROL more often than every 3 s does.
#[test]
fn pilot_input_failsafe_disarms_three_seconds_after_the_last_manual_control() {
    let mut g = Gcs::armed_in(sub::GUIDED);
    g.run(10.0);
    assert!(g.sub.armed(), "fed by neutral MANUAL_CONTROL at 2 Hz");
    g.feed_manual = false;
    g.heard.clear();
    let t0 = g.sub.sim_time();
    let mut disarmed_at = None;
    g.run_with(6.0, |g| {
        if g.ticks.is_multiple_of(2) {
            g.posvel(90.0, 0.5, 2.0);
        }
        if disarmed_at.is_none() && !g.sub.armed() {
            disarmed_at = Some(g.sub.sim_time() - t0);
        }
    });
    let at = disarmed_at.expect("disarmed");
    assert!((2.9..=3.6).contains(&at), "{at}");
    assert!(g.texts().contains(&"Lost manual control".to_string()));
    assert_eq!(g.last_heartbeat().system_status as u8, 5);
}

/// Leak (FS_LEAK_ENABLE 1): "Leak Detected", status 5 CRITICAL, repeated every 20 s; with 2, an
/// armed vehicle goes to SURFACE, which climbs and then switches itself to ALT_HOLD.
#[test]
fn leak_warns_critical_and_surface_climbs_then_holds() {
    let mut g = Gcs::armed_in(sub::GUIDED);
    let mut out = Vec::new();
    g.sub.inject_leak(&mut out);
    g.take(out);
    assert!(g.texts().contains(&"Leak Detected".to_string()));
    assert_eq!(g.last_heartbeat().system_status as u8, 5);
    assert_eq!(g.sub.mode(), sub::GUIDED);
    g.heard.clear();
    g.run(21.0);
    assert!(g.texts().contains(&"Leak Detected".to_string()));
    let mut g = Gcs::new(SubOptions {
        leak_surfaces: true,
        ..Default::default()
    });
    g.run(6.0);
    g.set_mode(sub::GUIDED);
    g.arm();
    g.sub.set_depth(3.1);
    let mut out = Vec::new();
    g.sub.inject_leak(&mut out);
    g.take(out);
    assert_eq!(g.sub.mode(), sub::SURFACE);
    g.run(5.0);
    assert!(g.sub.depth() < 0.06);
    assert_eq!(g.sub.mode(), sub::ALT_HOLD);
}

/// Depth signs: LOCAL_POSITION_NED.z is metres down; GLOBAL_POSITION_INT.relative_alt and
/// VFR_HUD.alt are negative under water, and relative_alt's zero moves to wherever the vehicle
/// was armed; pressure rises about 99 hPa per metre.
#[test]
fn depth_sign_conventions() {
    let mut g = Gcs::new(SubOptions::default());
    g.run(6.0);
    g.sub.set_depth(1.0);
    g.set_mode(sub::GUIDED);
    g.arm();
    for (id, hz) in [
        (LOCAL_POSITION_NED_ID, 5.0),
        (GLOBAL_POSITION_INT_ID, 5.0),
        (VFR_HUD_ID, 5.0),
        (SCALED_PRESSURE2_ID, 5.0),
    ] {
        g.stream(id, hz);
    }
    g.run_with(20.0, |g| {
        if g.ticks.is_multiple_of(2) {
            g.posvel(0.0, 0.0, 5.0);
        }
    });
    g.heard.clear();
    g.run_with(1.0, |g| {
        if g.ticks.is_multiple_of(2) {
            g.posvel(0.0, 0.0, 5.0);
        }
    });
    let (mut z, mut rel, mut hud, mut p) = (None, None, None, None);
    for m in &g.heard {
        match m {
            MavMessage::LOCAL_POSITION_NED(l) => z = Some(l.z),
            MavMessage::GLOBAL_POSITION_INT(q) => rel = Some(q.relative_alt),
            MavMessage::VFR_HUD(v) => hud = Some(v.alt),
            MavMessage::SCALED_PRESSURE2(s) => p = Some(s.press_abs),
            _ => {}
        }
    }
    let (z, rel, hud, p) = (z.unwrap(), rel.unwrap(), hud.unwrap(), p.unwrap());
    assert!((z - 5.0).abs() < 0.02, "{z}");
    assert!(
        (rel + 4000).abs() < 30,
        "armed at 1 m: relative_alt {rel} mm"
    );
    assert!((hud + 5.0).abs() < 0.05, "{hud}");
    assert!((p - (1023.0 + 99.1 * 5.0)).abs() < 3.0, "{p}");
}

/// The water has a surface and a bottom (SITL's sea floor at 50 m); disarmed, the vehicle
/// floats up at about 0.1 m/s.
#[test]
fn surface_bottom_and_floating_up_when_disarmed() {
    let mut g = Gcs::armed_in(sub::GUIDED);
    g.run_with(60.0, |g| {
        if g.ticks.is_multiple_of(2) {
            g.posvel(0.0, 0.0, 80.0);
        }
    });
    assert!((g.sub.depth() - 50.0).abs() < 1e-9, "{}", g.sub.depth());
    assert_eq!(
        g.command(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, 0.0, 0.0),
        MavResult::MAV_RESULT_ACCEPTED
    );
    g.run(10.0);
    let d = g.sub.depth();
    assert!((48.9..=49.1).contains(&d), "{d}");
    g.sub.set_depth(0.2);
    g.run(5.0);
    assert_eq!(g.sub.depth(), 0.0);
}

/// MAV_CMD_DO_CHANGE_SPEED: param2 0.5 ACCEPTED (WP speed only), 0 DENIED.
#[test]
fn change_speed_accepts_a_speed_and_denies_zero() {
    let mut g = Gcs::armed_in(sub::GUIDED);
    assert_eq!(
        g.command(MavCmd::MAV_CMD_DO_CHANGE_SPEED, 1.0, 0.5),
        MavResult::MAV_RESULT_ACCEPTED
    );
    assert_eq!(
        g.command(MavCmd::MAV_CMD_DO_CHANGE_SPEED, 1.0, 0.0),
        MavResult::MAV_RESULT_DENIED
    );
}
