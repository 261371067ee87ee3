//! `[driver.bluefin]`: the Bluefin Huxley driver's section (Goby3's bluefin_config). Kept with its vehicle (`vehicles/bluefin/`, beside its driver,
//! codec and emulator) and compiled into frontseat-config (its line in the list of
//! vehicles, `driver_sections!` in `config_schema/src/lib.rs`), where the whole config's defaults, validation, schema and example are made: the
//! vehicle's crate depends on the config, so the section cannot be one of its own types.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::FieldError;
use crate::check::{Checker, at};

/// Goby3's `BluefinConfig.AcceptingCommandsHook`: which Huxley message says the payload may
/// command.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
pub enum AcceptingCommandsHook {
    /// Any `$BFMSC` (mission-state message) means accepting commands.
    #[default]
    BfmscTrigger,
    /// `$BFMIS` with status `Running` means accepting commands.
    BfmisRunningTrigger,
    /// `$BFCTL` control = 1 means accepting commands, 0 gives control back.
    BfctlTrigger,
}

/// One point of the speed → RPM table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RpmTableEntry {
    /// Unit: m/s.
    pub speed: f64,
    /// Thruster revolutions per minute for that speed.
    pub rpm: i32,
}

/// The Bluefin Huxley driver: a TCP client of the Huxley "Standard Payload Interface" (`$BF…` /
/// `$BP…` NMEA sentences). Field names, defaults and units are Goby3's bluefin_config.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct BluefinConfig {
    /// Host name or IP address of the Huxley (required in Goby3; here it defaults to loopback,
    /// where `frontseat sim --vehicle bluefin` listens).
    pub huxley_tcp_address: String,
    /// TCP port of the Huxley payload interface.
    #[schemars(range(min = 1))]
    pub huxley_tcp_port: u16,
    /// Longest wait between reconnect attempts; attempts start at 50 ms and double up to this
    /// (Goby3 accepts this field but ignores it). Unit: s.
    #[schemars(range(min = 1))]
    pub reconnect_interval: u32,
    /// Times a sentence is written without an acknowledgement before it is dropped.
    #[schemars(range(min = 1))]
    pub nmea_resend_attempts: u32,
    /// Wait for a `$BFACK` before writing the sentence again. Unit: s.
    #[schemars(range(min = 1))]
    pub nmea_resend_interval: u32,
    /// Sentences dropped unacknowledged in a row (with nothing valid heard in between) that are
    /// tolerated; one more and the Huxley is declared unresponsive and the connection is
    /// re-opened.
    pub allowed_nmea_demerits: u32,
    /// The Huxley stops providing data after this long without `$BFNVG`. Unit: s.
    #[schemars(range(min = 1))]
    pub allow_missing_nav_interval: u32,
    /// Period of the `$BPSTS` heartbeat. Unit: s.
    #[schemars(range(min = 1))]
    pub heartbeat_interval: u32,
    /// Extra 3-letter sentence ids to enable with `$BPLOG,<id>,ON` at every connect.
    pub extra_bplog: Vec<String>,
    /// Send `$BPTMR` for micro_modem_raw_in data.
    pub send_tmr_messages: bool,
    /// Do not request or wait for `$BFACK`: every sentence is written once, and no command gets
    /// a response from the vehicle.
    pub disable_ack: bool,
    /// Which Huxley message means the vehicle accepts commands.
    pub accepting_commands_hook: AcceptingCommandsHook,
    /// Command thruster RPM (from rpm_table) instead of speed.
    pub use_rpm_table_for_speed: bool,
    /// Speed → RPM points, interpolated linearly; at least 2 when use_rpm_table_for_speed. Each
    /// entry is a `[[driver.bluefin.rpm_table]]` table with `speed` (m/s) and `rpm`.
    pub rpm_table: Vec<RpmTableEntry>,
}

impl Default for BluefinConfig {
    fn default() -> Self {
        Self {
            huxley_tcp_address: "127.0.0.1".into(),
            huxley_tcp_port: 29500,
            reconnect_interval: 10,
            nmea_resend_attempts: 3,
            nmea_resend_interval: 5,
            allowed_nmea_demerits: 3,
            allow_missing_nav_interval: 5,
            heartbeat_interval: 1,
            extra_bplog: Vec::new(),
            send_tmr_messages: true,
            disable_ack: false,
            accepting_commands_hook: AcceptingCommandsHook::BfmscTrigger,
            use_rpm_table_for_speed: false,
            rpm_table: Vec::new(),
        }
    }
}

impl crate::drivers::DriverSection for BluefinConfig {
    const CHECKED_WHEN_NOT_SELECTED: bool = true;

    fn check(&self, prefix: &str, c: &mut Checker) {
        c.non_empty(&at(prefix, "huxley_tcp_address"), &self.huxley_tcp_address);
        c.port(&at(prefix, "huxley_tcp_port"), self.huxley_tcp_port);
        for (name, v) in [
            ("reconnect_interval", self.reconnect_interval),
            ("nmea_resend_attempts", self.nmea_resend_attempts),
            ("nmea_resend_interval", self.nmea_resend_interval),
            (
                "allow_missing_nav_interval",
                self.allow_missing_nav_interval,
            ),
            ("heartbeat_interval", self.heartbeat_interval),
        ] {
            c.at_least(&at(prefix, name), u64::from(v), 1);
        }
        for (i, id) in self.extra_bplog.iter().enumerate() {
            if id.len() != 3 || !id.bytes().all(|b| b.is_ascii_alphanumeric()) {
                c.push(FieldError::new(
                    format!("{prefix}.extra_bplog[{i}]"),
                    format!("{id:?}"),
                    "must be a 3-letter sentence id such as \"SVS\"",
                ));
            }
        }
        for (i, e) in self.rpm_table.iter().enumerate() {
            c.non_negative(&format!("{prefix}.rpm_table[{i}].speed"), e.speed);
        }
        if self.use_rpm_table_for_speed && self.rpm_table.len() < 2 {
            c.push(FieldError::new(
                at(prefix, "rpm_table"),
                self.rpm_table.len(),
                "use_rpm_table_for_speed needs at least 2 entries",
            ));
        }
    }

    fn vehicle_link(&self) -> String {
        format!("tcp {}:{}", self.huxley_tcp_address, self.huxley_tcp_port)
    }
}
