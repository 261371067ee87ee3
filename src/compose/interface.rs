//! The composition root of `frontseat interface`: its root supervisor's children in start order
//! (the Zenoh gateway, the goby_coroner responder, the Goby3 gateway, the FrontSeatInterface with
//! its DriverActor, the FrontSeatTranslation, the web scope), under which policy each runs, and
//! the process around them: the bus claimed for a live driver, the recorder started first and
//! stopped last, systemd's READY, watchdog and STOPPING, and the exit code.

use std::process::ExitCode;
use std::sync::Arc;

use frontseat_actors::bus::Bus;
use frontseat_actors::interface::{InterfaceService, InterfaceSettings, ServiceExit, driver_node};
use frontseat_actors::service_child::{Service, service_child_with};
use frontseat_actors::supervisor::{ChildSpec, Policy, SupervisorHandle};
use frontseat_actors::systemd::{self, Notifier};
use frontseat_config::InterfaceConfig;
use frontseat_helm_side::{GatewayError, GatewayHandle, GatewayOptions};

use super::{gateways, recording};
use crate::shutdown::{SHUTDOWN_BOUND, exit_code, shutdown_signal};

/// The root supervisor's children for `frontseat interface`, in start order (stopped in the
/// reverse order): the gateways first, so that the interface's first statuses are already
/// exported and its last ones still are; then the FrontSeatInterface (with its DriverActor), the
/// FrontSeatTranslation and the web scope.
///
/// Only the FrontSeatInterface is on the vehicle side (its restart limit, its driver's and
/// exit_on_error end the process). Every other child is on the helm side: restarted without end,
/// so that no helm fault, however often it repeats, ends the process and with it the vehicle link.
pub fn children(
    config: &InterfaceConfig,
    bus: &Bus,
    current: systemd::InterfaceRef,
) -> Vec<ChildSpec> {
    let sup = &config.supervision;
    let ctx = (Arc::new(config.clone()), bus.clone());
    let mut children = Vec::new();
    if config.interprocess.enabled {
        children.push(
            service_child_with(
                "ZenohGateway",
                Policy::from(&sup.zenoh).helm_side(),
                ctx.clone(),
                |(cfg, bus)| async move {
                    match start_zenoh(&cfg, &bus).await {
                        Ok(Some(g)) => Ok(Box::new(g) as Box<dyn Service>),
                        Ok(None) => Err("[interprocess] is not enabled".to_string()),
                        Err(e) => Err(e.to_string()),
                    }
                },
            )
            .noted("with [interprocess] enabled; [supervision.zenoh]"),
        );
    }
    // First of the rest, so that its first answer already knows every child.
    let mut health =
        gateways::health_child(config.goby3.health_name("goby_frontseat_interface"), bus);
    health.policy = health.policy.helm_side();
    children.push(health.noted("answers goby_coroner (goby::health::request)"));
    if config.goby3.enabled {
        children.push(
            gateways::goby3_child(
                &config
                    .goby3
                    .with_client_name_for("goby_frontseat_interface"),
                &config.name,
                bus,
                interface_actors(config),
                Policy::from(&sup.goby3).helm_side(),
            )
            .noted("with [goby3] enabled; [supervision.goby3]"),
        );
    }
    children.push(service_child_with(
        "FrontSeatInterface",
        (&sup.interface).into(),
        (ctx.clone(), current),
        |((cfg, bus), current)| async move {
            let service = InterfaceService::start(&cfg, &bus, frontseat_drivers::BUILT_IN)
                .await
                .map_err(|e| e.to_string())?;
            *current.lock().unwrap_or_else(|p| p.into_inner()) = Some(service.actor().clone());
            Ok(Box::new(service) as Box<dyn Service>)
        },
    )
    .noted("[supervision.interface]; an error state (exit_on_error) or its driver's exhausted limit is not restarted: the process ends with exit 2 / exit 3")
    .nesting(vec![driver_node(&InterfaceSettings::from_config(config))]),
    );
    if let Some(moos) = &config.moos {
        children.push(
            frontseat_helm_side::translation::child_spec(
                frontseat_helm_side::translation::TranslationArgs {
                    cfg: moos.with_warp(config.sim_warp_factor),
                    vehicle: config.name.clone(),
                    bus: bus.clone(),
                    faults: None,
                    observer: Default::default(),
                },
                Policy::from(&sup.translation).helm_side(),
            )
            .noted("with [moos]; [supervision.translation]"),
        );
    }
    if let Some(o) = &config.opencpn {
        children.extend(opencpn_children(o, bus));
    }
    if config.ros2.enabled {
        children.push(ros2_child(config, bus));
    }
    if config.web.enabled {
        children.push(
            service_child_with(
                "WebScope",
                Policy::from(&sup.web).helm_side(),
                ctx,
                |(cfg, bus)| async move {
                    frontseat_web::WebService::start(&cfg, &bus)
                        .await
                        .map(|w| Box::new(w) as Box<dyn Service>)
                        .map_err(|e| e.to_string())
                },
            )
            .noted("with [web] enabled; [supervision.web]")
            .nesting(vec![frontseat_web::supervisor::hub_node()]),
        );
    }
    children
}

/// `[opencpn]`'s children: this vehicle's AIS and OpenCPN's route as its helm, both on the helm
/// side (restarted without end; a fault never ends the process).
fn opencpn_children(o: &frontseat_config::OpenCpnConfig, bus: &Bus) -> Vec<ChildSpec> {
    let policy = Policy::from(&frontseat_config::RestartConfig::default()).helm_side();
    let mut c = Vec::new();
    if o.ais.enabled {
        c.push(
            service_child_with(
                "AisReporter",
                policy.clone(),
                (Arc::new(o.ais.clone()), bus.clone()),
                |(cfg, bus)| async move {
                    frontseat_opencpn::lone::LoneAis::start(&cfg, &bus)
                        .await
                        .map(|s| Box::new(s) as Box<dyn Service>)
                        .map_err(|e| format!("[opencpn.ais]: {e}"))
                },
            )
            .noted("with [opencpn.ais] enabled: this vehicle as an AIS target (UDP, TCP)"),
        );
    }
    if o.helm.enabled {
        c.push(
            service_child_with(
                "OpenCpnHelm",
                policy,
                (Arc::new(o.helm.clone()), bus.clone()),
                |(cfg, bus)| async move {
                    frontseat_opencpn::helm::OpenCpnHelm::start(&cfg, &bus)
                        .await
                        .map(|s| Box::new(s) as Box<dyn Service>)
                        .map_err(|e| format!("[opencpn.helm] {}: {e}", cfg.listen))
                },
            )
            .noted("with [opencpn.helm] enabled: OpenCPN's APB/RMB as this vehicle's helm"),
        );
    }
    c
}

/// `[ros2]`: the vehicle as a ROS 2 participant over DDS, on the helm side (restarted without
/// end; a DDS fault never ends the process). Its samples reach the bus like a Zenoh helm's, so they
/// cross the command gate and the state machine like any helm's.
fn ros2_child(config: &InterfaceConfig, bus: &Bus) -> ChildSpec {
    service_child_with(
        "Ros2Gateway",
        Policy::from(&config.supervision.ros2).helm_side(),
        (Arc::new(config.clone()), bus.clone()),
        |(cfg, bus)| async move { start_ros2(&cfg, &bus) },
    )
    .noted("with [ros2] enabled; [supervision.ros2]")
}

#[cfg(feature = "ros2")]
fn start_ros2(cfg: &InterfaceConfig, bus: &Bus) -> Result<Box<dyn Service>, String> {
    frontseat_ros2::start(bus, &cfg.ros2, cfg.platform_name())
        .map(|g| Box::new(g) as Box<dyn Service>)
        .map_err(|e| e.to_string())
}

#[cfg(not(feature = "ros2"))]
fn start_ros2(_: &InterfaceConfig, _: &Bus) -> Result<Box<dyn Service>, String> {
    Err("[ros2] is enabled but this frontseat was built without the `ros2` feature".into())
}

/// `config` with every optional child of `frontseat interface` on.
pub(super) fn with_every_child(mut config: InterfaceConfig) -> InterfaceConfig {
    config.interprocess.enabled = true;
    config.goby3.enabled = true;
    config.moos.get_or_insert_with(Default::default);
    config.web.enabled = true;
    config.ros2.enabled = true;
    // Both OpenCPN children, as a config with [opencpn.ais] and [opencpn.helm] starts them (such
    // a config is refused with [moos] at --check; the tree only shows where each child sits).
    config.opencpn = Some(frontseat_config::OpenCpnConfig {
        ais: frontseat_config::AisConfig {
            enabled: true,
            vehicle: vec![frontseat_config::AisVehicleConfig {
                name: config.name.clone(),
                mmsi: frontseat_config::opencpn::SIM_MMSI_FIRST,
                label: None,
                ship_type: 33,
                call_sign: None,
                length_m: 2.0,
                beam_m: 0.5,
            }],
            ..Default::default()
        },
        helm: frontseat_config::OpenCpnHelmConfig {
            enabled: true,
            ..Default::default()
        },
    });
    config
}

/// The actors `frontseat interface` hosts, hence what its gateway exports and imports.
fn interface_actors(cfg: &InterfaceConfig) -> Vec<&'static str> {
    let mut hosted = vec!["FrontSeatInterface", "RootSupervisor", "HealthReporter"];
    if cfg.moos.is_some() {
        hosted.push("FrontSeatTranslation");
    }
    if cfg.opencpn.as_ref().is_some_and(|o| o.helm.enabled) {
        hosted.push("OpenCpnHelm");
    }
    hosted
}

/// Starts the interface's gateway; `None` when `[interprocess] enabled = false`. Start it before
/// the interface so that its first statuses are already exported.
async fn start_zenoh(
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

/// `frontseat interface -c FILE`: runs until SIGTERM/SIGINT, or until the vehicle side ends the
/// process (its restart limit, exit_on_error).
pub async fn run(config: InterfaceConfig) -> ExitCode {
    let notifier = Arc::new(Notifier::from_env());
    let bus = Bus::new();
    // A live driver runs on this bus: a replay may never share it.
    if let Err(held) = bus.claim(frontseat_actors::bus::BusRole::LiveDriver) {
        tracing::error!(
            ?held,
            "the bus is already claimed; not starting a live driver"
        );
        return ExitCode::from(2);
    }
    // Started before the children so their start-up is on the record too.
    let recorder = match recording::start_recorder(&bus, &config, "interface") {
        Ok(r) => r,
        Err(e) => {
            tracing::error!(error = %e, "cannot start the recorder ([record])");
            return ExitCode::from(2);
        }
    };
    let reporter = systemd::spawn_status_reporter(notifier.clone(), &bus);
    // One supervision tree: every part of the service is a child of the root supervisor,
    // restarted by its policy in [supervision]; past a limit the process exits non-zero.
    let current = systemd::InterfaceRef::default();
    let children = children(&config, &bus, current.clone());
    let mut root = match SupervisorHandle::start("root", children, Some(&bus)).await {
        Ok(r) => r,
        Err(e) => {
            tracing::error!(error = %e, "cannot start the frontseat interface");
            reporter.abort();
            recording::stop_recorder(recorder).await;
            return ExitCode::from(2);
        }
    };
    // READY only now: every child has started (the driver actor included) and the bus is up.
    notifier.ready();
    let watchdog = notifier.watchdog_period().and_then(|period| {
        systemd::spawn_watchdog(notifier.clone(), systemd::interface_probe(current, period))
    });
    tracing::info!(
        driver = %config.driver.name,
        frontseat = %config.driver.vehicle_link(),
        moos = config.moos.is_some(),
        interprocess = config.interprocess.enabled,
        goby3 = config.goby3.enabled,
        web = config.web.enabled,
        "frontseat interface running"
    );
    let exit = tokio::select! {
        e = root.wait() => e,
        _ = shutdown_signal() => ServiceExit::Clean,
    };
    notifier.stopping();
    if let Some(w) = watchdog {
        w.abort();
    }
    // Children stop in reverse start order, each within its bound.
    root.shutdown(SHUTDOWN_BOUND * 3).await;
    reporter.abort();
    recording::stop_recorder(recorder).await;
    if let ServiceExit::ErrorState(why) = &exit {
        // Goby3's goby_frontseat_interface quits with 0 here; exit_on_error_code says otherwise.
        tracing::error!(%why, code = config.exit_on_error_code, "exit_on_error: service ended");
        return ExitCode::from(config.exit_on_error_code);
    }
    exit_code(&exit)
}
