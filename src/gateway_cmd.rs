//! Zenoh for the services: the gateway `frontseat interface` starts when `[interprocess] enabled`
//! (hosting the FrontSeatInterface, plus the FrontSeatTranslation when it runs the MOOS bridge
//! in-process), and `frontseat moos-gateway` — the FrontSeatTranslation alone between a MOOSDB
//! and the interface reached over Zenoh, as Goby3's goby_moos_gateway.

use std::process::ExitCode;

use frontseat_actors::bus::Bus;
use frontseat_config::{GatewayConfig, InterfaceConfig};
use frontseat_gateway::{GatewayError, GatewayHandle, GatewayOptions};

/// The actors `frontseat interface` hosts, hence what its gateway exports and imports.
pub fn interface_actors(cfg: &InterfaceConfig) -> Vec<&'static str> {
    let mut hosted = vec!["FrontSeatInterface"];
    if cfg.moos.is_some() {
        hosted.push("FrontSeatTranslation");
    }
    hosted
}

/// Starts the interface's gateway; `None` when `[interprocess] enabled = false`. Start it before
/// the interface so that its first statuses are already exported.
pub async fn start_for_interface(
    cfg: &InterfaceConfig,
    bus: &Bus,
) -> Result<Option<GatewayHandle>, GatewayError> {
    if !cfg.interprocess.enabled {
        return Ok(None);
    }
    let platform = frontseat_gateway::resolve_platform(&cfg.interprocess, &cfg.name)?;
    frontseat_gateway::start(
        bus,
        &cfg.interprocess,
        &platform,
        &interface_actors(cfg),
        GatewayOptions::default(),
    )
    .await
    .map(Some)
}

/// A hint for the commonest failure: the interface already listens on the default endpoint.
fn open_hint(e: &GatewayError) -> &'static str {
    match e {
        GatewayError::Open(_) => {
            "if `frontseat interface` already listens on this endpoint, set [interprocess] \
             listen = [] and connect = [\"tcp/127.0.0.1:7447\"] (the interface's listen endpoint)"
        }
        _ => "",
    }
}

/// `frontseat moos-gateway -c FILE`: runs until SIGTERM/SIGINT.
pub async fn moos_gateway(cfg: GatewayConfig) -> ExitCode {
    let bus = Bus::new();
    let notifier = std::sync::Arc::new(crate::systemd::Notifier::from_env());
    let reporter = crate::systemd::spawn_translation_reporter(notifier.clone(), &bus);
    let platform = match frontseat_gateway::resolve_platform(&cfg.interprocess, &cfg.name) {
        Ok(p) => p,
        Err(e) => {
            tracing::error!(error = %e, "cannot start the MOOS gateway");
            return ExitCode::from(2);
        }
    };
    // The gateway first, so that what the MOOS side publishes from its first moment is exported.
    let gateway = match frontseat_gateway::start(
        &bus,
        &cfg.interprocess,
        &platform,
        &["FrontSeatTranslation"],
        GatewayOptions::default(),
    )
    .await
    {
        Ok(g) => g,
        Err(e) => {
            tracing::error!(error = %e, hint = open_hint(&e), "cannot start the Zenoh gateway");
            return ExitCode::from(2);
        }
    };
    let vehicle = if cfg.name.is_empty() {
        &platform
    } else {
        &cfg.name
    };
    let translation = match frontseat_actors::translation::spawn(&cfg.moos, vehicle, &bus).await {
        Ok(t) => t,
        Err(e) => {
            tracing::error!(error = %e, "cannot start the FrontSeatTranslation");
            gateway.close().await;
            return ExitCode::from(2);
        }
    };
    tracing::info!(
        platform = %platform,
        moosdb = %format!("{}:{}", cfg.moos.server, cfg.moos.port),
        "MOOS gateway running"
    );
    notifier.ready();
    let watchdog = crate::systemd::spawn_watchdog(notifier.clone(), || async { true });
    crate::shutdown::shutdown_signal().await;
    notifier.stopping();
    if let Some(w) = watchdog {
        w.abort();
    }
    translation.shutdown().await;
    reporter.abort();
    let stats = gateway.stats();
    gateway.close().await;
    tracing::info!(?stats, "MOOS gateway stopped");
    ExitCode::SUCCESS
}
