//! The ROS 2 names of what the gateway carries: each topic's ROS name, its DDS topic and type
//! names (`rt/` prefix, `<pkg>::msg::dds_::<Type>_`), its RIHS01 type hash and QoS class. The
//! hashes are copied from `ros2/type_hashes.txt` (see its first lines for what computed them);
//! the frontseat_msgs ones are recomputed from the .msg files by this module's test.

/// A message type as ROS 2 names it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RosType {
    /// `nav_msgs/msg/Odometry`
    pub ros: &'static str,
    /// RIHS01 type hash (REP-2011), `RIHS01_<64 hex>`.
    pub hash: &'static str,
}

impl RosType {
    /// `nav_msgs::msg::dds_::Odometry_`: the DDS type name rmw_cyclonedds and rmw_fastrtps use.
    pub fn dds_name(&self) -> String {
        let mut parts = self.ros.split('/');
        let (pkg, kind, name) = (
            parts.next().unwrap_or_default(),
            parts.next().unwrap_or_default(),
            parts.next().unwrap_or_default(),
        );
        format!("{pkg}::{kind}::dds_::{name}_")
    }
    /// The type hash a peer's endpoint USER_DATA names (`typehash=RIHS01_…;`, what the rmws
    /// put on every reader and writer since Iron), if it names one.
    pub fn hash_in_user_data(user_data: &[u8]) -> Option<&str> {
        let text = std::str::from_utf8(user_data).ok()?;
        text.split(';')
            .find_map(|kv| kv.trim_end_matches('\0').strip_prefix("typehash="))
    }
}

pub const ODOMETRY: RosType = RosType {
    ros: "nav_msgs/msg/Odometry",
    hash: "RIHS01_3cc97dc7fb7502f8714462c526d369e35b603cfc34d946e3f2eda2766dfec6e0",
};
pub const NAV_SAT_FIX: RosType = RosType {
    ros: "sensor_msgs/msg/NavSatFix",
    hash: "RIHS01_62223ab3fe210a15976021da7afddc9e200dc9ec75231c1b6a557fc598a65404",
};
pub const DIAGNOSTIC_ARRAY: RosType = RosType {
    ros: "diagnostic_msgs/msg/DiagnosticArray",
    hash: "RIHS01_5a8a36efb05fb25070fa0fb3810290c0e6cd4862b54a8fb975a1ee8dc55a333e",
};
pub const PARTICIPANT_ENTITIES_INFO: RosType = RosType {
    ros: "rmw_dds_common/msg/ParticipantEntitiesInfo",
    hash: "RIHS01_91a0593bacdcc50ea9bdcf849a938b128412cc1ea821245c663bcd26f83c295e",
};
pub const NODE_STATUS: RosType = RosType {
    ros: "frontseat_msgs/msg/NodeStatus",
    hash: "RIHS01_dc850f2ffbf257aa8dec058603812a7df0b6bfd51ca75a1bbcad5d26d4b071fe",
};
pub const INTERFACE_STATUS: RosType = RosType {
    ros: "frontseat_msgs/msg/InterfaceStatus",
    hash: "RIHS01_09d8217f46a61d0967985ec3739ce436fc90be495c9c768d52863c10579c6273",
};
pub const COMMAND_RESPONSE: RosType = RosType {
    ros: "frontseat_msgs/msg/CommandResponse",
    hash: "RIHS01_cd365c309859a58108b1cd33afe586abd6bbac92738eb83e686309ef321e6c13",
};
pub const COMMAND_REQUEST: RosType = RosType {
    ros: "frontseat_msgs/msg/CommandRequest",
    hash: "RIHS01_29f79a23d5a3015bc78c0200e6d08a8ffad53e87ccbc038edc5ae5cd6222c7bd",
};
pub const DESIRED_COURSE: RosType = RosType {
    ros: "frontseat_msgs/msg/DesiredCourse",
    hash: "RIHS01_c208a3874bf250d0d4372656a66a7977acc0ca2981f875301ed519452fd01a42",
};
pub const HELM_STATE_REPORT: RosType = RosType {
    ros: "frontseat_msgs/msg/HelmStateReport",
    hash: "RIHS01_beaceb70f95d4be0614619940cc9baca469177d2b5ae771b0135db62fb4dd32f",
};

/// The node the gateway announces: `/<namespace>/frontseat`, so that its `~/odom` is
/// `/<namespace>/frontseat/odom`.
pub const NODE_NAME: &str = "frontseat";
/// Graph discovery's topic (no `rt/` prefix: `avoid_ros_namespace_conventions`).
pub const DISCOVERY_TOPIC: &str = "ros_discovery_info";

/// `rt` + the fully qualified ROS topic name.
pub fn dds_topic(ros_topic: &str) -> String {
    format!("rt{ros_topic}")
}

#[cfg(test)]
mod tests {
    use super::*;
    use sha2::{Digest, Sha256};
    use std::collections::BTreeSet;

    const MSGS: &[(&str, &str)] = &[
        (
            "LatLonPoint",
            include_str!("../frontseat_msgs/msg/LatLonPoint.msg"),
        ),
        (
            "CartesianCoordinate",
            include_str!("../frontseat_msgs/msg/CartesianCoordinate.msg"),
        ),
        (
            "EulerAngles",
            include_str!("../frontseat_msgs/msg/EulerAngles.msg"),
        ),
        ("Speed", include_str!("../frontseat_msgs/msg/Speed.msg")),
        ("Source", include_str!("../frontseat_msgs/msg/Source.msg")),
        (
            "NodeStatus",
            include_str!("../frontseat_msgs/msg/NodeStatus.msg"),
        ),
        (
            "InterfaceStatus",
            include_str!("../frontseat_msgs/msg/InterfaceStatus.msg"),
        ),
        (
            "DesiredCourse",
            include_str!("../frontseat_msgs/msg/DesiredCourse.msg"),
        ),
        (
            "HelmStateReport",
            include_str!("../frontseat_msgs/msg/HelmStateReport.msg"),
        ),
        (
            "CommandRequest",
            include_str!("../frontseat_msgs/msg/CommandRequest.msg"),
        ),
        (
            "CommandResponse",
            include_str!("../frontseat_msgs/msg/CommandResponse.msg"),
        ),
    ];

    fn fields(name: &str) -> Vec<(String, String)> {
        let text = MSGS.iter().find(|(n, _)| *n == name).map(|(_, t)| *t);
        let text = text.unwrap_or_else(|| panic!("no {name}.msg"));
        text.lines()
            .map(|l| l.split('#').next().unwrap_or("").trim())
            .filter(|l| !l.is_empty() && !l.contains('='))
            .map(|l| {
                let mut it = l.split_whitespace();
                (
                    it.next().unwrap().to_string(),
                    it.next().unwrap().to_string(),
                )
            })
            .collect()
    }

    /// One field's type description (rosidl_generator_type_description; only the cases the
    /// frontseat_msgs use: primitives, string, nested types of the same package).
    fn field_type(t: &str) -> (u8, String) {
        let id = match t {
            "int32" => 6,
            "float64" => 11,
            "bool" => 15,
            "string" => 17,
            _ => return (1, format!("frontseat_msgs/msg/{t}")),
        };
        (id, String::new())
    }

    fn individual(name: &str) -> String {
        let fs: Vec<String> = fields(name)
            .iter()
            .map(|(t, f)| {
                let (id, nested) = field_type(t);
                format!(
                    "{{\"name\": \"{f}\", \"type\": {{\"type_id\": {id}, \"capacity\": 0, \
                     \"string_capacity\": 0, \"nested_type_name\": \"{nested}\"}}}}"
                )
            })
            .collect();
        format!(
            "{{\"type_name\": \"frontseat_msgs/msg/{name}\", \"fields\": [{}]}}",
            fs.join(", ")
        )
    }

    fn rihs01(name: &str) -> String {
        let mut refs = BTreeSet::new();
        let mut todo: Vec<String> = vec![name.to_string()];
        while let Some(t) = todo.pop() {
            for (ty, _) in fields(&t) {
                if field_type(&ty).0 == 1 && refs.insert(ty.clone()) {
                    todo.push(ty);
                }
            }
        }
        let referenced: Vec<String> = refs.iter().map(|r| individual(r)).collect();
        let doc = format!(
            "{{\"type_description\": {}, \"referenced_type_descriptions\": [{}]}}",
            individual(name),
            referenced.join(", ")
        );
        let digest = Sha256::digest(doc.as_bytes());
        let hex: String = digest.iter().map(|b| format!("{b:02x}")).collect();
        format!("RIHS01_{hex}")
    }

    #[test]
    fn frontseat_msgs_hashes_follow_from_the_msg_files() {
        for t in [
            NODE_STATUS,
            INTERFACE_STATUS,
            COMMAND_RESPONSE,
            COMMAND_REQUEST,
            DESIRED_COURSE,
            HELM_STATE_REPORT,
        ] {
            let name = t.ros.rsplit('/').next().unwrap();
            assert_eq!(rihs01(name), t.hash, "{}", t.ros);
        }
    }

    #[test]
    fn the_constants_are_the_ones_in_type_hashes_txt() {
        let file = include_str!("../type_hashes.txt");
        for t in [
            ODOMETRY,
            NAV_SAT_FIX,
            DIAGNOSTIC_ARRAY,
            PARTICIPANT_ENTITIES_INFO,
            NODE_STATUS,
            INTERFACE_STATUS,
            COMMAND_RESPONSE,
            COMMAND_REQUEST,
            DESIRED_COURSE,
            HELM_STATE_REPORT,
        ] {
            assert!(
                file.lines().any(|l| l == format!("{} {}", t.ros, t.hash)),
                "{}",
                t.ros
            );
        }
    }

    #[test]
    fn dds_names_as_the_rmws_mangle_them() {
        assert_eq!(ODOMETRY.dds_name(), "nav_msgs::msg::dds_::Odometry_");
        assert_eq!(
            DESIRED_COURSE.dds_name(),
            "frontseat_msgs::msg::dds_::DesiredCourse_"
        );
        assert_eq!(dds_topic("/auv1/frontseat/odom"), "rt/auv1/frontseat/odom");
    }
}
