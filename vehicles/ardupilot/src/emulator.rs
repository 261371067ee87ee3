//! ArduPilot Rover (motorboat frame) as a backseat sees it over MAVLink, on the simulator's
//! vehicle model: HEARTBEAT with mode and armed flag, the streams a GCS asks for with
//! SET_MESSAGE_INTERVAL, COMMAND_LONG (mode, arming, message intervals) answered by COMMAND_ACK,
//! GUIDED targets read by the README's type_mask rules and ignored outside GUIDED, the 3 s
//! target timeout on sim time, WP_SPEED, and readiness: an EKF that needs time for an absolute
//! position, and the EKF failsafe to HOLD of a vehicle put in GUIDED before it.

use std::collections::BTreeMap;

use mavlink::MessageData;

use frontseat_sim::emulator::Session;
use frontseat_sim::vehicle::{Limits, Setpoint, Vehicle};

use crate::codec::{Deframer, FrameError, MavMessage, Sender, decode};
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
/// Fastest stream a backseat may ask for: a flood of our own making helps nobody.
const MIN_INTERVAL_S: f64 = 0.01;
/// Statustexts kept for inspection.
const MAX_TEXTS: usize = 64;

pub struct RoverSession {
    opts: RoverOptions,
    vehicle: Vehicle,
    tx: Sender,
    deframer: Deframer,
    /// Sim seconds since boot.
    t: f64,
    mode: u32,
    armed: bool,
    /// Seconds between sends, and when each was last sent.
    intervals: BTreeMap<u32, (f64, f64)>,
    target: Option<Target>,
    last_target_t: Option<f64>,
    /// GUIDED was entered before the EKF had an absolute position.
    guided_on_backup: bool,
    failsafe_since: Option<f64>,
    pub stats: RoverStats,
}

impl RoverSession {
    pub fn new(opts: RoverOptions) -> Self {
        let mut intervals = BTreeMap::new();
        intervals.insert(HEARTBEAT_DATA::ID, (1.0, f64::NEG_INFINITY));
        Self {
            vehicle: Vehicle::new(opts.lat, opts.lon, opts.limits, (0.0, 0.0)),
            tx: Sender::new(opts.system_id, opts.component_id),
            deframer: Deframer::new(),
            t: 0.0,
            mode: rover::INITIALISING,
            armed: false,
            intervals,
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
        self.t
    }

    fn initialising(&self) -> bool {
        self.t < self.opts.init_s
    }

    pub fn ekf_ready(&self) -> bool {
        self.t >= self.opts.ekf_ready_s
    }

    fn failsafe(&self) -> bool {
        self.failsafe_since.is_some()
    }

    fn ekf_flags(&self) -> u16 {
        if self.initialising() {
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

    fn send(&mut self, msg: MavMessage, out: &mut Vec<u8>) {
        out.extend_from_slice(&self.tx.frame(&msg));
    }

    /// Sends a STATUSTEXT (cut to the 50 characters the message holds).
    pub fn statustext(&mut self, severity: MavSeverity, text: &str, out: &mut Vec<u8>) {
        let cut: String = text.chars().take(50).collect();
        if self.stats.statustexts.len() < MAX_TEXTS {
            self.stats.statustexts.push(cut.clone());
        }
        self.send(
            MavMessage::STATUSTEXT(STATUSTEXT_DATA {
                severity,
                text: cut.as_str().into(),
            }),
            out,
        );
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
        let system_status = if self.initialising() {
            MavState::MAV_STATE_CALIBRATING
        } else if self.failsafe() {
            MavState::MAV_STATE_CRITICAL
        } else if self.armed {
            MavState::MAV_STATE_ACTIVE
        } else {
            MavState::MAV_STATE_STANDBY
        };
        let msg = MavMessage::HEARTBEAT(HEARTBEAT_DATA {
            custom_mode: self.mode,
            mavtype: self.opts.mav_type,
            autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
            base_mode: base,
            system_status,
            mavlink_version: 3,
        });
        self.send(msg, out);
    }

    fn ack(&mut self, command: MavCmd, result: MavResult, out: &mut Vec<u8>) {
        self.send(
            MavMessage::COMMAND_ACK(COMMAND_ACK_DATA { command, result }),
            out,
        );
    }

    fn for_me(&self, system: u8) -> bool {
        system == 0 || system == self.opts.system_id
    }

    fn command(&mut self, c: &COMMAND_LONG_DATA, out: &mut Vec<u8>) {
        if !self.for_me(c.target_system) {
            return;
        }
        self.stats.commands += 1;
        let result = match c.command {
            MavCmd::MAV_CMD_DO_SET_MODE => {
                let mode = c.param2;
                let custom = (c.param1 as u32) & 1 == 1;
                let valid = mode.is_finite()
                    && mode >= 0.0
                    && mode.fract() == 0.0
                    && Firmware::Rover.mode_name(mode as u32).is_some()
                    && mode as u32 != rover::INITIALISING;
                if custom && valid && !self.initialising() {
                    self.set_mode(mode as u32, out);
                    MavResult::MAV_RESULT_ACCEPTED
                } else {
                    MavResult::MAV_RESULT_FAILED
                }
            }
            MavCmd::MAV_CMD_COMPONENT_ARM_DISARM => {
                if c.param1 == 1.0 {
                    if self.initialising() {
                        self.statustext(
                            MavSeverity::MAV_SEVERITY_CRITICAL,
                            "PreArm: AHRS not healthy",
                            out,
                        );
                        MavResult::MAV_RESULT_FAILED
                    } else {
                        if !self.armed {
                            self.armed = true;
                            self.statustext(MavSeverity::MAV_SEVERITY_INFO, "Arming motors", out);
                        }
                        MavResult::MAV_RESULT_ACCEPTED
                    }
                } else if c.param1 == 0.0 {
                    if self.armed {
                        self.armed = false;
                        self.statustext(MavSeverity::MAV_SEVERITY_INFO, "Disarming motors", out);
                    }
                    MavResult::MAV_RESULT_ACCEPTED
                } else {
                    MavResult::MAV_RESULT_DENIED
                }
            }
            MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL => {
                let id = c.param1;
                let us = c.param2;
                let known = id.is_finite()
                    && id >= 0.0
                    && STREAMABLE.contains(&(id as u32))
                    && us.is_finite();
                if !known {
                    MavResult::MAV_RESULT_FAILED
                } else {
                    let id = id as u32;
                    if us < 0.0 {
                        self.intervals.remove(&id);
                    } else {
                        let s = if us == 0.0 { 1.0 } else { f64::from(us) * 1e-6 };
                        self.intervals
                            .insert(id, (s.max(MIN_INTERVAL_S), f64::NEG_INFINITY));
                    }
                    MavResult::MAV_RESULT_ACCEPTED
                }
            }
            // README: answers FAILED in heading/speed mode.
            MavCmd::MAV_CMD_DO_CHANGE_SPEED => MavResult::MAV_RESULT_FAILED,
            _ => MavResult::MAV_RESULT_UNSUPPORTED,
        };
        self.ack(c.command, result, out);
    }

    fn target(&mut self, t: Target, system: u8, out: &mut Vec<u8>) {
        // Silently ignored outside GUIDED, and never acknowledged.
        if !self.for_me(system) || self.mode != rover::GUIDED {
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
                self.last_target_t = Some(self.t);
            }
        }
    }

    fn handle(&mut self, msg: MavMessage, out: &mut Vec<u8>) {
        match msg {
            MavMessage::HEARTBEAT(_) => self.stats.gcs_heartbeats += 1,
            MavMessage::COMMAND_LONG(c) => self.command(&c, out),
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

    /// Forces the EKF failsafe (tests of what a backseat makes of it).
    pub fn inject_ekf_failsafe(&mut self, out: &mut Vec<u8>) {
        self.ekf_failsafe(out);
    }

    fn ekf_failsafe(&mut self, out: &mut Vec<u8>) {
        self.stats.ekf_failsafes += 1;
        self.failsafe_since = Some(self.t);
        self.statustext(MavSeverity::MAV_SEVERITY_CRITICAL, "EKF failsafe", out);
        self.set_mode(rover::HOLD, out);
    }

    fn drive(&mut self, dt: f64, out: &mut Vec<u8>) {
        if self.mode == rover::GUIDED
            && let Some(t0) = self.last_target_t
            && self.t - t0 >= TARGET_TIMEOUT_S
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
            && self.t - since >= 3.0
        {
            self.failsafe_since = None;
            self.guided_on_backup = false;
            self.statustext(MavSeverity::MAV_SEVERITY_INFO, "EKF failsafe cleared", out);
        }
    }

    fn stream(&mut self, id: u32, out: &mut Vec<u8>) {
        let v = &self.vehicle;
        let (north, east) = {
            let h = v.heading.to_radians();
            (v.speed * h.cos(), v.speed * h.sin())
        };
        let boot_ms = (self.t * 1000.0) as u32;
        let fix = if self.ekf_ready() {
            GpsFixType::GPS_FIX_TYPE_3D_FIX
        } else {
            GpsFixType::GPS_FIX_TYPE_NO_FIX
        };
        let (lat, lon) = if self.initialising() {
            (0.0, 0.0)
        } else {
            self.vehicle.lat_lon()
        };
        let v = &self.vehicle;
        let hdg_cd = (v.heading * 100.0).round() as u16 % 36000;
        let msg = match id {
            HEARTBEAT_DATA::ID => return self.heartbeat(out),
            GLOBAL_POSITION_INT_DATA::ID => {
                MavMessage::GLOBAL_POSITION_INT(GLOBAL_POSITION_INT_DATA {
                    time_boot_ms: boot_ms,
                    lat: (lat * 1e7).round() as i32,
                    lon: (lon * 1e7).round() as i32,
                    alt: 0,
                    relative_alt: (-v.depth * 1000.0) as i32,
                    vx: (north * 100.0).round() as i16,
                    vy: (east * 100.0).round() as i16,
                    vz: 0,
                    hdg: hdg_cd,
                })
            }
            ATTITUDE_DATA::ID => {
                let yaw = if v.heading > 180.0 {
                    v.heading - 360.0
                } else {
                    v.heading
                };
                MavMessage::ATTITUDE(ATTITUDE_DATA {
                    time_boot_ms: boot_ms,
                    yaw: yaw.to_radians() as f32,
                    ..Default::default()
                })
            }
            VFR_HUD_DATA::ID => MavMessage::VFR_HUD(VFR_HUD_DATA {
                airspeed: 0.0,
                groundspeed: v.speed.abs() as f32,
                alt: 0.0,
                climb: 0.0,
                heading: (hdg_cd / 100) as i16,
                throttle: ((v.speed.abs() / self.opts.wp_speed.max(0.1)) * 100.0).min(100.0) as u16,
            }),
            SYS_STATUS_DATA::ID => {
                let mut sensors = MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_GYRO
                    | MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_ACCEL
                    | MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_MAG;
                let present = sensors | MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_GPS;
                if self.ekf_ready() {
                    sensors |= MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_GPS;
                }
                MavMessage::SYS_STATUS(SYS_STATUS_DATA {
                    onboard_control_sensors_present: present,
                    onboard_control_sensors_enabled: present,
                    onboard_control_sensors_health: sensors,
                    load: 100,
                    voltage_battery: 12_600,
                    current_battery: 150,
                    battery_remaining: 90,
                    ..Default::default()
                })
            }
            GPS_RAW_INT_DATA::ID => MavMessage::GPS_RAW_INT(GPS_RAW_INT_DATA {
                time_usec: (self.t * 1e6) as u64,
                lat: (lat * 1e7).round() as i32,
                lon: (lon * 1e7).round() as i32,
                alt: 0,
                eph: 121,
                epv: 200,
                vel: (v.speed.abs() * 100.0) as u16,
                cog: hdg_cd,
                fix_type: fix,
                satellites_visible: if self.ekf_ready() { 10 } else { 0 },
            }),
            EKF_STATUS_REPORT_DATA::ID => MavMessage::EKF_STATUS_REPORT(EKF_STATUS_REPORT_DATA {
                velocity_variance: 0.02,
                pos_horiz_variance: 0.01,
                pos_vert_variance: 0.01,
                compass_variance: 0.02,
                terrain_alt_variance: 0.0,
                flags: EkfStatusFlags::from_bits_retain(self.ekf_flags()),
            }),
            // Event-driven: nothing to stream.
            _ => return,
        };
        self.send(msg, out);
    }
}

impl Session for RoverSession {
    fn on_bytes(&mut self, bytes: &[u8], out: &mut Vec<u8>) {
        let mut frames = Vec::new();
        let mut bad = 0;
        self.deframer.feed(bytes, &mut |r| match r {
            Ok(f) => frames.push(f),
            Err(FrameError::Noise(_)) | Err(_) => bad += 1,
        });
        self.stats.bad_input += bad;
        for f in frames {
            match decode(&f) {
                Ok((_, msg)) => {
                    self.stats.frames_in += 1;
                    self.handle(msg, out);
                }
                Err(_) => self.stats.bad_input += 1,
            }
        }
    }

    fn step(&mut self, dt: f64, out: &mut Vec<u8>) {
        let was_init = self.initialising();
        self.t += dt;
        if was_init && !self.initialising() {
            self.mode = rover::MANUAL;
            self.statustext(MavSeverity::MAV_SEVERITY_INFO, "Ready to drive", out);
        }
        self.drive(dt, out);
        let due: Vec<u32> = self
            .intervals
            .iter()
            .filter(|(_, (every, last))| self.t - last >= every - 1e-9)
            .map(|(id, _)| *id)
            .collect();
        for id in due {
            if let Some(e) = self.intervals.get_mut(&id) {
                e.1 = self.t;
            }
            self.stream(id, out);
        }
    }

    fn reset_input(&mut self) {
        self.deframer = Deframer::new();
    }
}
