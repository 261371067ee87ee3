//! The composition root of `frontseat moos-gateway` (Goby3's goby_moos_gateway): the
//! FrontSeatTranslation alone between a MOOSDB and the interface, reached over Zenoh and/or
//! gobyd. Its root supervisor's children in start order (the transports, the goby_coroner
//! responder, the translation), the recorder of the helm's side of the link, systemd's READY and
//! watchdog, and the exit code.

use std::process::ExitCode;
use std::sync::Arc;

use frontseat_actors::bus::Bus;
use frontseat_actors::interface::ServiceExit;
use frontseat_actors::service_child::{Service, service_child_with};
use frontseat_actors::supervisor::{ChildSpec, SupervisorHandle};
use frontseat_config::GatewayConfig;
use frontseat_helm_side::{GatewayError, GatewayOptions};

use super::gateways::{goby3_child, health_child};
use super::recording;

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
pub(super) fn tree_children(bus: &Bus) -> Vec<ChildSpec> {
    let mut cfg = GatewayConfig::default();
    cfg.interprocess.enabled = true;
    cfg.goby3.enabled = true;
    children(&cfg, "platform", bus)
}

/// The root supervisor's children for `frontseat moos-gateway`, in start order: the transports
/// first, so that what the MOOS side publishes from its first moment is exported.
pub(super) fn children(cfg: &GatewayConfig, platform: &str, bus: &Bus) -> Vec<ChildSpec> {
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
pub async fn run(cfg: GatewayConfig) -> ExitCode {
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
    let recorder = match recording::start_gateway_recorder(&bus, &cfg) {
        Ok(r) => r,
        Err(e) => {
            tracing::error!(error = %e, "cannot start the recorder ([record])");
            reporter.abort();
            return ExitCode::from(2);
        }
    };
    let children = children(&cfg, &platform, &bus);
    let mut root = match SupervisorHandle::start("root", children, Some(&bus)).await {
        Ok(r) => r,
        Err(e) => {
            tracing::error!(error = %e, "cannot start the MOOS gateway");
            reporter.abort();
            recording::stop_recorder(recorder).await;
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
    recording::stop_recorder(recorder).await;
    tracing::info!("MOOS gateway stopped");
    crate::shutdown::exit_code(&exit)
}
