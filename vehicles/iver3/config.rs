//! `[driver.iver3]`: the Iver3 driver's section (Goby3's iver_config) and its mode table. Kept with its vehicle (`vehicles/iver3/`, beside its driver,
//! codec and emulator) and compiled into frontseat-config (its line in the list of
//! vehicles, `driver_sections!` in `config_schema/src/lib.rs`), where the whole config's defaults, validation, schema and example are made: the
//! vehicle's crate depends on the config, so the section cannot be one of its own types.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::FieldError;
use crate::check::{Checker, at};
use crate::interface::VehicleLinkConfig;
use crate::state_name::FrontSeatStateName;

/// FrontSeatState for each UVC mode (Goby3's IverModeAssignments, same defaults).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct IverModeAssignments {
    /// Mode letter missing or not known.
    pub unknown: FrontSeatStateName,
    /// `N`.
    pub normal: FrontSeatStateName,
    /// `S`.
    pub stopped: FrontSeatStateName,
    /// `P`.
    pub parking: FrontSeatStateName,
    /// `M`.
    pub manual_override: FrontSeatStateName,
    /// `m` or `Mp`.
    pub manual_parking: FrontSeatStateName,
    /// `A`.
    pub servo_mode: FrontSeatStateName,
    /// `W`.
    pub mission_mode: FrontSeatStateName,
}

impl Default for IverModeAssignments {
    fn default() -> Self {
        use FrontSeatStateName::*;
        Self {
            unknown: FrontseatIdle,
            normal: FrontseatAcceptingCommands,
            stopped: FrontseatIdle,
            parking: FrontseatInControl,
            manual_override: FrontseatAcceptingCommands,
            manual_parking: FrontseatAcceptingCommands,
            servo_mode: FrontseatAcceptingCommands,
            mission_mode: FrontseatAcceptingCommands,
        }
    }
}

/// The Iver3 driver (UVC Remote Helm NMEA). Field names and units follow Goby3's iver_config.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct Iver3Config {
    /// Serial device connected to Remote Helm (required for transport = "serial").
    #[schemars(example = &"/dev/ttyUSB0")]
    pub serial_port: String,
    /// Unit: baud.
    #[schemars(range(min = 1))]
    pub serial_baud: u32,
    /// If set, every valid $--RMC from the UVC is copied to this serial port at 4800 baud
    /// (8N1), for an NTP reference clock.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[schemars(example = &"/dev/ttyUSB2")]
    pub ntp_serial_port: Option<String>,
    /// Value of $OMS field 3. Unit: degrees.
    pub max_pitch_angle_degrees: i32,
    /// Remote Helm major version (required): below 5 $OMS depth is in feet, from 5 in metres.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[schemars(example = &5)]
    pub remote_helm_version_major: Option<i32>,
    /// $OMS timeout field: the UVC drops a command not refreshed within it. Unit: s, 0 to 120.
    #[schemars(range(min = 0, max = 120))]
    pub oms_timeout: u32,
    /// FrontSeatState for each UVC mode.
    pub mode_assignments: IverModeAssignments,
    /// The frontseat stops providing data after this long without $OSI or $C (Goby3's fixed
    /// allowed_skew). Unit: s.
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub providing_data_timeout: f64,
    /// Transport, serial framing, reconnect and acknowledgement settings.
    pub link: VehicleLinkConfig,
}

impl Default for Iver3Config {
    fn default() -> Self {
        Self {
            serial_port: String::new(),
            serial_baud: 19200,
            ntp_serial_port: None,
            max_pitch_angle_degrees: 45,
            remote_helm_version_major: None,
            oms_timeout: 5,
            mode_assignments: IverModeAssignments::default(),
            providing_data_timeout: 10.0,
            link: VehicleLinkConfig::default(),
        }
    }
}

impl crate::drivers::DriverSection for Iver3Config {
    const CHECKED_WHEN_NOT_SELECTED: bool = false;

    fn check(&self, prefix: &str, c: &mut Checker) {
        self.link.check(
            &at(prefix, "link"),
            &at(prefix, "serial_port"),
            &self.serial_port,
            c,
        );
        c.at_least(&at(prefix, "serial_baud"), u64::from(self.serial_baud), 1);
        c.count(
            &at(prefix, "oms_timeout"),
            u64::from(self.oms_timeout),
            0,
            120,
        );
        if self.remote_helm_version_major.is_none() {
            c.push(FieldError::new(
                at(prefix, "remote_helm_version_major"),
                "missing".to_string(),
                "required (as in Goby3): below 5 $OMS depth is sent in feet, from 5 in metres"
                    .to_string(),
            ));
        }
        c.positive(
            &at(prefix, "providing_data_timeout"),
            self.providing_data_timeout,
        );
    }

    fn vehicle_link(&self) -> String {
        self.link.describe(&self.serial_port, self.serial_baud)
    }
}
