//! NAV → MOOS: the NAV_* posts (and GPS_UPDATE_RECEIVED) of one node_status, in Goby3's order
//! and units, with the two conversions they need (uSimMarine's yaw, C++'s `%.15g`). Pure
//! functions; the data path posts what they return.

use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{NodeStatus, source};

/// One MOOS post of a node_status.
#[derive(Clone, Debug, PartialEq)]
pub enum NavValue {
    Double(f64),
    Text(String),
}

/// The NAV_* posts of one node_status, in the order Goby3 posts them. Units: metres, degrees for
/// NAV_HEADING / LAT / LONG, radians for NAV_YAW / PITCH / ROLL, m/s for NAV_SPEED.
///
/// NAV_X / NAV_Y are left out when the node_status has no local_fix (Goby3 would post 0, 0 —
/// a position the helm would steer by); the interface fills local_fix whenever its datum is
/// valid, so this only matters for a bad datum.
pub fn nav_posts(ns: &NodeStatus) -> Vec<(&'static str, NavValue)> {
    use NavValue::Double;
    let mut out = Vec::with_capacity(13);
    if let Some(l) = &ns.local_fix {
        out.push(("NAV_X", Double(l.x)));
        out.push(("NAV_Y", Double(l.y)));
    }
    out.push(("NAV_LAT", Double(ns.global_fix.lat)));
    out.push(("NAV_LONG", Double(ns.global_fix.lon)));
    if let Some(z) = ns.local_fix.as_ref().and_then(|l| l.z) {
        out.push(("NAV_Z", Double(z)));
    }
    if let Some(d) = ns.global_fix.depth {
        out.push(("NAV_DEPTH", Double(d)));
    }
    if let Some(h) = ns.pose.heading {
        out.push(("NAV_HEADING", Double(h)));
        out.push(("NAV_YAW", Double(yaw_from_heading(h))));
    }
    out.push(("NAV_SPEED", Double(ns.speed.over_ground)));
    if let Some(p) = ns.pose.pitch {
        out.push(("NAV_PITCH", Double(p.to_radians())));
    }
    if let Some(r) = ns.pose.roll {
        out.push(("NAV_ROLL", Double(r.to_radians())));
    }
    if let Some(a) = ns.global_fix.altitude {
        out.push(("NAV_ALTITUDE", Double(a)));
    }
    let gps = ns
        .source
        .as_ref()
        .and_then(|s| s.position)
        .is_some_and(|p| p == source::Sensor::Gps as i32);
    if gps {
        out.push((
            "GPS_UPDATE_RECEIVED",
            NavValue::Text(format!("Timestamp={}", format_g15(ns.time))),
        ));
    }
    out
}

/// uSimMarine's yaw: −heading folded into (−180°, 180°], in radians (0 = north, positive
/// counter-clockwise).
pub fn yaw_from_heading(heading_deg: f64) -> f64 {
    let mut y = (-heading_deg) % 360.0;
    if y <= -180.0 {
        y += 360.0;
    } else if y > 180.0 {
        y -= 360.0;
    }
    y.to_radians()
}

/// A double as C++ `ostream << setprecision(15)` prints it (`%.15g`), the form Goby3 gives the
/// GPS_UPDATE_RECEIVED timestamp.
pub fn format_g15(x: f64) -> String {
    const P: i32 = 15;
    if !x.is_finite() {
        return if x.is_nan() {
            "nan".into()
        } else if x > 0.0 {
            "inf".into()
        } else {
            "-inf".into()
        };
    }
    if x == 0.0 {
        return if x.is_sign_negative() { "-0" } else { "0" }.into();
    }
    // The exponent after rounding to P significant digits decides the style, as in C.
    let sci = format!("{:.*e}", (P - 1) as usize, x);
    let (mantissa, exp) = sci.split_once('e').unwrap_or((sci.as_str(), "0"));
    let exp: i32 = exp.parse().unwrap_or(0);
    if !(-4..P).contains(&exp) {
        let m = trim_fraction(mantissa);
        let sign = if exp < 0 { '-' } else { '+' };
        format!("{m}e{sign}{:02}", exp.abs())
    } else {
        let decimals = (P - 1 - exp).max(0) as usize;
        trim_fraction(&format!("{x:.decimals$}")).to_owned()
    }
}

fn trim_fraction(s: &str) -> &str {
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.')
    } else {
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
        CartesianCoordinate, EulerAngles, Source, Speed,
    };
    use frontseat_actors::proto::goby::middleware::protobuf::LatLonPoint;

    fn d(posts: &[(&'static str, NavValue)], key: &str) -> Option<f64> {
        posts
            .iter()
            .find(|(k, _)| *k == key)
            .and_then(|(_, v)| match v {
                NavValue::Double(x) => Some(*x),
                NavValue::Text(_) => None,
            })
    }

    fn full_status() -> NodeStatus {
        NodeStatus {
            time: 1_718_000_000.123_45,
            global_fix: LatLonPoint {
                lat: 41.5,
                lon: -70.25,
                depth: Some(3.5),
                altitude: Some(20.0),
            },
            local_fix: Some(CartesianCoordinate {
                x: 12.5,
                y: -7.0,
                z: Some(-3.5),
            }),
            pose: EulerAngles {
                heading: Some(270.0),
                pitch: Some(10.0),
                roll: Some(-5.0),
                ..Default::default()
            },
            speed: Speed {
                over_ground: 1.25,
                over_water: Some(9.0),
            },
            source: Some(Source {
                position: Some(source::Sensor::Gps as i32),
                ..Default::default()
            }),
            ..Default::default()
        }
    }

    #[test]
    fn node_status_becomes_every_nav_variable_in_goby_order() {
        let posts = nav_posts(&full_status());
        let keys: Vec<_> = posts.iter().map(|(k, _)| *k).collect();
        assert_eq!(
            keys,
            [
                "NAV_X",
                "NAV_Y",
                "NAV_LAT",
                "NAV_LONG",
                "NAV_Z",
                "NAV_DEPTH",
                "NAV_HEADING",
                "NAV_YAW",
                "NAV_SPEED",
                "NAV_PITCH",
                "NAV_ROLL",
                "NAV_ALTITUDE",
                "GPS_UPDATE_RECEIVED"
            ]
        );
        assert_eq!(d(&posts, "NAV_X"), Some(12.5));
        assert_eq!(d(&posts, "NAV_Y"), Some(-7.0));
        assert_eq!(d(&posts, "NAV_LAT"), Some(41.5));
        assert_eq!(d(&posts, "NAV_LONG"), Some(-70.25));
        assert_eq!(d(&posts, "NAV_Z"), Some(-3.5));
        assert_eq!(d(&posts, "NAV_DEPTH"), Some(3.5));
        assert_eq!(d(&posts, "NAV_HEADING"), Some(270.0));
        // Heading 270 (west) is yaw +90° (counter-clockwise from north).
        let yaw = d(&posts, "NAV_YAW").unwrap();
        assert!((yaw - std::f64::consts::FRAC_PI_2).abs() < 1e-12, "{yaw}");
        assert_eq!(d(&posts, "NAV_SPEED"), Some(1.25), "over ground, not water");
        assert!((d(&posts, "NAV_PITCH").unwrap() - 10f64.to_radians()).abs() < 1e-15);
        assert!((d(&posts, "NAV_ROLL").unwrap() - (-5f64).to_radians()).abs() < 1e-15);
        assert_eq!(d(&posts, "NAV_ALTITUDE"), Some(20.0));
        assert_eq!(
            posts.last().unwrap().1,
            NavValue::Text("Timestamp=1718000000.12345".into())
        );
    }

    #[test]
    fn optional_fields_are_only_posted_when_present() {
        let ns = NodeStatus {
            time: 5.0,
            global_fix: LatLonPoint {
                lat: 1.0,
                lon: 2.0,
                depth: None,
                altitude: None,
            },
            local_fix: Some(CartesianCoordinate {
                x: 3.0,
                y: 4.0,
                z: None,
            }),
            speed: Speed {
                over_ground: 0.5,
                over_water: None,
            },
            source: Some(Source {
                position: Some(source::Sensor::Usbl as i32),
                ..Default::default()
            }),
            ..Default::default()
        };
        let keys: Vec<_> = nav_posts(&ns).into_iter().map(|(k, _)| k).collect();
        assert_eq!(keys, ["NAV_X", "NAV_Y", "NAV_LAT", "NAV_LONG", "NAV_SPEED"]);
        let no_local = NodeStatus {
            local_fix: None,
            ..ns
        };
        let keys: Vec<_> = nav_posts(&no_local).into_iter().map(|(k, _)| k).collect();
        assert_eq!(keys, ["NAV_LAT", "NAV_LONG", "NAV_SPEED"]);
    }

    #[test]
    fn yaw_is_minus_heading_in_the_half_open_range() {
        let cases = [
            (0.0, 0.0),
            (90.0, -90.0),
            (180.0, 180.0),
            (181.0, 179.0),
            (270.0, 90.0),
            (359.0, 1.0),
            (360.0, 0.0),
            (-90.0, 90.0),
            (540.0, 180.0),
        ];
        for (h, yaw_deg) in cases {
            let y = yaw_from_heading(h);
            assert!(
                (y - f64::to_radians(yaw_deg)).abs() < 1e-12,
                "heading {h}: {} vs {yaw_deg}",
                y.to_degrees()
            );
            assert!(y > -std::f64::consts::PI && y <= std::f64::consts::PI);
        }
    }

    #[test]
    fn g15_formats_like_cpp_setprecision_15() {
        assert_eq!(format_g15(1_718_000_000.123_45), "1718000000.12345");
        assert_eq!(format_g15(1_718_000_000.123_457), "1718000000.12346");
        assert_eq!(format_g15(1_718_000_000.0), "1718000000");
        assert_eq!(format_g15(0.0), "0");
        assert_eq!(format_g15(12.5), "12.5");
        assert_eq!(format_g15(-0.000_125), "-0.000125");
        assert_eq!(format_g15(0.000_012_5), "1.25e-05");
        assert_eq!(format_g15(1e15), "1e+15");
        assert_eq!(format_g15(123_456_789_012_345.0), "123456789012345");
        assert_eq!(format_g15(f64::NAN), "nan");
    }
}
