//! Pure rules used by both the driver and the emulator: VehicleState → the frontseat's control
//! state with a reason, EstimatedState → an absolute position (the reference point displaced by
//! the NED offset) with its sanity checks, and the Reference that steers a course (a point ahead
//! on the heading, speed in m/s, depth).

use crate::imc::{
    self, DesiredSpeed, DesiredZ, EstimatedState, Message, Reference, VehicleState, consts,
};

/// FollowReference's message id: the maneuver a VehicleState names while ours runs.
pub const FOLLOW_REFERENCE: u16 = imc::FollowReference::ID;
/// The flags of a steering Reference: LOCATION | SPEED | DIRECT, plus Z when a depth is given.
pub const STEER_FLAGS: u8 =
    consts::reference::LOCATION | consts::reference::SPEED | consts::reference::DIRECT;
/// DUNE's words when the References stop (`FollowReference/AUV/Task.cpp`).
pub const TIMEOUT_TEXT: &str = "FollowReference maneuver error: reference source timed out";

/// What the vehicle is doing, for the frontseat state.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Control {
    /// Ready for (or running) our FollowReference plan.
    AcceptingCommands,
    /// Running something of its own (a plan, calibration, external control).
    InControl,
    /// Booting or in error: nothing to drive.
    Idle,
}

/// The control state a VehicleState says, and why. `ours` = the maneuver running is our plan.
pub fn control(vs: &VehicleState, plan_engine_blocked: bool, ours: bool) -> (Control, String) {
    use consts::op_mode::*;
    match vs.op_mode {
        SERVICE if plan_engine_blocked => (
            Control::Idle,
            "SERVICE, but the plan engine is BLOCKED".into(),
        ),
        SERVICE => (
            Control::AcceptingCommands,
            "SERVICE: ready for a FollowReference plan".into(),
        ),
        MANEUVER if vs.maneuver_type == FOLLOW_REFERENCE && ours => (
            Control::AcceptingCommands,
            "MANEUVER: our FollowReference".into(),
        ),
        MANEUVER => (
            Control::InControl,
            format!(
                "MANEUVER: the vehicle's own (maneuver id {})",
                vs.maneuver_type
            ),
        ),
        EXTERNAL => (
            Control::InControl,
            format!(
                "EXTERNAL: control loops {:#x} held by someone else",
                vs.control_loops
            ),
        ),
        CALIBRATION => (Control::InControl, "CALIBRATION".into()),
        ERROR => (
            Control::Idle,
            format!(
                "ERROR: {} (entities: {})",
                if vs.last_error.is_empty() {
                    "no reason given"
                } else {
                    &vs.last_error
                },
                vs.error_ents
            ),
        ),
        BOOT => (Control::Idle, "BOOT".into()),
        other => (Control::Idle, format!("unknown op_mode {other}")),
    }
}

/// A usable absolute position and attitude, in degrees and metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Position {
    pub lat: f64,
    pub lon: f64,
    pub depth: f64,
    /// Above the bottom; None when the vehicle says invalid (negative).
    pub altitude: Option<f64>,
    /// Degrees in [0, 360).
    pub heading: f64,
    pub pitch: f64,
    pub roll: f64,
    pub speed_over_ground: f64,
}

/// WGS-84 semi-major axis and first eccentricity squared.
const A: f64 = 6_378_137.0;
const E2: f64 = 6.694_379_990_14e-3;
/// DUNE re-centres its reference beyond 1 km; an offset far beyond that is not navigation.
const MAX_OFFSET_M: f64 = 20_000.0;
/// Deeper than any ocean, or higher above the bottom than any sonar reads.
const MAX_DEPTH_M: f64 = 12_000.0;
const MAX_SPEED_MPS: f64 = 50.0;

/// `lat`, `lon` (rad) displaced by `north`, `east` metres on the local meridian/normal radii
/// (the facts file: a flat-earth step is fine for DUNE's ≤ 1 km offsets).
pub fn displace(lat: f64, lon: f64, north: f64, east: f64) -> (f64, f64) {
    let s = lat.sin();
    let w = 1.0 - E2 * s * s;
    let rn = A / w.sqrt();
    let rm = rn * (1.0 - E2) / w;
    (lat + north / rm, lon + east / (rn * lat.cos()))
}

/// North and east metres from (lat0, lon0) to (lat, lon), all rad; the inverse of [`displace`].
pub fn offset(lat0: f64, lon0: f64, lat: f64, lon: f64) -> (f64, f64) {
    let s = lat0.sin();
    let w = 1.0 - E2 * s * s;
    let rn = A / w.sqrt();
    let rm = rn * (1.0 - E2) / w;
    ((lat - lat0) * rm, (lon - lon0) * rn * lat0.cos())
}

/// EstimatedState → a position, or why it is not one.
pub fn position(e: &EstimatedState) -> Result<Position, String> {
    let f32s = [
        e.x, e.y, e.z, e.phi, e.theta, e.psi, e.vx, e.vy, e.depth, e.alt,
    ];
    if !(e.lat.is_finite() && e.lon.is_finite() && f32s.iter().all(|v| v.is_finite())) {
        return Err("a non-finite field".into());
    }
    if e.lat.abs() > std::f64::consts::FRAC_PI_2 || e.lon.abs() > std::f64::consts::PI {
        return Err(format!(
            "reference point outside the globe (lat {} rad, lon {} rad)",
            e.lat, e.lon
        ));
    }
    let (x, y) = (f64::from(e.x), f64::from(e.y));
    if x.hypot(y) > MAX_OFFSET_M {
        return Err(format!(
            "offset {x} m north, {y} m east is beyond {MAX_OFFSET_M} m"
        ));
    }
    let depth = f64::from(e.depth);
    if !(-100.0..=MAX_DEPTH_M).contains(&depth) || f64::from(e.alt) > MAX_DEPTH_M {
        return Err(format!(
            "depth {depth} m or altitude {} m out of range",
            e.alt
        ));
    }
    let sog = f64::from(e.vx).hypot(f64::from(e.vy));
    if sog > MAX_SPEED_MPS {
        return Err(format!("speed over ground {sog} m/s"));
    }
    let angles = [e.phi, e.theta, e.psi];
    if angles.iter().any(|a| a.abs() > 7.0) {
        return Err("attitude angles beyond ±2π".into());
    }
    let (lat, lon) = displace(e.lat, e.lon, x, y);
    if lat.abs() > std::f64::consts::FRAC_PI_2 {
        return Err("displaced position beyond a pole".into());
    }
    let lon_deg = (lon.to_degrees() + 180.0).rem_euclid(360.0) - 180.0;
    Ok(Position {
        lat: lat.to_degrees(),
        lon: lon_deg,
        depth: depth.max(0.0),
        altitude: (e.alt >= 0.0).then_some(f64::from(e.alt)),
        heading: frontseat_sim::vehicle::wrap_heading(f64::from(e.psi).to_degrees()),
        pitch: f64::from(e.theta).to_degrees(),
        roll: f64::from(e.phi).to_degrees(),
        speed_over_ground: sog,
    })
}

/// The Reference for a course: a point `lookahead` metres from (lat, lon) (degrees) along
/// `heading` (degrees), at `speed` m/s, at `depth` metres when given.
pub fn steering_reference(
    lat: f64,
    lon: f64,
    heading: f64,
    speed: f64,
    depth: Option<f64>,
    lookahead: f64,
) -> Reference {
    let h = heading.to_radians();
    let (plat, plon) = displace(
        lat.to_radians(),
        lon.to_radians(),
        lookahead * h.cos(),
        lookahead * h.sin(),
    );
    Reference {
        flags: STEER_FLAGS
            | if depth.is_some() {
                consts::reference::Z
            } else {
                0
            },
        speed: Some(Box::new(Message::DesiredSpeed(DesiredSpeed {
            value: speed,
            speed_units: consts::METERS_PS,
        }))),
        z: depth.map(|d| {
            Box::new(Message::DesiredZ(DesiredZ {
                value: d as f32,
                z_units: consts::Z_DEPTH,
            }))
        }),
        lat: plat,
        lon: plon,
        radius: 0.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn displacement_round_trips_and_matches_a_degree_of_latitude() {
        let (lat0, lon0) = (41.185f64.to_radians(), (-8.7062f64).to_radians());
        let (lat, lon) = displace(lat0, lon0, 100.0, -50.0);
        let (n, e) = offset(lat0, lon0, lat, lon);
        assert!((n - 100.0).abs() < 1e-6 && (e + 50.0).abs() < 1e-6);
        // A degree of latitude near 41° N is about 111 060 m.
        let (lat1, _) = displace(lat0, lon0, 111_060.0, 0.0);
        assert!(((lat1 - lat0).to_degrees() - 1.0).abs() < 2e-3);
    }

    #[test]
    fn position_is_the_reference_displaced_by_x_and_y() {
        let e = EstimatedState {
            lat: 41.185f64.to_radians(),
            lon: (-8.7062f64).to_radians(),
            x: 1000.0,
            y: 0.0,
            psi: -std::f32::consts::FRAC_PI_2,
            vx: 1.0,
            vy: 1.0,
            depth: 2.0,
            alt: -1.0,
            ..Default::default()
        };
        let p = position(&e).unwrap();
        assert!((p.lat - 41.194_004).abs() < 1e-4, "{}", p.lat);
        assert!((p.lon + 8.7062).abs() < 1e-9);
        assert!((p.heading - 270.0).abs() < 1e-5, "{}", p.heading);
        assert_eq!(p.altitude, None);
        assert!((p.speed_over_ground - 2f64.sqrt()).abs() < 1e-9);
        for bad in [
            EstimatedState {
                lat: f64::NAN,
                ..e.clone()
            },
            EstimatedState {
                depth: 1e7,
                ..e.clone()
            },
            EstimatedState {
                x: 1e6,
                ..e.clone()
            },
            EstimatedState {
                lat: 4.0,
                ..e.clone()
            },
            EstimatedState {
                vx: 1e3,
                ..e.clone()
            },
        ] {
            assert!(position(&bad).is_err(), "{bad:?}");
        }
    }

    #[test]
    fn steering_reference_points_ahead_on_the_heading() {
        let r = steering_reference(41.185, -8.7062, 90.0, 1.5, Some(2.0), 300.0);
        let (n, e) = offset(
            41.185f64.to_radians(),
            (-8.7062f64).to_radians(),
            r.lat,
            r.lon,
        );
        assert!(n.abs() < 1e-6 && (e - 300.0).abs() < 1e-6, "{n} {e}");
        assert_eq!(r.flags, 0x27);
        let r = steering_reference(41.185, -8.7062, 0.0, 1.0, None, 300.0);
        assert_eq!((r.flags, r.z.is_none()), (0x23, true));
    }

    #[test]
    fn vehicle_state_rules() {
        use consts::op_mode::*;
        let vs = |op_mode, maneuver_type| VehicleState {
            op_mode,
            maneuver_type,
            ..Default::default()
        };
        let rows = [
            (
                vs(SERVICE, 0xFFFF),
                false,
                false,
                Control::AcceptingCommands,
            ),
            (vs(SERVICE, 0xFFFF), true, false, Control::Idle),
            (vs(MANEUVER, 478), false, true, Control::AcceptingCommands),
            (vs(MANEUVER, 478), false, false, Control::InControl),
            (vs(MANEUVER, 450), false, true, Control::InControl),
            (vs(EXTERNAL, 0xFFFF), false, false, Control::InControl),
            (vs(CALIBRATION, 0xFFFF), false, false, Control::InControl),
            (vs(ERROR, 0xFFFF), false, false, Control::Idle),
            (vs(BOOT, 0xFFFF), false, false, Control::Idle),
            (vs(77, 0xFFFF), false, false, Control::Idle),
        ];
        for (v, blocked, ours, want) in rows {
            assert_eq!(control(&v, blocked, ours).0, want, "{v:?} {blocked} {ours}");
        }
    }
}
