//! The long-running services: `frontseat interface` and `frontseat sim`. Each one builds its
//! parts, waits for SIGTERM/SIGINT or for its own end, and drains within a bound.

use std::net::SocketAddr;
use std::process::ExitCode;
use std::sync::Arc;
use std::time::Duration;

use frontseat_actors::bus::Bus;
use frontseat_actors::interface::{InterfaceService, ServiceExit};
use frontseat_actors::supervisor::SupervisorHandle;
use frontseat_config::{FaultKind, InterfaceConfig, SimConfig};
use frontseat_sim::{CtrlState, Fault, ScheduledFault, SimOptions, SimServer};

use frontseat_actors::systemd::{self, Notifier};

/// How long an orderly shutdown may take before we give up waiting.
pub const SHUTDOWN_BOUND: Duration = Duration::from_secs(3);

pub use crate::shutdown::shutdown_signal;

pub fn exit_code(exit: &ServiceExit) -> ExitCode {
    match exit {
        ServiceExit::Clean => ExitCode::SUCCESS,
        other => {
            tracing::error!(?other, "service ended with an error");
            ExitCode::from(other.code() as u8)
        }
    }
}

pub async fn interface(config: InterfaceConfig) -> ExitCode {
    let notifier = Arc::new(Notifier::from_env());
    let bus = Bus::new();
    // The gateway first, so the interface's first statuses are already exported.
    let gateway = match crate::gateway_cmd::start_for_interface(&config, &bus).await {
        Ok(g) => g,
        Err(e) => {
            tracing::error!(error = %e, "cannot start the Zenoh gateway");
            return ExitCode::from(2);
        }
    };
    let goby3 = match crate::gateway_cmd::start_goby3(
        &config.goby3,
        &config.name,
        &bus,
        &crate::gateway_cmd::interface_actors(&config),
    ) {
        Ok(g) => g,
        Err(e) => {
            tracing::error!(error = %e, "cannot start the Goby3 transport");
            return ExitCode::from(2);
        }
    };
    let reporter = systemd::spawn_status_reporter(notifier.clone(), &bus);
    let mut service = match InterfaceService::start(&config, &bus).await {
        Ok(s) => s,
        Err(e) => {
            tracing::error!(error = %e, "cannot start the frontseat interface");
            return ExitCode::from(2);
        }
    };
    // The root supervisor: the FrontSeatTranslation (and what else runs beside the interface)
    // restarted by its policy in [supervision]; past the limit the process exits non-zero.
    let mut children = Vec::new();
    if let Some(moos) = &config.moos {
        children.push(frontseat_actors::translation::child_spec(
            frontseat_actors::translation::TranslationArgs {
                cfg: moos.clone(),
                vehicle: config.name.clone(),
                bus: bus.clone(),
                chaos: None,
                observer: Default::default(),
            },
            (&config.supervision.translation).into(),
        ));
    }
    let mut root = match SupervisorHandle::start("root", children, Some(&bus)).await {
        Ok(r) => r,
        Err(e) => {
            tracing::error!(error = %e, "cannot start the MOOS bridge (FrontSeatTranslation)");
            service.shutdown(SHUTDOWN_BOUND).await;
            return ExitCode::from(2);
        }
    };
    let web = if config.web.enabled {
        match frontseat_web::WebService::start(&config, &bus).await {
            Ok(w) => Some(w),
            Err(e) => {
                tracing::error!(error = %e, "cannot start the web scope");
                root.shutdown(SHUTDOWN_BOUND).await;
                service.shutdown(SHUTDOWN_BOUND).await;
                return ExitCode::from(2);
            }
        }
    } else {
        None
    };
    // READY only now: the driver actor has started and the bus is up.
    notifier.ready();
    let watchdog = notifier.watchdog_period().and_then(|period| {
        systemd::spawn_watchdog(notifier.clone(), systemd::interface_probe(&service, period))
    });
    tracing::info!(
        driver = %config.driver.name,
        frontseat = %format!("{}:{}", config.driver.basic_simulator.tcp_address, config.driver.basic_simulator.tcp_port),
        moos = config.moos.is_some(),
        interprocess = config.interprocess.enabled,
        goby3 = config.goby3.enabled,
        "frontseat interface running"
    );
    let exit = tokio::select! {
        e = service.wait() => e,
        e = root.wait() => {
            notifier.stopping();
            service.shutdown(SHUTDOWN_BOUND).await;
            e
        }
        _ = shutdown_signal() => {
            notifier.stopping();
            service.shutdown(SHUTDOWN_BOUND).await
        }
    };
    notifier.stopping();
    if let Some(w) = watchdog {
        w.abort();
    }
    if let Some(w) = web {
        w.shutdown(SHUTDOWN_BOUND).await;
    }
    root.shutdown(SHUTDOWN_BOUND).await;
    if let Some(g) = gateway {
        let _ = tokio::time::timeout(SHUTDOWN_BOUND, g.close()).await;
    }
    if let Some(g) = goby3 {
        let _ = tokio::time::timeout(SHUTDOWN_BOUND, g.close()).await;
    }
    reporter.abort();
    exit_code(&exit)
}

pub fn sim_options(config: &SimConfig) -> SimOptions {
    let scheduled_faults = config
        .faults
        .iter()
        .map(|f| ScheduledFault {
            at_s: f.at,
            fault: match f.kind {
                FaultKind::DropConnection => Fault::DropConnection,
                FaultKind::StopNav => Fault::StopNav {
                    seconds: f.seconds.unwrap_or(10.0),
                },
                FaultKind::Garbage => Fault::Garbage {
                    lines: f.lines.unwrap_or(1),
                },
                FaultKind::OversizedLine => Fault::OversizedLine,
                FaultKind::CtrlPayload => Fault::Ctrl(CtrlState::Payload),
                FaultKind::CtrlAuv => Fault::Ctrl(CtrlState::Auv),
                FaultKind::CtrlIdle => Fault::Ctrl(CtrlState::Idle),
            },
        })
        .collect();
    SimOptions {
        max_line_bytes: config.max_line_bytes,
        current_east: config.current.east,
        current_north: config.current.north,
        scheduled_faults,
        max_vehicles: config.max_vehicles,
        resume_grace: std::time::Duration::from_secs_f64(config.resume_grace_s.clamp(0.0, 3600.0)),
    }
}

pub async fn sim(config: SimConfig) -> ExitCode {
    let addr: SocketAddr = match format!("{}:{}", config.bind, config.port).parse() {
        Ok(a) => a,
        Err(_) => match format!("[{}]:{}", config.bind, config.port).parse() {
            Ok(a) => a,
            Err(e) => {
                eprintln!("bind address `{}`: {e}", config.bind);
                return ExitCode::from(2);
            }
        },
    };
    let sim = match SimServer::bind(addr, sim_options(&config)).await {
        Ok(s) => s,
        Err(e) => {
            tracing::error!(error = %e, %addr, "cannot start the simulator");
            return ExitCode::from(2);
        }
    };
    tracing::info!(addr = %sim.local_addr(), "basic frontseat simulator listening");
    let notifier = Arc::new(Notifier::from_env());
    notifier.ready();
    notifier.status(&format!("listening on {}", sim.local_addr()));
    let probe_sim = sim.clone();
    let watchdog = systemd::spawn_watchdog(notifier.clone(), move || {
        // The simulator's tasks share the runtime with this probe: answering proves it runs.
        let s = probe_sim.clone();
        async move {
            let _ = s.stats();
            true
        }
    });
    shutdown_signal().await;
    notifier.stopping();
    if let Some(w) = watchdog {
        w.abort();
    }
    sim.shutdown().await;
    tracing::info!(stats = ?sim.stats(), "simulator stopped");
    ExitCode::SUCCESS
}
