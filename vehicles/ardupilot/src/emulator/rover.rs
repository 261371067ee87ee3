//! ArduPilot Rover (motorboat frame) as a backseat sees it over MAVLink, on the simulator's
//! vehicle model: HEARTBEAT with mode and armed flag, the streams a GCS asks for with
//! SET_MESSAGE_INTERVAL, COMMAND_LONG (mode, arming, message intervals) answered by COMMAND_ACK,
//! GUIDED targets read by the README's type_mask rules and ignored outside GUIDED, the 3 s
//! target timeout on sim time, WP_SPEED, and readiness: an EKF that needs time for an absolute
//! position, and the EKF failsafe to HOLD of a vehicle put in GUIDED before it.
//! What it shares with the other firmware (frames, the stream schedule, arming, COMMAND_ACK,
//! STATUSTEXT, the streamed messages' layout) is written once in `session`; this file is its own part.
//!
//! # Fault hooks (for the chaos harness and tests)
//! On a running [`Emulator`](frontseat_sim::emulator::Emulator) of either firmware
//! ([`RoverSession`], [`SubSession`](crate::sub_emulator::SubSession)), through
//! `emu.session()`; each takes effect without an output buffer:
//! - `refuse_commands(Some(MavResult::MAV_RESULT_DENIED))`: every COMMAND_LONG and SET_MODE
//!   addressed to the vehicle is answered so (any MAV_RESULT) and not acted on; `None` ends it.
//! - `change_mode(mode)`: the vehicle switches mode by itself at its next step, as a pilot's RC
//!   switch or a failsafe would, and announces it by a HEARTBEAT.
//! - `go_silent(true)`: the vehicle sends nothing (HEARTBEAT, streams, ACKs, STATUSTEXT) until
//!   `go_silent(false)`; it goes on hearing and acting.
//! - `fault_counters()`: what the hooks made it do ([`FaultCounters`]).
//! - dropping the backseat's connection is the runner's: `emu.drop_connection()` (TCP).
//! - garbage and truncated frames are the runner's too: `emu.inject_bytes(bytes)`.

use mavlink::MessageData;

use frontseat_sim::vehicle::{Limits, Setpoint, Vehicle};

use crate::codec::MavMessage;
use crate::dialect::*;
use crate::infer::{self, EKF_READY, TARGET_TIMEOUT_S, TARGET_TIMEOUT_TEXT, Target};
use crate::modes::{Firmware, rover};
pub use crate::session::FaultCounters;
use crate::session::{self, Autopilot, Face};

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

/// Streamed messages the emulator can send, by id.
const STREAMABLE: [u32; 8] = [
    HEARTBEAT_DATA::ID,
    GLOBAL_POSITION_INT_DATA::ID,
    ATTITUDE_DATA::ID,
    VFR_HUD_DATA::ID,
    SYS_STATUS_DATA::ID,
    GPS_RAW_INT_DATA::ID,
    EKF_STATUS_REPORT_DATA::ID,
    STATUSTEXT_DATA::ID,
];

pub struct RoverSession {
    opts: RoverOptions,
    vehicle: Vehicle,
    ap: Autopilot,
    mode: u32,
    armed: bool,
    target: Option<Target>,
    last_target_t: Option<f64>,
    /// GUIDED was entered before the EKF had an absolute position.
    guided_on_backup: bool,
    failsafe_since: Option<f64>,
    pub stats: RoverStats,
}

impl RoverSession {
    pub fn new(opts: RoverOptions) -> Self {
        Self {
            vehicle: Vehicle::new(opts.lat, opts.lon, opts.limits, (0.0, 0.0)),
            ap: Autopilot::new(opts.system_id, opts.component_id, opts.init_s, &STREAMABLE),
            mode: rover::INITIALISING,
            armed: false,
            target: None,
            last_target_t: None,
            guided_on_backup: false,
            failsafe_since: None,
            stats: RoverStats::default(),
            opts,
        }
    }

    pub fn mode(&self) -> u32 {
        self.mode
    }

    pub fn armed(&self) -> bool {
        self.armed
    }

    pub fn vehicle(&self) -> &Vehicle {
        &self.vehicle
    }

    pub fn sim_time(&self) -> f64 {
        self.ap.t
    }

    pub fn ekf_ready(&self) -> bool {
        self.ap.t >= self.opts.ekf_ready_s
    }

    fn failsafe(&self) -> bool {
        self.failsafe_since.is_some()
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

    /// Sends a STATUSTEXT (cut to the 50 characters the message holds).
    pub fn statustext(&mut self, severity: MavSeverity, text: &str, out: &mut Vec<u8>) {
        Face::statustext(self, severity, text, out);
    }

    fn set_mode(&mut self, mode: u32, out: &mut Vec<u8>) {
        if mode != self.mode {
            self.guided_on_backup = mode == rover::GUIDED && !self.ekf_ready();
            self.target = None;
            self.last_target_t = None;
            self.mode = mode;
            self.vehicle.set_setpoint(Setpoint {
                heading: self.vehicle.heading,
                speed: 0.0,
                depth: 0.0,
            });
            // A mode change is announced at once, as ArduPilot's GCS sees it.
            self.heartbeat(out);
        }
    }

    fn heartbeat(&mut self, out: &mut Vec<u8>) {
        let mut base = MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED;
        if self.armed {
            base |= MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED;
        }
        base |= match self.mode {
            rover::GUIDED => MavModeFlag::MAV_MODE_FLAG_GUIDED_ENABLED,
            rover::AUTO | rover::RTL | rover::SMART_RTL => MavModeFlag::MAV_MODE_FLAG_AUTO_ENABLED,
            _ => MavModeFlag::MAV_MODE_FLAG_MANUAL_INPUT_ENABLED,
        };
        let status =
            self.ap
                .system_status(MavState::MAV_STATE_CALIBRATING, self.failsafe(), self.armed);
        self.ap
            .heartbeat(self.mode, self.opts.mav_type, base, status, out);
    }

    /// Rover's own COMMAND_LONGs: mode by number, and no speed change in heading/speed mode.
    fn rover_command(&mut self, c: &COMMAND_LONG_DATA, out: &mut Vec<u8>) -> MavResult {
        match c.command {
            MavCmd::MAV_CMD_DO_SET_MODE => {
                let mode = c.param2;
                let custom = (c.param1 as u32) & 1 == 1;
                let valid = mode.is_finite()
                    && mode >= 0.0
                    && mode.fract() == 0.0
                    && Firmware::Rover.mode_name(mode as u32).is_some()
                    && mode as u32 != rover::INITIALISING;
                if custom && valid && !self.ap.initialising() {
                    self.set_mode(mode as u32, out);
                    MavResult::MAV_RESULT_ACCEPTED
                } else {
                    MavResult::MAV_RESULT_FAILED
                }
            }
            // README: answers FAILED in heading/speed mode.
            MavCmd::MAV_CMD_DO_CHANGE_SPEED => MavResult::MAV_RESULT_FAILED,
            _ => MavResult::MAV_RESULT_UNSUPPORTED,
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
                self.target = Some(t);
                self.last_target_t = Some(self.ap.t);
            }
        }
    }

    /// Fault hook: every COMMAND_LONG and SET_MODE addressed to the vehicle is answered with
    /// `answer` (MAV_RESULT_DENIED, _FAILED, …) and not acted on; `None` ends it.
    pub fn refuse_commands(&mut self, answer: Option<MavResult>) {
        self.ap.faults.refusal = answer;
    }

    /// Fault hook: the vehicle switches to `mode` by itself at its next step (after boot), as a
    /// pilot's RC switch or a failsafe would, announcing it by a HEARTBEAT.
    pub fn change_mode(&mut self, mode: u32) {
        self.ap.faults.own_mode = Some(mode);
    }

    /// Fault hook: the vehicle sends nothing (no HEARTBEAT, stream, ACK or STATUSTEXT) while
    /// `silent`, and goes on hearing and acting on what it is sent.
    pub fn go_silent(&mut self, silent: bool) {
        self.ap.faults.silent = silent;
    }

    /// What the fault hooks made the vehicle do.
    pub fn fault_counters(&self) -> FaultCounters {
        self.ap.faults.counters.clone()
    }

    /// Forces the EKF failsafe (tests of what a backseat makes of it).
    pub fn inject_ekf_failsafe(&mut self, out: &mut Vec<u8>) {
        self.ekf_failsafe(out);
    }

    fn ekf_failsafe(&mut self, out: &mut Vec<u8>) {
        self.stats.ekf_failsafes += 1;
        self.failsafe_since = Some(self.ap.t);
        self.statustext(MavSeverity::MAV_SEVERITY_CRITICAL, "EKF failsafe", out);
        self.set_mode(rover::HOLD, out);
    }
}

impl Face for RoverSession {
    fn set_mode(&mut self, mode: u32, out: &mut Vec<u8>) {
        RoverSession::set_mode(self, mode, out);
    }

    fn command(&mut self, c: &COMMAND_LONG_DATA, out: &mut Vec<u8>) -> MavResult {
        self.rover_command(c, out)
    }

    fn arm(&mut self, out: &mut Vec<u8>) {
        if !self.armed {
            self.armed = true;
            self.statustext(MavSeverity::MAV_SEVERITY_INFO, "Arming motors", out);
        }
    }

    fn disarm(&mut self, why: &str, out: &mut Vec<u8>) {
        if self.armed {
            self.armed = false;
            self.statustext(MavSeverity::MAV_SEVERITY_INFO, why, out);
        }
    }

    fn booted(&mut self, out: &mut Vec<u8>) {
        self.mode = rover::MANUAL;
        self.statustext(MavSeverity::MAV_SEVERITY_INFO, "Ready to drive", out);
    }

    fn handle(&mut self, _sender: u8, msg: MavMessage, out: &mut Vec<u8>) {
        match msg {
            MavMessage::HEARTBEAT(_) => self.stats.gcs_heartbeats += 1,
            MavMessage::COMMAND_LONG(c) => session::command(self, &c, out),
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
                self.target(t, p.target_system, out);
            }
            MavMessage::SET_POSITION_TARGET_LOCAL_NED(p) => {
                // Dropped without a word until the EKF origin is set.
                if !self.ekf_ready() {
                    self.stats.targets_ignored += 1;
                    return;
                }
                let name = "LOCAL_NED target";
                let (vx, vy) = match p.coordinate_frame as u8 {
                    1 | 7 => (p.vx, p.vy),
                    8 | 9 => {
                        let h = self.vehicle.heading.to_radians() as f32;
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
                self.target(t, p.target_system, out);
            }
            _ => {}
        }
    }

    fn drive(&mut self, dt: f64, out: &mut Vec<u8>) {
        if self.mode == rover::GUIDED
            && let Some(t0) = self.last_target_t
            && self.ap.t - t0 >= TARGET_TIMEOUT_S
        {
            self.stats.target_timeouts += 1;
            self.last_target_t = None;
            self.target = None;
            self.statustext(MavSeverity::MAV_SEVERITY_INFO, TARGET_TIMEOUT_TEXT, out);
        }
        let cap = self.opts.wp_speed.max(0.0);
        let sp = match (&self.target, self.armed && self.mode == rover::GUIDED) {
            (Some(Target::Course { heading, speed }), true) => Setpoint {
                heading: *heading,
                speed: speed.clamp(-cap, cap),
                depth: 0.0,
            },
            (Some(Target::TurnRate { speed, rate }), true) => Setpoint {
                heading: self.vehicle.heading + rate * dt,
                speed: speed.clamp(-cap, cap),
                depth: 0.0,
            },
            (Some(Target::Position { lat, lon }), true) => {
                let (la, lo) = self.vehicle.lat_lon();
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
                heading: self.vehicle.heading,
                speed: 0.0,
                depth: 0.0,
            },
        };
        self.vehicle.set_setpoint(sp);
        self.vehicle.step(dt);
        if self.guided_on_backup
            && self.mode == rover::GUIDED
            && !self.failsafe()
            && self.vehicle.speed.abs() > 0.3
        {
            self.ekf_failsafe(out);
        }
        if let Some(since) = self.failsafe_since
            && self.ekf_ready()
            && self.ap.t - since >= 3.0
        {
            self.failsafe_since = None;
            self.guided_on_backup = false;
            self.statustext(MavSeverity::MAV_SEVERITY_INFO, "EKF failsafe cleared", out);
        }
    }

    fn stream(&mut self, id: u32, out: &mut Vec<u8>) {
        let s = self.ap.snapshot(&mut self.vehicle);
        let depth = self.vehicle.depth;
        let fix = if self.ekf_ready() {
            GpsFixType::GPS_FIX_TYPE_3D_FIX
        } else {
            GpsFixType::GPS_FIX_TYPE_NO_FIX
        };
        let msg = match id {
            HEARTBEAT_DATA::ID => return self.heartbeat(out),
            GLOBAL_POSITION_INT_DATA::ID => {
                session::global_position(&s, 0, (-depth * 1000.0) as i32, 0)
            }
            ATTITUDE_DATA::ID => session::attitude(&s, 0.0),
            VFR_HUD_DATA::ID => session::vfr_hud(
                &s,
                0.0,
                0.0,
                ((s.speed / self.opts.wp_speed.max(0.1)) * 100.0).min(100.0) as u16,
            ),
            SYS_STATUS_DATA::ID => {
                let mut sensors = MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_GYRO
                    | MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_ACCEL
                    | MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_MAG;
                let present = sensors | MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_GPS;
                if self.ekf_ready() {
                    sensors |= MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_GPS;
                }
                session::sys_status(present, sensors, 12_600, 150)
            }
            GPS_RAW_INT_DATA::ID => session::gps_raw(
                &s,
                self.ap.t,
                fix,
                if self.ekf_ready() { 10 } else { 0 },
                (s.speed * 100.0) as u16,
                s.hdg_cd,
            ),
            EKF_STATUS_REPORT_DATA::ID => session::ekf_report(self.ekf_flags()),
            // Event-driven: nothing to stream.
            _ => return,
        };
        self.ap.send(msg, out);
    }
}

session::shared_session!(RoverSession);
