//! Zenoh and Goby3 for the services: the gateways `frontseat interface` starts when
//! `[interprocess] enabled` (Zenoh) and `[goby3] enabled` (a gobyd client), hosting the
//! FrontSeatInterface, plus the FrontSeatTranslation when it runs the MOOS bridge in-process; and
//! `frontseat moos-gateway` — the FrontSeatTranslation alone between a MOOSDB and the interface
//! reached over Zenoh and/or gobyd, as Goby3's goby_moos_gateway.

use std::process::ExitCode;
use std::sync::Arc;

use frontseat_actors::bus::Bus;
use frontseat_actors::interface::ServiceExit;
use frontseat_actors::service_child::{Service, service_child_with};
use frontseat_actors::supervisor::{ChildSpec, SupervisorHandle};
use frontseat_config::Goby3Config;
use frontseat_config::{GatewayConfig, InterfaceConfig};
use frontseat_helm_side::goby3::{Goby3Handle, Goby3Settings};
use frontseat_helm_side::{GatewayError, GatewayHandle, GatewayOptions};

/// The actors `frontseat interface` hosts, hence what its gateway exports and imports.
pub fn interface_actors(cfg: &InterfaceConfig) -> Vec<&'static str> {
    let mut hosted = vec!["FrontSeatInterface", "RootSupervisor", "HealthReporter"];
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
    let platform = frontseat_helm_side::resolve_platform(&cfg.interprocess, &cfg.name)?;
    frontseat_helm_side::start(
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
    frontseat_helm_side::goby3::start(bus, settings, hosted, GatewayOptions::default()).map(Some)
}

/// The Goby3 transport as a child of a root supervisor, for `hosted` actors.
pub fn goby3_child(
    cfg: &Goby3Config,
    name: &str,
    bus: &Bus,
    hosted: Vec<&'static str>,
    policy: frontseat_actors::supervisor::Policy,
) -> ChildSpec {
    let ctx = (Arc::new(cfg.clone()), name.to_string(), bus.clone(), hosted);
    service_child_with(
        "Goby3Gateway",
        policy,
        ctx,
        |(cfg, name, bus, hosted)| async move {
            match start_goby3(&cfg, &name, &bus, &hosted) {
                Ok(Some(g)) => Ok(Box::new(g) as Box<dyn Service>),
                Ok(None) => Err("[goby3] is not enabled".to_string()),
                Err(e) => Err(e.to_string()),
            }
        },
    )
}

/// The goby_coroner responder as a child of a root supervisor, answering as `name`; restarted
/// by the default policy (it holds nothing but the last statuses).
pub fn health_child(name: &str, bus: &Bus) -> ChildSpec {
    service_child_with(
        "HealthReporter",
        (&frontseat_config::RestartConfig::default()).into(),
        (name.to_string(), bus.clone()),
        |(name, bus)| async move {
            Ok(
                Box::new(frontseat_actors::health::HealthReporter::spawn(&bus, &name))
                    as Box<dyn Service>,
            )
        },
    )
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

/// `frontseat moos-gateway`'s children with both transports on, for the printed tree.
pub fn tree_children(bus: &Bus) -> Vec<ChildSpec> {
    let mut cfg = GatewayConfig::default();
    cfg.interprocess.enabled = true;
    cfg.goby3.enabled = true;
    gateway_children(&cfg, "platform", bus)
}

/// The root supervisor's children for `frontseat moos-gateway`, in start order: the transports
/// first, so that what the MOOS side publishes from its first moment is exported.
fn gateway_children(cfg: &GatewayConfig, platform: &str, bus: &Bus) -> Vec<ChildSpec> {
    const HOSTED: [&str; 3] = ["FrontSeatTranslation", "RootSupervisor", "HealthReporter"];
    let sup = &cfg.supervision;
    let mut children = Vec::new();
    if cfg.interprocess.enabled {
        let ctx = (
            Arc::new(cfg.interprocess.clone()),
            platform.to_string(),
            bus.clone(),
        );
        children.push(
            service_child_with(
                "ZenohGateway",
                (&sup.zenoh).into(),
                ctx,
                |(icfg, platform, bus)| async move {
                    frontseat_helm_side::start(
                        &bus,
                        &icfg,
                        &platform,
                        &HOSTED,
                        GatewayOptions::default(),
                    )
                    .await
                    .map(|g| Box::new(g) as Box<dyn Service>)
                    .map_err(|e| format!("{e} {}", open_hint(&e)))
                },
            )
            .noted("with [interprocess] enabled; [supervision.zenoh]"),
        );
    }
    if cfg.goby3.enabled {
        children.push(
            goby3_child(
                &cfg.goby3.with_client_name_for("goby_moos_gateway"),
                &cfg.name,
                bus,
                HOSTED.to_vec(),
                (&sup.goby3).into(),
            )
            .noted("with [goby3] enabled; [supervision.goby3]"),
        );
    }
    children.push(
        health_child(cfg.goby3.health_name("goby_moos_gateway"), bus)
            .noted("answers goby_coroner (goby::health::request)"),
    );
    let vehicle = if cfg.name.is_empty() {
        platform.to_string()
    } else {
        cfg.name.clone()
    };
    children.push(
        frontseat_helm_side::translation::child_spec(
            frontseat_helm_side::translation::TranslationArgs {
                cfg: cfg.moos.with_warp(1.0),
                vehicle,
                bus: bus.clone(),
                faults: None,
                observer: Default::default(),
            },
            (&sup.translation).into(),
        )
        .noted("[supervision.translation]"),
    );
    children
}

/// `frontseat moos-gateway -c FILE`: runs until SIGTERM/SIGINT, or until its root supervisor
/// gives up on a child (non-zero exit).
pub async fn moos_gateway(cfg: GatewayConfig) -> ExitCode {
    let bus = Bus::new();
    let notifier = std::sync::Arc::new(frontseat_actors::systemd::Notifier::from_env());
    let reporter = frontseat_actors::systemd::spawn_translation_reporter(notifier.clone(), &bus);
    let platform = match frontseat_helm_side::resolve_platform(&cfg.interprocess, &cfg.name) {
        Ok(p) => p,
        Err(e) => {
            tracing::error!(error = %e, "cannot start the MOOS gateway");
            return ExitCode::from(2);
        }
    };
    let recorder = match crate::record_cmd::start_gateway_recorder(&bus, &cfg) {
        Ok(r) => r,
        Err(e) => {
            tracing::error!(error = %e, "cannot start the recorder ([record])");
            reporter.abort();
            return ExitCode::from(2);
        }
    };
    let children = gateway_children(&cfg, &platform, &bus);
    let mut root = match SupervisorHandle::start("root", children, Some(&bus)).await {
        Ok(r) => r,
        Err(e) => {
            tracing::error!(error = %e, "cannot start the MOOS gateway");
            reporter.abort();
            crate::record_cmd::stop_recorder(recorder).await;
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
    let exit = tokio::select! {
        e = root.wait() => e,
        _ = crate::shutdown::shutdown_signal() => ServiceExit::Clean,
    };
    notifier.stopping();
    if let Some(w) = watchdog {
        w.abort();
    }
    root.shutdown(crate::shutdown::SHUTDOWN_BOUND * 3).await;
    reporter.abort();
    crate::record_cmd::stop_recorder(recorder).await;
    tracing::info!("MOOS gateway stopped");
    crate::shutdown::exit_code(&exit)
}
