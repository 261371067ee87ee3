//! ArduSub's part of the one ArduPilot emulator (BlueROV2, `vectored` frame), on the simulator's
//! vehicle model with depth dynamics (`frontseat sim --vehicle ardusub`), from
//! `shared/protocol/ardupilot/ardusub.md`: HEARTBEAT type SUBMARINE booting in MANUAL 19, GUIDED
//! and the other position modes refused "requires position" without an estimate, the streams
//! (depth = LOCAL_POSITION_NED.z, relative_alt re-zeroed at each arming, pressure), the targets
//! GUIDED follows and the ones it drops or ignores (a non-ignored acceleration drops the message,
//! GLOBAL_INT's yaw is ignored, position-only targets restart their trajectory), the 3 s velocity
//! timeout, ALT_HOLD's depth / attitude / pilot-thrust path, and the GCS, pilot-input and leak
//! failsafes. What every firmware does alike (frames, modes, arming, COMMAND_ACK, STATUSTEXT,
//! the streams' schedule) is the emulator's (`super`).

use mavlink::MessageData;

use frontseat_sim::vehicle::{Limits, Setpoint, Vehicle, short_turn, wrap_heading};

use super::link::{self, Autopilot, Snapshot};
use super::{FirmwarePart, SubSession};
use crate::codec::MavMessage;
use crate::dialect::*;
use crate::infer::{
    self, EKF_READY, SUB_ATTITUDE_TIMEOUT_S, SUB_TARGET_TIMEOUT_S, SubTarget, quaternion_heading,
};
use crate::modes::{Firmware, sub};

/// How the emulated Sub starts, and its parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct SubOptions {
    pub lat: f64,
    pub lon: f64,
    pub system_id: u8,
    pub component_id: u8,
    /// MAV_GCS_SYSID: the only sender whose HEARTBEAT / MANUAL_CONTROL count.
    pub gcs_sysid: u8,
    /// Sim seconds of boot (no arming, EKF uninitialised).
    pub init_s: f64,
    /// Sim seconds until the EKF has a horizontal position (GPS/DVL).
    pub ekf_ready_s: f64,
    /// A position estimate at all (false: a BlueROV2 with only its depth sensor).
    pub position_estimate: bool,
    /// Sea floor depth. Unit: m (SITL: 50).
    pub bottom_m: f64,
    /// WPNAV_SPEED_DN / WPNAV_SPEED_UP. Unit: m/s.
    pub speed_dn: f64,
    pub speed_up: f64,
    /// Vertical acceleration limit (PILOT_ACCEL_Z 200 cm/s²). Unit: m/s².
    pub accel_z: f64,
    /// Depth controller gain: commanded vertical speed per metre of error. Unit: 1/s.
    pub depth_gain: f64,
    /// A position-only target's vertical acceleration from rest, restarted at each arrival. m/s².
    pub wp_accel_z: f64,
    /// WPNAV_SPEED. Unit: m/s.
    pub wp_speed: f64,
    /// Horizontal speed at MANUAL_CONTROL x = 1000. Unit: m/s (SITL, JS_GAIN 0.5: 1.04).
    pub thrust_full_mps: f64,
    /// Turn rate (AUTO_YAW_SLEW_RATE 60°/s caps it). Unit: deg/s.
    pub hdg_rate: f64,
    /// Horizontal acceleration. Unit: m/s².
    pub accel: f64,
    /// FS_GCS_ENABLE = 2 (disarm) after FS_GCS_TIMEOUT s.
    pub gcs_failsafe_s: Option<f64>,
    /// FS_PILOT_INPUT = 2 (disarm) after FS_PILOT_TIMEOUT s, when no RC feeds it (a BlueROV2;
    /// SITL feeds neutral RC and never trips: None).
    pub pilot_failsafe_s: Option<f64>,
    /// FS_LEAK_ENABLE = 2: a leak switches an armed vehicle to SURFACE (1: warn only).
    pub leak_surfaces: bool,
    /// Rise rate of a disarmed vehicle. Unit: m/s (SITL: about 0.1).
    pub float_up: f64,
}

impl Default for SubOptions {
    fn default() -> Self {
        Self {
            lat: 42.358456,
            lon: -71.087589,
            system_id: 1,
            component_id: 1,
            gcs_sysid: 255,
            init_s: 1.0,
            ekf_ready_s: 5.0,
            position_estimate: true,
            bottom_m: 50.0,
            speed_dn: 1.5,
            speed_up: 2.5,
            accel_z: 2.0,
            depth_gain: 1.0,
            wp_accel_z: 0.25,
            wp_speed: 1.0,
            thrust_full_mps: 1.04,
            hdg_rate: 45.0,
            accel: 0.5,
            gcs_failsafe_s: Some(5.0),
            pilot_failsafe_s: Some(3.0),
            leak_surfaces: false,
            float_up: 0.1,
        }
    }
}

/// What the emulated Sub saw and did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SubStats {
    pub frames_in: u64,
    pub bad_input: u64,
    pub gcs_heartbeats: u64,
    pub manual_controls: u64,
    pub commands: u64,
    pub targets_followed: u64,
    /// Dropped without a word: outside GUIDED, another system, a non-ignored acceleration, an
    /// unsupported frame.
    pub targets_dropped: u64,
    /// GLOBAL_INT targets whose yaw GUIDED ignored.
    pub yaw_ignored: u64,
    pub attitude_targets: u64,
    pub target_timeouts: u64,
    pub wp_restarts: u64,
    pub gcs_failsafes: u64,
    pub pilot_failsafes: u64,
    pub statustexts: Vec<String>,
    pub last_target: Option<SubTarget>,
}
shared_counters!(SubStats);

/// Streamed messages the Sub sends beside every firmware's, by id.
const EXTRA_STREAMS: [u32; 3] = [
    LOCAL_POSITION_NED_DATA::ID,
    SCALED_PRESSURE_DATA::ID,
    SCALED_PRESSURE2_DATA::ID,
];
/// RC_OVERRIDE_TIME: a pilot input lasts this long.
const RC_OVERRIDE_S: f64 = 3.0;
/// Surface pressure and its rise per metre of water (ardusub.md: ≈ 99 hPa/m). Unit: hPa.
const SURFACE_HPA: f64 = 1023.0;
const HPA_PER_M: f64 = 99.1;
/// A leak is repeated this often (FS_LEAK_ENABLE 1).
const LEAK_REPEAT_S: f64 = 20.0;

/// What GUIDED is following.
#[derive(Debug, Clone, PartialEq)]
enum Guided {
    /// Velocity north/east (m/s), optional depth, optional yaw (deg), from when.
    Velocity {
        vel: (f64, f64),
        depth: Option<f64>,
        vz: f64,
        yaw: Option<f64>,
        at: f64,
    },
    /// Drive to a point; the vertical trajectory restarts at `at`.
    Waypoint {
        north: f64,
        east: f64,
        depth: f64,
        yaw: Option<f64>,
        at: f64,
    },
}

/// ArduSub's own state.
pub struct Sub {
    opts: SubOptions,
    /// Vertical speed, m/s down.
    w: f64,
    depth_target: f64,
    heading_hold: f64,
    guided: Option<Guided>,
    /// ALT_HOLD: (heading, when) of the last attitude target.
    attitude: Option<(f64, f64)>,
    /// Pilot input: (x, z, when).
    manual: Option<(i16, i16, f64)>,
    gcs_seen: Option<f64>,
    gcs_failsafe: bool,
    pilot_seen: Option<f64>,
    armed_at: f64,
    pilot_failsafe: bool,
    leak: Option<f64>,
    /// relative_alt's zero (home), re-set at each arming.
    home_depth: f64,
}

impl SubSession {
    pub fn depth(&self) -> f64 {
        self.vehicle.depth
    }

    /// Places the vehicle at a depth (tests start from one).
    pub fn set_depth(&mut self, d: f64) {
        self.vehicle.depth = d.clamp(0.0, self.fw.opts.bottom_m);
        self.fw.depth_target = self.vehicle.depth;
    }

    /// The EKF has a horizontal position (GUIDED, AUTO, POSHOLD, CIRCLE may be entered).
    pub fn position_ok(&self) -> bool {
        self.fw.opts.position_estimate && self.ap.t >= self.fw.opts.ekf_ready_s
    }

    /// A target GUIDED accepted.
    fn follow(&mut self, t: SubTarget) {
        let now = self.ap.t;
        let g = match &t {
            SubTarget::PosVel { pos, vel, yaw } => Guided::Velocity {
                vel: *vel,
                depth: Some(pos.2),
                vz: 0.0,
                yaw: *yaw,
                at: now,
            },
            SubTarget::Vel { vel, yaw } => Guided::Velocity {
                vel: (vel.0, vel.1),
                depth: None,
                vz: vel.2,
                yaw: *yaw,
                at: now,
            },
            SubTarget::Wp { pos, yaw } => {
                self.stats.wp_restarts += 1;
                // The trajectory starts again from rest at each arrival.
                self.fw.w = 0.0;
                Guided::Waypoint {
                    north: pos.0,
                    east: pos.1,
                    depth: pos.2,
                    yaw: *yaw,
                    at: now,
                }
            }
            SubTarget::Dropped(_) => {
                self.stats.targets_dropped += 1;
                return;
            }
        };
        self.stats.targets_followed += 1;
        self.stats.last_target = Some(t);
        self.fw.guided = Some(g);
    }

    fn north_east_down(&mut self) -> (f64, f64, f64) {
        (self.vehicle.y, self.vehicle.x, self.vehicle.depth)
    }

    fn local_target(&mut self, p: &SET_POSITION_TARGET_LOCAL_NED_DATA) {
        if !self.ap.for_me(p.target_system) || self.mode != sub::GUIDED {
            self.stats.targets_dropped += 1;
            return;
        }
        let frame = p.coordinate_frame as u8;
        let (pos, vel) = match frame {
            1 | 7 => ((p.x, p.y, p.z), (p.vx, p.vy, p.vz)),
            // Body frames: rotated by the yaw at reception.
            8 | 9 | 12 => {
                let h = self.vehicle.heading.to_radians() as f32;
                let rot = |a: f32, b: f32| (a * h.cos() - b * h.sin(), a * h.sin() + b * h.cos());
                let (px, py) = rot(p.x, p.y);
                let (vx, vy) = rot(p.vx, p.vy);
                ((px, py, p.z), (vx, vy, p.vz))
            }
            _ => {
                self.stats.targets_dropped += 1;
                return;
            }
        };
        let here = self.north_east_down();
        // Body frames other than BODY_NED add the current position too.
        let f = if matches!(frame, 9 | 12) { 7 } else { frame };
        let mut t = infer::interpret_sub_target(p.type_mask.bits(), f, here, pos, vel, p.yaw);
        // Yaw is relative only in BODY_OFFSET_NED.
        if frame == 9
            && let SubTarget::PosVel { yaw: Some(y), .. }
            | SubTarget::Vel { yaw: Some(y), .. }
            | SubTarget::Wp { yaw: Some(y), .. } = &mut t
        {
            *y = wrap_heading(*y + self.vehicle.heading);
        }
        self.follow(t);
    }

    fn global_target(&mut self, p: &SET_POSITION_TARGET_GLOBAL_INT_DATA) {
        if !self.ap.for_me(p.target_system) {
            self.stats.targets_dropped += 1;
            return;
        }
        let mask = p.type_mask.bits();
        match self.mode {
            // ALT_HOLD: z alone sets the depth target (alt = −depth); frame and lat/lon ignored.
            sub::ALT_HOLD if mask & 0b100 == 0 && p.alt.is_finite() => {
                self.fw.depth_target = (-f64::from(p.alt)).clamp(0.0, self.fw.opts.bottom_m);
                self.stats.targets_followed += 1;
            }
            sub::GUIDED => {
                // GUIDED ignores the yaw and yaw-rate fields of a GLOBAL_INT target.
                if mask & (1 << 10) == 0 {
                    self.stats.yaw_ignored += 1;
                }
                let (lat0, lon0) = self.vehicle.origin();
                let north = (f64::from(p.lat_int) * 1e-7 - lat0) * 111_320.0;
                let east =
                    (f64::from(p.lon_int) * 1e-7 - lon0) * 111_320.0 * lat0.to_radians().cos();
                let t = infer::interpret_sub_target(
                    mask | (1 << 10),
                    1,
                    (0.0, 0.0, 0.0),
                    (north as f32, east as f32, -p.alt),
                    (p.vx, p.vy, p.vz),
                    0.0,
                );
                self.follow(t);
            }
            _ => self.stats.targets_dropped += 1,
        }
    }

    fn attitude_target(&mut self, a: &SET_ATTITUDE_TARGET_DATA) {
        let mask = a.type_mask.bits();
        if !self.ap.for_me(a.target_system) || self.mode != sub::ALT_HOLD || mask & 0x40 == 0 {
            // GUIDED's attitude path (bits 6 and 7 clear) gives no speed: not emulated.
            self.stats.targets_dropped += 1;
            return;
        }
        if let Some(h) = quaternion_heading(a.q) {
            self.stats.attitude_targets += 1;
            self.fw.attitude = Some((h, self.ap.t));
        }
    }

    /// HEARTBEAT / MANUAL_CONTROL / RC override from MAV_GCS_SYSID: the GCS failsafe's food.
    fn gcs_alive(&mut self, out: &mut Vec<u8>) {
        self.fw.gcs_seen = Some(self.ap.t);
        if self.fw.gcs_failsafe {
            self.fw.gcs_failsafe = false;
            self.statustext(
                MavSeverity::MAV_SEVERITY_CRITICAL,
                "GCS Failsafe Cleared",
                out,
            );
        }
    }

    fn pilot_input(&mut self, x: i16, z: i16, out: &mut Vec<u8>) {
        self.fw.pilot_seen = Some(self.ap.t);
        self.fw.manual = Some((x.clamp(-1000, 1000), z.clamp(0, 1000), self.ap.t));
        if self.fw.pilot_failsafe {
            self.fw.pilot_failsafe = false;
            self.statustext(
                MavSeverity::MAV_SEVERITY_CRITICAL,
                "Manual control regained",
                out,
            );
        }
    }

    /// The pilot (a joystick button, QGroundControl) selects a mode.
    pub fn pilot_sets_mode(&mut self, mode: u32, out: &mut Vec<u8>) {
        self.set_mode(mode, out);
    }

    /// A leak detector trips (FS_LEAK_ENABLE 1 warns; with `leak_surfaces`, SURFACE if armed).
    pub fn inject_leak(&mut self, out: &mut Vec<u8>) {
        self.fw.leak = Some(self.ap.t);
        self.statustext(MavSeverity::MAV_SEVERITY_CRITICAL, "Leak Detected", out);
        if self.fw.opts.leak_surfaces && self.armed {
            self.set_mode(sub::SURFACE, out);
        }
        self.heartbeat(out);
    }

    fn failsafes(&mut self, out: &mut Vec<u8>) {
        if let (Some(limit), Some(seen)) = (self.fw.opts.gcs_failsafe_s, self.fw.gcs_seen)
            && self.armed
            && !self.fw.gcs_failsafe
            && self.ap.t - seen > limit
        {
            self.fw.gcs_failsafe = true;
            self.stats.gcs_failsafes += 1;
            let text = format!("MYGCS: {}, heartbeat lost", self.fw.opts.gcs_sysid);
            self.statustext(MavSeverity::MAV_SEVERITY_CRITICAL, &text, out);
            self.disarm("Disarming motors", out);
        }
        if let Some(limit) = self.fw.opts.pilot_failsafe_s
            && self.armed
            && !self.fw.pilot_failsafe
            && self.ap.t - self.fw.pilot_seen.unwrap_or(0.0).max(self.fw.armed_at) > limit
        {
            self.fw.pilot_failsafe = true;
            self.stats.pilot_failsafes += 1;
            self.statustext(
                MavSeverity::MAV_SEVERITY_CRITICAL,
                "Lost manual control",
                out,
            );
            self.disarm("Disarming motors", out);
        }
        if let Some(since) = self.fw.leak
            && self.ap.t - since >= LEAK_REPEAT_S
        {
            self.fw.leak = Some(self.ap.t);
            self.statustext(MavSeverity::MAV_SEVERITY_CRITICAL, "Leak Detected", out);
        }
    }

    /// The pilot's forward input (m/s), while its override lasts.
    fn pilot_forward(&self) -> f64 {
        match self.fw.manual {
            Some((x, _, at)) if self.ap.t - at <= RC_OVERRIDE_S => {
                f64::from(x) / 1000.0 * self.fw.opts.thrust_full_mps
            }
            _ => 0.0,
        }
    }

    /// Heading, horizontal speed, and the depth controller's (target, max down, max up).
    fn control(&mut self, out: &mut Vec<u8>) -> (f64, f64, f64, f64, f64) {
        let (dn, up) = (self.fw.opts.speed_dn, self.fw.opts.speed_up);
        let here = self.vehicle.heading;
        if !self.armed {
            // Positive buoyancy: a disarmed vehicle floats up.
            return (
                here,
                0.0,
                0.0,
                -self.fw.opts.float_up,
                self.fw.opts.float_up,
            );
        }
        match self.mode {
            sub::GUIDED => {
                let timed_out = match &self.fw.guided {
                    Some(Guided::Velocity { at, .. }) => self.ap.t - at >= SUB_TARGET_TIMEOUT_S,
                    _ => false,
                };
                if timed_out {
                    // Velocity zeroed; depth and heading held (no STATUSTEXT).
                    self.stats.target_timeouts += 1;
                    if let Some(Guided::Velocity { depth, yaw, .. }) = self.fw.guided.take() {
                        self.fw.depth_target = depth.unwrap_or(self.vehicle.depth);
                        self.fw.heading_hold = yaw.unwrap_or(here);
                    }
                }
                match self.fw.guided.clone() {
                    Some(Guided::Velocity {
                        vel,
                        depth,
                        vz,
                        yaw,
                        ..
                    }) => {
                        if let Some(y) = yaw {
                            self.fw.heading_hold = y;
                        }
                        let speed = vel.0.hypot(vel.1);
                        let target = match depth {
                            Some(d) => d,
                            None => self.vehicle.depth + vz,
                        };
                        self.fw.depth_target = target;
                        (self.fw.heading_hold, speed, target, dn, up)
                    }
                    Some(Guided::Waypoint {
                        north,
                        east,
                        depth,
                        yaw,
                        at,
                    }) => {
                        let (n, e, _) = self.north_east_down();
                        let (dn_, de) = (north - n, east - e);
                        let dist = dn_.hypot(de);
                        let bearing = wrap_heading(de.atan2(dn_).to_degrees());
                        let heading = yaw.unwrap_or(if dist > 1.0 { bearing } else { here });
                        let speed = if dist > 1.0 {
                            self.fw.opts.wp_speed
                        } else {
                            0.0
                        };
                        // The restarted trajectory: vertical speed grows from rest.
                        let ramp = self.fw.opts.wp_accel_z * (self.ap.t - at);
                        self.fw.depth_target = depth;
                        (heading, speed, depth, ramp.min(dn), ramp.min(up))
                    }
                    None => (self.fw.heading_hold, 0.0, self.fw.depth_target, dn, up),
                }
            }
            sub::ALT_HOLD => {
                let heading = match self.fw.attitude {
                    Some((h, at)) if self.ap.t - at <= SUB_ATTITUDE_TIMEOUT_S => h,
                    _ => self.fw.heading_hold,
                };
                (heading, self.pilot_forward(), self.fw.depth_target, dn, up)
            }
            sub::SURFACE => {
                if self.vehicle.depth <= 0.05 {
                    self.set_mode(sub::ALT_HOLD, out);
                }
                (here, 0.0, 0.0, dn, up)
            }
            // MANUAL, STABILIZE, ACRO: the pilot's thrust; depth holds (neutral buoyancy).
            _ => (here, self.pilot_forward(), self.fw.depth_target, dn, up),
        }
    }
}

impl FirmwarePart for Sub {
    type Options = SubOptions;
    type Stats = SubStats;
    const FIRMWARE: Firmware = Firmware::Sub;
    const POWER_ON_MODE: u32 = sub::MANUAL;
    const BOOTING: MavState = MavState::MAV_STATE_BOOT;
    const DISARM_HEARTBEAT: bool = true;

    fn start(opts: SubOptions) -> (Self, Vehicle, Autopilot) {
        let limits = Limits {
            accel: opts.accel,
            hdg_rate: opts.hdg_rate,
            // Depth is ours (below): the model's own depth stays where we put it.
            z_rate: 0.0,
        };
        let vehicle = Vehicle::new(opts.lat, opts.lon, limits, (0.0, 0.0));
        let ap = Autopilot::new(
            opts.system_id,
            opts.component_id,
            opts.init_s,
            &EXTRA_STREAMS,
        );
        let part = Sub {
            opts,
            w: 0.0,
            depth_target: 0.0,
            heading_hold: 0.0,
            guided: None,
            attitude: None,
            manual: None,
            gcs_seen: None,
            gcs_failsafe: false,
            pilot_seen: None,
            armed_at: 0.0,
            pilot_failsafe: false,
            leak: None,
            home_depth: 0.0,
        };
        (part, vehicle, ap)
    }

    fn mav_type(&self) -> MavType {
        MavType::MAV_TYPE_SUBMARINE
    }

    /// ardusub.md: 0x51 disarmed (0x80 added when armed), whatever the mode.
    fn mode_flags(_: u32) -> MavModeFlag {
        MavModeFlag::MAV_MODE_FLAG_STABILIZE_ENABLED
            | MavModeFlag::MAV_MODE_FLAG_MANUAL_INPUT_ENABLED
    }

    fn failsafe(&self) -> bool {
        self.gcs_failsafe || self.pilot_failsafe || self.leak.is_some()
    }

    /// GUIDED, AUTO, POSHOLD and CIRCLE need a position estimate.
    fn refuses_mode(s: &mut SubSession, mode: u32, out: &mut Vec<u8>) -> bool {
        let needs_position = matches!(mode, sub::GUIDED | sub::AUTO | sub::POSHOLD | sub::CIRCLE);
        let refused = needs_position && !s.position_ok();
        if refused {
            let name = Firmware::Sub.mode_name(mode).unwrap_or("mode");
            s.statustext(
                MavSeverity::MAV_SEVERITY_WARNING,
                &format!("Mode change failed: {name} requires position"),
                out,
            );
        }
        refused
    }

    fn entering(s: &mut SubSession, _: u32) {
        s.fw.guided = None;
        s.fw.attitude = None;
        // Every mode starts by holding what it finds.
        s.fw.depth_target = s.vehicle.depth;
        s.fw.heading_hold = s.vehicle.heading;
    }

    /// The WP speed, and a heading in GUIDED.
    fn command(s: &mut SubSession, c: &COMMAND_LONG_DATA, _: &mut Vec<u8>) -> MavResult {
        match c.command {
            // ardusub.md: param2 > 0 sets the WP speed only; 0 is DENIED.
            MavCmd::MAV_CMD_DO_CHANGE_SPEED => {
                if c.param2.is_finite() && c.param2 > 0.0 {
                    s.fw.opts.wp_speed = f64::from(c.param2).min(5.0);
                    MavResult::MAV_RESULT_ACCEPTED
                } else {
                    MavResult::MAV_RESULT_DENIED
                }
            }
            MavCmd::MAV_CMD_CONDITION_YAW if s.mode == sub::GUIDED => {
                if c.param1.is_finite() {
                    s.fw.heading_hold = wrap_heading(f64::from(c.param1));
                    if let Some(Guided::Velocity { yaw, .. } | Guided::Waypoint { yaw, .. }) =
                        &mut s.fw.guided
                    {
                        *yaw = Some(s.fw.heading_hold);
                    }
                    MavResult::MAV_RESULT_ACCEPTED
                } else {
                    MavResult::MAV_RESULT_DENIED
                }
            }
            _ => MavResult::MAV_RESULT_UNSUPPORTED,
        }
    }

    fn armed(s: &mut SubSession) {
        s.fw.armed_at = s.ap.t;
        // Home moves to here at every arming: relative_alt's zero moves.
        s.fw.home_depth = s.vehicle.depth;
        s.fw.depth_target = s.vehicle.depth;
        s.fw.heading_hold = s.vehicle.heading;
    }

    fn booted(s: &mut SubSession, out: &mut Vec<u8>) {
        s.statustext(
            MavSeverity::MAV_SEVERITY_INFO,
            "ArduSub V4.7.0-dev (emulated)",
            out,
        );
    }

    fn handle(s: &mut SubSession, sender: u8, msg: MavMessage, out: &mut Vec<u8>) {
        let gcs = sender == s.fw.opts.gcs_sysid;
        match msg {
            MavMessage::HEARTBEAT(_) if gcs => {
                s.stats.gcs_heartbeats += 1;
                s.gcs_alive(out);
            }
            // Accepted only from MAV_GCS_SYSID with target = MAV_SYSID.
            MavMessage::MANUAL_CONTROL(m) if gcs && m.target == s.fw.opts.system_id => {
                s.stats.manual_controls += 1;
                s.gcs_alive(out);
                s.pilot_input(m.x, m.z, out);
                // Buttons fire BTNn_FUNCTION: BTN4 disarm, BTN6 arm (defaults).
                if m.buttons & (1 << 4) != 0 {
                    s.disarm("Disarming motors", out);
                }
            }
            MavMessage::RC_CHANNELS_OVERRIDE(r) if gcs && s.ap.for_me(r.target_system) => {
                s.gcs_alive(out);
                let x = (i32::from(r.chan5_raw) - 1500).clamp(-500, 500) * 2;
                let z = (i32::from(r.chan3_raw) - 1000).clamp(0, 1000);
                s.pilot_input(x as i16, z as i16, out);
            }
            MavMessage::SET_POSITION_TARGET_LOCAL_NED(p) => s.local_target(&p),
            MavMessage::SET_POSITION_TARGET_GLOBAL_INT(p) => s.global_target(&p),
            MavMessage::SET_ATTITUDE_TARGET(a) => s.attitude_target(&a),
            _ => {}
        }
    }

    fn drive(s: &mut SubSession, dt: f64, out: &mut Vec<u8>) {
        s.failsafes(out);
        let (heading, speed, target, max_dn, max_up) = s.control(out);
        let target = target.clamp(0.0, s.fw.opts.bottom_m);
        let want_w = if s.armed {
            (s.fw.opts.depth_gain * (target - s.vehicle.depth)).clamp(-max_up, max_dn)
        } else {
            -s.fw.opts.float_up
        };
        let dw = (want_w - s.fw.w).clamp(-s.fw.opts.accel_z * dt, s.fw.opts.accel_z * dt);
        s.fw.w += dw;
        let mut d = s.vehicle.depth + s.fw.w * dt;
        if d <= 0.0 {
            d = 0.0;
            s.fw.w = s.fw.w.max(0.0);
        } else if d >= s.fw.opts.bottom_m {
            d = s.fw.opts.bottom_m;
            s.fw.w = s.fw.w.min(0.0);
        }
        s.vehicle.depth = d;
        s.vehicle.set_setpoint(Setpoint {
            heading,
            speed,
            depth: d,
        });
        s.vehicle.step(dt);
    }

    fn stream(s: &mut SubSession, id: u32, snap: &Snapshot) -> Option<MavMessage> {
        let (n, e, depth) = s.north_east_down();
        let pos = s.position_ok();
        let w = s.fw.w;
        Some(match id {
            GLOBAL_POSITION_INT_DATA::ID => link::global_position(
                snap,
                (-depth * 1000.0) as i32,
                // Home (its zero) was re-set at arming.
                (-(depth - s.fw.home_depth) * 1000.0) as i32,
                (w * 100.0).round() as i16,
            ),
            LOCAL_POSITION_NED_DATA::ID => {
                MavMessage::LOCAL_POSITION_NED(LOCAL_POSITION_NED_DATA {
                    time_boot_ms: snap.boot_ms,
                    x: n as f32,
                    y: e as f32,
                    z: depth as f32,
                    vx: snap.vn as f32,
                    vy: snap.ve as f32,
                    vz: w as f32,
                })
            }
            // A vectored frame dives level; a little nose-down while descending.
            ATTITUDE_DATA::ID => link::attitude(snap, (-0.05 * w) as f32),
            VFR_HUD_DATA::ID => link::vfr_hud(snap, -depth as f32, -w as f32, 0),
            SYS_STATUS_DATA::ID => {
                let depth_sensor = MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE;
                let present = MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_GYRO
                    | MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_ACCEL
                    | MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_MAG
                    | depth_sensor;
                link::sys_status(present, present, 16_000, 300)
            }
            GPS_RAW_INT_DATA::ID => link::gps_raw(
                snap,
                s.ap.t,
                if pos {
                    GpsFixType::GPS_FIX_TYPE_RTK_FIXED
                } else {
                    GpsFixType::GPS_FIX_TYPE_NO_GPS
                },
                if pos { 10 } else { 0 },
                0,
                0,
            ),
            EKF_STATUS_REPORT_DATA::ID => link::ekf_report(if s.ap.initialising() {
                EkfStatusFlags::EKF_UNINITIALIZED.bits()
            } else if pos {
                EKF_READY
            } else {
                // Attitude, velocities and depth; constant position.
                0x00A7
            }),
            // SITL makes every baro a water sensor; a BlueROV2's Bar30 is instance 1.
            SCALED_PRESSURE_DATA::ID | SCALED_PRESSURE2_DATA::ID => {
                let p = (SURFACE_HPA + HPA_PER_M * depth) as f32;
                if id == SCALED_PRESSURE_DATA::ID {
                    MavMessage::SCALED_PRESSURE(SCALED_PRESSURE_DATA {
                        time_boot_ms: snap.boot_ms,
                        press_abs: p,
                        temperature: 1500,
                        ..Default::default()
                    })
                } else {
                    MavMessage::SCALED_PRESSURE2(SCALED_PRESSURE2_DATA {
                        time_boot_ms: snap.boot_ms,
                        press_abs: p,
                        press_diff: 0.0,
                        temperature: 1500,
                    })
                }
            }
            _ => return None,
        })
    }
}

/// The signed heading error from `from` to `to`, degrees (for tests and the demo's figures).
pub fn heading_error(from: f64, to: f64) -> f64 {
    short_turn(from, to)
}
