//! Configuration of `frontseat interface`: the top level mirrors Goby3's `frontseat_cfg`
//! (same field names, defaults and units), plus our sections for the driver's reconnect policy,
//! supervision, MOOS, Zenoh, telemetry, chaos and the bus.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::check::{Checker, at};
use crate::goby3::Goby3Config;
use crate::ros2::Ros2Config;
use crate::sections::{InterprocessConfig, LatLonConfig, MoosConfig, TelemetryConfig};
use crate::web::WebConfig;
use crate::{DriverConfig, FieldError, MAX_WARP, ServiceConfig};

/// Goby3's `VehicleType`, written by its proto names.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
pub enum VehicleType {
    Unknown,
    #[default]
    Auv,
    Glider,
    Usv,
    UsvPowered,
    UsvSailing,
    Rov,
    Target,
    Buoy,
    Mooring,
    MooringSubsurface,
    MooringSurface,
    Ship,
    Other,
}

impl VehicleType {
    /// The enum number in Goby3's `goby.middleware.frontseat.protobuf.VehicleType`.
    pub fn proto_value(self) -> i32 {
        match self {
            Self::Other => -1,
            Self::Unknown => 0,
            Self::Auv => 10,
            Self::Glider => 11,
            Self::Usv => 20,
            Self::UsvPowered => 21,
            Self::UsvSailing => 22,
            Self::Rov => 30,
            Self::Target => 50,
            Self::Buoy => 60,
            Self::Mooring => 61,
            Self::MooringSubsurface => 62,
            Self::MooringSurface => 63,
            Self::Ship => 100,
        }
    }

    /// The proto name, as written in the config ("AUV", "USV_POWERED", …).
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Unknown => "UNKNOWN",
            Self::Auv => "AUV",
            Self::Glider => "GLIDER",
            Self::Usv => "USV",
            Self::UsvPowered => "USV_POWERED",
            Self::UsvSailing => "USV_SAILING",
            Self::Rov => "ROV",
            Self::Target => "TARGET",
            Self::Buoy => "BUOY",
            Self::Mooring => "MOORING",
            Self::MooringSubsurface => "MOORING_SUBSURFACE",
            Self::MooringSurface => "MOORING_SURFACE",
            Self::Ship => "SHIP",
            Self::Other => "OTHER",
        }
    }
}

/// Configuration of the frontseat interface service (`frontseat interface -c FILE`). The top
/// level follows Goby3's frontseat_cfg.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct InterfaceConfig {
    /// Vehicle name: fills NodeStatus.name and is the default Zenoh platform name.
    pub name: String,
    /// Datum of the local grid: NodeStatus local_fix (x east, y north) is computed around it.
    pub origin: LatLonConfig,
    /// Vehicle type reported in NodeStatus.type.
    pub r#type: VehicleType,
    /// Require the helm even for a listening mission where the frontseat is in control.
    pub require_helm: bool,
    /// If require_helm, how long to wait for the helm to start before moving to the helm error
    /// state. Unit: s.
    #[schemars(range(min = 0.0))]
    pub helm_running_timeout: f64,
    /// A driving helm must repeat its helm_state at least this often: not heard for this long,
    /// the helm counts as not running (with require_helm the interface leaves COMMAND for the
    /// helm error state by the usual rule, and climbs back once the helm is heard again), so a
    /// helm cut off by a lost link cannot keep steering with its last setpoint. 0 = never: the
    /// last helm_state holds until another arrives (Goby3). Unit: s.
    #[schemars(range(min = 0.0))]
    pub helm_state_timeout: f64,
    /// How long to wait for the frontseat to be connected before moving to the frontseat error
    /// state. Unit: s.
    #[schemars(range(min = 0.0))]
    pub frontseat_connected_timeout: f64,
    /// Time between InterfaceStatus publications (also published at every state change);
    /// 0 = no periodic status. Unit: s.
    #[schemars(range(min = 0.0))]
    pub status_period: f64,
    /// Exit the service when it enters an error state (with exit_on_error_code).
    pub exit_on_error: bool,
    /// The process exit code when exit_on_error ends the service. 0 is Goby3's (its interface
    /// quits with 0, so systemd's Restart=on-failure does not restart it); a non-zero code (we
    /// used 2) makes Restart=on-failure bring the interface back.
    pub exit_on_error_code: u8,
    /// Simulation time warp: every timer runs this many times faster, and the basic simulator is
    /// told WARP:<this>. Unit: factor, greater than 0 and at most 10000.
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    #[schemars(range(max = 10000.0))]
    pub sim_warp_factor: f64,
    /// The frontseat driver.
    pub driver: DriverConfig,
    /// Restarting the driver after it fails.
    pub supervision: SupervisionConfig,
    /// The safety envelope: a setpoint outside it never reaches the frontseat.
    pub limits: LimitsConfig,
    /// Goby3's debugging backdoor `raw_send_request`: who may use it and how much one may carry.
    pub raw_send: RawSendConfig,
    /// Bridge to pHelmIvP on a MOOSDB. Absent = no MOOS bridge; an empty [moos] table enables it
    /// with the defaults shown.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub moos: Option<MoosConfig>,
    /// Inter-process and multi-host publish/subscribe over Zenoh.
    pub interprocess: InterprocessConfig,
    /// Joining an existing Goby3 system through its gobyd (beside or instead of Zenoh).
    pub goby3: Goby3Config,
    /// OpenTelemetry trace export.
    pub telemetry: TelemetryConfig,
    /// Fault injection for chaos testing.
    pub chaos: ChaosConfig,
    /// The in-process publish/subscribe bus.
    pub bus: BusConfig,
    /// The live web scope and commander served by this process.
    pub web: WebConfig,
    /// Recording every message this process sees to MCAP files.
    pub record: crate::RecordConfig,
    /// OpenCPN: this vehicle as an AIS target, and OpenCPN's route as its helm. Absent = off.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub opencpn: Option<crate::OpenCpnConfig>,
    /// The vehicle as a ROS 2 participant over DDS (topics under the platform name).
    pub ros2: Ros2Config,
}

impl Default for InterfaceConfig {
    fn default() -> Self {
        Self {
            name: String::new(),
            origin: LatLonConfig::default(),
            r#type: VehicleType::Auv,
            require_helm: true,
            helm_running_timeout: 10.0,
            helm_state_timeout: 0.0,
            frontseat_connected_timeout: 10.0,
            status_period: 5.0,
            exit_on_error: false,
            exit_on_error_code: 0,
            sim_warp_factor: 1.0,
            driver: DriverConfig::default(),
            supervision: SupervisionConfig::default(),
            limits: LimitsConfig::default(),
            raw_send: RawSendConfig::default(),
            moos: None,
            interprocess: InterprocessConfig::default(),
            goby3: Goby3Config::default(),
            telemetry: TelemetryConfig::default(),
            chaos: ChaosConfig::default(),
            bus: BusConfig::default(),
            web: WebConfig::default(),
            record: crate::RecordConfig::default(),
            opencpn: None,
            ros2: Ros2Config::default(),
        }
    }
}

impl InterfaceConfig {
    /// The platform name: `[interprocess] platform`, else `name`, else Goby3's default (the
    /// Zenoh gateway's rule, `frontseat_helm_side::resolve_platform`).
    pub fn platform_name(&self) -> &str {
        match (self.interprocess.platform.as_str(), self.name.as_str()) {
            ("", "") => "default_goby_platform",
            ("", n) => n,
            (p, _) => p,
        }
    }
}

impl InterfaceConfig {
    /// Goby3's way of choosing the driver: `FRONTSEAT_DRIVER_LIBRARY` (given here as
    /// `env_library`), or `driver.library`, naming one of Goby3's own driver libraries
    /// (`libgoby_frontseat_bluefin.so.30`) selects our built-in driver of that vehicle, so a
    /// Goby3 unit file works unchanged. Returns what was chosen (to be logged); None when no
    /// Goby3 library is named (another library stays a plugin of ours).
    pub fn select_goby3_driver(&mut self, env_library: Option<&str>) -> Option<String> {
        let (source, library) = match env_library.filter(|l| !l.is_empty()) {
            Some(l) => ("FRONTSEAT_DRIVER_LIBRARY", l.to_owned()),
            None => ("driver.library", self.driver.library.clone()?),
        };
        let builtin = crate::goby3_import::goby3_driver_for_library(&library)?;
        let was = std::mem::replace(&mut self.driver.name, builtin.to_owned());
        self.driver.library = None;
        Some(format!(
            "{source}={library} is Goby3's {builtin} driver library: running frontseat's built-in \
             `{builtin}` driver (config's [driver] name was {was:?})"
        ))
    }
}

impl ServiceConfig for InterfaceConfig {
    const SERVICE: &'static str = "interface";

    fn validate(&self) -> Vec<FieldError> {
        let mut c = Checker::default();
        // The name names the record files and is the default Zenoh platform.
        crate::names::check_optional("name", &self.name, &mut c);
        self.origin.check("origin", &mut c);
        c.non_negative("helm_running_timeout", self.helm_running_timeout);
        c.non_negative("helm_state_timeout", self.helm_state_timeout);
        c.non_negative(
            "frontseat_connected_timeout",
            self.frontseat_connected_timeout,
        );
        c.non_negative("status_period", self.status_period);
        c.positive_up_to("sim_warp_factor", self.sim_warp_factor, MAX_WARP);
        self.driver.check("driver", &mut c);
        self.supervision.check("supervision", &mut c);
        self.limits.check("limits", &mut c);
        self.raw_send.check("raw_send", &mut c);
        if let Some(m) = &self.moos {
            m.check("moos", &mut c);
            // Goby3 has one warp for the interface and its MOOS side (moos_plugin_translator.cpp:56);
            // two that differ would run the helm's clock apart from the vehicle's, silently.
            if m.time_warp > 0.0 && m.time_warp != self.sim_warp_factor {
                c.push(FieldError::new(
                    "moos.time_warp",
                    m.time_warp,
                    format!(
                        "differs from sim_warp_factor = {}: leave time_warp out (0) to follow it, \
                         or set both to the MOOSDB's MOOSTimeWarp",
                        self.sim_warp_factor
                    ),
                ));
            }
        }
        self.interprocess.check("interprocess", &mut c);
        self.goby3.check("goby3", &mut c);
        self.telemetry.check("telemetry", &mut c);
        self.bus.check("bus", &mut c);
        self.web.check("web", &mut c);
        self.record.check("record", &mut c);
        self.ros2.check("ros2", self.platform_name(), &mut c);
        if let Some(o) = &self.opencpn {
            o.check("opencpn", &mut c);
            if o.helm.enabled && self.moos.is_some() {
                c.push(FieldError::new(
                    "opencpn.helm.enabled",
                    true,
                    "[moos] gives this vehicle's helm to pHelmIvP already: one helm input per vehicle",
                ));
            }
            if o.helm.enabled && self.helm_state_timeout <= 0.0 {
                c.push(FieldError::new(
                    "helm_state_timeout",
                    self.helm_state_timeout,
                    "must be greater than 0 with [opencpn.helm]: when OpenCPN's sentences stop, the vehicle leaves COMMAND by it",
                ));
            }
        }
        c.errors
    }

    fn warnings(&self) -> Vec<String> {
        let mut w = self.web.warnings("web");
        w.extend(self.interprocess.warnings("interprocess"));
        w.extend(self.ros2.warnings("ros2"));
        if let Some(o) = &self.opencpn {
            w.extend(o.warnings("opencpn"));
        }
        w
    }

    fn import_goby3(
        text: &str,
        file: &str,
    ) -> Option<Result<crate::goby3_import::Imported, crate::ConfigError>> {
        Some(crate::goby3_import::import_interface(text, file))
    }
}

/// Restarting a failed driver (panic, or the driver actor stopping) with exponential backoff.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct SupervisionConfig {
    /// Delay before the first restart; doubles per restart up to restart_max_delay_ms. Unit: ms.
    #[schemars(range(min = 1))]
    pub restart_initial_delay_ms: u64,
    /// Cap of the restart delay. Unit: ms.
    #[schemars(range(min = 1))]
    pub restart_max_delay_ms: u64,
    /// Restarts allowed within restart_window_s; one more failure ends the service (non-zero exit,
    /// so systemd restarts it). 0 = never restart the driver: its first failure ends the service.
    pub max_restarts: u32,
    /// Sliding window over which restarts are counted. Unit: s.
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub restart_window_s: f64,
    /// The FrontSeatTranslation (MOOS bridge), supervised by the root supervisor.
    pub translation: RestartConfig,
    /// The FrontSeatInterface (with its DriverActor) under the root supervisor: restarted when
    /// the interface actor itself fails. An error state with exit_on_error and the driver's
    /// exhausted restart limit are not restarted: they end the process (exit 2, exit 3).
    pub interface: RestartConfig,
    /// The Zenoh gateway (`[interprocess] enabled`) under the root supervisor.
    pub zenoh: RestartConfig,
    /// The Goby3 transport (`[goby3] enabled`) under the root supervisor.
    pub goby3: RestartConfig,
    /// The web scope (`[web] enabled`) under the root supervisor; its hub has its own bounded
    /// restarts inside it.
    pub web: RestartConfig,
    /// The ROS 2 gateway (`[ros2] enabled`) under the root supervisor.
    pub ros2: RestartConfig,
}

/// When a supervised actor ends.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum RestartPolicy {
    /// Never restart; a failure ends the service (non-zero exit).
    Never,
    /// Restart after a failure (a panic or an error), not after an orderly stop.
    OnFailure,
    /// Restart whenever it ends.
    Always,
}

/// How the root supervisor restarts one actor (OTP's and dora-rs's knobs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct RestartConfig {
    /// `never`, `on-failure` or `always`.
    pub policy: RestartPolicy,
    /// Restarts allowed within restart_window_s; one more ends the service with a non-zero exit
    /// so that systemd restarts the process.
    pub max_restarts: u32,
    /// Sliding window over which restarts are counted. Unit: s.
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub restart_window_s: f64,
    /// Delay before the first restart; doubles per restart in the window up to backoff_max_ms.
    /// Unit: ms.
    #[schemars(range(min = 1))]
    pub backoff_initial_ms: u64,
    /// Cap of the restart delay. Unit: ms.
    #[schemars(range(min = 1))]
    pub backoff_max_ms: u64,
}

impl Default for RestartConfig {
    fn default() -> Self {
        Self {
            policy: RestartPolicy::OnFailure,
            max_restarts: 10,
            restart_window_s: 60.0,
            backoff_initial_ms: 50,
            backoff_max_ms: 2000,
        }
    }
}

impl RestartConfig {
    pub(crate) fn check_at(&self, prefix: &str, c: &mut Checker) {
        let initial = at(prefix, "backoff_initial_ms");
        let max = at(prefix, "backoff_max_ms");
        c.at_least(&initial, self.backoff_initial_ms, 1);
        c.at_least(&max, self.backoff_max_ms, 1);
        c.ordered(&initial, self.backoff_initial_ms, &max, self.backoff_max_ms);
        c.positive(&at(prefix, "restart_window_s"), self.restart_window_s);
    }
}

impl Default for SupervisionConfig {
    fn default() -> Self {
        Self {
            restart_initial_delay_ms: 100,
            restart_max_delay_ms: 2000,
            max_restarts: 10,
            restart_window_s: 60.0,
            translation: RestartConfig::default(),
            interface: RestartConfig {
                max_restarts: 3,
                ..RestartConfig::default()
            },
            zenoh: RestartConfig::default(),
            goby3: RestartConfig::default(),
            web: RestartConfig::default(),
            ros2: RestartConfig::default(),
        }
    }
}

impl SupervisionConfig {
    fn check(&self, prefix: &str, c: &mut Checker) {
        let initial = at(prefix, "restart_initial_delay_ms");
        let max = at(prefix, "restart_max_delay_ms");
        c.at_least(&initial, self.restart_initial_delay_ms, 1);
        c.at_least(&max, self.restart_max_delay_ms, 1);
        c.ordered(
            &initial,
            self.restart_initial_delay_ms,
            &max,
            self.restart_max_delay_ms,
        );
        c.positive(&at(prefix, "restart_window_s"), self.restart_window_s);
        self.translation.check_at(&at(prefix, "translation"), c);
        self.interface.check_at(&at(prefix, "interface"), c);
        self.zenoh.check_at(&at(prefix, "zenoh"), c);
        self.goby3.check_at(&at(prefix, "goby3"), c);
        self.web.check_at(&at(prefix, "web"), c);
        self.ros2.check_at(&at(prefix, "ros2"), c);
    }
}

/// The vehicle's safety envelope. Every setpoint — from the bus, MOOS, Zenoh, Goby3 or a
/// command_request — is checked against it before it can reach the driver: non-finite values are
/// refused, heading is wrapped into [0, 360), and a value outside these limits refuses the whole
/// setpoint (failed CommandResponse when one was requested, a counter, a log line). Set them to
/// what your vehicle can do.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct LimitsConfig {
    /// Highest speed a setpoint may ask for (0 is the lowest). Unit: m/s, greater than 0, at most 100.
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    #[schemars(range(max = 100.0))]
    pub max_speed: f64,
    /// Deepest depth a setpoint may ask for (0, the surface, is the shallowest). Unit: m, positive
    /// down, at most 12000.
    #[schemars(range(min = 0.0, max = 12000.0))]
    pub max_depth: f64,
    /// Lowest desired altitude above the bottom. Unit: m, at least 0.
    #[schemars(range(min = 0.0))]
    pub min_altitude: f64,
    /// Highest desired altitude above the bottom. Unit: m.
    #[schemars(range(min = 0.0))]
    pub max_altitude: f64,
    /// Largest pitch either way (nose up or down). Unit: degrees, 0 to 90.
    #[schemars(range(min = 0.0, max = 90.0))]
    pub max_abs_pitch: f64,
    /// Largest roll either way. Unit: degrees, 0 to 180.
    #[schemars(range(min = 0.0, max = 180.0))]
    pub max_abs_roll: f64,
    /// Largest vertical rate either way. Unit: m/s.
    #[schemars(range(min = 0.0))]
    pub max_abs_z_rate: f64,
    /// Physical bounds of the navigation coming back from the vehicle (`[limits.navigation]`).
    pub navigation: NavLimitsConfig,
}

/// What navigation from the frontseat may say before it reaches the helm: physical bounds, wider
/// than any vehicle, so that only an impossible value (a broken or hostile frontseat: speed
/// 1e308) is caught. Position (latitude, longitude, local x/y), time, speed over ground, depth and
/// z, and heading refuse the whole node_status (the helm keeps its last good NAV rather than
/// steering by a stale value beside fresh ones); altitude, pitch, roll, the angular rates, course
/// over ground and speed over water are dropped from it and the rest is published. Heading and
/// course over ground are wrapped into [0, 360) when within ten turns, and refused past that.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct NavLimitsConfig {
    /// Largest speed over ground or over water either way. Unit: m/s, greater than 0.
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub max_abs_speed: f64,
    /// Shallowest depth (negative: above the sea surface). Unit: m, positive down.
    pub min_depth: f64,
    /// Deepest depth. Unit: m, positive down.
    pub max_depth: f64,
    /// Highest altitude above the bottom. Unit: m, greater than 0.
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub max_altitude: f64,
    /// Largest pitch either way. Unit: degrees, 0 to 90.
    #[schemars(range(min = 0.0, max = 90.0))]
    pub max_abs_pitch: f64,
    /// Largest roll either way. Unit: degrees, 0 to 180.
    #[schemars(range(min = 0.0, max = 180.0))]
    pub max_abs_roll: f64,
    /// Largest roll, pitch or heading rate either way. Unit: degrees/s, greater than 0.
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub max_abs_angular_rate: f64,
    /// Fastest a depth may change between two navigation messages (a pressure sensor that
    /// jumps is refused; a new level held for a few messages is believed). Unit: m/s, greater
    /// than 0.
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub max_abs_depth_rate: f64,
}

impl Default for NavLimitsConfig {
    fn default() -> Self {
        Self {
            max_abs_speed: 50.0,
            min_depth: -100.0,
            max_depth: 11_000.0,
            max_altitude: 11_000.0,
            max_abs_pitch: 90.0,
            max_abs_roll: 180.0,
            max_abs_angular_rate: 1000.0,
            max_abs_depth_rate: 20.0,
        }
    }
}

impl NavLimitsConfig {
    fn check(&self, prefix: &str, c: &mut Checker) {
        c.positive(&at(prefix, "max_abs_speed"), self.max_abs_speed);
        c.within(&at(prefix, "min_depth"), self.min_depth, -1.0e5, 1.0e5);
        c.within(&at(prefix, "max_depth"), self.max_depth, -1.0e5, 1.0e5);
        if self.min_depth.is_finite()
            && self.max_depth.is_finite()
            && self.min_depth > self.max_depth
        {
            c.push(FieldError::new(
                at(prefix, "min_depth"),
                self.min_depth,
                format!(
                    "greater than {} ({})",
                    at(prefix, "max_depth"),
                    self.max_depth
                ),
            ));
        }
        c.positive(&at(prefix, "max_altitude"), self.max_altitude);
        c.within(&at(prefix, "max_abs_pitch"), self.max_abs_pitch, 0.0, 90.0);
        c.within(&at(prefix, "max_abs_roll"), self.max_abs_roll, 0.0, 180.0);
        c.positive(
            &at(prefix, "max_abs_angular_rate"),
            self.max_abs_angular_rate,
        );
        c.positive(&at(prefix, "max_abs_depth_rate"), self.max_abs_depth_rate);
    }
}

impl Default for LimitsConfig {
    fn default() -> Self {
        Self {
            max_speed: 5.0,
            max_depth: 300.0,
            min_altitude: 0.0,
            max_altitude: 1000.0,
            max_abs_pitch: 45.0,
            max_abs_roll: 45.0,
            max_abs_z_rate: 2.0,
            navigation: NavLimitsConfig::default(),
        }
    }
}

impl LimitsConfig {
    fn check(&self, prefix: &str, c: &mut Checker) {
        c.positive_up_to(&at(prefix, "max_speed"), self.max_speed, 100.0);
        c.within(&at(prefix, "max_depth"), self.max_depth, 0.0, 12000.0);
        c.non_negative(&at(prefix, "min_altitude"), self.min_altitude);
        c.non_negative(&at(prefix, "max_altitude"), self.max_altitude);
        if self.min_altitude.is_finite()
            && self.max_altitude.is_finite()
            && self.min_altitude > self.max_altitude
        {
            c.push(FieldError::new(
                at(prefix, "min_altitude"),
                self.min_altitude,
                format!(
                    "greater than {} ({})",
                    at(prefix, "max_altitude"),
                    self.max_altitude
                ),
            ));
        }
        c.within(&at(prefix, "max_abs_pitch"), self.max_abs_pitch, 0.0, 90.0);
        c.within(&at(prefix, "max_abs_roll"), self.max_abs_roll, 0.0, 180.0);
        c.non_negative(&at(prefix, "max_abs_z_rate"), self.max_abs_z_rate);
        self.navigation.check(&at(prefix, "navigation"), c);
    }
}

/// Where a `raw_send_request` came from, as the interface tells them apart.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum RawSource {
    /// Published in this process (the demo helm, the chaos harness, an in-process plugin).
    Local,
    /// A Goby3 application through gobyd (`[goby3]`).
    Goby3,
    /// Another process or host over Zenoh (`[interprocess]`).
    Zenoh,
    /// The web commander (`[web]`).
    Web,
}

/// `raw_send_request` bypasses the safety envelope: its bytes go to the vehicle as they are. It
/// is kept because Goby3 has it (and Goby3 applications use it for vehicle sentences the
/// interface does not model), but bounded: one raw message is exactly one line (or, for a driver
/// with a binary protocol, one frame) — an embedded CR or LF is refused, so one request cannot
/// become two commands —, at most `max_bytes`, and only from the `sources` listed. Every raw send
/// accepted or refused is counted (`raw_sent`, `raw_refused` in the detail status) and logged.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct RawSendConfig {
    /// Who may send raw: any of "local", "goby3", "zenoh", "web"; empty = raw sends refused.
    /// Default: local and goby3 — in-process code, and Goby3 applications as in Goby3; the web
    /// commander and Zenoh, reachable from the network and new in frontseat, must be named.
    pub sources: Vec<RawSource>,
    /// Largest raw message, terminator excluded. Unit: bytes, 1 to 65536.
    #[schemars(range(min = 1, max = 65536))]
    pub max_bytes: usize,
}

impl Default for RawSendConfig {
    fn default() -> Self {
        Self {
            sources: vec![RawSource::Local, RawSource::Goby3],
            max_bytes: 512,
        }
    }
}

impl RawSendConfig {
    fn check(&self, prefix: &str, c: &mut Checker) {
        if !(1..=65536).contains(&self.max_bytes) {
            c.push(FieldError::new(
                at(prefix, "max_bytes"),
                self.max_bytes,
                "outside [1, 65536]",
            ));
        }
    }
}

/// Fault injection. The fault-injection group exists only when this is enabled.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct ChaosConfig {
    /// Accept injected faults (driver panics, hangs, …). Never enable on a vehicle.
    pub enabled: bool,
}

/// The in-process bus.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct BusConfig {
    /// Capacity of each subscriber's queue; when full, new messages for that subscriber are
    /// dropped and counted. Unit: messages, 1 to 1048576.
    #[schemars(range(min = 1, max = 1048576))]
    pub queue_capacity: usize,
}

/// Upper bound of [`BusConfig::queue_capacity`], so a typo cannot reserve gigabytes.
pub const MAX_QUEUE_CAPACITY: usize = 1 << 20;

impl Default for BusConfig {
    fn default() -> Self {
        Self {
            queue_capacity: 1024,
        }
    }
}

impl BusConfig {
    fn check(&self, prefix: &str, c: &mut Checker) {
        c.count(
            &at(prefix, "queue_capacity"),
            self.queue_capacity as u64,
            1,
            MAX_QUEUE_CAPACITY as u64,
        );
    }
}

/// How a vehicle driver reaches the vehicle.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum TransportKind {
    /// The serial port named by the driver's serial port setting.
    #[default]
    Serial,
    /// A TCP connection to tcp_address:tcp_port (a serial-over-IP adapter, or an emulator).
    Tcp,
}

/// Serial parity.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum ParityConfig {
    #[default]
    None,
    Odd,
    Even,
}

/// Serial flow control.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum FlowControlConfig {
    #[default]
    None,
    /// XON/XOFF.
    Software,
    /// RTS/CTS.
    Hardware,
}

pub use crate::state_name::FrontSeatStateName;

impl VehicleLinkConfig {
    /// "serial PORT @ BAUD baud" or "tcp ADDRESS:PORT", for the start-up log line.
    pub(crate) fn describe(&self, serial_port: &str, serial_baud: u32) -> String {
        match self.transport {
            TransportKind::Serial => format!("serial {serial_port} @ {serial_baud} baud"),
            TransportKind::Tcp => format!("tcp {}:{}", self.tcp_address, self.tcp_port),
        }
    }
}

/// The link settings both vehicle drivers share (ours; Goby3 has only port and baud).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct VehicleLinkConfig {
    /// Serial port or TCP.
    pub transport: TransportKind,
    /// Data bits per character, 5 to 8.
    #[schemars(range(min = 5, max = 8))]
    pub data_bits: u8,
    /// Serial parity: "none", "odd" or "even".
    pub parity: ParityConfig,
    /// Stop bits, 1 or 2.
    #[schemars(range(min = 1, max = 2))]
    pub stop_bits: u8,
    /// Serial flow control: "none", "software" (XON/XOFF) or "hardware" (RTS/CTS).
    pub flow_control: FlowControlConfig,
    /// Host of the serial-over-IP adapter when transport = "tcp".
    pub tcp_address: String,
    /// TCP port when transport = "tcp".
    pub tcp_port: u16,
    /// First delay before reopening a vanished device or lost connection; doubles per failure
    /// up to reconnect_max_ms. Unit: ms.
    #[schemars(range(min = 1))]
    pub reconnect_initial_ms: u64,
    /// Cap of the reopen delay. Unit: ms.
    #[schemars(range(min = 1))]
    pub reconnect_max_ms: u64,
    /// A command that asked for a response and got no acknowledgement from the vehicle within
    /// this long is answered as failed. Unit: s.
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub ack_timeout: f64,
}

impl Default for VehicleLinkConfig {
    fn default() -> Self {
        Self {
            transport: TransportKind::Serial,
            data_bits: 8,
            parity: ParityConfig::None,
            stop_bits: 1,
            flow_control: FlowControlConfig::None,
            tcp_address: "127.0.0.1".into(),
            tcp_port: 54330,
            reconnect_initial_ms: 100,
            reconnect_max_ms: 5000,
            ack_timeout: 5.0,
        }
    }
}

impl VehicleLinkConfig {
    /// `serial_port_path` is the full path of the driver's serial port field (it lives beside
    /// this section, under Goby3's name).
    pub(crate) fn check(
        &self,
        prefix: &str,
        serial_port_path: &str,
        serial_port: &str,
        c: &mut Checker,
    ) {
        match self.transport {
            TransportKind::Serial => c.non_empty(serial_port_path, serial_port),
            TransportKind::Tcp => {
                c.non_empty(&at(prefix, "tcp_address"), &self.tcp_address);
                c.port(&at(prefix, "tcp_port"), self.tcp_port);
            }
        }
        c.count(&at(prefix, "data_bits"), u64::from(self.data_bits), 5, 8);
        c.count(&at(prefix, "stop_bits"), u64::from(self.stop_bits), 1, 2);
        let initial = at(prefix, "reconnect_initial_ms");
        let max = at(prefix, "reconnect_max_ms");
        c.at_least(&initial, self.reconnect_initial_ms, 1);
        c.at_least(&max, self.reconnect_max_ms, 1);
        c.ordered(
            &initial,
            self.reconnect_initial_ms,
            &max,
            self.reconnect_max_ms,
        );
        c.positive(&at(prefix, "ack_timeout"), self.ack_timeout);
    }
}
