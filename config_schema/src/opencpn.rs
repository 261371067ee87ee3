//! `[opencpn]` (the interface) and `[ais]` (the topside): vehicles reported to OpenCPN (or any
//! chart plotter) as AIS class B targets, each with its MMSI from here, and OpenCPN's autopilot
//! output taken as one vehicle's helm. The MMSI rules follow the shared OpenCPN facts §3.4:
//! simulated vehicles use 299000001-299999999; 97x (SART/MOB/EPIRB), 98x (craft of a parent
//! ship), 99x (aids to navigation), 199x (OpenCPN's own pseudo-targets) and non-ship forms are
//! refused, so a vehicle is never drawn as a distress beacon or a buoy.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::FieldError;
use crate::check::{Checker, at};

/// First MMSI of the range for simulated vehicles.
pub const SIM_MMSI_FIRST: u32 = 299_000_001;
/// Last MMSI of the range for simulated vehicles.
pub const SIM_MMSI_LAST: u32 = 299_999_999;

/// Why an MMSI is refused; `None` when it is a ship station's (MID 201-775).
pub fn mmsi_problem(mmsi: u32) -> Option<&'static str> {
    let mid = mmsi / 1_000_000;
    if !(100_000_000..=999_999_999).contains(&mmsi) {
        return Some("not 9 digits");
    }
    match mid {
        970..=979 => Some("97x is a SART, MOB or EPIRB: OpenCPN draws it as a distress beacon"),
        980..=989 => Some("98x is a craft of a parent ship: its 24B carries no dimensions"),
        990..=999 => Some("99x is an aid to navigation"),
        199 => Some("199x is OpenCPN's own pseudo-MMSI range (ARPA, GpsGate, APRS)"),
        201..=775 => None,
        _ => Some("not a ship station (MID 201-775); OpenCPN 5.12+ draws it as a net buoy"),
    }
}

/// Where AIS goes, how often, and for which vehicles.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct AisConfig {
    /// Send AIS at all.
    pub enabled: bool,
    /// UDP destinations, "host:port" each: OpenCPN's UDP input connection (its port; OpenCPN
    /// listens on every address whatever the connection says).
    #[schemars(example = vec!["127.0.0.1:10110".to_string()])]
    pub udp: Vec<String>,
    /// A TCP server sending the same sentences to every client that connects (OpenCPN's TCP
    /// connection with any address but 0.0.0.0 is a client). It only sends: nothing read from a
    /// client steers anything. Loopback by default; empty = no TCP server.
    pub tcp_listen: String,
    /// Most TCP clients at once; a further one is refused. A client that does not keep up is
    /// dropped (its queue is bounded).
    #[schemars(range(min = 1, max = 64))]
    pub max_tcp_clients: usize,
    /// Between two position reports (type 18) of a vehicle. Class B sends every 3-30 s;
    /// 1-10 s suits a chart. Unit: s, 0.1 to 60.
    #[schemars(range(min = 0.1, max = 60.0))]
    pub position_interval_s: f64,
    /// Between two static reports (type 24 A and B: name, type, call sign, size). The standard's
    /// is 6 min; shorter makes a newly started OpenCPN name the targets sooner. Unit: s, 1 to 360.
    #[schemars(range(min = 1.0, max = 360.0))]
    pub static_interval_s: f64,
    /// A vehicle whose node_status is older than this is no longer reported, so OpenCPN marks it
    /// lost (after its own MarkLost_Minutes) rather than showing it frozen. Unit: s, 0.1 to 3600.
    #[schemars(range(min = 0.1, max = 3600.0))]
    pub stale_after_s: f64,
    /// The vehicles reported and their MMSIs. A vehicle heard but not listed is not reported.
    #[schemars(example = example_vehicles())]
    pub vehicle: Vec<AisVehicleConfig>,
}

impl Default for AisConfig {
    fn default() -> Self {
        Self {
            enabled: false,
            udp: vec!["127.0.0.1:10110".into()],
            tcp_listen: String::new(),
            max_tcp_clients: 8,
            position_interval_s: 2.0,
            static_interval_s: 30.0,
            stale_after_s: 10.0,
            vehicle: Vec::new(),
        }
    }
}

/// One vehicle as an AIS target.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct AisVehicleConfig {
    /// The vehicle's platform name (node_status's).
    pub name: String,
    /// Its MMSI: 299000001-299999999 for a simulated vehicle (never reuse one for another
    /// vehicle: OpenCPN caches names per MMSI). A real vessel keeps the MMSI assigned to it.
    pub mmsi: u32,
    /// The name shown in OpenCPN (at most 20 characters of A-Z, 0-9 and punctuation); the
    /// platform name upper-cased when absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub label: Option<String>,
    /// AIS ship type (33 = underwater operations, 37 = pleasure craft, 52 = tug, 90 = other).
    #[serde(default = "default_ship_type")]
    pub ship_type: u8,
    /// Call sign, at most 7 characters; empty when absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub call_sign: Option<String>,
    /// Length, for the target's outline. Unit: m.
    #[serde(default = "default_length")]
    pub length_m: f64,
    #[serde(default = "default_beam")]
    /// Beam (width). Unit: m.
    pub beam_m: f64,
}

fn default_ship_type() -> u8 {
    33
}
fn default_length() -> f64 {
    4.0
}
fn default_beam() -> f64 {
    2.0
}

fn example_vehicles() -> Vec<AisVehicleConfig> {
    vec![AisVehicleConfig {
        name: "auv1".into(),
        mmsi: SIM_MMSI_FIRST,
        label: None,
        ship_type: 33,
        call_sign: None,
        length_m: 4.0,
        beam_m: 2.0,
    }]
}

/// Whether `addr` parses as an IP and port; and whether it is loopback.
fn socket(addr: &str) -> Option<std::net::SocketAddr> {
    addr.parse().ok()
}

impl AisConfig {
    pub(crate) fn check(&self, prefix: &str, c: &mut Checker) {
        if !self.enabled {
            return;
        }
        for (i, u) in self.udp.iter().enumerate() {
            if socket(u).is_none() {
                c.push(FieldError::new(
                    at(prefix, &format!("udp[{i}]")),
                    format!("{u:?}"),
                    "not an IP address and port",
                ));
            }
        }
        if !self.tcp_listen.is_empty() && socket(&self.tcp_listen).is_none() {
            c.push(FieldError::new(
                at(prefix, "tcp_listen"),
                format!("{:?}", self.tcp_listen),
                "not an IP address and port",
            ));
        }
        if self.udp.is_empty() && self.tcp_listen.is_empty() {
            c.push(FieldError::new(
                at(prefix, "udp"),
                "[]",
                "with no tcp_listen either, AIS would go nowhere",
            ));
        }
        if !(1..=64).contains(&self.max_tcp_clients) {
            c.push(FieldError::new(
                at(prefix, "max_tcp_clients"),
                self.max_tcp_clients,
                "outside [1, 64]",
            ));
        }
        c.within(
            &at(prefix, "position_interval_s"),
            self.position_interval_s,
            0.1,
            60.0,
        );
        c.within(
            &at(prefix, "static_interval_s"),
            self.static_interval_s,
            1.0,
            360.0,
        );
        c.within(
            &at(prefix, "stale_after_s"),
            self.stale_after_s,
            0.1,
            3600.0,
        );
        let mut seen: std::collections::BTreeMap<u32, &str> = Default::default();
        let mut names: std::collections::BTreeSet<&str> = Default::default();
        for (i, v) in self.vehicle.iter().enumerate() {
            let p = at(prefix, &format!("vehicle[{i}]"));
            if v.name.is_empty() || !names.insert(&v.name) {
                c.push(FieldError::new(
                    at(&p, "name"),
                    format!("{:?}", v.name),
                    "empty, or listed twice",
                ));
            }
            if let Some(why) = mmsi_problem(v.mmsi) {
                c.push(FieldError::new(at(&p, "mmsi"), v.mmsi, format!("vehicle `{}`: {why}; use {SIM_MMSI_FIRST}-{SIM_MMSI_LAST} for a simulated vehicle", v.name)));
            }
            if let Some(other) = seen.insert(v.mmsi, &v.name) {
                c.push(FieldError::new(at(&p, "mmsi"), v.mmsi, format!("vehicle `{}` has the MMSI of vehicle `{other}`: every vehicle needs its own", v.name)));
            }
            c.within(&at(&p, "length_m"), v.length_m, 0.0, 1022.0);
            c.within(&at(&p, "beam_m"), v.beam_m, 0.0, 126.0);
        }
    }

    /// The errors of this section at `prefix` (for a service outside this crate: the topside).
    pub fn errors_at(&self, prefix: &str) -> Vec<FieldError> {
        let mut c = Checker::default();
        self.check(prefix, &mut c);
        c.errors
    }

    pub fn warnings(&self, prefix: &str) -> Vec<String> {
        let mut w = Vec::new();
        if self.enabled
            && let Some(a) = socket(&self.tcp_listen)
            && !a.ip().is_loopback()
        {
            w.push(format!(
                "{} {a} is beyond loopback: anyone who reaches it sees where the vehicles are",
                at(prefix, "tcp_listen")
            ));
        }
        for v in self
            .vehicle
            .iter()
            .filter(|v| !(SIM_MMSI_FIRST..=SIM_MMSI_LAST).contains(&v.mmsi))
        {
            w.push(format!("{}: vehicle `{}` MMSI {} is outside the simulated range {SIM_MMSI_FIRST}-{SIM_MMSI_LAST}: use it only if it is this vehicle's own", at(prefix, "vehicle"), v.name, v.mmsi));
        }
        w
    }
}

/// `[opencpn]` of the interface: this vehicle as an AIS target, and OpenCPN as its helm.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct OpenCpnConfig {
    /// This vehicle reported as an AIS target (one `[[opencpn.ais.vehicle]]`: this vehicle).
    pub ais: AisConfig,
    /// OpenCPN's autopilot output (APB, RMB) as this vehicle's helm.
    pub helm: OpenCpnHelmConfig,
}

/// OpenCPN's autopilot output as this vehicle's helm. Enabling it gives this vehicle's helm to
/// OpenCPN: the interface refuses a config that also gives it to pHelmIvP (`[moos]`), and at run
/// time the input stands down while any other helm (Zenoh, gobyd, the web commander) is heard.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct OpenCpnHelmConfig {
    /// Take OpenCPN's autopilot output as this vehicle's helm.
    pub enabled: bool,
    /// UDP address to read OpenCPN's output on (its output connection's address and port).
    /// NMEA has no authentication: anyone who can send here steers the vehicle, so an address
    /// beyond loopback is refused unless allow_non_loopback is set.
    pub listen: String,
    /// Accept a listen address beyond loopback (a trusted network only: NMEA carries no token).
    pub allow_non_loopback: bool,
    /// Speed asked for while following a route. Unit: m/s, 0 to 10.
    #[schemars(range(min = 0.0, max = 10.0))]
    pub speed: f64,
    /// Depth asked for (0 at the surface, for a vehicle that dives). Unit: m, 0 to 10000.
    #[schemars(range(min = 0.0, max = 10000.0))]
    pub depth: f64,
    /// No valid APB/RMB for this long: the input stops driving (it stops publishing helm_state,
    /// and the interface's helm_state_timeout, which must be set, takes the vehicle out of
    /// COMMAND). Unit: s, 0.5 to 600.
    #[schemars(range(min = 0.5, max = 600.0))]
    pub timeout_s: f64,
    /// After another helm's helm_state or desired_course is heard, stand down this long since
    /// the last one. Unit: s, 0.5 to 3600.
    #[schemars(range(min = 0.5, max = 3600.0))]
    pub standdown_s: f64,
}

impl Default for OpenCpnHelmConfig {
    fn default() -> Self {
        Self {
            enabled: false,
            listen: "127.0.0.1:10111".into(),
            allow_non_loopback: false,
            speed: 1.5,
            depth: 0.0,
            timeout_s: 3.0,
            standdown_s: 10.0,
        }
    }
}

impl OpenCpnConfig {
    pub(crate) fn check(&self, prefix: &str, c: &mut Checker) {
        let ais = at(prefix, "ais");
        self.ais.check(&ais, c);
        if self.ais.enabled && self.ais.vehicle.len() != 1 {
            c.push(FieldError::new(at(&ais, "vehicle"), self.ais.vehicle.len(), "the interface reports one vehicle, itself: give exactly one [[opencpn.ais.vehicle]]"));
        }
        let h = &self.helm;
        if !h.enabled {
            return;
        }
        let p = at(prefix, "helm");
        match socket(&h.listen) {
            None => c.push(FieldError::new(at(&p, "listen"), format!("{:?}", h.listen), "not an IP address and port")),
            Some(a) if !a.ip().is_loopback() && !h.allow_non_loopback => c.push(FieldError::new(
                at(&p, "listen"),
                a,
                "beyond loopback, and NMEA has no token: anyone who reaches it would steer the vehicle; set allow_non_loopback = true only on a trusted network",
            )),
            _ => {}
        }
        c.within(&at(&p, "speed"), h.speed, 0.0, 10.0);
        c.within(&at(&p, "depth"), h.depth, 0.0, 10_000.0);
        c.within(&at(&p, "timeout_s"), h.timeout_s, 0.5, 600.0);
        c.within(&at(&p, "standdown_s"), h.standdown_s, 0.5, 3600.0);
    }

    pub(crate) fn warnings(&self, prefix: &str) -> Vec<String> {
        let mut w = self.ais.warnings(&at(prefix, "ais"));
        if self.helm.enabled
            && let Some(a) = socket(&self.helm.listen)
            && !a.ip().is_loopback()
        {
            w.push(format!("{}.helm.listen {a} is beyond loopback: anyone who can send it NMEA steers the vehicle", prefix));
        }
        w
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn veh(name: &str, mmsi: u32) -> AisVehicleConfig {
        AisVehicleConfig {
            mmsi,
            name: name.into(),
            ..example_vehicles().remove(0)
        }
    }

    fn errors(a: &AisConfig) -> Vec<String> {
        let mut c = Checker::default();
        a.check("ais", &mut c);
        c.errors.iter().map(|e| e.to_string()).collect()
    }

    #[test]
    fn duplicate_and_out_of_range_mmsis_are_refused_naming_the_vehicle() {
        let a = AisConfig {
            enabled: true,
            vehicle: vec![
                veh("auv1", 299_000_001),
                veh("auv2", 299_000_001),
                veh("asv", 970_000_001),
            ],
            ..Default::default()
        };
        let e = errors(&a).join("\n");
        assert!(
            e.contains("vehicle `auv2` has the MMSI of vehicle `auv1`"),
            "{e}"
        );
        assert!(e.contains("vehicle `asv`: 97x is a SART"), "{e}");
        assert_eq!(
            errors(&AisConfig {
                enabled: true,
                vehicle: vec![veh("a", 299_000_001), veh("b", 299_000_002)],
                ..Default::default()
            }),
            Vec::<String>::new()
        );
    }

    #[test]
    fn mmsi_rules() {
        assert_eq!(mmsi_problem(299_000_001), None);
        assert_eq!(mmsi_problem(366_123_456), None);
        for bad in [
            12_345,
            199_200_001,
            980_000_001,
            992_000_001,
            111_229_000,
            880_000_001,
        ] {
            assert!(mmsi_problem(bad).is_some(), "{bad}");
        }
    }

    #[test]
    fn a_helm_beyond_loopback_needs_the_opt_in() {
        let mut o = OpenCpnConfig::default();
        o.helm.enabled = true;
        o.helm.listen = "0.0.0.0:10111".into();
        let mut c = Checker::default();
        o.check("opencpn", &mut c);
        assert!(c.errors[0].to_string().contains("NMEA has no token"));
        o.helm.allow_non_loopback = true;
        let mut c = Checker::default();
        o.check("opencpn", &mut c);
        assert!(c.errors.is_empty());
    }
}
