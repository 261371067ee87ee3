//! The safety envelope: the one check every setpoint crosses on its way to a driver, whatever sent
//! it (the bus, pHelmIvP through MOOS, a Zenoh or Goby3 helm, a command_request, the web
//! commander) — they all reach the driver through FrontSeatInterface, which calls [`check_course`].
//! Navigation coming back is checked by `nav_gate`. Pure: no I/O, no clock; the interface counts
//! and logs what it refuses.
//!
//! Rules: a non-finite value refuses the setpoint; a heading within ten turns either way is
//! wrapped into [0, 360), one beyond (1e308) is not a heading and is refused; speed, depth,
//! altitude, pitch, roll and z_rate must lie within the configured [`Limits`]; a course without a
//! heading keeps the last commanded heading (else the vehicle's current heading) — never the
//! protobuf default 0, which would turn the vehicle north.

use frontseat_config::LimitsConfig;

use crate::proto::goby::middleware::frontseat::protobuf::DesiredCourse;

/// The envelope, from `[limits]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    pub max_speed: f64,
    pub max_depth: f64,
    pub min_altitude: f64,
    pub max_altitude: f64,
    pub max_abs_pitch: f64,
    pub max_abs_roll: f64,
    pub max_abs_z_rate: f64,
}

impl From<&LimitsConfig> for Limits {
    fn from(c: &LimitsConfig) -> Self {
        Self {
            max_speed: c.max_speed,
            max_depth: c.max_depth,
            min_altitude: c.min_altitude,
            max_altitude: c.max_altitude,
            max_abs_pitch: c.max_abs_pitch,
            max_abs_roll: c.max_abs_roll,
            max_abs_z_rate: c.max_abs_z_rate,
        }
    }
}

impl Default for Limits {
    fn default() -> Self {
        Self::from(&LimitsConfig::default())
    }
}

/// Why a setpoint was refused: the field, its value and the rule.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{field} = {value}: {rule}")]
pub struct Refusal {
    pub field: &'static str,
    pub value: f64,
    pub rule: String,
}

fn refuse(field: &'static str, value: f64, rule: impl Into<String>) -> Refusal {
    Refusal {
        field,
        value,
        rule: rule.into(),
    }
}

fn finite(field: &'static str, v: f64) -> Result<f64, Refusal> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(refuse(field, v, "not a finite number"))
    }
}

fn within(
    field: &'static str,
    v: Option<f64>,
    lo: f64,
    hi: f64,
    unit: &str,
) -> Result<(), Refusal> {
    let Some(v) = v else { return Ok(()) };
    finite(field, v)?;
    if (lo..=hi).contains(&v) {
        Ok(())
    } else {
        Err(refuse(field, v, format!("outside [{lo}, {hi}] {unit}")))
    }
}

/// Past this magnitude a heading is not wrapped but refused: ten turns either way covers every
/// convention a vehicle or helm uses (−180..180, 0..360, a little past); beyond, the number is not
/// an angle (`1e308` rem 360 is an arbitrary 296).
pub const MAX_WRAPPABLE_DEGREES: f64 = 3600.0;

/// Wraps degrees into [0, 360) (`rem_euclid` alone gives 360 for tiny negative inputs).
pub fn wrap_heading(h: f64) -> f64 {
    let w = h.rem_euclid(360.0);
    if w >= 360.0 { 0.0 } else { w }
}

/// What the gate knows besides the course itself.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GateContext {
    /// Heading of the last course that passed the gate.
    pub last_commanded_heading: Option<f64>,
    /// The vehicle's heading from the newest navigation.
    pub current_heading: Option<f64>,
}

/// The course that may go to the driver, or why not.
pub fn check_course(
    course: &DesiredCourse,
    limits: &Limits,
    ctx: &GateContext,
) -> Result<DesiredCourse, Refusal> {
    let mut c = *course;
    finite("time", c.time)?;
    c.heading = match c.heading {
        Some(h) => {
            finite("heading", h)?;
            let max = MAX_WRAPPABLE_DEGREES;
            if h.abs() > max {
                return Err(refuse(
                    "heading",
                    h,
                    format!("beyond ±{max} degrees: not a heading to wrap"),
                ));
            }
            Some(wrap_heading(h))
        }
        None => match ctx.last_commanded_heading.or(ctx.current_heading) {
            Some(h) => Some(wrap_heading(h)),
            None => {
                return Err(refuse(
                    "heading",
                    f64::NAN,
                    "missing, and no heading was commanded or navigated yet",
                ));
            }
        },
    };
    within("speed", c.speed, 0.0, limits.max_speed, "m/s")?;
    within("depth", c.depth, 0.0, limits.max_depth, "m")?;
    within(
        "altitude",
        c.altitude,
        limits.min_altitude,
        limits.max_altitude,
        "m",
    )?;
    within(
        "pitch",
        c.pitch,
        -limits.max_abs_pitch,
        limits.max_abs_pitch,
        "degrees",
    )?;
    within(
        "roll",
        c.roll,
        -limits.max_abs_roll,
        limits.max_abs_roll,
        "degrees",
    )?;
    within(
        "z_rate",
        c.z_rate,
        -limits.max_abs_z_rate,
        limits.max_abs_z_rate,
        "m/s",
    )?;
    Ok(c)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn course(heading: Option<f64>, speed: f64) -> DesiredCourse {
        DesiredCourse {
            time: 1.0,
            heading,
            speed: Some(speed),
            ..Default::default()
        }
    }

    fn ctx() -> GateContext {
        GateContext {
            last_commanded_heading: Some(123.0),
            current_heading: Some(200.0),
        }
    }

    /// One row per rule: (name, course, expected refused field or accepted heading).
    #[test]
    fn rules_table() {
        let l = Limits::default();
        let with = |f: &dyn Fn(&mut DesiredCourse)| {
            let mut c = course(Some(90.0), 1.5);
            f(&mut c);
            c
        };
        let refused: Vec<(&str, DesiredCourse, &str)> = vec![
            ("NaN heading", course(Some(f64::NAN), 1.5), "heading"),
            (
                "infinite heading",
                course(Some(f64::INFINITY), 1.5),
                "heading",
            ),
            ("1e308 heading", course(Some(1e308), 1.5), "heading"),
            ("-5.1e307 heading", course(Some(-5.1e307), 1.5), "heading"),
            (
                "heading past ten turns",
                course(Some(3600.5), 1.5),
                "heading",
            ),
            ("NaN speed", course(Some(90.0), f64::NAN), "speed"),
            ("1e308 speed", course(Some(90.0), 1e308), "speed"),
            ("negative speed", course(Some(90.0), -0.1), "speed"),
            ("speed over max", course(Some(90.0), 5.01), "speed"),
            ("NaN time", with(&|c| c.time = f64::NAN), "time"),
            ("negative depth", with(&|c| c.depth = Some(-1.0)), "depth"),
            ("depth over max", with(&|c| c.depth = Some(300.5)), "depth"),
            (
                "infinite depth",
                with(&|c| c.depth = Some(f64::INFINITY)),
                "depth",
            ),
            (
                "altitude below min",
                with(&|c| c.altitude = Some(-2.0)),
                "altitude",
            ),
            (
                "altitude NaN",
                with(&|c| c.altitude = Some(f64::NAN)),
                "altitude",
            ),
            ("pitch too steep", with(&|c| c.pitch = Some(-46.0)), "pitch"),
            ("roll too far", with(&|c| c.roll = Some(50.0)), "roll"),
            (
                "z_rate too fast",
                with(&|c| c.z_rate = Some(-2.5)),
                "z_rate",
            ),
        ];
        for (name, c, field) in refused {
            let r = check_course(&c, &l, &ctx()).expect_err(name);
            assert_eq!(r.field, field, "{name}: {r}");
        }
        let accepted: Vec<(&str, DesiredCourse, f64)> = vec![
            ("in range", course(Some(90.0), 1.5), 90.0),
            ("heading 360 wraps to 0", course(Some(360.0), 1.5), 0.0),
            ("heading -90 wraps to 270", course(Some(-90.0), 1.5), 270.0),
            ("heading 725 wraps to 5", course(Some(725.0), 1.5), 5.0),
            ("heading -3600 wraps to 0", course(Some(-3600.0), 1.5), 0.0),
            (
                "tiny negative wraps below 360",
                course(Some(-1e-20), 1.5),
                0.0,
            ),
            (
                "no heading keeps the last commanded",
                course(None, 1.5),
                123.0,
            ),
            ("speed 0 and max are inside", course(Some(10.0), 5.0), 10.0),
            (
                "edges of every limit",
                with(&|c| {
                    c.depth = Some(300.0);
                    c.pitch = Some(45.0);
                    c.roll = Some(-45.0);
                    c.z_rate = Some(2.0);
                    c.altitude = Some(0.0);
                }),
                90.0,
            ),
        ];
        for (name, c, heading) in accepted {
            let out = check_course(&c, &l, &ctx()).unwrap_or_else(|r| panic!("{name}: {r}"));
            assert_eq!(out.heading, Some(heading), "{name}");
            assert!((0.0..360.0).contains(&heading));
        }
    }

    #[test]
    fn a_missing_heading_falls_back_to_navigation_then_refuses() {
        let l = Limits::default();
        let nav_only = GateContext {
            last_commanded_heading: None,
            current_heading: Some(200.0),
        };
        assert_eq!(
            check_course(&course(None, 1.0), &l, &nav_only).map(|c| c.heading),
            Ok(Some(200.0))
        );
        let r = check_course(&course(None, 1.0), &l, &GateContext::default()).unwrap_err();
        assert_eq!(r.field, "heading");
    }

    #[test]
    fn unset_optional_fields_stay_unset() {
        let out = check_course(&course(Some(1.0), 1.0), &Limits::default(), &ctx()).unwrap();
        assert_eq!(
            (out.depth, out.pitch, out.roll, out.z_rate, out.altitude),
            (None, None, None, None, None)
        );
    }
}
