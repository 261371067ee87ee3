//! `[driver.basic_simulator]`: the basic simulator driver's section (Goby3's basic_simulator_config) and the simulated vehicle it starts. Kept with its vehicle (`vehicles/basic_simulator/`, beside its driver,
//! codec and emulator) and compiled into frontseat-config (its line in the list of
//! vehicles, `driver_sections!` in `config_schema/src/lib.rs`), where the whole config's defaults, validation, schema and example are made: the
//! vehicle's crate depends on the config, so the section cannot be one of its own types.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::check::{Checker, at};
use crate::sections::{DEFAULT_ORIGIN_LAT, DEFAULT_ORIGIN_LON};

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

impl crate::drivers::DriverSection for BasicSimulatorConfig {
    const CHECKED_WHEN_NOT_SELECTED: bool = true;

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

    fn vehicle_link(&self) -> String {
        format!("tcp {}:{}", self.tcp_address, self.tcp_port)
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
    pub(crate) fn check(&self, prefix: &str, c: &mut Checker) {
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
    pub(crate) fn check(&self, prefix: &str, c: &mut Checker) {
        c.non_negative(&at(prefix, "accel"), self.accel);
        c.non_negative(&at(prefix, "hdg_rate"), self.hdg_rate);
        c.non_negative(&at(prefix, "z_rate"), self.z_rate);
    }
}
