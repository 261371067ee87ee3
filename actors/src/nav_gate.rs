//! The navigation gate: what a frontseat says about itself is checked field by field against
//! physical bounds (`[limits.navigation]`) before the helm may see it, as carefully as a setpoint
//! is checked before the vehicle may see it (`command_gate`). Pure: no I/O, no clock; the
//! interface counts per field and logs what this refuses or drops.
//!
//! Two outcomes per field, fixed by what the helm does with it:
//! - **refuse the message** — time, position (latitude, longitude, local x/y), depth and z, heading,
//!   speed over ground: the helm steers by these. Publishing the rest without one would leave the
//!   helm holding a stale value beside fresh ones (or a default: no depth becomes NAV_Z = 0), so
//!   the whole node_status is withheld and the helm keeps its last good navigation.
//! - **drop the field** — altitude, pitch, roll, the angular rates, course over ground, speed over
//!   water: auxiliary; their absence is already a state every helm handles ("no bottom lock").
//!
//! Depth is also checked against the last accepted one ([`DepthContinuity`]): a pressure sensor
//! that jumps faster than `max_abs_depth_rate` refuses the message, until the new level has held
//! for a few messages (then it is believed: a sensor re-zeroed, not a spike).
//!
//! Heading and course over ground are compass angles: within ten turns either way they are wrapped
//! into [0, 360) (some vehicles report −180..180 or slightly past 360); beyond that the number is
//! not an angle (`1e308` rem 360 is an arbitrary 296) and is treated as out of bounds.

use frontseat_config::NavLimitsConfig;

use crate::command_gate::{MAX_WRAPPABLE_DEGREES, wrap_heading};
use crate::proto::goby::middleware::frontseat::protobuf::NodeStatus;

/// Every local x/y on earth is within half its circumference of the datum.
const MAX_LOCAL_XY_M: f64 = 2.0e7;

/// Unix time in seconds past which a timestamp is not a time (year ≈ 5138).
const MAX_UNIX_TIME_S: f64 = 1.0e11;

/// The bounds, from `[limits.navigation]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NavLimits {
    pub max_abs_speed: f64,
    pub min_depth: f64,
    pub max_depth: f64,
    pub max_altitude: f64,
    pub max_abs_pitch: f64,
    pub max_abs_roll: f64,
    pub max_abs_angular_rate: f64,
    pub max_abs_depth_rate: f64,
}

impl From<&NavLimitsConfig> for NavLimits {
    fn from(c: &NavLimitsConfig) -> Self {
        Self {
            max_abs_speed: c.max_abs_speed,
            min_depth: c.min_depth,
            max_depth: c.max_depth,
            max_altitude: c.max_altitude,
            max_abs_pitch: c.max_abs_pitch,
            max_abs_roll: c.max_abs_roll,
            max_abs_angular_rate: c.max_abs_angular_rate,
            max_abs_depth_rate: c.max_abs_depth_rate,
        }
    }
}

impl Default for NavLimits {
    fn default() -> Self {
        Self::from(&NavLimitsConfig::default())
    }
}

/// Every checked field of NodeStatus; the index of a per-field counter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NavField {
    Time,
    Lat,
    Lon,
    Depth,
    Altitude,
    LocalX,
    LocalY,
    LocalZ,
    Heading,
    CourseOverGround,
    Pitch,
    Roll,
    RollRate,
    PitchRate,
    HeadingRate,
    SpeedOverGround,
    SpeedOverWater,
}

/// What an out-of-bounds field costs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OnViolation {
    RefuseMessage,
    DropField,
}

impl NavField {
    pub const COUNT: usize = 17;
    pub const ALL: [NavField; Self::COUNT] = [
        NavField::Time,
        NavField::Lat,
        NavField::Lon,
        NavField::Depth,
        NavField::Altitude,
        NavField::LocalX,
        NavField::LocalY,
        NavField::LocalZ,
        NavField::Heading,
        NavField::CourseOverGround,
        NavField::Pitch,
        NavField::Roll,
        NavField::RollRate,
        NavField::PitchRate,
        NavField::HeadingRate,
        NavField::SpeedOverGround,
        NavField::SpeedOverWater,
    ];

    /// The protobuf path, as logged and as the key of the per-field counts.
    pub fn name(self) -> &'static str {
        match self {
            NavField::Time => "time",
            NavField::Lat => "global_fix.lat",
            NavField::Lon => "global_fix.lon",
            NavField::Depth => "global_fix.depth",
            NavField::Altitude => "global_fix.altitude",
            NavField::LocalX => "local_fix.x",
            NavField::LocalY => "local_fix.y",
            NavField::LocalZ => "local_fix.z",
            NavField::Heading => "pose.heading",
            NavField::CourseOverGround => "pose.course_over_ground",
            NavField::Pitch => "pose.pitch",
            NavField::Roll => "pose.roll",
            NavField::RollRate => "pose.roll_rate",
            NavField::PitchRate => "pose.pitch_rate",
            NavField::HeadingRate => "pose.heading_rate",
            NavField::SpeedOverGround => "speed.over_ground",
            NavField::SpeedOverWater => "speed.over_water",
        }
    }

    pub fn on_violation(self) -> OnViolation {
        match self {
            NavField::Time
            | NavField::Lat
            | NavField::Lon
            | NavField::Depth
            | NavField::LocalX
            | NavField::LocalY
            | NavField::LocalZ
            | NavField::Heading
            | NavField::SpeedOverGround => OnViolation::RefuseMessage,
            NavField::Altitude
            | NavField::CourseOverGround
            | NavField::Pitch
            | NavField::Roll
            | NavField::RollRate
            | NavField::PitchRate
            | NavField::HeadingRate
            | NavField::SpeedOverWater => OnViolation::DropField,
        }
    }

    pub fn index(self) -> usize {
        self as usize
    }
}

/// A field outside its bounds: which, its value and the bound it broke.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{} = {value}: {rule}", field.name())]
pub struct NavViolation {
    pub field: NavField,
    pub value: f64,
    pub rule: String,
}

/// `Ok(v)` when finite and within [lo, hi].
fn bounded(field: NavField, v: f64, lo: f64, hi: f64, unit: &str) -> Result<f64, NavViolation> {
    if !v.is_finite() {
        return Err(NavViolation {
            field,
            value: v,
            rule: "not a finite number".into(),
        });
    }
    if (lo..=hi).contains(&v) {
        Ok(v)
    } else {
        Err(NavViolation {
            field,
            value: v,
            rule: format!("outside [{lo}, {hi}] {unit}"),
        })
    }
}

/// A compass angle wrapped into [0, 360), or why it is not one.
fn angle(field: NavField, v: f64) -> Result<f64, NavViolation> {
    bounded(
        field,
        v,
        -MAX_WRAPPABLE_DEGREES,
        MAX_WRAPPABLE_DEGREES,
        "degrees (not an angle to wrap)",
    )
    .map(wrap_heading)
}

/// A jump held this many messages in a row is a new level, not a spike.
pub const DEPTH_JUMP_BELIEVED_AFTER: u32 = 5;

/// The last depth the gate let through, to refuse one that jumps: stateful, so the interface
/// keeps one per vehicle and calls [`DepthContinuity::check`] after [`check_navigation`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DepthContinuity {
    /// (time, depth) of the last depth accepted.
    last: Option<(f64, f64)>,
    /// Jumps refused in a row.
    refused_in_a_row: u32,
}

impl DepthContinuity {
    /// Refuses a depth that moved faster than `max_abs_depth_rate` from the last accepted one.
    /// `t` is the interface's own (simulated) clock in seconds when the message arrived: a
    /// driver's time stamp is wall time, and a warped simulation would look 10 times as fast.
    /// Messages without a depth, or not later than the last, are not judged.
    pub fn check(&mut self, ns: &NodeStatus, t: f64, l: &NavLimits) -> Result<(), NavViolation> {
        let Some(d) = ns.global_fix.depth.filter(|d| d.is_finite()) else {
            return Ok(());
        };
        if let Some((t0, d0)) = self.last
            && t > t0
        {
            let rate = (d - d0).abs() / (t - t0);
            if rate > l.max_abs_depth_rate && self.refused_in_a_row + 1 < DEPTH_JUMP_BELIEVED_AFTER
            {
                self.refused_in_a_row += 1;
                return Err(NavViolation {
                    field: NavField::Depth,
                    value: d,
                    rule: format!(
                        "jumped {:.2} m from {d0} in {:.3} s (over {} m/s)",
                        d - d0,
                        t - t0,
                        l.max_abs_depth_rate
                    ),
                });
            }
        }
        if self.last.is_none_or(|(t0, _)| t > t0) {
            self.last = Some((t, d));
            self.refused_in_a_row = 0;
        }
        Ok(())
    }
}

/// The navigation made fit for the helm: `ns` with headings wrapped and the out-of-bounds
/// auxiliary fields removed, and the violations that removed them (empty when all was well);
/// or the violation that refuses the whole message (`ns` is then left half-checked: discard it).
pub fn check_navigation(
    ns: &mut NodeStatus,
    l: &NavLimits,
) -> Result<Vec<NavViolation>, NavViolation> {
    use NavField as F;
    bounded(F::Time, ns.time, 0.0, MAX_UNIX_TIME_S, "s since 1970")?;
    let g = &mut ns.global_fix;
    bounded(F::Lat, g.lat, -90.0, 90.0, "degrees")?;
    bounded(F::Lon, g.lon, -180.0, 180.0, "degrees")?;
    if let Some(d) = g.depth {
        bounded(F::Depth, d, l.min_depth, l.max_depth, "m")?;
    }
    if let Some(lf) = &ns.local_fix {
        bounded(F::LocalX, lf.x, -MAX_LOCAL_XY_M, MAX_LOCAL_XY_M, "m")?;
        bounded(F::LocalY, lf.y, -MAX_LOCAL_XY_M, MAX_LOCAL_XY_M, "m")?;
        if let Some(z) = lf.z {
            bounded(F::LocalZ, z, -l.max_depth, -l.min_depth, "m")?;
        }
    }
    bounded(
        F::SpeedOverGround,
        ns.speed.over_ground,
        -l.max_abs_speed,
        l.max_abs_speed,
        "m/s",
    )?;
    if let Some(h) = ns.pose.heading {
        ns.pose.heading = Some(angle(F::Heading, h)?);
    }

    let mut dropped = Vec::new();
    let mut keep = |slot: &mut Option<f64>, r: Result<f64, NavViolation>| match r {
        Ok(v) => *slot = Some(v),
        Err(v) => {
            *slot = None;
            dropped.push(v);
        }
    };
    let g = &mut ns.global_fix;
    if let Some(a) = g.altitude {
        keep(
            &mut g.altitude,
            bounded(F::Altitude, a, 0.0, l.max_altitude, "m"),
        );
    }
    let p = &mut ns.pose;
    if let Some(c) = p.course_over_ground {
        keep(&mut p.course_over_ground, angle(F::CourseOverGround, c));
    }
    if let Some(v) = p.pitch {
        let m = l.max_abs_pitch;
        keep(&mut p.pitch, bounded(F::Pitch, v, -m, m, "degrees"));
    }
    if let Some(v) = p.roll {
        let m = l.max_abs_roll;
        keep(&mut p.roll, bounded(F::Roll, v, -m, m, "degrees"));
    }
    let m = l.max_abs_angular_rate;
    for (field, slot) in [
        (F::RollRate, &mut p.roll_rate),
        (F::PitchRate, &mut p.pitch_rate),
        (F::HeadingRate, &mut p.heading_rate),
    ] {
        if let Some(v) = *slot {
            keep(slot, bounded(field, v, -m, m, "degrees/s"));
        }
    }
    if let Some(v) = ns.speed.over_water {
        let m = l.max_abs_speed;
        keep(
            &mut ns.speed.over_water,
            bounded(F::SpeedOverWater, v, -m, m, "m/s"),
        );
    }
    Ok(dropped)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::proto::goby::middleware::frontseat::protobuf::{
        CartesianCoordinate, EulerAngles, Speed,
    };
    use crate::proto::goby::middleware::protobuf::LatLonPoint;

    /// Navigation with every field set and in bounds.
    fn full() -> NodeStatus {
        NodeStatus {
            time: 1.7e9,
            global_fix: LatLonPoint {
                lat: 42.0,
                lon: -71.0,
                depth: Some(12.0),
                altitude: Some(8.0),
            },
            local_fix: Some(CartesianCoordinate {
                x: 10.0,
                y: -20.0,
                z: Some(-12.0),
            }),
            pose: EulerAngles {
                roll: Some(-3.0),
                pitch: Some(5.0),
                heading: Some(90.0),
                course_over_ground: Some(92.0),
                roll_rate: Some(1.0),
                pitch_rate: Some(-1.0),
                heading_rate: Some(2.0),
            },
            speed: Speed {
                over_ground: 1.5,
                over_water: Some(1.4),
            },
            ..Default::default()
        }
    }

    fn set(field: NavField, ns: &mut NodeStatus, v: f64) {
        use NavField as F;
        let l = ns.local_fix.get_or_insert_with(Default::default);
        match field {
            F::Time => ns.time = v,
            F::Lat => ns.global_fix.lat = v,
            F::Lon => ns.global_fix.lon = v,
            F::Depth => ns.global_fix.depth = Some(v),
            F::Altitude => ns.global_fix.altitude = Some(v),
            F::LocalX => l.x = v,
            F::LocalY => l.y = v,
            F::LocalZ => l.z = Some(v),
            F::Heading => ns.pose.heading = Some(v),
            F::CourseOverGround => ns.pose.course_over_ground = Some(v),
            F::Pitch => ns.pose.pitch = Some(v),
            F::Roll => ns.pose.roll = Some(v),
            F::RollRate => ns.pose.roll_rate = Some(v),
            F::PitchRate => ns.pose.pitch_rate = Some(v),
            F::HeadingRate => ns.pose.heading_rate = Some(v),
            F::SpeedOverGround => ns.speed.over_ground = v,
            F::SpeedOverWater => ns.speed.over_water = Some(v),
        }
    }

    fn get(field: NavField, ns: &NodeStatus) -> Option<f64> {
        use NavField as F;
        let l = ns.local_fix.unwrap_or_default();
        match field {
            F::Time => Some(ns.time),
            F::Lat => Some(ns.global_fix.lat),
            F::Lon => Some(ns.global_fix.lon),
            F::Depth => ns.global_fix.depth,
            F::Altitude => ns.global_fix.altitude,
            F::LocalX => Some(l.x),
            F::LocalY => Some(l.y),
            F::LocalZ => l.z,
            F::Heading => ns.pose.heading,
            F::CourseOverGround => ns.pose.course_over_ground,
            F::Pitch => ns.pose.pitch,
            F::Roll => ns.pose.roll,
            F::RollRate => ns.pose.roll_rate,
            F::PitchRate => ns.pose.pitch_rate,
            F::HeadingRate => ns.pose.heading_rate,
            F::SpeedOverGround => Some(ns.speed.over_ground),
            F::SpeedOverWater => ns.speed.over_water,
        }
    }

    #[test]
    fn all_lists_every_field_once_in_index_order() {
        for (i, f) in NavField::ALL.iter().enumerate() {
            assert_eq!(f.index(), i, "{f:?}");
        }
    }

    #[test]
    fn in_bounds_navigation_passes_unchanged() {
        let mut ns = full();
        assert_eq!(check_navigation(&mut ns, &NavLimits::default()), Ok(vec![]));
        assert_eq!(ns, full());
    }

    /// One row per field: the values that break it (each alone, the rest in bounds), and whether
    /// that refuses the message or drops the field.
    #[test]
    fn every_field_table() {
        use NavField as F;
        use OnViolation::*;
        let absurd = [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 1e308, -5.1e307];
        let rows: Vec<(NavField, Vec<f64>, OnViolation)> = vec![
            (F::Time, vec![-1.0, 1e20], RefuseMessage),
            (F::Lat, vec![95.0, -90.1], RefuseMessage),
            (F::Lon, vec![180.5, -181.0], RefuseMessage),
            (F::Depth, vec![11_000.5, -100.5], RefuseMessage),
            (F::LocalX, vec![2.1e7, -1e20], RefuseMessage),
            (F::LocalY, vec![2.1e7, -1e20], RefuseMessage),
            (F::LocalZ, vec![-11_001.0, 101.0], RefuseMessage),
            (F::Heading, vec![3600.5, -1e20], RefuseMessage),
            (F::SpeedOverGround, vec![1e20, 50.1, -50.1], RefuseMessage),
            (F::Altitude, vec![-0.5, 11_000.5], DropField),
            (F::CourseOverGround, vec![3601.0, -1e9], DropField),
            (F::Pitch, vec![90.5, -91.0], DropField),
            (F::Roll, vec![180.5, -181.0], DropField),
            (F::RollRate, vec![1000.5, -2000.0], DropField),
            (F::PitchRate, vec![1000.5], DropField),
            (F::HeadingRate, vec![-1000.5], DropField),
            (F::SpeedOverWater, vec![50.5, -1e20], DropField),
        ];
        assert_eq!(rows.len(), NavField::COUNT, "a row for every field");
        let l = NavLimits::default();
        for (field, bad, action) in rows {
            assert_eq!(field.on_violation(), action, "{field:?}");
            for v in absurd.iter().chain(bad.iter()).copied() {
                let mut ns = full();
                set(field, &mut ns, v);
                let out = check_navigation(&mut ns, &l);
                match action {
                    RefuseMessage => {
                        let r = out.expect_err(&format!("{field:?} = {v} refuses the message"));
                        assert_eq!(r.field, field, "{field:?} = {v}: {r}");
                    }
                    DropField => {
                        let dropped = out.unwrap_or_else(|r| panic!("{field:?} = {v}: {r}"));
                        assert_eq!(dropped.len(), 1, "{field:?} = {v}");
                        assert_eq!(dropped[0].field, field);
                        assert_eq!(get(field, &ns), None, "{field:?} = {v} dropped");
                        let mut rest = full();
                        set(field, &mut rest, 0.0);
                        for other in NavField::ALL.iter().filter(|f| **f != field) {
                            assert_eq!(get(*other, &ns), get(*other, &rest), "{other:?} kept");
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn headings_within_ten_turns_are_wrapped() {
        let l = NavLimits::default();
        for (h, want) in [
            (-90.0, 270.0),
            (360.0, 0.0),
            (725.0, 5.0),
            (-3600.0, 0.0),
            (3599.5, 359.5),
        ] {
            let mut ns = full();
            ns.pose.heading = Some(h);
            ns.pose.course_over_ground = Some(h);
            assert_eq!(check_navigation(&mut ns, &l), Ok(vec![]), "{h}");
            assert_eq!(ns.pose.heading, Some(want), "{h}");
            assert_eq!(ns.pose.course_over_ground, Some(want), "{h}");
        }
    }

    #[test]
    fn the_limits_are_the_configured_ones() {
        let l = NavLimits {
            max_abs_speed: 3.0,
            max_depth: 100.0,
            min_depth: 0.0,
            ..Default::default()
        };
        let mut ns = full();
        ns.speed.over_ground = 3.5;
        assert_eq!(
            check_navigation(&mut ns, &l).unwrap_err().field,
            NavField::SpeedOverGround
        );
        let mut ns = full();
        ns.global_fix.depth = Some(120.0);
        assert_eq!(
            check_navigation(&mut ns, &l).unwrap_err().field,
            NavField::Depth
        );
        let mut ns = full();
        ns.global_fix.depth = Some(-0.5);
        assert_eq!(
            check_navigation(&mut ns, &l).unwrap_err().field,
            NavField::Depth
        );
    }

    /// A Sub's depth sensor: NaN, 1e9 m, 200 m above the surface are refused by bounds; a
    /// pressure reading that jumps 40 m in 0.2 s is refused by continuity, until held.
    #[test]
    fn depth_bounds_and_jumps() {
        let l = NavLimits::default();
        for bad in [f64::NAN, 1e9, -200.0] {
            let mut ns = full();
            ns.global_fix.depth = Some(bad);
            assert_eq!(
                check_navigation(&mut ns, &l).unwrap_err().field,
                NavField::Depth,
                "{bad}"
            );
        }
        let at = |d: f64| {
            let mut ns = full();
            ns.global_fix.depth = Some(d);
            ns
        };
        let mut c = DepthContinuity::default();
        assert!(c.check(&at(5.0), 0.0, &l).is_ok());
        assert!(c.check(&at(5.1), 0.2, &l).is_ok());
        let r = c.check(&at(45.0), 0.4, &l).unwrap_err();
        assert_eq!(r.field, NavField::Depth);
        assert!(r.rule.contains("jumped"), "{r}");
        // The spike passes; the next good reading is judged against the last accepted one.
        assert!(c.check(&at(5.2), 0.6, &l).is_ok());
        // A new level held for a few messages is believed.
        let mut refused = 0;
        for i in 0..DEPTH_JUMP_BELIEVED_AFTER {
            if c.check(&at(30.0), 0.8 + f64::from(i) * 0.2, &l).is_err() {
                refused += 1;
            }
        }
        assert_eq!(refused, DEPTH_JUMP_BELIEVED_AFTER - 1);
        assert!(c.check(&at(30.1), 2.0, &l).is_ok());
        // Same time stamp or older: not judged, not adopted.
        assert!(c.check(&at(0.0), 2.0, &l).is_ok());
        assert!(c.check(&at(30.2), 2.2, &l).is_ok());
    }

    #[test]
    fn several_auxiliary_fields_drop_together() {
        let mut ns = full();
        ns.pose.pitch = Some(f64::NAN);
        ns.pose.roll = Some(1e308);
        ns.global_fix.altitude = Some(f64::NAN);
        let dropped = check_navigation(&mut ns, &NavLimits::default()).unwrap();
        let fields: Vec<NavField> = dropped.iter().map(|d| d.field).collect();
        assert_eq!(
            fields,
            vec![NavField::Altitude, NavField::Pitch, NavField::Roll]
        );
        assert_eq!(ns.pose.heading, Some(90.0));
        assert_eq!(ns.speed.over_ground, 1.5);
    }
}
