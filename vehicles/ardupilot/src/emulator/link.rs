//! The link side of the one ArduPilot emulator, alike on every firmware: the session's frames
//! in and out (deframing, our sequence numbers), the sim clock since boot and the boot time, the
//! streams a GCS asks for with SET_MESSAGE_INTERVAL and their schedule, the fault hooks' state,
//! and the stream messages' common layout.

use std::collections::BTreeMap;

use mavlink::MessageData;

use frontseat_sim::vehicle::Vehicle;

use crate::codec::{Deframer, MavMessage, Sender};
use crate::dialect::*;

/// Fastest stream a backseat may ask for: a flood of our own making helps nobody.
const MIN_INTERVAL_S: f64 = 0.01;
/// Statustexts kept for inspection.
pub(crate) const MAX_TEXTS: usize = 64;

/// The shared part of an emulated firmware's session.
pub struct Autopilot {
    system_id: u8,
    tx: Sender,
    pub(crate) deframer: Deframer,
    /// Sim seconds since boot.
    pub(crate) t: f64,
    /// Sim seconds of boot (no arming, EKF uninitialised).
    init_s: f64,
    /// Streamed messages the firmware sends beside [`STREAMS`], by id.
    extra_streams: &'static [u32],
    /// Seconds between sends, and when each was last sent.
    intervals: BTreeMap<u32, (f64, f64)>,
    /// The chaos harness's faults, set through the emulator's fault hooks.
    pub(crate) faults: Faults,
}

/// The faults a test or the chaos harness has switched on (the emulator module's doc lists
/// the hooks that set them).
#[derive(Debug, Default)]
pub(crate) struct Faults {
    /// Every COMMAND_LONG and SET_MODE addressed to us is answered with this, and not acted on.
    pub(crate) refusal: Option<MavResult>,
    /// Nothing is sent.
    pub(crate) silent: bool,
    /// A mode the vehicle switches to by itself at the next step after boot.
    pub(crate) own_mode: Option<u32>,
    /// Armed and put in GUIDED at the next step after boot (`operator_arms_guided`).
    pub(crate) arm_guided: bool,
    pub(crate) counters: FaultCounters,
}

/// What the fault hooks made the emulated vehicle do.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct FaultCounters {
    /// COMMAND_LONGs and SET_MODEs answered with the refusal instead of acted on.
    pub commands_refused: u64,
    /// Mode changes the vehicle made by itself (`change_mode`).
    pub own_mode_changes: u64,
    /// Bytes not sent while silent.
    pub bytes_withheld: u64,
}

/// Streamed messages every firmware can send, by id.
pub(crate) const STREAMS: [u32; 8] = [
    HEARTBEAT_DATA::ID,
    GLOBAL_POSITION_INT_DATA::ID,
    ATTITUDE_DATA::ID,
    VFR_HUD_DATA::ID,
    SYS_STATUS_DATA::ID,
    GPS_RAW_INT_DATA::ID,
    EKF_STATUS_REPORT_DATA::ID,
    STATUSTEXT_DATA::ID,
];

/// A firmware's stats, which count what the shared part sees (written by `shared_counters!`).
pub trait Counters {
    fn tally(&mut self) -> Tally<'_>;
}

/// Where a firmware's stats count what the shared part sees.
pub struct Tally<'a> {
    pub(crate) frames_in: &'a mut u64,
    pub(crate) bad_input: &'a mut u64,
    pub(crate) commands: &'a mut u64,
    pub(crate) statustexts: &'a mut Vec<String>,
}

impl Autopilot {
    /// A session at boot, streaming HEARTBEAT at 1 Hz until asked otherwise.
    pub(crate) fn new(
        system_id: u8,
        component_id: u8,
        init_s: f64,
        extra_streams: &'static [u32],
    ) -> Self {
        let mut intervals = BTreeMap::new();
        intervals.insert(HEARTBEAT_DATA::ID, (1.0, f64::NEG_INFINITY));
        Self {
            system_id,
            tx: Sender::new(system_id, component_id),
            deframer: Deframer::new(),
            t: 0.0,
            init_s,
            extra_streams,
            intervals,
            faults: Faults::default(),
        }
    }

    pub(crate) fn initialising(&self) -> bool {
        self.t < self.init_s
    }

    pub(crate) fn send(&mut self, msg: MavMessage, out: &mut Vec<u8>) {
        out.extend_from_slice(&self.tx.frame(&msg));
    }

    pub(crate) fn for_me(&self, system: u8) -> bool {
        system == 0 || system == self.system_id
    }

    /// The HEARTBEAT of an ArduPilot autopilot in `custom_mode`.
    pub(crate) fn heartbeat(
        &mut self,
        custom_mode: u32,
        mavtype: MavType,
        base_mode: MavModeFlag,
        system_status: MavState,
        out: &mut Vec<u8>,
    ) {
        let msg = MavMessage::HEARTBEAT(HEARTBEAT_DATA {
            custom_mode,
            mavtype,
            autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
            base_mode,
            system_status,
            mavlink_version: 3,
        });
        self.send(msg, out);
    }

    /// HEARTBEAT's system_status: `booting` during boot, then critical in a failsafe, active
    /// when armed, standby.
    pub(crate) fn system_status(&self, booting: MavState, failsafe: bool, armed: bool) -> MavState {
        if self.initialising() {
            booting
        } else if failsafe {
            MavState::MAV_STATE_CRITICAL
        } else if armed {
            MavState::MAV_STATE_ACTIVE
        } else {
            MavState::MAV_STATE_STANDBY
        }
    }

    /// MAV_CMD_SET_MESSAGE_INTERVAL: param1 the message id, param2 µs (0 the default 1 s, < 0
    /// stops it).
    pub(crate) fn set_interval(&mut self, id: f32, us: f32) -> MavResult {
        let n = id as u32;
        let known = id.is_finite()
            && id >= 0.0
            && (STREAMS.contains(&n) || self.extra_streams.contains(&n))
            && us.is_finite();
        if !known {
            MavResult::MAV_RESULT_FAILED
        } else {
            let id = n;
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

    /// The streams due now, marked sent.
    pub(crate) fn due(&mut self) -> Vec<u32> {
        let due: Vec<u32> = self
            .intervals
            .iter()
            .filter(|(_, (every, last))| self.t - last >= every - 1e-9)
            .map(|(id, _)| *id)
            .collect();
        for id in &due {
            if let Some(e) = self.intervals.get_mut(id) {
                e.1 = self.t;
            }
        }
        due
    }

    pub(crate) fn reset_input(&mut self) {
        self.deframer = Deframer::new();
    }

    /// What every stream reads of the vehicle model, in MAVLink's units.
    pub(crate) fn snapshot(&self, v: &mut Vehicle) -> Snapshot {
        let h = v.heading.to_radians();
        let (lat, lon) = if self.initialising() {
            (0.0, 0.0)
        } else {
            v.lat_lon()
        };
        Snapshot {
            boot_ms: (self.t * 1000.0) as u32,
            lat,
            lon,
            vn: v.speed * h.cos(),
            ve: v.speed * h.sin(),
            hdg_cd: (v.heading * 100.0).round() as u16 % 36000,
            yaw: if v.heading > 180.0 {
                v.heading - 360.0
            } else {
                v.heading
            },
            speed: v.speed.abs(),
        }
    }
}

/// The vehicle model as the streams read it.
pub struct Snapshot {
    pub(crate) boot_ms: u32,
    /// (0, 0) during boot.
    pub(crate) lat: f64,
    pub(crate) lon: f64,
    /// Velocity north and east. Unit: m/s.
    pub(crate) vn: f64,
    pub(crate) ve: f64,
    /// Heading. Unit: centidegrees, 0..36000.
    pub(crate) hdg_cd: u16,
    /// Heading. Unit: degrees, −180..180.
    pub(crate) yaw: f64,
    /// Speed over ground. Unit: m/s.
    pub(crate) speed: f64,
}

/// GLOBAL_POSITION_INT; altitudes in mm, vertical speed in cm/s (down).
pub(crate) fn global_position(s: &Snapshot, alt: i32, relative_alt: i32, vz: i16) -> MavMessage {
    MavMessage::GLOBAL_POSITION_INT(GLOBAL_POSITION_INT_DATA {
        time_boot_ms: s.boot_ms,
        lat: (s.lat * 1e7).round() as i32,
        lon: (s.lon * 1e7).round() as i32,
        alt,
        relative_alt,
        vx: (s.vn * 100.0).round() as i16,
        vy: (s.ve * 100.0).round() as i16,
        vz,
        hdg: s.hdg_cd,
    })
}

/// ATTITUDE: level but for `pitch` (rad).
pub(crate) fn attitude(s: &Snapshot, pitch: f32) -> MavMessage {
    MavMessage::ATTITUDE(ATTITUDE_DATA {
        time_boot_ms: s.boot_ms,
        pitch,
        yaw: s.yaw.to_radians() as f32,
        ..Default::default()
    })
}

/// VFR_HUD; `alt` m up, `climb` m/s up, `throttle` %.
pub(crate) fn vfr_hud(s: &Snapshot, alt: f32, climb: f32, throttle: u16) -> MavMessage {
    MavMessage::VFR_HUD(VFR_HUD_DATA {
        airspeed: 0.0,
        groundspeed: s.speed as f32,
        alt,
        climb,
        heading: (s.hdg_cd / 100) as i16,
        throttle,
    })
}

/// SYS_STATUS of sensors present and enabled, `health` the healthy ones; battery in mV, cA.
pub(crate) fn sys_status(
    present: MavSysStatusSensor,
    health: MavSysStatusSensor,
    voltage_battery: u16,
    current_battery: i16,
) -> MavMessage {
    MavMessage::SYS_STATUS(SYS_STATUS_DATA {
        onboard_control_sensors_present: present,
        onboard_control_sensors_enabled: present,
        onboard_control_sensors_health: health,
        load: 100,
        voltage_battery,
        current_battery,
        battery_remaining: 90,
        ..Default::default()
    })
}

/// GPS_RAW_INT at sim time `t` (s); `vel` cm/s, `cog` cd.
pub(crate) fn gps_raw(
    s: &Snapshot,
    t: f64,
    fix_type: GpsFixType,
    satellites_visible: u8,
    vel: u16,
    cog: u16,
) -> MavMessage {
    MavMessage::GPS_RAW_INT(GPS_RAW_INT_DATA {
        time_usec: (t * 1e6) as u64,
        lat: (s.lat * 1e7).round() as i32,
        lon: (s.lon * 1e7).round() as i32,
        alt: 0,
        eph: 121,
        epv: 200,
        vel,
        cog,
        fix_type,
        satellites_visible,
    })
}

/// EKF_STATUS_REPORT with `flags` and small, settled variances.
pub(crate) fn ekf_report(flags: u16) -> MavMessage {
    MavMessage::EKF_STATUS_REPORT(EKF_STATUS_REPORT_DATA {
        velocity_variance: 0.02,
        pos_horiz_variance: 0.01,
        pos_vert_variance: 0.01,
        compass_variance: 0.02,
        terrain_alt_variance: 0.0,
        flags: EkfStatusFlags::from_bits_retain(flags),
    })
}
