//! The composition root of `frontseat sim` (the basic simulator): one root supervisor over the
//! simulator server, which isolates each vehicle connection inside it; the port bound before the
//! supervisor so that a port in use is one clear line; systemd's READY, STATUS and watchdog.
//! [`sim_child`] is also the demo's embedded simulator.

use std::net::SocketAddr;
use std::process::ExitCode;
use std::sync::Arc;
use std::time::Duration;

use frontseat_actors::bus::Bus;
use frontseat_actors::interface::ServiceExit;
use frontseat_actors::service_child::{BoxFuture, Service, service_child_with};
use frontseat_actors::supervisor::{ChildFailure, ChildSpec, SupervisorHandle};
use frontseat_actors::systemd::{self, Notifier};
use frontseat_config::{FaultKind, SimConfig};
use frontseat_sim::{CtrlState, Fault, ScheduledFault, SimHandle, SimOptions, SimServer};

use crate::shutdown::{SHUTDOWN_BOUND, exit_code, shutdown_signal};

/// The root supervisor's children for `frontseat sim`: the server alone. `first` is the server
/// [`run`] bound already; `current` receives each started one.
pub(super) fn children(
    first: Option<SimHandle>,
    addr: SocketAddr,
    config: &SimConfig,
    current: Arc<std::sync::Mutex<Option<SimHandle>>>,
) -> Vec<ChildSpec> {
    vec![
        sim_child(
            first,
            addr,
            sim_options(config),
            (&config.supervision).into(),
            current,
            None,
        )
        .noted("[supervision] of the sim config; one task per vehicle connection: a panic closes only that connection (vehicle_panics)"),
    ]
}

/// `frontseat sim`'s children as `frontseat interfaces` prints them: the default config's.
pub(super) fn tree_children() -> Vec<ChildSpec> {
    let sim = SimConfig::default();
    children(
        None,
        SocketAddr::from(([127, 0, 0, 1], sim.port)),
        &sim,
        Default::default(),
    )
}

/// The server's options from the sim config: its bounds, current and scheduled faults.
fn sim_options(config: &SimConfig) -> SimOptions {
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

/// `frontseat sim`: runs until SIGTERM/SIGINT, or until its root supervisor gives up on the
/// server.
pub async fn run(config: SimConfig) -> ExitCode {
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
    let children = children(Some(first), addr, &config, current.clone());
    let mut root = match SupervisorHandle::start("root", children, None).await {
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
