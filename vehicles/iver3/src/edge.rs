//! The Iver3 driver's edge: the Remote Helm sentences and the UVC's units and mode letters
//! (pure, in [`crate::codec`] and [`crate::units`], shared with the emulator) mapped onto Goby's
//! protobuf types (NodeStatus, DesiredCourse, IverMissionMode) and back. Table-tested.

pub use crate::codec::*;
pub use crate::units::*;

use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    DesiredCourse, EulerAngles, NodeStatus, Speed,
};
use frontseat_actors::proto::goby::middleware::protobuf::LatLonPoint;

/// Goby3's IverState.IverMissionMode for a UVC mode.
pub fn mode_proto(
    m: IverMode,
) -> frontseat_actors::proto::goby::middleware::frontseat::protobuf::iver_state::IverMissionMode {
    use frontseat_actors::proto::goby::middleware::frontseat::protobuf::iver_state::IverMissionMode as M;
    match m {
        IverMode::Unknown => M::IverModeUnknown,
        IverMode::Normal => M::IverModeNormal,
        IverMode::Stopped => M::IverModeStopped,
        IverMode::Parking => M::IverModeParking,
        IverMode::ManualOverride => M::IverModeManualOverride,
        IverMode::ManualParking => M::IverModeManualParking,
        IverMode::Servo => M::IverModeServoMode,
        IverMode::Mission => M::IverModeMissionMode,
    }
}

/// `$OSI` → NodeStatus: feet → metres, knots → m/s. Time is the backseat clock at reception
/// (as in Goby3); local_fix is filled by the interface.
pub fn osi_to_node_status(o: &Osi, now_unix: f64) -> NodeStatus {
    NodeStatus {
        time: now_unix,
        global_fix: LatLonPoint {
            lat: o.lat,
            lon: o.lon,
            depth: Some(o.depth_ft * METRES_PER_FOOT),
            altitude: Some(o.altimeter_ft * METRES_PER_FOOT),
        },
        pose: EulerAngles {
            heading: Some(o.heading),
            ..Default::default()
        },
        speed: Speed {
            over_ground: o.speed_kn * MPS_PER_KNOT,
            over_water: None,
        },
        ..Default::default()
    }
}

/// DesiredCourse (metres, m/s) → `$OMS` (feet or metres by Remote Helm version, knots).
pub fn course_to_oms(
    c: &DesiredCourse,
    remote_helm_version_major: i32,
    max_pitch_angle_degrees: i32,
    oms_timeout: u32,
) -> Oms {
    oms_for_course(
        c.heading(),
        c.depth(),
        c.speed(),
        remote_helm_version_major,
        max_pitch_angle_degrees,
        oms_timeout,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn course(heading: f64, depth: f64, speed: f64) -> DesiredCourse {
        DesiredCourse {
            time: 0.0,
            heading: Some(heading),
            depth: Some(depth),
            speed: Some(speed),
            ..Default::default()
        }
    }

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
            let line = Sentence::Oms(course_to_oms(&course(h, d, s), rh, 45, 5)).to_line();
            let body = &want[1..want.len() - 3];
            let want = with_checksum(body);
            assert_eq!(line, want, "{h} {d} {s} rh{rh}");
        }
    }

    #[test]
    fn osi_units_become_si() {
        let Sentence::Osi(o) = Sentence::parse(
            "$OSI,7F7F7F7F80,N,0,42.358400,-71.087600,2.9,0.0,N,32.8,P0,-14.5,demo.mis,0,90.0,10.5*47",
        )
        .unwrap() else {
            panic!()
        };
        let ns = osi_to_node_status(&o, 1.0);
        assert!((ns.global_fix.depth() - 3.2004).abs() < 1e-9);
        assert!((ns.global_fix.altitude() - 9.99744).abs() < 1e-9);
        assert!((ns.speed.over_ground - 2.9 * 1852.0 / 3600.0).abs() < 1e-12);
        assert_eq!(ns.pose.heading(), 90.0);
        assert_eq!((ns.global_fix.lat, ns.global_fix.lon), (42.3584, -71.0876));
    }
}
