//! Configuration of `frontseat interface`: the top level mirrors Goby3's `frontseat_cfg`
//! (same field names, defaults and units), plus our sections for the driver's reconnect policy,
//! supervision, MOOS, Zenoh, telemetry, chaos and the bus.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::check::{Checker, at};
use crate::sections::{
    DEFAULT_ORIGIN_LAT, DEFAULT_ORIGIN_LON, InterprocessConfig, LatLonConfig, MoosConfig,
    TelemetryConfig,
};
use crate::web::WebConfig;
use crate::{FieldError, MAX_WARP, ServiceConfig};

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
    /// How long to wait for the frontseat to be connected before moving to the frontseat error
    /// state. Unit: s.
    #[schemars(range(min = 0.0))]
    pub frontseat_connected_timeout: f64,
    /// Time between InterfaceStatus publications (also published at every state change);
    /// 0 = no periodic status. Unit: s.
    #[schemars(range(min = 0.0))]
    pub status_period: f64,
    /// Exit the service (non-zero) when it enters an error state.
    pub exit_on_error: bool,
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
    /// Bridge to pHelmIvP on a MOOSDB. Absent = no MOOS bridge; an empty [moos] table enables it
    /// with the defaults shown.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub moos: Option<MoosConfig>,
    /// Inter-process and multi-host publish/subscribe over Zenoh.
    pub interprocess: InterprocessConfig,
    /// OpenTelemetry trace export.
    pub telemetry: TelemetryConfig,
    /// Fault injection for chaos testing.
    pub chaos: ChaosConfig,
    /// The in-process publish/subscribe bus.
    pub bus: BusConfig,
    /// The live web scope and commander served by this process.
    pub web: WebConfig,
}

impl Default for InterfaceConfig {
    fn default() -> Self {
        Self {
            name: String::new(),
            origin: LatLonConfig::default(),
            r#type: VehicleType::Auv,
            require_helm: true,
            helm_running_timeout: 10.0,
            frontseat_connected_timeout: 10.0,
            status_period: 5.0,
            exit_on_error: false,
            sim_warp_factor: 1.0,
            driver: DriverConfig::default(),
            supervision: SupervisionConfig::default(),
            limits: LimitsConfig::default(),
            moos: None,
            interprocess: InterprocessConfig::default(),
            telemetry: TelemetryConfig::default(),
            chaos: ChaosConfig::default(),
            bus: BusConfig::default(),
            web: WebConfig::default(),
        }
    }
}

impl ServiceConfig for InterfaceConfig {
    const SERVICE: &'static str = "interface";

    fn validate(&self) -> Vec<FieldError> {
        let mut c = Checker::default();
        self.origin.check("origin", &mut c);
        c.non_negative("helm_running_timeout", self.helm_running_timeout);
        c.non_negative(
            "frontseat_connected_timeout",
            self.frontseat_connected_timeout,
        );
        c.non_negative("status_period", self.status_period);
        c.positive_up_to("sim_warp_factor", self.sim_warp_factor, MAX_WARP);
        self.driver.check("driver", &mut c);
        self.supervision.check("supervision", &mut c);
        self.limits.check("limits", &mut c);
        if let Some(m) = &self.moos {
            m.check("moos", &mut c);
        }
        self.interprocess.check("interprocess", &mut c);
        self.telemetry.check("telemetry", &mut c);
        self.bus.check("bus", &mut c);
        self.web.check("web", &mut c);
        c.errors
    }

    fn warnings(&self) -> Vec<String> {
        self.web.warnings("web")
    }
}

/// Which frontseat driver to run and its settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct DriverConfig {
    /// Built-in driver to run when no library is given: "basic_simulator".
    pub name: String,
    /// Path to a driver plugin (shared library) to load instead of a built-in driver;
    /// FRONTSEAT_DRIVER_LIBRARY in the environment does the same.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[schemars(example = &"/usr/local/lib/frontseat/libmy_driver.so")]
    pub library: Option<String>,
    /// Settings of the basic simulator driver (Goby3's basic_simulator_config).
    pub basic_simulator: BasicSimulatorConfig,
}

/// Name of the one built-in driver.
pub const BASIC_SIMULATOR: &str = "basic_simulator";

impl Default for DriverConfig {
    fn default() -> Self {
        Self {
            name: BASIC_SIMULATOR.into(),
            library: None,
            basic_simulator: BasicSimulatorConfig::default(),
        }
    }
}

impl DriverConfig {
    fn check(&self, prefix: &str, c: &mut Checker) {
        match &self.library {
            Some(lib) => c.non_empty(&at(prefix, "library"), lib),
            None if self.name != BASIC_SIMULATOR => c.push(FieldError::new(
                at(prefix, "name"),
                format!("{:?}", self.name),
                format!("unknown built-in driver; the built-in is \"{BASIC_SIMULATOR}\" (or set library)"),
            )),
            None => {}
        }
        self.basic_simulator
            .check(&at(prefix, "basic_simulator"), c);
    }
}

/// The basic simulator driver: a TCP client of `frontseat sim` (or Goby3's simulator).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct BasicSimulatorConfig {
    /// Host name or IP address of the simulator.
    pub tcp_address: String,
    /// TCP port of the simulator.
    #[schemars(range(min = 1))]
    pub tcp_port: u16,
    /// Sent to the simulator as START on every (re)connect.
    pub start: SimStartConfig,
    /// First delay before reconnecting after a failed connect or a lost connection; doubles per
    /// failure up to reconnect_max_ms. Unit: ms.
    #[schemars(range(min = 1))]
    pub reconnect_initial_ms: u64,
    /// Cap of the reconnect delay. Unit: ms.
    #[schemars(range(min = 1))]
    pub reconnect_max_ms: u64,
    /// The frontseat stops providing data after this long without a NAV line. Unit: s.
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub nav_timeout: f64,
}

impl Default for BasicSimulatorConfig {
    fn default() -> Self {
        Self {
            tcp_address: "127.0.0.1".into(),
            tcp_port: 54321,
            start: SimStartConfig::default(),
            reconnect_initial_ms: 50,
            reconnect_max_ms: 1000,
            nav_timeout: 10.0,
        }
    }
}

impl BasicSimulatorConfig {
    fn check(&self, prefix: &str, c: &mut Checker) {
        c.non_empty(&at(prefix, "tcp_address"), &self.tcp_address);
        c.port(&at(prefix, "tcp_port"), self.tcp_port);
        self.start.check(&at(prefix, "start"), c);
        let initial = at(prefix, "reconnect_initial_ms");
        let max = at(prefix, "reconnect_max_ms");
        // 0 would never grow under doubling: a reconnect storm against a dead simulator.
        c.at_least(&initial, self.reconnect_initial_ms, 1);
        c.at_least(&max, self.reconnect_max_ms, 1);
        c.ordered(
            &initial,
            self.reconnect_initial_ms,
            &max,
            self.reconnect_max_ms,
        );
        c.positive(&at(prefix, "nav_timeout"), self.nav_timeout);
    }
}

/// The START line: where and how the simulated vehicle starts.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct SimStartConfig {
    /// Start latitude (START LAT, sent at full precision). Unit: decimal degrees, -90 to 90.
    #[schemars(range(min = -90.0, max = 90.0))]
    pub lat: f64,
    /// Start longitude (START LON). Unit: decimal degrees, -180 to 180.
    #[schemars(range(min = -180.0, max = 180.0))]
    pub lon: f64,
    /// How long the simulator stays in PAYLOAD before going IDLE (START DURATION); 0 = forever.
    /// Unit: s.
    #[schemars(range(min = 0.0))]
    pub duration: f64,
    /// Simulator update rate (START FREQ). Unit: Hz, greater than 0 and at most 1000.
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    #[schemars(range(max = 1000.0))]
    pub control_freq: f64,
    /// Vehicle dynamics limits.
    pub vehicle: SimVehicleConfig,
}

impl Default for SimStartConfig {
    fn default() -> Self {
        Self {
            lat: DEFAULT_ORIGIN_LAT,
            lon: DEFAULT_ORIGIN_LON,
            duration: 0.0,
            control_freq: 10.0,
            vehicle: SimVehicleConfig::default(),
        }
    }
}

impl SimStartConfig {
    fn check(&self, prefix: &str, c: &mut Checker) {
        c.latitude(&at(prefix, "lat"), self.lat);
        c.longitude(&at(prefix, "lon"), self.lon);
        c.non_negative(&at(prefix, "duration"), self.duration);
        c.positive_up_to(&at(prefix, "control_freq"), self.control_freq, 1000.0);
        self.vehicle.check(&at(prefix, "vehicle"), c);
    }
}

/// Dynamics limits of the simulated vehicle.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct SimVehicleConfig {
    /// Maximum acceleration (START ACCEL). Unit: m/s².
    #[schemars(range(min = 0.0))]
    pub accel: f64,
    /// Maximum turn rate (START HDG_RATE). Unit: deg/s.
    #[schemars(range(min = 0.0))]
    pub hdg_rate: f64,
    /// Maximum vertical speed (START Z_RATE). Unit: m/s.
    #[schemars(range(min = 0.0))]
    pub z_rate: f64,
}

impl Default for SimVehicleConfig {
    fn default() -> Self {
        Self {
            accel: 0.5,
            hdg_rate: 45.0,
            z_rate: 2.0,
        }
    }
}

impl SimVehicleConfig {
    fn check(&self, prefix: &str, c: &mut Checker) {
        c.non_negative(&at(prefix, "accel"), self.accel);
        c.non_negative(&at(prefix, "hdg_rate"), self.hdg_rate);
        c.non_negative(&at(prefix, "z_rate"), self.z_rate);
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
