//! What a backseat concludes from what an ArduPilot vehicle says, and what it sends for a
//! course — pure functions, one rule each, used by both the driver and the emulator so that the
//! two read the README's facts the same way (and each fact has a table test here).

use crate::dialect::{
    EKF_STATUS_REPORT_DATA, EkfStatusFlags, GLOBAL_POSITION_INT_DATA, GpsFixType, HEARTBEAT_DATA,
    MavAutopilot, MavFrame, MavModeFlag, MavState, PositionTargetTypemask,
    SET_POSITION_TARGET_GLOBAL_INT_DATA,
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

/// The GUIDED target for a heading (degrees) and speed (m/s), plus a depth for Sub (metres,
/// down), addressed to (`system`, `component`).
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
