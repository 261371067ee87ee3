//! The SV2 driver's edge: the frames, messages and unit conversions (pure, in [`crate::codec`],
//! shared with the emulator) mapped onto Goby's NodeStatus.

pub use crate::codec::*;

use frontseat_actors::proto::goby::middleware::frontseat::protobuf::NodeStatus;
use frontseat_actors::proto::goby::middleware::protobuf::LatLonPoint;

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
    fn status_positions() {
        let ns = status_to_node_status(degrees_to_wire(42.3584), degrees_to_wire(-71.0876), 1.0)
            .unwrap();
        assert!((ns.global_fix.lat - 42.3584).abs() < 1e-6);
        assert!((ns.global_fix.lon + 71.0876).abs() < 1e-6);
        assert!(status_to_node_status(degrees_to_wire(95.0), 0, 1.0).is_none());
    }
}
