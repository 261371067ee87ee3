//! The SV2 driver's edge: the frames and messages (shared with the emulator, from
//! `frontseat_sim::waveglider_sv2::codec`) and the conversions between Goby's units and the
//! C&C's (heading as whole degrees 0..=359, position in signed 1/10000 arc minutes). Pure.

pub use frontseat_sim::waveglider_sv2::codec::*;

use crate::proto::goby::middleware::frontseat::protobuf::NodeStatus;
use crate::proto::goby::middleware::protobuf::LatLonPoint;

/// A heading in degrees → the command's whole degrees in 0..=359 (Goby3 truncates and does
/// not wrap: -10 or 720 went out as garbage). Non-finite → None.
pub fn heading_to_wire(h: f64) -> Option<u16> {
    if !h.is_finite() {
        return None;
    }
    let r = h.rem_euclid(360.0).round();
    Some(if r >= 360.0 { 0 } else { r as u16 })
}

/// The position of a status request with a valid fix → NodeStatus (lat/lon only).
pub fn status_to_node_status(latitude: u32, longitude: u32, now_unix: f64) -> Option<NodeStatus> {
    let (lat, lon) = (wire_to_degrees(latitude), wire_to_degrees(longitude));
    if !(-90.0..=90.0).contains(&lat) || !(-180.0..=180.0).contains(&lon) {
        return None;
    }
    Some(NodeStatus {
        time: now_unix,
        global_fix: LatLonPoint {
            lat,
            lon,
            depth: Some(0.0),
            altitude: None,
        },
        ..Default::default()
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn headings_wrap_and_round() {
        for (h, want) in [
            (90.0, Some(90)),
            (90.4, Some(90)),
            (90.6, Some(91)),
            (359.7, Some(0)),
            (-10.0, Some(350)),
            (720.0 + 45.0, Some(45)),
            (f64::NAN, None),
            (f64::INFINITY, None),
        ] {
            assert_eq!(heading_to_wire(h), want, "{h}");
        }
    }

    #[test]
    fn status_positions() {
        let ns = status_to_node_status(degrees_to_wire(42.3584), degrees_to_wire(-71.0876), 1.0)
            .unwrap();
        assert!((ns.global_fix.lat - 42.3584).abs() < 1e-6);
        assert!((ns.global_fix.lon + 71.0876).abs() < 1e-6);
        assert!(status_to_node_status(degrees_to_wire(95.0), 0, 1.0).is_none());
    }
}
