//! `frontseat demo --fleet N`: the lecture's trail example on Zenoh. One basic simulator and one
//! `frontseat interface` *process* per vehicle, started and stopped by the launcher
//! (frontseat-launch) from a launch file this writes (so `frontseat launch` can run the same
//! fleet); then, in this process, one helm per vehicle reaching its interface over Zenoh only: a
//! leader flying the homework path (the example helm) and followers keeping a V behind it from
//! the leader's node_status, received over Zenoh (frontseat_demo_helm::trail). Writes one track
//! CSV per vehicle and one SVG of all of them.
//!
//! [`fleet`] names the vehicles, [`launch_file`] writes what the launcher runs, [`flying`] flies
//! the helms; this sequences them.

mod fleet;
mod flying;
mod launch_file;

use std::process::ExitCode;
use std::time::Duration;

use tokio::sync::oneshot;

use crate::demo::DemoArgs;
use fleet::{MAX_FLEET, names};
use flying::{fly, helms_only, write_outputs};
use launch_file::{launch_config, write_launch_file, write_topside};

/// How long the interfaces may take to come up.
const UP_BOUND: Duration = Duration::from_secs(60);

/// `n` distinct free loopback ports. Every listener is held until all are taken: one dropped
/// before the next bind lets the kernel hand the same port out twice (about 1 run in 2 000 for
/// five ports here), which the launcher then refuses as a port clash.
fn free_ports(n: usize) -> std::io::Result<Vec<u16>> {
    let held = (0..n)
        .map(|_| std::net::TcpListener::bind("127.0.0.1:0"))
        .collect::<std::io::Result<Vec<_>>>()?;
    held.iter()
        .map(|l| l.local_addr().map(|a| a.port()))
        .collect()
}

pub async fn run(args: DemoArgs) -> ExitCode {
    let n = args.fleet.unwrap_or(3);
    if !(2..=MAX_FLEET).contains(&n) {
        eprintln!("--fleet must be 2 to {MAX_FLEET} vehicles (a leader and its followers)");
        return ExitCode::from(2);
    }
    if args.vehicle != crate::vehicle_kind::VehicleKind::Basic || args.record.is_some() {
        eprintln!(
            "--fleet flies basic-simulator vehicles and records nothing: drop --vehicle and --record"
        );
        return ExitCode::from(2);
    }
    if !(args.warp.is_finite() && args.warp > 0.0 && args.warp <= 100.0) {
        eprintln!("--warp must be in (0, 100] with --fleet");
        return ExitCode::from(2);
    }
    for (what, v) in [
        ("--trail-behind", args.trail_behind),
        ("--trail-side", args.trail_side),
    ] {
        if !(v.is_finite() && (0.0..=200.0).contains(&v)) {
            eprintln!("{what} must be in [0, 200] m");
            return ExitCode::from(2);
        }
    }
    if let Err(e) = std::fs::create_dir_all(&args.out) {
        eprintln!("cannot create {}: {e}", args.out.display());
        return ExitCode::from(1);
    }
    if !args.fleet_connect.is_empty() {
        return helms_only(&args, n).await;
    }
    let Ok(ports) = free_ports(n + 2) else {
        eprintln!("cannot find free loopback ports");
        return ExitCode::from(1);
    };
    let (sim_port, topside_port, zenoh_ports) = (ports[0], ports[1], &ports[2..]);
    let (cfg, slots) = launch_config(&args, n, sim_port, zenoh_ports);
    if args.web {
        if args.web_listen.parse::<std::net::SocketAddr>().is_err() {
            eprintln!("--web-listen must be an IP address and port");
            return ExitCode::from(2);
        }
        if let Err(e) = write_topside(&args, n, zenoh_ports, topside_port) {
            eprintln!("{e}");
            return ExitCode::from(1);
        }
    }
    let launch_file = match write_launch_file(&args.out, &cfg) {
        Ok(f) => f,
        Err(e) => {
            eprintln!("{e}");
            return ExitCode::from(1);
        }
    };
    let exe = match std::env::current_exe() {
        Ok(p) => p,
        Err(e) => {
            eprintln!("cannot find this binary: {e}");
            return ExitCode::from(1);
        }
    };
    eprintln!(
        "frontseat demo --fleet {n}: simulator on 127.0.0.1:{sim_port}, {n} interface processes ({}), warp {}",
        names(n).join(", "),
        args.warp
    );
    // Listening from here on: a Ctrl-C or SIGTERM while the fleet starts or flies stops the
    // launcher, which stops every vehicle process (they are in process groups of their own, so
    // a terminal's Ctrl-C does not reach them, and this process dying by the default action
    // left them running).
    let signal = crate::shutdown::shutdown_signal();
    tokio::pin!(signal);
    let (stop_tx, stop_rx) = oneshot::channel::<()>();
    let (up_tx, up_rx) = oneshot::channel();
    let file = launch_file.clone();
    let mut launcher = tokio::spawn(async move {
        frontseat_launch::run_with(
            cfg,
            &file,
            exe,
            async {
                let _ = stop_rx.await;
            },
            Some(up_tx),
        )
        .await
    });
    let up = tokio::select! {
        r = tokio::time::timeout(UP_BOUND, up_rx) => matches!(r, Ok(Ok(()))),
        _ = &mut launcher => false,
        _ = &mut signal => return stop_on_signal(stop_tx, launcher).await,
    };
    if !up {
        let _ = stop_tx.send(());
        let why = match tokio::time::timeout(Duration::from_secs(20), launcher).await {
            Ok(Ok(o)) if o.exit_code() != 0 => Some(o),
            _ => None,
        };
        match &why {
            Some(o) => eprintln!("the fleet did not come up: {o}"),
            None => {
                eprintln!("the fleet did not come up; see the [sim] and [interface-…] lines above")
            }
        }
        return ExitCode::from(why.map_or(1, |o| o.exit_code()));
    }
    let endpoints: Vec<String> = zenoh_ports
        .iter()
        .chain(args.web.then_some(topside_port).iter())
        .map(|p| format!("tcp/127.0.0.1:{p}"))
        .collect();
    let flown = tokio::select! {
        f = fly(&args, n, endpoints, &slots) => f,
        _ = &mut signal => return stop_on_signal(stop_tx, launcher).await,
    };
    if args.web && flown.is_ok() {
        eprintln!(
            "frontseat demo: fleet done; topside on http://{}/ (each vehicle's page on the next ports) — Ctrl-C to stop",
            args.web_listen
        );
        signal.await;
    }
    let _ = stop_tx.send(());
    let outcome = match tokio::time::timeout(Duration::from_secs(30), launcher).await {
        Ok(Ok(o)) => o,
        _ => frontseat_launch::Outcome::Launcher("the launcher did not stop in time".into()),
    };
    let tracks = match flown {
        Ok(t) => t,
        Err(e) => {
            eprintln!("frontseat demo --fleet: {e}");
            return ExitCode::from(1);
        }
    };
    let code = write_outputs(&args.out, &tracks);
    if outcome != frontseat_launch::Outcome::Clean {
        eprintln!("frontseat demo --fleet: the launcher ended: {outcome}");
        return ExitCode::from(outcome.exit_code().max(1));
    }
    code
}

/// A signal before the flight ended: the launcher stops every process it started; exit 130.
async fn stop_on_signal(
    stop_tx: oneshot::Sender<()>,
    launcher: tokio::task::JoinHandle<frontseat_launch::Outcome>,
) -> ExitCode {
    eprintln!("frontseat demo --fleet: stopping the fleet (signal)");
    let _ = stop_tx.send(());
    if tokio::time::timeout(Duration::from_secs(30), launcher)
        .await
        .is_err()
    {
        eprintln!("frontseat demo --fleet: the launcher did not stop within 30 s");
    }
    ExitCode::from(130)
}
