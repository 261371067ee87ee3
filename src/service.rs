//! The long-running services: `frontseat interface` and `frontseat sim`. Each one builds its
//! parts, waits for SIGTERM/SIGINT or for its own end, and drains within a bound.

use std::net::SocketAddr;
use std::process::ExitCode;
use std::sync::Arc;
use std::time::Duration;

use frontseat_actors::bus::Bus;
use frontseat_actors::interface::{InterfaceService, InterfaceSettings, ServiceExit, driver_node};
use frontseat_actors::service_child::{BoxFuture, Service, service_child_with};
use frontseat_actors::supervisor::{
    ChildFailure, ChildSpec, Policy, SupervisorHandle, TREE_PREAMBLE, render_tree,
};
use frontseat_config::{FaultKind, InterfaceConfig, SimConfig};
use frontseat_sim::{CtrlState, Fault, ScheduledFault, SimHandle, SimOptions, SimServer};

use frontseat_actors::systemd::{self, Notifier};

pub use crate::shutdown::{SHUTDOWN_BOUND, exit_code, shutdown_signal};

/// The root supervisor's children for `frontseat interface`, in start order (stopped in the
/// reverse order): the gateways first, so that the interface's first statuses are already
/// exported and its last ones still are; then the FrontSeatInterface (with its DriverActor), the
/// FrontSeatTranslation and the web scope.
///
/// Only the FrontSeatInterface is on the vehicle side (its restart limit, its driver's and
/// exit_on_error end the process). Every other child is on the helm side: restarted without end,
/// so that no helm fault, however often it repeats, ends the process and with it the vehicle link.
pub fn interface_children(
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
                    match crate::gateway_cmd::start_for_interface(&cfg, &bus).await {
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
        crate::gateway_cmd::health_child(config.goby3.health_name("goby_frontseat_interface"), bus);
    health.policy = health.policy.helm_side();
    children.push(health.noted("answers goby_coroner (goby::health::request)"));
    if config.goby3.enabled {
        children.push(
            crate::gateway_cmd::goby3_child(
                &config
                    .goby3
                    .with_client_name_for("goby_frontseat_interface"),
                &config.name,
                bus,
                crate::gateway_cmd::interface_actors(config),
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

/// `config` with every optional child of `frontseat interface` on.
fn with_every_child(mut config: InterfaceConfig) -> InterfaceConfig {
    config.interprocess.enabled = true;
    config.goby3.enabled = true;
    config.moos.get_or_insert_with(Default::default);
    config.web.enabled = true;
    config
}

/// The supervision trees `frontseat interfaces` prints, rendered from the child specs that
/// `frontseat interface` (with every optional child on), `frontseat sim` and `frontseat
/// moos-gateway` start: a child added there is a child printed here. Builds, starts nothing.
pub fn supervision_tree() -> String {
    let bus = Bus::new();
    let nodes = |c: Vec<ChildSpec>| c.iter().map(ChildSpec::node).collect::<Vec<_>>();
    let interface = interface_children(
        &with_every_child(InterfaceConfig::default()),
        &bus,
        Default::default(),
    );
    let sim = SimConfig::default();
    let sim = sim_child(
        None,
        SocketAddr::from(([127, 0, 0, 1], sim.port)),
        sim_options(&sim),
        (&sim.supervision).into(),
        Default::default(),
        None,
    )
    .noted("[supervision] of the sim config; one task per vehicle connection: a panic closes only that connection (vehicle_panics)");
    let mut out = TREE_PREAMBLE.to_string();
    out.push_str(&render_tree(
        "frontseat interface",
        "gives up only past a vehicle-side limit: exit 3 (or the child's code)",
        &nodes(interface),
    ));
    out.push_str(&render_tree(
        "frontseat sim (and the demo: these and the interface's under one root)",
        "gives up past the server's limit",
        &nodes(vec![sim]),
    ));
    out.push_str(&render_tree(
        "frontseat moos-gateway",
        "gives up past a child's limit: exit 3",
        &nodes(crate::gateway_cmd::tree_children(&bus)),
    ));
    out
}

pub async fn interface(config: InterfaceConfig) -> ExitCode {
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
    let recorder = match crate::record_cmd::start_recorder(&bus, &config, "interface") {
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
    let children = interface_children(&config, &bus, current.clone());
    let mut root = match SupervisorHandle::start("root", children, Some(&bus)).await {
        Ok(r) => r,
        Err(e) => {
            tracing::error!(error = %e, "cannot start the frontseat interface");
            reporter.abort();
            crate::record_cmd::stop_recorder(recorder).await;
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
    crate::record_cmd::stop_recorder(recorder).await;
    if let ServiceExit::ErrorState(why) = &exit {
        // Goby3's goby_frontseat_interface quits with 0 here; exit_on_error_code says otherwise.
        tracing::error!(%why, code = config.exit_on_error_code, "exit_on_error: service ended");
        return ExitCode::from(config.exit_on_error_code);
    }
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
        start_timeout: std::time::Duration::from_secs_f64(
            config.start_timeout_s.clamp(0.0, 3600.0),
        ),
        max_pending: config.max_pending.max(1),
    }
}

/// The root supervisor's child for `frontseat sim` (and the demo's embedded simulator): the
/// server, which isolates each vehicle connection inside it. `first`, when given, is a server
/// already bound (the demo needs its port before the interface starts); a restart binds the
/// port the first one got. `current` receives each started server; `embed` puts the
/// simulator's truth and fault groups on that bus.
pub fn sim_child(
    first: Option<SimHandle>,
    addr: SocketAddr,
    opts: SimOptions,
    policy: frontseat_actors::supervisor::Policy,
    current: Arc<std::sync::Mutex<Option<SimHandle>>>,
    embed: Option<Bus>,
) -> ChildSpec {
    let ctx = (
        Arc::new(std::sync::Mutex::new(first)),
        Arc::new(std::sync::Mutex::new(addr)),
        opts,
        current,
        embed,
    );
    service_child_with(
        "SimServer",
        policy,
        ctx,
        |(first, addr, opts, current, embed)| async move {
            let ready = first.lock().unwrap_or_else(|p| p.into_inner()).take();
            let sim = match ready {
                Some(s) => s,
                None => {
                    let at = *addr.lock().unwrap_or_else(|p| p.into_inner());
                    SimServer::bind(at, opts).await.map_err(|e| e.to_string())?
                }
            };
            // Port 0 asked for any port: a restart takes the same one back.
            *addr.lock().unwrap_or_else(|p| p.into_inner()) = sim.local_addr();
            *current.lock().unwrap_or_else(|p| p.into_inner()) = Some(sim.clone());
            let glue = embed
                .as_ref()
                .map(|bus| frontseat_actors::sim_glue::embed(&sim, bus));
            Ok(Box::new(SimService { sim, _glue: glue }) as Box<dyn Service>)
        },
    )
}

/// A running simulator server with its bus glue (when embedded).
struct SimService {
    sim: SimHandle,
    _glue: Option<frontseat_actors::sim_glue::EmbeddedSimulator>,
}

impl Service for SimService {
    fn ended(&mut self) -> BoxFuture<'_, Result<(), ChildFailure>> {
        Service::ended(&mut self.sim)
    }
    fn stop(self: Box<Self>, within: Duration) -> BoxFuture<'static, ()> {
        Box::new(self.sim).stop(within)
    }
}

/// What to do when the simulator cannot listen: the port and the setting that chose it.
fn sim_bind_error(addr: SocketAddr, e: &frontseat_sim::SimError) -> String {
    let in_use = matches!(e, frontseat_sim::SimError::Bind { source, .. }
        if source.kind() == std::io::ErrorKind::AddrInUse);
    if in_use {
        format!(
            "frontseat sim: cannot listen on {addr}: port {} is already in use (another `frontseat \
             sim`?). Choose another with `port` in the sim config or `--port`, and set the \
             interface's `[driver.basic_simulator] tcp_port` to match; `--port 0` takes any free port.",
            addr.port()
        )
    } else {
        format!("frontseat sim: {e} (the sim config's `bind` and `port`, or --bind/--port)")
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
    // Bound here, before the supervisor, so that a port already taken is one clear line naming the
    // port and the setting to change, not a supervisor failure.
    let first = match SimServer::bind(addr, sim_options(&config)).await {
        Ok(s) => s,
        Err(e) => {
            eprintln!("{}", sim_bind_error(addr, &e));
            return ExitCode::from(2);
        }
    };
    let current = Arc::new(std::sync::Mutex::new(None));
    let child = sim_child(
        Some(first),
        addr,
        sim_options(&config),
        (&config.supervision).into(),
        current.clone(),
        None,
    );
    let mut root = match SupervisorHandle::start("root", vec![child], None).await {
        Ok(r) => r,
        Err(e) => {
            tracing::error!(error = %e, %addr, "cannot start the simulator");
            return ExitCode::from(2);
        }
    };
    let now = || current.lock().unwrap_or_else(|p| p.into_inner()).clone();
    let listening = now().map(|s| s.local_addr()).unwrap_or(addr);
    let notifier = Arc::new(Notifier::from_env());
    notifier.ready();
    notifier.status(&format!("listening on {listening}"));
    let probe = current.clone();
    let watchdog = systemd::spawn_watchdog(notifier.clone(), move || {
        // The simulator's tasks share the runtime with this probe: answering proves it runs.
        let up = probe
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .as_ref()
            .map(|s| {
                let _ = s.stats();
            })
            .is_some();
        async move { up }
    });
    let exit = tokio::select! {
        e = root.wait() => e,
        _ = shutdown_signal() => ServiceExit::Clean,
    };
    notifier.stopping();
    if let Some(w) = watchdog {
        w.abort();
    }
    let last = now();
    root.shutdown(SHUTDOWN_BOUND * 2).await;
    if let Some(sim) = last {
        tracing::info!(stats = ?sim.stats(), "simulator stopped");
    }
    exit_code(&exit)
}

#[cfg(test)]
mod tests {
    use super::*;
    use frontseat_actors::supervisor::tree_names;

    /// A loopback port nothing listens on: bound by the system, then let go.
    fn closed_port() -> u16 {
        std::net::TcpListener::bind("127.0.0.1:0")
            .and_then(|l| l.local_addr())
            .map(|a| a.port())
            .unwrap_or(9)
    }

    /// What `frontseat interfaces` prints for `frontseat interface` is what that service
    /// starts: the printed children (in start order) are the names the root supervisor reports
    /// for the children it started, and each one's nested children are the ones it runs.
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn the_printed_tree_is_the_started_tree() {
        let printed = supervision_tree();
        let section: String = printed
            .split("# frontseat ")
            .find(|s| s.starts_with("interface\n"))
            .expect("a `frontseat interface` tree")
            .to_string();
        let names = tree_names(&section);
        let printed_children: Vec<&str> = names
            .iter()
            .filter(|(depth, _)| *depth == 1)
            .map(|(_, n)| n.as_str())
            .collect();

        // The same config as printed, every optional child on, its sockets on free loopback ports.
        let mut cfg = with_every_child(InterfaceConfig::default());
        cfg.interprocess.listen = vec!["tcp/127.0.0.1:0".into()];
        cfg.web.listen = "127.0.0.1:0".into();
        cfg.goby3.platform = format!("tree-test-{}", std::process::id());
        cfg.goby3.ip_address = "127.0.0.1".into();
        cfg.goby3.tcp_port = closed_port();
        if let Some(m) = cfg.moos.as_mut() {
            m.port = closed_port();
        }
        cfg.driver.basic_simulator.tcp_port = closed_port();
        let bus = Bus::new();
        let current = systemd::InterfaceRef::default();
        let root = SupervisorHandle::start(
            "root",
            interface_children(&cfg, &bus, current.clone()),
            Some(&bus),
        )
        .await
        .expect("the tree starts");
        let snap = root
            .snapshot(Duration::from_secs(5))
            .await
            .expect("the root answers");
        let started: Vec<&str> = snap.children.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(printed_children, started, "{printed}");

        // The interface runs one nested supervisor, which runs as many children as are printed
        // under it.
        let under_interface = names
            .iter()
            .skip_while(|(_, n)| n != "FrontSeatInterface")
            .skip(1)
            .take_while(|(depth, _)| *depth == 2)
            .count();
        let fsi = current
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .clone()
            .expect("the interface started");
        let nested = fsi.get_children();
        assert_eq!(nested.len(), 1, "the driver's supervisor");
        assert_eq!(nested[0].get_children().len(), under_interface, "{printed}");
        assert_eq!(under_interface, 1, "{printed}");
        root.shutdown(Duration::from_secs(10)).await;
    }
}
