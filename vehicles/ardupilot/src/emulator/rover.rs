//! The Rover's part of the one ArduPilot emulator (motorboat frame), on the simulator's
//! vehicle model: HEARTBEAT type SURFACE_BOAT with its mode flags, GUIDED targets read by the
//! README's type_mask rules and ignored outside GUIDED, the 3 s target timeout on sim time,
//! WP_SPEED, and readiness: an EKF that needs time for an absolute position, and the EKF failsafe
//! to HOLD of a vehicle put in GUIDED before it. What every firmware does alike (frames, modes,
//! arming, COMMAND_ACK, STATUSTEXT, the streams' schedule) is the emulator's (`super`).

use mavlink::MessageData;

use frontseat_sim::vehicle::{Limits, Setpoint, Vehicle};

use super::link::{self, Autopilot, Snapshot};
use super::{FirmwarePart, RoverSession};
use crate::codec::MavMessage;
use crate::dialect::*;
use crate::infer::{self, EKF_READY, TARGET_TIMEOUT_S, TARGET_TIMEOUT_TEXT, Target};
use crate::modes::{Firmware, rover};

/// How the emulated Rover starts.
#[derive(Debug, Clone, PartialEq)]
pub struct RoverOptions {
    pub lat: f64,
    pub lon: f64,
    pub limits: Limits,
    pub system_id: u8,
    pub component_id: u8,
    /// WP_SPEED: GUIDED speeds above it are silently capped. m/s (rover.parm sets 5).
    pub wp_speed: f64,
    /// Sim seconds in INITIALISING (no arming, no position).
    pub init_s: f64,
    /// Sim seconds until the EKF has an absolute position and GPS a 3D fix.
    pub ekf_ready_s: f64,
    /// HEARTBEAT type: MAV_TYPE_SURFACE_BOAT for the motorboat frame.
    pub mav_type: MavType,
}

impl Default for RoverOptions {
    fn default() -> Self {
        Self {
            lat: 42.358456,
            lon: -71.087589,
            limits: Limits {
                accel: 0.5,
                hdg_rate: 45.0,
                z_rate: 0.0,
            },
            system_id: 1,
            component_id: 1,
            wp_speed: 5.0,
            init_s: 1.0,
            ekf_ready_s: 5.0,
            mav_type: MavType::MAV_TYPE_SURFACE_BOAT,
        }
    }
}

/// What the emulated Rover saw and did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RoverStats {
    pub frames_in: u64,
    pub bad_input: u64,
    pub gcs_heartbeats: u64,
    pub commands: u64,
    pub targets_followed: u64,
    /// Targets outside GUIDED (or for another system): silently dropped, as Rover does.
    pub targets_ignored: u64,
    pub targets_refused: u64,
    pub target_timeouts: u64,
    pub ekf_failsafes: u64,
    pub statustexts: Vec<String>,
    pub last_target: Option<Target>,
}
shared_counters!(RoverStats);

/// The Rover's own state.
pub struct Rover {
    opts: RoverOptions,
    target: Option<Target>,
    last_target_t: Option<f64>,
    /// GUIDED was entered before the EKF had an absolute position.
    guided_on_backup: bool,
    failsafe_since: Option<f64>,
}

impl RoverSession {
    pub fn ekf_ready(&self) -> bool {
        self.ap.t >= self.fw.opts.ekf_ready_s
    }

    fn ekf_flags(&self) -> u16 {
        if self.ap.initialising() {
            EkfStatusFlags::EKF_UNINITIALIZED.bits()
        } else if self.ekf_ready() {
            EKF_READY
        } else {
            // Attitude and velocities, no absolute position: the backup estimate.
            (EkfStatusFlags::EKF_ATTITUDE
                | EkfStatusFlags::EKF_VELOCITY_HORIZ
                | EkfStatusFlags::EKF_VELOCITY_VERT
                | EkfStatusFlags::EKF_POS_VERT_ABS
                | EkfStatusFlags::EKF_CONST_POS_MODE)
                .bits()
        }
    }

    fn target(&mut self, t: Target, system: u8, out: &mut Vec<u8>) {
        // Silently ignored outside GUIDED, and never acknowledged.
        if !self.ap.for_me(system) || self.mode != rover::GUIDED {
            self.stats.targets_ignored += 1;
            return;
        }
        match t {
            Target::Refused(why) => {
                self.stats.targets_refused += 1;
                self.statustext(MavSeverity::MAV_SEVERITY_WARNING, &why, out);
            }
            t => {
                self.stats.targets_followed += 1;
                self.stats.last_target = Some(t.clone());
                self.fw.target = Some(t);
                self.fw.last_target_t = Some(self.ap.t);
            }
        }
    }

    /// Forces the EKF failsafe (tests of what a backseat makes of it).
    pub fn inject_ekf_failsafe(&mut self, out: &mut Vec<u8>) {
        self.ekf_failsafe(out);
    }

    fn ekf_failsafe(&mut self, out: &mut Vec<u8>) {
        self.stats.ekf_failsafes += 1;
        self.fw.failsafe_since = Some(self.ap.t);
        self.statustext(MavSeverity::MAV_SEVERITY_CRITICAL, "EKF failsafe", out);
        self.set_mode(rover::HOLD, out);
    }
}

impl FirmwarePart for Rover {
    type Options = RoverOptions;
    type Stats = RoverStats;
    const FIRMWARE: Firmware = Firmware::Rover;
    const POWER_ON_MODE: u32 = rover::INITIALISING;
    const BOOTING: MavState = MavState::MAV_STATE_CALIBRATING;
    const DISARM_HEARTBEAT: bool = false;

    fn start(opts: RoverOptions) -> (Self, Vehicle, Autopilot) {
        let vehicle = Vehicle::new(opts.lat, opts.lon, opts.limits, (0.0, 0.0));
        let ap = Autopilot::new(opts.system_id, opts.component_id, opts.init_s, &[]);
        let part = Rover {
            opts,
            target: None,
            last_target_t: None,
            guided_on_backup: false,
            failsafe_since: None,
        };
        (part, vehicle, ap)
    }

    fn mav_type(&self) -> MavType {
        self.opts.mav_type
    }

    fn mode_flags(mode: u32) -> MavModeFlag {
        match mode {
            rover::GUIDED => MavModeFlag::MAV_MODE_FLAG_GUIDED_ENABLED,
            rover::AUTO | rover::RTL | rover::SMART_RTL => MavModeFlag::MAV_MODE_FLAG_AUTO_ENABLED,
            _ => MavModeFlag::MAV_MODE_FLAG_MANUAL_INPUT_ENABLED,
        }
    }

    fn failsafe(&self) -> bool {
        self.failsafe_since.is_some()
    }

    /// INITIALISING is the boot's, never asked for.
    fn refuses_mode(_: &mut RoverSession, mode: u32, _: &mut Vec<u8>) -> bool {
        mode == rover::INITIALISING
    }

    fn entering(s: &mut RoverSession, mode: u32) {
        s.fw.guided_on_backup = mode == rover::GUIDED && !s.ekf_ready();
        s.fw.target = None;
        s.fw.last_target_t = None;
        s.vehicle.set_setpoint(Setpoint {
            heading: s.vehicle.heading,
            speed: 0.0,
            depth: 0.0,
        });
    }

    /// No speed change in heading/speed mode.
    fn command(_: &mut RoverSession, c: &COMMAND_LONG_DATA, _: &mut Vec<u8>) -> MavResult {
        match c.command {
            // README: answers FAILED in heading/speed mode.
            MavCmd::MAV_CMD_DO_CHANGE_SPEED => MavResult::MAV_RESULT_FAILED,
            _ => MavResult::MAV_RESULT_UNSUPPORTED,
        }
    }

    fn armed(_: &mut RoverSession) {}

    fn booted(s: &mut RoverSession, out: &mut Vec<u8>) {
        s.mode = rover::MANUAL;
        s.statustext(MavSeverity::MAV_SEVERITY_INFO, "Ready to drive", out);
    }

    fn handle(s: &mut RoverSession, _sender: u8, msg: MavMessage, out: &mut Vec<u8>) {
        match msg {
            MavMessage::HEARTBEAT(_) => s.stats.gcs_heartbeats += 1,
            MavMessage::SET_POSITION_TARGET_GLOBAL_INT(p) => {
                let name = "GLOBAL_INT target";
                let global = matches!(
                    p.coordinate_frame as u8,
                    0 | 3 | 5 | 6 | 10 | 11 // GLOBAL, RELATIVE_ALT, their _INT forms, TERRAIN_ALT
                );
                let t = if global {
                    infer::interpret_target(
                        name,
                        p.type_mask.bits(),
                        Some((f64::from(p.lat_int) * 1e-7, f64::from(p.lon_int) * 1e-7)),
                        p.vx,
                        p.vy,
                        p.yaw,
                        p.yaw_rate,
                    )
                } else {
                    Target::Refused(format!("Ignoring {name}; unsupported frame"))
                };
                s.target(t, p.target_system, out);
            }
            MavMessage::SET_POSITION_TARGET_LOCAL_NED(p) => {
                // Dropped without a word until the EKF origin is set.
                if !s.ekf_ready() {
                    s.stats.targets_ignored += 1;
                    return;
                }
                let name = "LOCAL_NED target";
                let (vx, vy) = match p.coordinate_frame as u8 {
                    1 | 7 => (p.vx, p.vy),
                    8 | 9 => {
                        let h = s.vehicle.heading.to_radians() as f32;
                        (
                            p.vx * h.cos() - p.vy * h.sin(),
                            p.vx * h.sin() + p.vy * h.cos(),
                        )
                    }
                    _ => (f32::NAN, f32::NAN),
                };
                let t = infer::interpret_target(
                    name,
                    p.type_mask.bits(),
                    None,
                    vx,
                    vy,
                    p.yaw,
                    p.yaw_rate,
                );
                s.target(t, p.target_system, out);
            }
            _ => {}
        }
    }

    fn drive(s: &mut RoverSession, dt: f64, out: &mut Vec<u8>) {
        if s.mode == rover::GUIDED
            && let Some(t0) = s.fw.last_target_t
            && s.ap.t - t0 >= TARGET_TIMEOUT_S
        {
            s.stats.target_timeouts += 1;
            s.fw.last_target_t = None;
            s.fw.target = None;
            s.statustext(MavSeverity::MAV_SEVERITY_INFO, TARGET_TIMEOUT_TEXT, out);
        }
        let cap = s.fw.opts.wp_speed.max(0.0);
        let sp = match (&s.fw.target, s.armed && s.mode == rover::GUIDED) {
            (Some(Target::Course { heading, speed }), true) => Setpoint {
                heading: *heading,
                speed: speed.clamp(-cap, cap),
                depth: 0.0,
            },
            (Some(Target::TurnRate { speed, rate }), true) => Setpoint {
                heading: s.vehicle.heading + rate * dt,
                speed: speed.clamp(-cap, cap),
                depth: 0.0,
            },
            (Some(Target::Position { lat, lon }), true) => {
                let (la, lo) = s.vehicle.lat_lon();
                let north = (lat - la) * 111_320.0;
                let east = (lon - lo) * 111_320.0 * la.to_radians().cos();
                let dist = north.hypot(east);
                Setpoint {
                    heading: east.atan2(north).to_degrees(),
                    speed: if dist < 2.0 { 0.0 } else { cap },
                    depth: 0.0,
                }
            }
            // HOLD, a timed-out target, disarmed, no mission: a boat loiters where it is.
            _ => Setpoint {
                heading: s.vehicle.heading,
                speed: 0.0,
                depth: 0.0,
            },
        };
        s.vehicle.set_setpoint(sp);
        s.vehicle.step(dt);
        if s.fw.guided_on_backup
            && s.mode == rover::GUIDED
            && !s.fw.failsafe()
            && s.vehicle.speed.abs() > 0.3
        {
            s.ekf_failsafe(out);
        }
        if let Some(since) = s.fw.failsafe_since
            && s.ekf_ready()
            && s.ap.t - since >= 3.0
        {
            s.fw.failsafe_since = None;
            s.fw.guided_on_backup = false;
            s.statustext(MavSeverity::MAV_SEVERITY_INFO, "EKF failsafe cleared", out);
        }
    }

    fn stream(s: &mut RoverSession, id: u32, snap: &Snapshot) -> Option<MavMessage> {
        let ekf_ready = s.ekf_ready();
        let fix = if ekf_ready {
            GpsFixType::GPS_FIX_TYPE_3D_FIX
        } else {
            GpsFixType::GPS_FIX_TYPE_NO_FIX
        };
        Some(match id {
            GLOBAL_POSITION_INT_DATA::ID => {
                link::global_position(snap, 0, (-s.vehicle.depth * 1000.0) as i32, 0)
            }
            ATTITUDE_DATA::ID => link::attitude(snap, 0.0),
            VFR_HUD_DATA::ID => link::vfr_hud(
                snap,
                0.0,
                0.0,
                ((snap.speed / s.fw.opts.wp_speed.max(0.1)) * 100.0).min(100.0) as u16,
            ),
            SYS_STATUS_DATA::ID => {
                let mut sensors = MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_GYRO
                    | MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_ACCEL
                    | MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_MAG;
                let present = sensors | MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_GPS;
                if ekf_ready {
                    sensors |= MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_GPS;
                }
                link::sys_status(present, sensors, 12_600, 150)
            }
            GPS_RAW_INT_DATA::ID => link::gps_raw(
                snap,
                s.ap.t,
                fix,
                if ekf_ready { 10 } else { 0 },
                (snap.speed * 100.0) as u16,
                snap.hdg_cd,
            ),
            EKF_STATUS_REPORT_DATA::ID => link::ekf_report(s.ekf_flags()),
            // Event-driven: nothing to stream.
            _ => return None,
        })
    }
}
