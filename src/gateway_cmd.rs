//! Zenoh and Goby3 for the services: the gateways `frontseat interface` starts when
//! `[interprocess] enabled` (Zenoh) and `[goby3] enabled` (a gobyd client), hosting the
//! FrontSeatInterface, plus the FrontSeatTranslation when it runs the MOOS bridge in-process; and
//! `frontseat moos-gateway` — the FrontSeatTranslation alone between a MOOSDB and the interface
//! reached over Zenoh and/or gobyd, as Goby3's goby_moos_gateway.

use std::process::ExitCode;

use frontseat_actors::bus::Bus;
use frontseat_config::Goby3Config;
use frontseat_config::{GatewayConfig, InterfaceConfig};
use frontseat_gateway::goby3::{Goby3Handle, Goby3Settings};
use frontseat_gateway::{GatewayError, GatewayHandle, GatewayOptions};

/// The actors `frontseat interface` hosts, hence what its gateway exports and imports.
pub fn interface_actors(cfg: &InterfaceConfig) -> Vec<&'static str> {
    let mut hosted = vec!["FrontSeatInterface", "RootSupervisor"];
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

/// Starts the Goby3 transport for `hosted` actors; `None` when `[goby3] enabled = false`. It
/// returns at once: gobyd is joined (and re-joined) in the background.
pub fn start_goby3(
    cfg: &Goby3Config,
    name: &str,
    bus: &Bus,
    hosted: &[&str],
) -> Result<Option<Goby3Handle>, GatewayError> {
    if !cfg.enabled {
        return Ok(None);
    }
    let settings = Goby3Settings::from_config(cfg, name)?;
    frontseat_gateway::goby3::start(bus, settings, hosted, GatewayOptions::default()).map(Some)
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
    let notifier = std::sync::Arc::new(frontseat_actors::systemd::Notifier::from_env());
    let reporter = frontseat_actors::systemd::spawn_translation_reporter(notifier.clone(), &bus);
    let platform = match frontseat_gateway::resolve_platform(&cfg.interprocess, &cfg.name) {
        Ok(p) => p,
        Err(e) => {
            tracing::error!(error = %e, "cannot start the MOOS gateway");
            return ExitCode::from(2);
        }
    };
    // The gateways first, so that what the MOOS side publishes from its first moment is exported.
    let hosted = ["FrontSeatTranslation"];
    let gateway = if cfg.interprocess.enabled {
        match frontseat_gateway::start(
            &bus,
            &cfg.interprocess,
            &platform,
            &hosted,
            GatewayOptions::default(),
        )
        .await
        {
            Ok(g) => Some(g),
            Err(e) => {
                tracing::error!(error = %e, hint = open_hint(&e), "cannot start the Zenoh gateway");
                return ExitCode::from(2);
            }
        }
    } else {
        None
    };
    let goby3 = match start_goby3(&cfg.goby3, &cfg.name, &bus, &hosted) {
        Ok(g) => g,
        Err(e) => {
            tracing::error!(error = %e, "cannot start the Goby3 transport");
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
            if let Some(g) = gateway {
                g.close().await;
            }
            return ExitCode::from(2);
        }
    };
    tracing::info!(
        platform = %platform,
        moosdb = %format!("{}:{}", cfg.moos.server, cfg.moos.port),
        zenoh = cfg.interprocess.enabled,
        goby3 = cfg.goby3.enabled,
        "MOOS gateway running"
    );
    notifier.ready();
    let watchdog = frontseat_actors::systemd::spawn_watchdog(notifier.clone(), || async { true });
    crate::shutdown::shutdown_signal().await;
    notifier.stopping();
    if let Some(w) = watchdog {
        w.abort();
    }
    translation.shutdown().await;
    reporter.abort();
    if let Some(g) = goby3 {
        let stats = g.stats();
        g.close().await;
        tracing::info!(?stats, "Goby3 transport stopped");
    }
    if let Some(g) = gateway {
        let stats = g.stats();
        g.close().await;
        tracing::info!(?stats, "Zenoh gateway stopped");
    }
    tracing::info!("MOOS gateway stopped");
    ExitCode::SUCCESS
}
