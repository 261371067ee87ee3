//! The `[ros2]` section of `frontseat interface`: the vehicle as a ROS 2 participant over DDS
//! (crate `frontseat-ros2`): domain, namespace, which topic groups, QoS, who may reach it. Also
//! the ROS 2 name rules the namespace must follow, so `--check` refuses a platform name that
//! cannot be one (rmw's `validate_namespace`/`validate_full_topic_name`).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::FieldError;
use crate::check::{Checker, at};

/// Highest DDS domain id whose ports fit UDP (7400 + 250·domain + …; ROS 2 allows 0-232).
pub const MAX_DOMAIN_ID: u16 = 232;
/// Longest fully qualified ROS topic name (rmw: 255 − 8).
pub const MAX_TOPIC_CHARS: usize = 247;
/// The longest topic the gateway publishes below its namespace.
const LONGEST_SUFFIX: &str = "/frontseat/command_response";

/// The topic groups the gateway can carry.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Ros2Group {
    /// Published: `odom` (nav_msgs/Odometry), `fix` (sensor_msgs/NavSatFix), `node_status`.
    Navigation,
    /// Published: `status` (frontseat_msgs/InterfaceStatus).
    Status,
    /// Published: `/diagnostics` (diagnostic_msgs/DiagnosticArray).
    Diagnostics,
    /// Subscribed: `desired_course`, `helm_state`, `command_request`; published:
    /// `command_response`. What arrives crosses the interface's command gate like any helm's.
    Commands,
}

/// DDS reliability of a topic class.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Ros2Reliability {
    Reliable,
    BestEffort,
}

/// QoS of each class of topic (history is always keep-last).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct Ros2QosConfig {
    /// Odometry, NavSatFix, node_status writers. Reliable (the default) also serves best-effort
    /// (sensor-data) subscribers; a best-effort writer reaches no reliable subscriber (Nav2's).
    pub navigation: Ros2Reliability,
    /// Keep-last depth of the navigation writers. Unit: samples, 1 to 1000.
    #[schemars(range(min = 1, max = 1000))]
    pub navigation_depth: u32,
    /// status, command_response, diagnostics writers and the command readers. Reliable: a
    /// reliable reader matches only reliable writers (a best-effort one matches both).
    pub commands: Ros2Reliability,
    /// Keep-last depth of the status and command readers and writers. Unit: samples, 1 to 1000.
    #[schemars(range(min = 1, max = 1000))]
    pub commands_depth: u32,
}

impl Default for Ros2QosConfig {
    fn default() -> Self {
        Self {
            navigation: Ros2Reliability::Reliable,
            navigation_depth: 10,
            commands: Ros2Reliability::Reliable,
            commands_depth: 10,
        }
    }
}

/// The vehicle as a ROS 2 participant over DDS (no ROS installed): a ROS 2 helm sees
/// `/<namespace>/frontseat/odom`, `fix`, `node_status`, `status`, `command_response` and
/// `/diagnostics`, and steers through `desired_course`, `helm_state`, `command_request`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct Ros2Config {
    /// Join DDS as a ROS 2 participant.
    pub enabled: bool,
    /// DDS domain (ROS_DOMAIN_ID), 0 to 232.
    #[schemars(range(min = 0, max = 232))]
    pub domain_id: u16,
    /// ROS namespace of the topics, e.g. "auv1" or "/fleet/auv1"; empty = the platform name
    /// (`[interprocess] platform`, else `name`, else default_goby_platform). Tokens of letters,
    /// digits and '_', not starting with a digit.
    pub namespace: String,
    /// Which topic groups: "navigation", "status", "diagnostics", "commands".
    pub groups: Vec<Ros2Group>,
    /// Odometry `header.frame_id`: ENU about the datum (`origin`), x east, y north, z up.
    pub odom_frame: String,
    /// Odometry `child_frame_id` and NavSatFix `header.frame_id`: the vehicle (REP-105).
    pub base_frame: String,
    /// DDS (like ROS 2) has no authentication, and the command topics steer the vehicle. false:
    /// discovery and data stay on loopback (127.0.0.1) and samples from a participant that
    /// announces any other address are refused and counted. true: every interface may be used
    /// and any host on the network that speaks DDS can steer the vehicle — only on a network
    /// where that is wanted (or with `groups` leaving out "commands").
    pub allow_remote_peers: bool,
    /// Command samples (desired_course, helm_state, command_request together) accepted per
    /// second; more are refused and counted, so a flooding peer cannot flood the vehicle.
    /// Unit: Hz, 1 to 1000.
    #[schemars(range(min = 1.0, max = 1000.0))]
    pub max_command_rate_hz: f64,
    /// Writer and reader QoS.
    pub qos: Ros2QosConfig,
}

impl Default for Ros2Config {
    fn default() -> Self {
        Self {
            enabled: false,
            domain_id: 0,
            namespace: String::new(),
            groups: vec![
                Ros2Group::Navigation,
                Ros2Group::Status,
                Ros2Group::Diagnostics,
                Ros2Group::Commands,
            ],
            odom_frame: "odom".into(),
            base_frame: "base_link".into(),
            allow_remote_peers: false,
            max_command_rate_hz: 50.0,
            qos: Ros2QosConfig::default(),
        }
    }
}

/// Why a name cannot be a ROS 2 name token.
pub fn check_ros_token(token: &str) -> Result<(), String> {
    let mut chars = token.chars();
    match chars.next() {
        None => return Err("an empty token (\"//\" or a trailing '/')".into()),
        Some(c) if c.is_ascii_digit() => {
            return Err(format!("token {token:?} starts with a digit"));
        }
        _ => {}
    }
    if let Some(c) = token
        .chars()
        .find(|c| !(c.is_ascii_alphanumeric() || *c == '_'))
    {
        return Err(format!(
            "token {token:?} contains {c:?}: only letters, digits and '_' are allowed"
        ));
    }
    Ok(())
}

/// The fully qualified namespace (`/a/b`) of `ns` ("a/b", "/a/b" or "a"), or the ROS 2 rule it
/// breaks.
pub fn ros_namespace(ns: &str) -> Result<String, String> {
    let body = ns.strip_prefix('/').unwrap_or(ns);
    if body.is_empty() {
        return Err(
            "empty (the root namespace is not allowed: topics would clash across vehicles)".into(),
        );
    }
    for t in body.split('/') {
        check_ros_token(t)?;
    }
    let full = format!("/{body}");
    if full.len() + LONGEST_SUFFIX.len() > MAX_TOPIC_CHARS {
        return Err(format!(
            "{} characters: with {LONGEST_SUFFIX} it passes ROS 2's {MAX_TOPIC_CHARS}-character topic limit",
            full.len()
        ));
    }
    Ok(full)
}

impl Ros2Config {
    /// The namespace the gateway uses, given the resolved platform name.
    pub fn resolve_namespace(&self, platform: &str) -> Result<String, String> {
        if self.namespace.is_empty() {
            ros_namespace(platform)
        } else {
            ros_namespace(&self.namespace)
        }
    }

    pub fn has(&self, g: Ros2Group) -> bool {
        self.groups.contains(&g)
    }

    /// `platform`: the platform name the namespace defaults to.
    pub(crate) fn check(&self, prefix: &str, platform: &str, c: &mut Checker) {
        if self.domain_id > MAX_DOMAIN_ID {
            c.push(FieldError::new(
                at(prefix, "domain_id"),
                self.domain_id,
                format!("outside [0, {MAX_DOMAIN_ID}]"),
            ));
        }
        if self.enabled
            && let Err(why) = self.resolve_namespace(platform)
        {
            let (field, value) = if self.namespace.is_empty() {
                (
                    at(prefix, "namespace"),
                    format!("\"\" (the platform name {platform:?})"),
                )
            } else {
                (at(prefix, "namespace"), format!("{:?}", self.namespace))
            };
            c.push(FieldError::new(
                field,
                value,
                format!("not a ROS 2 namespace: {why}; set [ros2] namespace to a valid one"),
            ));
        }
        for (name, v) in [
            ("odom_frame", &self.odom_frame),
            ("base_frame", &self.base_frame),
        ] {
            if v.is_empty() || v.len() > 128 || v.chars().any(char::is_control) {
                c.push(FieldError::new(
                    at(prefix, name),
                    format!("{v:?}"),
                    "empty, longer than 128 bytes or with a control character",
                ));
            }
        }
        if !(self.max_command_rate_hz.is_finite()
            && (1.0..=1000.0).contains(&self.max_command_rate_hz))
        {
            c.push(FieldError::new(
                at(prefix, "max_command_rate_hz"),
                self.max_command_rate_hz,
                "outside [1, 1000]",
            ));
        }
        let q = at(prefix, "qos");
        c.count(
            &at(&q, "navigation_depth"),
            self.qos.navigation_depth.into(),
            1,
            1000,
        );
        c.count(
            &at(&q, "commands_depth"),
            self.qos.commands_depth.into(),
            1,
            1000,
        );
    }

    pub(crate) fn warnings(&self, prefix: &str) -> Vec<String> {
        let mut w = Vec::new();
        if self.enabled && self.allow_remote_peers && self.has(Ros2Group::Commands) {
            w.push(format!(
                "{} = true with the \"commands\" group: any host that speaks DDS on this network can steer the vehicle (DDS has no authentication)",
                at(prefix, "allow_remote_peers")
            ));
        }
        w
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ros_namespaces_follow_rmw_rules() {
        assert_eq!(ros_namespace("auv1").as_deref(), Ok("/auv1"));
        assert_eq!(ros_namespace("/fleet/auv_1").as_deref(), Ok("/fleet/auv_1"));
        assert!(ros_namespace("auv-1").unwrap_err().contains("'-'"));
        assert!(
            ros_namespace("1auv")
                .unwrap_err()
                .contains("starts with a digit")
        );
        assert!(ros_namespace("a//b").unwrap_err().contains("empty token"));
        assert!(ros_namespace("").is_err());
        assert!(ros_namespace(&"a".repeat(230)).unwrap_err().contains("247"));
    }

    #[test]
    fn check_names_the_rule_a_platform_breaks() {
        let cfg = Ros2Config {
            enabled: true,
            ..Default::default()
        };
        let mut c = Checker::default();
        cfg.check("ros2", "auv-1", &mut c);
        assert_eq!(c.errors.len(), 1, "{:?}", c.errors);
        let text = c.errors[0].to_string();
        assert!(
            text.contains("ros2.namespace") && text.contains("'-'"),
            "{text}"
        );
        // Off, the platform name is not its business.
        let mut c = Checker::default();
        Ros2Config::default().check("ros2", "auv-1", &mut c);
        assert!(c.errors.is_empty());
    }
}
