//! `[driver.waveglider_sv2]`: the Wave Glider SV2 driver's section (Goby3's waveglider_sv2_config). Kept with its vehicle (`vehicles/waveglider_sv2/`, beside its driver,
//! codec and emulator) and compiled into frontseat-config (its line in the list of
//! vehicles, `driver_sections!` in `config_schema/src/lib.rs`), where the whole config's defaults, validation, schema and example are made: the
//! vehicle's crate depends on the config, so the section cannot be one of its own types.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::check::{Checker, at};
use crate::interface::VehicleLinkConfig;

/// The Wave Glider SV2 driver (payload protocol to the C&C board). Field names and units
/// follow Goby3's waveglider_sv2_config.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct WavegliderSv2Config {
    /// Serial device to the C&C "PM" port (required for transport = "serial").
    #[schemars(example = &"/dev/ttyUSB1")]
    pub pm_serial_port: String,
    /// Unit: baud.
    #[schemars(range(min = 1))]
    pub pm_serial_baud: u32,
    /// High byte of the driver's address, 0 to 255.
    #[schemars(range(min = 0, max = 255))]
    pub board_id: u32,
    /// Low byte of the driver's address, 0 to 255.
    #[schemars(range(min = 0, max = 255))]
    pub task_id: u32,
    /// The frontseat stops providing data after this long without a status request (Goby3's
    /// fixed 30 s). Unit: s.
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub providing_data_timeout: f64,
    /// Publish a NodeStatus from the position in each status request whose fix is valid
    /// (Goby3 publishes no navigation; the position unit is our reading, see
    /// docs/goby3-differences.md).
    pub publish_navigation: bool,
    /// Transport, serial framing, reconnect and acknowledgement settings.
    pub link: VehicleLinkConfig,
}

impl Default for WavegliderSv2Config {
    fn default() -> Self {
        Self {
            pm_serial_port: String::new(),
            pm_serial_baud: 115_200,
            board_id: 0x03,
            task_id: 0x01,
            providing_data_timeout: 30.0,
            publish_navigation: false,
            link: VehicleLinkConfig {
                ack_timeout: 10.0,
                ..VehicleLinkConfig::default()
            },
        }
    }
}

impl crate::drivers::DriverSection for WavegliderSv2Config {
    const CHECKED_WHEN_NOT_SELECTED: bool = false;

    fn check(&self, prefix: &str, c: &mut Checker) {
        self.link.check(
            &at(prefix, "link"),
            &at(prefix, "pm_serial_port"),
            &self.pm_serial_port,
            c,
        );
        c.at_least(
            &at(prefix, "pm_serial_baud"),
            u64::from(self.pm_serial_baud),
            1,
        );
        c.count(&at(prefix, "board_id"), u64::from(self.board_id), 0, 255);
        c.count(&at(prefix, "task_id"), u64::from(self.task_id), 0, 255);
        c.positive(
            &at(prefix, "providing_data_timeout"),
            self.providing_data_timeout,
        );
    }

    fn vehicle_link(&self) -> String {
        self.link.describe(&self.pm_serial_port, self.pm_serial_baud)
    }
}
