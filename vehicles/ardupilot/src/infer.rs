//! What a backseat concludes from what an ArduPilot vehicle says, and what it sends for a
//! course — pure functions, one rule each, used by both the driver and the emulator so that the
//! two read the README's facts the same way (and each fact has a table test here).

use crate::dialect::{
    AttitudeTargetTypemask, EKF_STATUS_REPORT_DATA, EkfStatusFlags, GLOBAL_POSITION_INT_DATA,
    GpsFixType, HEARTBEAT_DATA, MANUAL_CONTROL_DATA, MavAutopilot, MavFrame, MavModeFlag, MavState,
    PositionTargetTypemask, SET_ATTITUDE_TARGET_DATA, SET_POSITION_TARGET_GLOBAL_INT_DATA,
    SET_POSITION_TARGET_LOCAL_NED_DATA,
};
use crate::modes::{Control, Firmware};
use frontseat_sim::vehicle::wrap_heading;

/// Heading + speed: velocity and yaw used (vx = speed, yaw = heading).
pub const MASK_VELOCITY_YAW: u16 = 0x09C7;
/// Velocity only: heading is the direction of (vx, vy) north/east.
pub const MASK_VELOCITY_ONLY: u16 = 0x0DC7;
/// Velocity and yaw rate.
pub const MASK_VELOCITY_YAW_RATE: u16 = 0x05C7;
/// EKF flags of a fully ready estimate (README: 0x033f).
pub const EKF_READY: u16 = 0x033f;
/// Rover GUIDED drops a target this long (sim time) after the last one.
pub const TARGET_TIMEOUT_S: f64 = 3.0;
/// What Rover says when it drops a target.
pub const TARGET_TIMEOUT_TEXT: &str = "target not received last 3secs, stopping";

/// A vehicle's HEARTBEAT as the backseat reads it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Beat {
    pub armed: bool,
    pub mode: u32,
    pub system_status: MavState,
}

impl Beat {
    /// None when the HEARTBEAT is not an autopilot's (a GCS, a companion, a gimbal).
    pub fn of(hb: &HEARTBEAT_DATA) -> Option<Self> {
        if hb.autopilot == MavAutopilot::MAV_AUTOPILOT_INVALID {
            return None;
        }
        Some(Self {
            armed: hb
                .base_mode
                .contains(MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED),
            mode: hb.custom_mode,
            system_status: hb.system_status,
        })
    }
}

/// The frontseat's control state and why, from one HEARTBEAT and the mode table.
///
/// Disarmed is idle whatever the mode; an armed vehicle in failsafe (system_status CRITICAL or
/// EMERGENCY: ArduPilot's failsafes switch to HOLD by themselves) is the autopilot in control,
/// so the helm leaves COMMAND instead of reading HOLD as a stop it could command out of.
pub fn control(beat: Beat, table: &dyn Fn(u32) -> Control) -> (Control, &'static str) {
    if !beat.armed {
        return (Control::Idle, "disarmed");
    }
    if matches!(
        beat.system_status,
        MavState::MAV_STATE_CRITICAL | MavState::MAV_STATE_EMERGENCY
    ) {
        return (Control::InControl, "failsafe (system_status critical)");
    }
    let c = table(beat.mode);
    let why = match c {
        Control::Idle => "armed in a manual or hold mode",
        Control::InControl => "armed in an autonomous mode of the autopilot",
        Control::AcceptingCommands => "armed in GUIDED",
    };
    (c, why)
}

/// Why the vehicle's navigation cannot be steered by, or Ok.
pub fn nav_usable(ekf: Option<EkfStatusFlags>, fix: Option<GpsFixType>) -> Result<(), String> {
    if let Some(f) = ekf {
        let need = EkfStatusFlags::EKF_ATTITUDE
            | EkfStatusFlags::EKF_VELOCITY_HORIZ
            | EkfStatusFlags::EKF_POS_HORIZ_ABS;
        if !f.contains(need) {
            return Err(format!(
                "EKF has no absolute horizontal position (flags {:#06x})",
                f.bits()
            ));
        }
        if f.intersects(EkfStatusFlags::EKF_CONST_POS_MODE | EkfStatusFlags::EKF_UNINITIALIZED) {
            return Err(format!(
                "EKF in constant-position mode or uninitialised (flags {:#06x})",
                f.bits()
            ));
        }
    }
    if let Some(fix) = fix
        && (fix as u8) < GpsFixType::GPS_FIX_TYPE_3D_FIX as u8
    {
        return Err(format!("GPS without a 3D fix ({fix:?})"));
    }
    Ok(())
}

/// The EKF's readiness for GUIDED, as the emulator and a careful backseat judge it.
pub fn ekf_ready(r: &EKF_STATUS_REPORT_DATA) -> bool {
    r.flags.bits() & EKF_READY == EKF_READY
}

/// A position from GLOBAL_POSITION_INT, checked.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Position {
    pub lat: f64,
    pub lon: f64,
    /// Metres above home (relative_alt); negative under water.
    pub relative_alt: f64,
    /// Degrees [0, 360), when the vehicle knows it.
    pub heading: Option<f64>,
    /// m/s over ground.
    pub speed_over_ground: f64,
}

/// GLOBAL_POSITION_INT → a position, refusing what cannot be one (out of range; 0/0 is what
/// ArduPilot sends before it has a position).
pub fn position(p: &GLOBAL_POSITION_INT_DATA) -> Result<Position, String> {
    let lat = f64::from(p.lat) * 1e-7;
    let lon = f64::from(p.lon) * 1e-7;
    if !(-90.0..=90.0).contains(&lat) || !(-180.0..=180.0).contains(&lon) {
        return Err(format!("position out of range: lat {lat}, lon {lon}"));
    }
    if p.lat == 0 && p.lon == 0 {
        return Err("no position yet (lat/lon 0/0)".into());
    }
    Ok(Position {
        lat,
        lon,
        relative_alt: f64::from(p.relative_alt) * 1e-3,
        // UINT16_MAX = unknown.
        heading: (p.hdg != u16::MAX).then(|| f64::from(p.hdg % 36000) / 100.0),
        speed_over_ground: f64::from(p.vx).hypot(f64::from(p.vy)) / 100.0,
    })
}

/// Rover's GUIDED target for a heading (degrees) and speed (m/s), addressed to (`system`,
/// `component`). (With `Firmware::Sub` and a depth it also sets z, but ArduSub ignores a
/// GLOBAL_INT target's yaw in GUIDED: the driver sends a Sub [`sub_guided_target`] instead.)
pub fn course_target(
    firmware: Firmware,
    heading_deg: f64,
    speed: f64,
    depth: Option<f64>,
    system: u8,
    component: u8,
    time_boot_ms: u32,
) -> SET_POSITION_TARGET_GLOBAL_INT_DATA {
    let mut mask = MASK_VELOCITY_YAW;
    let mut alt = 0.0;
    if let (Firmware::Sub, Some(d)) = (firmware, depth) {
        // z used: clear Z_IGNORE; relative altitude is up, depth is down.
        mask &= !PositionTargetTypemask::POSITION_TARGET_TYPEMASK_Z_IGNORE.bits();
        alt = -d as f32;
    }
    SET_POSITION_TARGET_GLOBAL_INT_DATA {
        time_boot_ms,
        lat_int: 0,
        lon_int: 0,
        alt,
        vx: speed as f32,
        vy: 0.0,
        vz: 0.0,
        afx: 0.0,
        afy: 0.0,
        afz: 0.0,
        yaw: heading_deg.to_radians() as f32,
        yaw_rate: 0.0,
        type_mask: PositionTargetTypemask::from_bits_retain(mask),
        target_system: system,
        target_component: component,
        coordinate_frame: MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT,
    }
}

/// Sub GUIDED, heading + speed + depth (ardusub.md, "Recommended"): LOCAL_NED position +
/// velocity + yaw; acceleration and yaw rate ignored.
pub const SUB_MASK_POS_VEL_YAW: u16 = 0x09C0;
/// Sub ALT_HOLD depth: every group ignored but z (bit 2), which ALT_HOLD reads alone.
pub const SUB_MASK_Z_ONLY: u16 = 0x0DFB;
/// Sub ALT_HOLD heading: body rates and throttle ignored, the attitude used.
pub const SUB_ATTITUDE_MASK: u8 = 0x47;
/// ArduSub zeroes a velocity (and PosVel) target this long (autopilot time) after the last one.
pub const SUB_TARGET_TIMEOUT_S: f64 = 3.0;
/// ALT_HOLD obeys a SET_ATTITUDE_TARGET this long after each one, then turns back.
pub const SUB_ATTITUDE_TIMEOUT_S: f64 = 5.0;
/// MANUAL_CONTROL z that neither climbs nor dives (0..1000).
pub const MANUAL_Z_NEUTRAL: i16 = 500;

/// The Sub's GUIDED target for a course: x, y = the vehicle's latest LOCAL_POSITION_NED (so the
/// position part never pulls it back), z = depth (down), (vx, vy) = speed along the heading,
/// yaw = heading. Re-sent at 5 Hz, it is ArduSub's PosVel controller following the course.
#[allow(clippy::too_many_arguments)]
pub fn sub_guided_target(
    heading_deg: f64,
    speed: f64,
    depth: f64,
    north: f64,
    east: f64,
    system: u8,
    component: u8,
    time_boot_ms: u32,
) -> SET_POSITION_TARGET_LOCAL_NED_DATA {
    let h = heading_deg.to_radians();
    SET_POSITION_TARGET_LOCAL_NED_DATA {
        time_boot_ms,
        x: north as f32,
        y: east as f32,
        z: depth as f32,
        vx: (speed * h.cos()) as f32,
        vy: (speed * h.sin()) as f32,
        vz: 0.0,
        afx: 0.0,
        afy: 0.0,
        afz: 0.0,
        yaw: yaw_radians(heading_deg),
        yaw_rate: 0.0,
        type_mask: PositionTargetTypemask::from_bits_retain(SUB_MASK_POS_VEL_YAW),
        target_system: system,
        target_component: component,
        coordinate_frame: MavFrame::MAV_FRAME_LOCAL_NED,
    }
}

/// A heading in degrees as ArduPilot's yaw: radians in (−π, π], 0 = north, clockwise.
fn yaw_radians(heading_deg: f64) -> f32 {
    let w = wrap_heading(heading_deg);
    let signed = if w > 180.0 { w - 360.0 } else { w };
    signed.to_radians() as f32
}

/// The Sub's ALT_HOLD depth target: SET_POSITION_TARGET_GLOBAL_INT with only z used; ALT_HOLD
/// reads `alt` as metres up from the EKF origin (alt = −depth) and ignores frame and lat/lon.
pub fn sub_depth_target(
    depth: f64,
    system: u8,
    component: u8,
    time_boot_ms: u32,
) -> SET_POSITION_TARGET_GLOBAL_INT_DATA {
    SET_POSITION_TARGET_GLOBAL_INT_DATA {
        time_boot_ms,
        alt: -depth as f32,
        type_mask: PositionTargetTypemask::from_bits_retain(SUB_MASK_Z_ONLY),
        target_system: system,
        target_component: component,
        coordinate_frame: MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT,
        ..Default::default()
    }
}

/// The quaternion (w, x, y, z) of a level attitude at `heading_deg`.
pub fn level_quaternion(heading_deg: f64) -> [f32; 4] {
    let half = f64::from(yaw_radians(heading_deg)) / 2.0;
    [half.cos() as f32, 0.0, 0.0, half.sin() as f32]
}

/// The yaw (degrees, [0, 360)) of a quaternion (w, x, y, z), or None when it is not one.
pub fn quaternion_heading(q: [f32; 4]) -> Option<f64> {
    let [w, x, y, z] = q.map(f64::from);
    let n = (w * w + x * x + y * y + z * z).sqrt();
    if !n.is_finite() || n < 1e-6 {
        return None;
    }
    let yaw = (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z));
    Some(wrap_heading(yaw.to_degrees()))
}

/// The Sub's ALT_HOLD heading: a level attitude at the heading, throttle ignored.
pub fn sub_attitude_target(
    heading_deg: f64,
    system: u8,
    component: u8,
    time_boot_ms: u32,
) -> SET_ATTITUDE_TARGET_DATA {
    SET_ATTITUDE_TARGET_DATA {
        time_boot_ms,
        q: level_quaternion(heading_deg),
        body_roll_rate: 0.0,
        body_pitch_rate: 0.0,
        body_yaw_rate: 0.0,
        thrust: 0.5,
        target_system: system,
        target_component: component,
        type_mask: AttitudeTargetTypemask::from_bits_retain(SUB_ATTITUDE_MASK),
    }
}

/// MANUAL_CONTROL as a companion sends it to a Sub: forward `x` (−1000..1000), no lateral or yaw,
/// z neutral (500: ALT_HOLD keeps its depth), no buttons (each button fires a BTNn_FUNCTION:
/// the defaults arm, disarm and change mode).
pub fn manual_control(x: i16, system: u8) -> MANUAL_CONTROL_DATA {
    MANUAL_CONTROL_DATA {
        x: x.clamp(-1000, 1000),
        y: 0,
        z: MANUAL_Z_NEUTRAL,
        r: 0,
        buttons: 0,
        target: system,
    }
}

/// MANUAL_CONTROL x for a desired speed (open-loop: `per_mps` counts per m/s).
pub fn thrust_for_speed(speed: f64, per_mps: f64) -> i16 {
    let x = speed * per_mps;
    if x.is_finite() {
        x.round().clamp(-1000.0, 1000.0) as i16
    } else {
        0
    }
}

/// What Sub GUIDED makes of a SET_POSITION_TARGET_LOCAL_NED (ardusub.md, GCS_MAVLink_Sub.cpp):
/// a group is ignored if any of its bits is set; position covers x, y and z together.
#[derive(Debug, Clone, PartialEq)]
pub enum SubTarget {
    /// Position + velocity (PosVel controller): north, east, down (m); velocity north, east
    /// (m/s); yaw (degrees) when used.
    PosVel {
        pos: (f64, f64, f64),
        vel: (f64, f64),
        yaw: Option<f64>,
    },
    /// Velocity only (Velocity controller): north, east, down (m/s).
    Vel {
        vel: (f64, f64, f64),
        yaw: Option<f64>,
    },
    /// Position only (waypoint controller): restarts its trajectory at each arrival.
    Wp {
        pos: (f64, f64, f64),
        yaw: Option<f64>,
    },
    /// Dropped without a word, and why (for the emulator's counters).
    Dropped(&'static str),
}

/// Sub's reading of a LOCAL_NED target (frame LOCAL_NED 1 or LOCAL_OFFSET_NED 7 here; the body
/// frames are rotated by the caller). `here` is the vehicle's (north, east, down) for offsets.
#[allow(clippy::too_many_arguments)]
pub fn interpret_sub_target(
    mask: u16,
    frame: u8,
    here: (f64, f64, f64),
    pos: (f32, f32, f32),
    vel: (f32, f32, f32),
    yaw: f32,
) -> SubTarget {
    let ignored = |bits: u16| mask & bits != 0;
    if !ignored(0b1_1100_0000) {
        return SubTarget::Dropped("acceleration not ignored");
    }
    let pos_used = !ignored(0b111);
    let vel_used = !ignored(0b11_1000);
    let yaw = (!ignored(1 << 10)).then_some(yaw);
    let fin = |v: &[f32]| v.iter().all(|x| x.is_finite());
    if (pos_used && !fin(&[pos.0, pos.1, pos.2]))
        || (vel_used && !fin(&[vel.0, vel.1, vel.2]))
        || yaw.is_some_and(|y| !y.is_finite())
    {
        return SubTarget::Dropped("non-finite field");
    }
    let yaw = yaw.map(|y| wrap_heading(f64::from(y).to_degrees()));
    let offset = matches!(frame, 7 | 9);
    let p = (
        f64::from(pos.0) + if offset { here.0 } else { 0.0 },
        f64::from(pos.1) + if offset { here.1 } else { 0.0 },
        f64::from(pos.2) + if offset { here.2 } else { 0.0 },
    );
    let v = (f64::from(vel.0), f64::from(vel.1), f64::from(vel.2));
    match (pos_used, vel_used) {
        (true, true) => SubTarget::PosVel {
            pos: p,
            vel: (v.0, v.1),
            yaw,
        },
        (false, true) => SubTarget::Vel { vel: v, yaw },
        (true, false) => SubTarget::Wp { pos: p, yaw },
        (false, false) => SubTarget::Dropped("neither position nor velocity used"),
    }
}

/// What Rover GUIDED makes of a target's fields by its type_mask (README: a group is ignored if
/// any of its bits is set).
#[derive(Debug, Clone, PartialEq)]
pub enum Target {
    /// Heading (degrees) and signed speed (m/s; negative reverses).
    Course { heading: f64, speed: f64 },
    /// Speed and a turn rate (deg/s).
    TurnRate { speed: f64, rate: f64 },
    /// Drive to a point.
    Position { lat: f64, lon: f64 },
    /// Refused, with the STATUSTEXT Rover sends.
    Refused(String),
}

/// Reads a target's fields by `mask`. `msg` names the message in the refusal text, which must
/// fit STATUSTEXT's 50 characters with it ("GLOBAL_INT target" does).
#[allow(clippy::too_many_arguments)]
pub fn interpret_target(
    msg: &str,
    mask: u16,
    lat_lon: Option<(f64, f64)>,
    vx: f32,
    vy: f32,
    yaw: f32,
    yaw_rate: f32,
) -> Target {
    let ignored = |bits: u16| mask & bits != 0;
    let pos_ignore = ignored(0b11);
    let vel_ignore = ignored(0b1_1000);
    let acc_ignore = ignored(0b1100_0000);
    let yaw_ignore = ignored(1 << 10);
    let yaw_rate_ignore = ignored(1 << 11);
    if !acc_ignore {
        return Target::Refused(format!("Ignoring {msg}; set ACC_IGNORE in mask"));
    }
    let finite = [vx, vy, yaw, yaw_rate].iter().all(|v| v.is_finite());
    if !finite {
        return Target::Refused(format!("Ignoring {msg}; non-finite field"));
    }
    if !pos_ignore {
        return match lat_lon {
            Some((lat, lon)) => Target::Position { lat, lon },
            None => Target::Refused(format!("Ignoring {msg}; position needs an EKF origin")),
        };
    }
    let (vx, vy) = (f64::from(vx), f64::from(vy));
    let speed = vx.hypot(vy);
    if !vel_ignore && !yaw_ignore {
        let signed = if vx < 0.0 { -speed } else { speed };
        return Target::Course {
            heading: wrap_heading(f64::from(yaw).to_degrees()),
            speed: signed,
        };
    }
    if !vel_ignore && !yaw_rate_ignore {
        return Target::TurnRate {
            speed,
            rate: f64::from(yaw_rate).to_degrees(),
        };
    }
    if !vel_ignore {
        return Target::Course {
            heading: wrap_heading(vy.atan2(vx).to_degrees()),
            speed,
        };
    }
    Target::Refused(format!(
        "Ignoring {msg}; no usable field in mask {mask:#06x}"
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn beat(armed: bool, mode: u32, s: MavState) -> Beat {
        Beat {
            armed,
            mode,
            system_status: s,
        }
    }

    /// The state inference, one row per rule.
    #[test]
    fn state_inference_rules() {
        let t = |m| Firmware::Rover.default_control(m);
        let ok = MavState::MAV_STATE_ACTIVE;
        let rows = [
            (
                "armed + GUIDED accepts",
                beat(true, 15, ok),
                Control::AcceptingCommands,
            ),
            (
                "armed + AUTO is the autopilot's",
                beat(true, 10, ok),
                Control::InControl,
            ),
            (
                "armed + RTL is the autopilot's",
                beat(true, 11, ok),
                Control::InControl,
            ),
            ("armed + MANUAL is idle", beat(true, 0, ok), Control::Idle),
            ("armed + HOLD is idle", beat(true, 4, ok), Control::Idle),
            (
                "disarmed GUIDED is idle",
                beat(false, 15, ok),
                Control::Idle,
            ),
            (
                "failsafe to HOLD is the autopilot in control",
                beat(true, 4, MavState::MAV_STATE_CRITICAL),
                Control::InControl,
            ),
        ];
        for (rule, b, want) in rows {
            assert_eq!(control(b, &t).0, want, "{rule}");
        }
    }

    #[test]
    fn type_mask_rules_of_the_readme() {
        let m = "GLOBAL_INT target";
        let h90 = std::f32::consts::FRAC_PI_2;
        // (rule, mask, vx, vy, yaw, yaw_rate, want)
        let rows: [(&str, u16, f32, f32, f32, f32, Target); 6] = [
            (
                "0x09C7 velocity + yaw",
                0x09C7,
                2.0,
                0.0,
                h90,
                0.0,
                Target::Course {
                    heading: 90.0,
                    speed: 2.0,
                },
            ),
            (
                "0x09C7 with vx < 0 reverses",
                0x09C7,
                -1.0,
                0.0,
                h90,
                0.0,
                Target::Course {
                    heading: 90.0,
                    speed: -1.0,
                },
            ),
            (
                "0x0DC7 velocity only: heading from (vx, vy)",
                0x0DC7,
                -3.0 * std::f32::consts::FRAC_1_SQRT_2,
                -3.0 * std::f32::consts::FRAC_1_SQRT_2,
                0.0,
                0.0,
                Target::Course {
                    heading: 225.0,
                    speed: 3.0,
                },
            ),
            (
                "0x05C7 velocity + yaw rate",
                0x05C7,
                1.0,
                0.0,
                0.0,
                0.1,
                Target::TurnRate {
                    speed: 1.0,
                    rate: 0.1f32.to_degrees() as f64,
                },
            ),
            (
                "acceleration bits clear: refused",
                0x0907,
                1.0,
                0.0,
                0.0,
                0.0,
                Target::Refused(format!("Ignoring {m}; set ACC_IGNORE in mask")),
            ),
            (
                "only one acceleration bit set still counts as ignored",
                0x0947,
                1.0,
                0.0,
                h90,
                0.0,
                Target::Course {
                    heading: 90.0,
                    speed: 1.0,
                },
            ),
        ];
        for (rule, mask, vx, vy, yaw, yr, want) in rows {
            let got = interpret_target(m, mask, None, vx, vy, yaw, yr);
            match (&got, &want) {
                (
                    Target::Course {
                        heading: a,
                        speed: b,
                    },
                    Target::Course {
                        heading: c,
                        speed: d,
                    },
                ) => assert!(
                    (a - c).abs() < 1e-3 && (b - d).abs() < 1e-3,
                    "{rule}: {got:?}"
                ),
                (
                    Target::TurnRate { speed: a, rate: b },
                    Target::TurnRate { speed: c, rate: d },
                ) => {
                    assert!(
                        (a - c).abs() < 1e-6 && (b - d).abs() < 1e-3,
                        "{rule}: {got:?}"
                    )
                }
                _ => assert_eq!(got, want, "{rule}"),
            }
        }
        assert!(matches!(
            interpret_target(m, 0x0DC0, Some((1.0, 2.0)), 0.0, 0.0, 0.0, 0.0),
            Target::Position { .. }
        ));
    }

    #[test]
    fn course_target_is_0x09c7_with_vx_speed_and_yaw_radians() {
        let t = course_target(Firmware::Rover, 90.0, 2.0, Some(5.0), 1, 1, 0);
        assert_eq!(t.type_mask.bits(), 0x09C7);
        assert_eq!(t.vx, 2.0);
        assert!((t.yaw - std::f32::consts::FRAC_PI_2).abs() < 1e-6);
        let s = course_target(Firmware::Sub, 90.0, 1.0, Some(5.0), 1, 1, 0);
        assert_eq!(s.type_mask.bits(), 0x09C3);
        assert_eq!(s.alt, -5.0);
    }

    #[test]
    fn sub_targets_of_the_facts_file() {
        // GUIDED: 0x09C0, LOCAL_NED, x/y the vehicle's, z depth, velocity along the heading.
        let t = sub_guided_target(90.0, 0.5, 5.0, 12.0, -3.0, 1, 1, 0);
        assert_eq!(t.type_mask.bits(), 0x09C0);
        assert_eq!(t.coordinate_frame, MavFrame::MAV_FRAME_LOCAL_NED);
        assert_eq!((t.x, t.y, t.z), (12.0, -3.0, 5.0));
        assert!(t.vx.abs() < 1e-6 && (t.vy - 0.5).abs() < 1e-6, "{t:?}");
        assert!((t.yaw - std::f32::consts::FRAC_PI_2).abs() < 1e-6);
        let west = sub_guided_target(270.0, 1.0, 0.0, 0.0, 0.0, 1, 1, 0);
        assert!(
            (west.yaw + std::f32::consts::FRAC_PI_2).abs() < 1e-6,
            "{west:?}"
        );
        // ALT_HOLD: z alone (bit 2 clear), alt = −depth.
        let d = sub_depth_target(5.0, 1, 1, 0);
        assert_eq!(d.type_mask.bits() & 0b111, 0b011);
        assert_eq!(d.alt, -5.0);
        let a = sub_attitude_target(90.0, 1, 1, 0);
        assert_eq!(a.type_mask.bits(), 0x47);
        assert!((quaternion_heading(a.q).unwrap() - 90.0).abs() < 1e-4);
        assert!((quaternion_heading(level_quaternion(225.0)).unwrap() - 225.0).abs() < 1e-4);
        assert_eq!(quaternion_heading([0.0; 4]), None);
        assert_eq!(thrust_for_speed(0.5, 1000.0), 500);
        assert_eq!(thrust_for_speed(3.0, 1000.0), 1000);
        assert_eq!(thrust_for_speed(f64::NAN, 1000.0), 0);
        let m = manual_control(500, 1);
        assert_eq!((m.x, m.z, m.buttons, m.target), (500, 500, 0, 1));
    }

    /// ardusub.md's type_mask rules, one row each.
    #[test]
    fn sub_type_mask_rules() {
        let here = (10.0, 20.0, 1.0);
        let p = (1.0, 2.0, 5.0);
        let v = (0.0, 0.5, 0.0);
        let h90 = std::f32::consts::FRAC_PI_2;
        let r = |mask, frame| interpret_sub_target(mask, frame, here, p, v, h90);
        match r(0x09C0, 1) {
            SubTarget::PosVel {
                pos: (1.0, 2.0, 5.0),
                vel: (0.0, 0.5),
                yaw: Some(y),
            } => assert!((y - 90.0).abs() < 1e-4),
            other => panic!("{other:?}"),
        }
        // Acceleration not ignored: dropped, whatever else.
        assert!(matches!(r(0x0800, 1), SubTarget::Dropped(_)));
        assert!(matches!(r(0x0807, 1), SubTarget::Dropped(_)));
        // One position bit set ignores x, y and z together.
        assert!(matches!(r(0x09C4, 1), SubTarget::Vel { .. }));
        assert!(matches!(r(0x09C7, 1), SubTarget::Vel { yaw: Some(_), .. }));
        assert!(matches!(r(0x0DF8, 1), SubTarget::Wp { yaw: None, .. }));
        // Offsets add the vehicle's position.
        assert_eq!(
            r(0x0DF8, 7),
            SubTarget::Wp {
                pos: (11.0, 22.0, 6.0),
                yaw: None
            }
        );
    }

    #[test]
    fn navigation_readiness() {
        let ready = EkfStatusFlags::from_bits_retain(EKF_READY);
        assert!(nav_usable(Some(ready), Some(GpsFixType::GPS_FIX_TYPE_3D_FIX)).is_ok());
        assert!(nav_usable(None, None).is_ok());
        assert!(nav_usable(Some(EkfStatusFlags::EKF_ATTITUDE), None).is_err());
        assert!(nav_usable(Some(ready), Some(GpsFixType::GPS_FIX_TYPE_2D_FIX)).is_err());
        let mut p = GLOBAL_POSITION_INT_DATA {
            lat: 423_584_560,
            lon: -710_875_890,
            hdg: 9000,
            vx: 100,
            ..Default::default()
        };
        let pos = position(&p).unwrap();
        assert_eq!(pos.heading, Some(90.0));
        assert!((pos.speed_over_ground - 1.0).abs() < 1e-9);
        p.lat = 950_000_000;
        assert!(position(&p).is_err());
        p.lat = 0;
        p.lon = 0;
        assert!(position(&p).is_err());
    }
}
