//! The UVC's units and mode letters, pure: feet and knots to metres and m/s and back, the `$OSI`
//! mode letter, the heading as `$OMS` prints it, and the `$OMS` a course becomes. The driver maps
//! these onto Goby's protobuf types at its edge (`edge.rs`); they live
//! here so the emulator and the tests read the same rules without the runtime.

use crate::codec::{MPS_PER_KNOT, Oms};

pub const METRES_PER_FOOT: f64 = 0.3048;

/// The UVC's modes (Goby3's IverState.IverMode).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum IverMode {
    Unknown,
    Normal,
    Stopped,
    Parking,
    ManualOverride,
    ManualParking,
    Servo,
    Mission,
}

impl IverMode {
    /// The `$OSI` mode field. Goby3 looks at the first character only, which reads PeRL's
    /// manual-parking `Mp` as manual override; both `m` and `Mp` are manual parking here.
    pub fn from_field(f: &str) -> IverMode {
        if f == "Mp" {
            return IverMode::ManualParking;
        }
        match f.chars().next() {
            Some('N') => IverMode::Normal,
            Some('S') => IverMode::Stopped,
            Some('P') => IverMode::Parking,
            Some('M') => IverMode::ManualOverride,
            Some('m') => IverMode::ManualParking,
            Some('A') => IverMode::Servo,
            Some('W') => IverMode::Mission,
            _ => IverMode::Unknown,
        }
    }
}

/// Longest mission name accepted in `$OMSTART` (a UVC file name).
pub const MAX_MISSION_NAME: usize = 64;

/// Whether `f` can be one NMEA field as is: printable ASCII without the separators (`,`), the
/// checksum and start marks (`*`, `$`, `!`) or line ends, so that a mission name from the bus
/// cannot add fields or sentences to what is written to the vehicle.
pub fn is_field_safe(f: &str) -> bool {
    f.len() <= MAX_MISSION_NAME
        && f.bytes()
            .all(|b| b.is_ascii_graphic() && !matches!(b, b',' | b'*' | b'$' | b'!') || b == b' ')
}

/// Heading into [0, 360) as it will be printed (one decimal): 359.96 would print as 360.0,
/// which Goby3 sends; it is 0.0 here.
pub fn oms_heading(h: f64) -> f64 {
    let r = (h.rem_euclid(360.0) * 10.0).round() / 10.0;
    if r >= 360.0 { 0.0 } else { r }
}

/// A course in metres and m/s → `$OMS` (depth in feet or metres by Remote Helm version, speed
/// in knots).
pub fn oms_for_course(
    heading_deg: f64,
    depth_m: f64,
    speed_mps: f64,
    remote_helm_version_major: i32,
    max_pitch_angle_degrees: i32,
    oms_timeout: u32,
) -> Oms {
    let depth = if Oms::depth_unit_is_feet(remote_helm_version_major) {
        depth_m / METRES_PER_FOOT
    } else {
        depth_m
    };
    Oms {
        heading: oms_heading(heading_deg),
        depth,
        max_pitch: f64::from(max_pitch_angle_degrees),
        speed_kn: speed_mps / MPS_PER_KNOT,
        timeout_s: oms_timeout,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::codec::{Sentence, with_checksum};

    #[test]
    fn oms_lines_for_both_remote_helm_generations() {
        let cases = [
            // (heading, depth m, speed m/s, RH major, line)
            (180.0, 3.0, 1.5, 5, "$OMS,180.0,3.0,45.0,2.9,5*78"),
            (180.0, 3.0, 1.5, 4, "$OMS,180.0,9.8,45.0,2.9,5*7A"),
            (-90.0, 0.0, 0.0, 5, "$OMS,270.0,0.0,45.0,0.0,5*75"),
            (359.96, 0.0, 0.0, 5, "$OMS,0.0,0.0,45.0,0.0,5*71"),
            (720.0 + 45.0, 10.0, 2.0, 3, "$OMS,45.0,32.8,45.0,3.9,5*40"),
        ];
        for (h, d, s, rh, want) in cases {
            let line = Sentence::Oms(oms_for_course(h, d, s, rh, 45, 5)).to_line();
            let body = &want[1..want.len() - 3];
            let want = with_checksum(body);
            assert_eq!(line, want, "{h} {d} {s} rh{rh}");
        }
    }

    #[test]
    fn mode_letters() {
        for (f, m) in [
            ("N", IverMode::Normal),
            ("S", IverMode::Stopped),
            ("P", IverMode::Parking),
            ("M", IverMode::ManualOverride),
            ("m", IverMode::ManualParking),
            ("mP", IverMode::ManualParking),
            ("Mp", IverMode::ManualParking),
            ("A", IverMode::Servo),
            ("W", IverMode::Mission),
            ("", IverMode::Unknown),
            ("X", IverMode::Unknown),
        ] {
            assert_eq!(IverMode::from_field(f), m, "{f:?}");
        }
    }

    #[test]
    fn field_safety() {
        assert!(is_field_safe("demo.mis"));
        assert!(is_field_safe("a b"));
        for bad in [
            "a,b",
            "a*b",
            "$x",
            "!x",
            "a\r\nb",
            "é",
            &"x".repeat(MAX_MISSION_NAME + 1),
        ] {
            assert!(!is_field_safe(bad), "{bad:?}");
        }
    }
}
