//! Typed TOML configuration for the frontseat services (`interface`, `sim`, `moos-gateway`):
//! defaults, validation with field paths, the commented example config and the JSON Schema.
//!
//! The doc comments on the config structs are the single source of field descriptions: schemars
//! turns them into the schema, and [`example`] walks that schema to comment the example file.
//! Each vehicle's `[driver.<vehicle>]` section is written in its vehicle's folder
//! (`vehicles/<vehicle>/config.rs`) and compiled here from one list of vehicles
//! (`driver_sections!` below, see [`drivers`]): the vehicle crates depend on this one, and the
//! whole config (defaults, validation, schema, example) is made in one place.
#![forbid(unsafe_code)]

mod check;
#[macro_use]
mod drivers;
mod error;
mod example;
mod gateway;
mod goby3;
pub mod goby3_import;
mod interface;
pub mod names;
pub mod opencpn;
mod record;
mod ros2;
mod sections;
mod sim;
mod state_name;
mod web;
mod zenoh_security;

use std::io::Read;
use std::path::Path;

use schemars::JsonSchema;
use serde::Serialize;
use serde::de::DeserializeOwned;

pub use error::{ConfigError, FieldError};
pub use gateway::{GatewayConfig, GatewaySupervisionConfig};
pub use goby3::{Goby3Config, Goby3Transport};
pub use interface::{
    BusConfig, ChaosConfig, FlowControlConfig, FrontSeatStateName, InterfaceConfig, LimitsConfig,
    MAX_QUEUE_CAPACITY, NavLimitsConfig, ParityConfig, RawSendConfig, RawSource, RestartConfig,
    RestartPolicy, SupervisionConfig, TransportKind, VehicleLinkConfig, VehicleType,
};
pub use opencpn::{AisConfig, AisVehicleConfig, OpenCpnConfig, OpenCpnHelmConfig};
pub use record::{FOXGLOVE_TOKEN_ENV, FoxgloveConfig, RecordCompression, RecordConfig};
pub use ros2::{
    Ros2Config, Ros2Group, Ros2QosConfig, Ros2Reliability, check_ros_token, ros_namespace,
};
pub use sections::{
    DEFAULT_MAX_EXPORT_BATCH_SIZE, DEFAULT_MAX_QUEUE_SIZE, DEFAULT_METRICS_INTERVAL_S,
    DEFAULT_ORIGIN_LAT, DEFAULT_ORIGIN_LON, DEFAULT_SCHEDULED_DELAY_MS, InterprocessConfig,
    InterprocessMode, LatLonConfig, MoosConfig, TelemetryConfig,
};
pub use sim::{CurrentConfig, FaultKind, MAX_LINE_BYTES_LIMIT, ScheduledFaultConfig, SimConfig};
pub use web::{MIN_TOKEN_CHARS, WEB_TOKEN_ENV, WebConfig};
pub use zenoh_security::{ZenohAccessConfig, ZenohSecurity, ZenohTlsConfig, endpoint_protocol};

// The config's list of built-in vehicles, in the order of their `[driver.<vehicle>]` sections.
// Each section is written in its vehicle's folder and compiled in here (the vehicle crates depend
// on this one, so a section cannot be a type of its vehicle's own crate); adding a vehicle is its
// `config.rs` and one entry here (see src/drivers.rs for what the entry makes).
driver_sections! {
    /// Settings of the basic simulator driver (Goby3's basic_simulator_config).
    basic_simulator: "../../vehicles/basic_simulator/config.rs" => BasicSimulatorConfig, BASIC_SIMULATOR;
    /// Settings of the Iver3 driver (Goby3's iver_config), used when name = "iver3".
    iver3: "../../vehicles/iver3/config.rs" => Iver3Config, IVER3;
    /// Settings of the Wave Glider SV2 driver (Goby3's waveglider_sv2_config), used when
    /// name = "waveglider_sv2".
    waveglider_sv2: "../../vehicles/waveglider_sv2/config.rs" => WavegliderSv2Config, WAVEGLIDER_SV2;
    /// Settings of the Bluefin Huxley driver (Goby3's bluefin_config), used when name = "bluefin".
    bluefin: "../../vehicles/bluefin/config.rs" => BluefinConfig, BLUEFIN;
    /// Settings of the ArduPilot (MAVLink) driver, used when name = "ardupilot".
    ardupilot: "../../vehicles/ardupilot/config.rs" => ArdupilotConfig, ARDUPILOT;
    /// Settings of the LSTS DUNE (IMC) driver, used when name = "dune".
    dune: "../../vehicles/dune/config.rs" => DuneConfig, DUNE;
}

/// Largest accepted time warp (sim_warp_factor, moos.time_warp).
pub const MAX_WARP: f64 = 10_000.0;

/// Largest config file [`load`] reads; a config is a few kilobytes, so anything bigger is a
/// mistake (wrong file) and must not be read into memory whole.
pub const MAX_FILE_BYTES: u64 = 1 << 20;

/// A service's configuration: its TOML shape (serde), its schema (schemars) and its rules.
pub trait ServiceConfig: Serialize + DeserializeOwned + JsonSchema + Default {
    /// The subcommand this configures: "interface", "sim", "moos-gateway".
    const SERVICE: &'static str;

    /// Every broken rule; empty means valid.
    fn validate(&self) -> Vec<FieldError>;

    /// Advice about a valid config (`--check` prints it); none by default.
    fn warnings(&self) -> Vec<String> {
        Vec::new()
    }

    /// The Goby3 application's .pb.cfg of this service turned into our TOML, when there is one
    /// (`interface`: goby_frontseat_interface, `moos-gateway`: goby_moos_gateway).
    fn import_goby3(
        _text: &str,
        _file: &str,
    ) -> Option<Result<goby3_import::Imported, ConfigError>> {
        None
    }
}

/// Read, parse and validate a config file: TOML, or a Goby3 `.pb.cfg` of the Goby3 application
/// the service replaces. Returns the config and, for a .pb.cfg, the Goby3 fields it set that
/// have no setting here (each named; the service logs them, `--check` prints them).
pub fn load_with_notes<T: ServiceConfig>(path: &Path) -> Result<(T, Vec<String>), ConfigError> {
    let file = path.display().to_string();
    let text = read_text(path)?;
    if goby3_import::is_goby3_file(&file) {
        let imported = T::import_goby3(&text, &file).unwrap_or_else(|| {
            Err(ConfigError::Parse {
                file: file.clone(),
                line: 0,
                column: 0,
                message: format!(
                    "a Goby3 .pb.cfg, but `frontseat {}` has no Goby3 counterpart: use TOML",
                    T::SERVICE
                ),
            })
        })?;
        let cfg = parse::<T>(&imported.toml, &format!("{file} (as imported)"))?;
        return Ok((cfg, imported.warnings()));
    }
    Ok((parse(&text, &file)?, Vec::new()))
}

/// A Goby3 .pb.cfg of `T`'s Goby3 application as commented TOML (`--import-goby3`).
pub fn import_goby3<T: ServiceConfig>(path: &Path) -> Result<goby3_import::Imported, ConfigError> {
    let file = path.display().to_string();
    let text = read_text(path)?;
    let imported = T::import_goby3(&text, &file).unwrap_or_else(|| {
        Err(ConfigError::Parse {
            file: file.clone(),
            line: 0,
            column: 0,
            message: format!(
                "`frontseat {}` has no Goby3 counterpart to import",
                T::SERVICE
            ),
        })
    })?;
    // What it prints must load: checked here, so a bad value is reported against the Goby3 file.
    parse::<T>(&imported.toml, &format!("{file} (as imported)"))?;
    Ok(imported)
}

/// Read, parse and validate a config file (TOML, or a Goby3 .pb.cfg: see [`load_with_notes`]).
pub fn load<T: ServiceConfig>(path: &Path) -> Result<T, ConfigError> {
    load_with_notes(path).map(|(cfg, _)| cfg)
}

/// A config file's text: bounded in size, UTF-8.
pub fn read_text(path: &Path) -> Result<String, ConfigError> {
    let file = path.display().to_string();
    let io = |source| ConfigError::Io {
        file: file.clone(),
        source,
    };
    let f = std::fs::File::open(path).map_err(io)?;
    let mut bytes = Vec::new();
    f.take(MAX_FILE_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(io)?;
    if bytes.len() as u64 > MAX_FILE_BYTES {
        return Err(io(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("larger than {MAX_FILE_BYTES} bytes; not a config file"),
        )));
    }
    String::from_utf8(bytes).map_err(|e| not_utf8(&file, e.as_bytes(), e.utf8_error()))
}

/// A byte that is not UTF-8 is a parse error like any other: its line and column (counted in
/// the valid text before it), the byte, and for a .pb.cfg the same prefix as its other errors.
fn not_utf8(file: &str, bytes: &[u8], e: std::str::Utf8Error) -> ConfigError {
    let at = e.valid_up_to();
    // Valid by construction: from_utf8 checked everything before `at`.
    let before = std::str::from_utf8(&bytes[..at]).unwrap_or_default();
    let (line, column) = line_column(before, before.len()).unwrap_or((0, 0));
    let byte = bytes.get(at).copied().unwrap_or_default();
    let what = match e.error_len() {
        Some(_) => format!("byte 0x{byte:02X} is not UTF-8"),
        None => format!("the file ends inside a UTF-8 character (byte 0x{byte:02X})"),
    };
    let prefix = if goby3_import::is_goby3_file(file) {
        goby3_import::PARSE_ERROR_PREFIX
    } else {
        ""
    };
    ConfigError::Parse {
        file: file.to_owned(),
        line,
        column,
        message: format!("{prefix}{what}: a config file is UTF-8 text"),
    }
}

/// Parse and validate TOML text; `file_name` only labels the errors.
pub fn parse<T: ServiceConfig>(text: &str, file_name: &str) -> Result<T, ConfigError> {
    let cfg: T = toml::from_str(text).map_err(|e| {
        let mut err = parse_error(&e, text, file_name);
        moved::explain::<T>(&mut err, text, e.span().map(|s| s.start));
        err
    })?;
    let errors = cfg.validate();
    if errors.is_empty() {
        Ok(cfg)
    } else {
        Err(ConfigError::Invalid {
            file: file_name.to_owned(),
            errors,
        })
    }
}

/// The complete example config of `T`: every field with its default value, each preceded by
/// its description and unit. Optional sections and settings that are off by default are printed
/// commented out (`#[moos]`, `#server = …`), so the text loads as it is and equals
/// `T::default()`.
pub fn example<T: ServiceConfig>() -> String {
    example::render::<T>()
}

/// The JSON Schema of `T`, pretty-printed.
pub fn schema<T: ServiceConfig>() -> String {
    let schema = schemars::schema_for!(T);
    // A Schema is a serde_json::Value underneath; serializing it cannot fail.
    serde_json::to_string_pretty(&schema).unwrap_or_default()
}

mod moved;

fn parse_error(e: &toml::de::Error, text: &str, file: &str) -> ConfigError {
    let (line, column) = e
        .span()
        .and_then(|span| line_column(text, span.start))
        .unwrap_or((0, 0));
    let mut message = e.message().trim().to_owned();
    // serde's type errors ("invalid type: string \"x\", expected f64") do not say which key;
    // the source does, so name it.
    if let Some(path) = e.span().and_then(|span| value_path(text, span.start)) {
        message = format!("{path}: {message}");
    }
    ConfigError::Parse {
        file: file.to_owned(),
        line,
        column,
        message,
    }
}

/// Dotted path of the key whose value starts before `offset` on the same line, using the last
/// `[table]` header above it; None when `offset` is not inside a `key = value` line's value.
fn value_path(text: &str, offset: usize) -> Option<String> {
    let before = text.get(..offset)?;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    let (key, _) = before[line_start..].split_once('=')?;
    let key = key.trim();
    if key.is_empty() || key.starts_with('#') || key.starts_with('[') {
        return None;
    }
    let header = before[..line_start].lines().rev().find_map(|l| {
        let l = l.trim();
        let inner = l.strip_prefix("[[").and_then(|r| r.split_once("]]"));
        let inner = inner.or_else(|| l.strip_prefix('[').and_then(|r| r.split_once(']')));
        inner.map(|(name, _)| name.trim().to_owned())
    });
    Some(match header {
        Some(h) if !h.is_empty() => format!("{h}.{key}"),
        _ => key.to_owned(),
    })
}

/// 1-based line and character column of byte `offset`.
fn line_column(text: &str, offset: usize) -> Option<(usize, usize)> {
    let before = text.get(..offset)?;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    let line = before.matches('\n').count() + 1;
    let column = before[line_start..].chars().count() + 1;
    Some((line, column))
}
