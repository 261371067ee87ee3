//! Starting and stopping a process's recorder (`[record]`, `demo --record FILE`): the run's
//! metadata from its config, and the one rule every root follows — started before its children
//! so their start-up is on the record, stopped after them so their last words are too. The
//! recorder itself is `frontseat-record`.

use std::path::Path;

use frontseat_actors::bus::Bus;
use frontseat_config::InterfaceConfig;
use frontseat_record::recorder::{RecordMeta, config_digest};
use frontseat_record::service::RecordService;

/// The interface's (or demo's) `[record]`: the recorder and/or the Foxglove live server;
/// `Ok(None)` when neither is enabled.
pub fn start_recorder(
    bus: &Bus,
    cfg: &InterfaceConfig,
    application: &str,
) -> Result<Option<RecordService>, String> {
    start_with(bus, &cfg.record, &cfg.name, run_meta(cfg, application))
}

/// `demo --record FILE [--force]`: refused (exit 2 from the caller) when FILE exists without
/// `force`, or is not a plain file name in a directory; with `force` the run records beside FILE
/// and renames onto it when it ends.
pub fn start_demo_recorder(
    bus: &Bus,
    cfg: &InterfaceConfig,
    path: &Path,
    force: bool,
) -> Result<Option<RecordService>, (u8, String)> {
    if path.file_name().is_none() {
        return Err((2, format!("--record {}: not a file name", path.display())));
    }
    if !force && std::fs::symlink_metadata(path).is_ok() {
        return Err((
            2,
            format!("--record {} exists (--force to replace it)", path.display()),
        ));
    }
    RecordService::spawn_adjusted(bus, &cfg.record, &cfg.name, run_meta(cfg, "demo"), |o| {
        o.replace = force;
    })
    .map_err(|e| (1, e.to_string()))
}

/// The MOOS gateway's recorder (the helm's side of the link) when `[record] enabled`.
pub fn start_gateway_recorder(
    bus: &Bus,
    cfg: &frontseat_config::GatewayConfig,
) -> Result<Option<RecordService>, String> {
    let mut extra = std::collections::BTreeMap::new();
    extra.insert("application".into(), "moos-gateway".to_string());
    let meta = RecordMeta {
        vehicle: cfg.name.clone(),
        config_digest: config_digest(&serde_json::to_string(cfg).unwrap_or_default()),
        version: env!("CARGO_PKG_VERSION").into(),
        extra,
        ..Default::default()
    };
    start_with(bus, &cfg.record, &cfg.name, meta)
}

fn start_with(
    bus: &Bus,
    record: &frontseat_config::RecordConfig,
    name: &str,
    meta: RecordMeta,
) -> Result<Option<RecordService>, String> {
    RecordService::spawn(bus, record, name, meta).map_err(|e| e.to_string())
}

/// The run's metadata from the interface config.
fn run_meta(cfg: &InterfaceConfig, application: &str) -> RecordMeta {
    let mut extra = std::collections::BTreeMap::new();
    extra.insert("application".into(), application.to_string());
    RecordMeta {
        vehicle: cfg.name.clone(),
        datum_lat: cfg.origin.lat,
        datum_lon: cfg.origin.lon,
        config_digest: config_digest(&serde_json::to_string(cfg).unwrap_or_default()),
        version: env!("CARGO_PKG_VERSION").into(),
        driver: cfg.driver.name.clone(),
        extra,
    }
}

/// Stops the recorder and the live server of `[record]` (the file is closed with its summary).
pub async fn stop_recorder(rec: Option<RecordService>) {
    if let Some(r) = rec {
        r.stop().await;
    }
}
