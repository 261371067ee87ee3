//! `frontseat demo`: the simulator (real TCP on an ephemeral loopback port), the interface with
//! the basic simulator driver, and the example helm, in one process with no external service.
//! `--vehicle bluefin` swaps in the Huxley emulator and the real Bluefin driver.

use std::io::{IsTerminal, Write};
use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;
use frontseat_actors::bus::Bus;
use frontseat_actors::clock::SimClock;
use frontseat_actors::supervisor::SupervisorHandle;
use frontseat_config::InterfaceConfig;
use frontseat_demo_helm::{self as demo_helm, DemoParams};
use frontseat_sim::{SimOptions, SimServer};

use crate::service::SHUTDOWN_BOUND;
use crate::vehicle_kind::VehicleKind;

#[derive(Args, Debug, Clone)]
pub struct DemoArgs {
    /// Run faster than real time: simulator ticks and every interface timer speed up N times.
    #[arg(long, default_value_t = 10.0)]
    pub warp: f64,
    /// Where the track CSV and SVG go.
    #[arg(long, value_name = "DIR", default_value = "demo-out")]
    pub out: PathBuf,
    /// Seconds (simulated) of the east leg.
    #[arg(long, default_value_t = 60.0)]
    pub east: f64,
    /// Seconds (simulated) of the south leg.
    #[arg(long, default_value_t = 60.0)]
    pub south: f64,
    /// Print one status line per simulated second instead of a live line.
    #[arg(long)]
    pub lines: bool,
    /// Fly a vehicle emulator through its real driver instead of the basic simulator: bluefin,
    /// ardupilot or ardusub (loopback TCP; ardusub dives 5 m, 10 m, 5 m), iver3 or
    /// waveglider_sv2 (pseudo-terminal).
    #[arg(long, value_enum, default_value_t = VehicleKind::Basic)]
    pub vehicle: VehicleKind,
    /// Also serve the web scope and commander (on 127.0.0.1:50001 unless --web-listen).
    #[arg(long)]
    pub web: bool,
    /// Address of the web scope with --web.
    #[arg(long, value_name = "ADDR", default_value = "127.0.0.1:50001")]
    pub web_listen: String,
    /// Record every group of the run to this MCAP file (`frontseat log info FILE` reads it).
    /// An existing FILE is kept unless --force.
    #[arg(long, value_name = "FILE")]
    pub record: Option<PathBuf>,
    /// With --record: replace FILE if it exists (the new recording is renamed onto it at the end).
    #[arg(long, requires = "record")]
    pub force: bool,
    /// Fly a fleet of N vehicles (2 to 12; 3 when no number is given): one simulator, one
    /// `frontseat interface` process per vehicle (each its own Zenoh platform), a leader on the
    /// homework path and N-1 followers trailing it in a V from the leader's node_status received
    /// over Zenoh. Writes track-<vehicle>.csv per vehicle (track-leader.csv for the leader),
    /// fleet.svg and the fleet's launch file.
    #[arg(long, value_name = "N", num_args = 0..=1, default_missing_value = "3")]
    pub fleet: Option<usize>,
    /// With --fleet: how far behind the leader each pair of followers keeps. Unit: m.
    #[arg(long, value_name = "M", default_value_t = 20.0)]
    pub trail_behind: f64,
    /// With --fleet: how far to the side of the leader the followers keep (right, then left).
    /// Unit: m.
    #[arg(long, value_name = "M", default_value_t = 15.0)]
    pub trail_side: f64,
    /// With --fleet: fly only the helms, against interfaces already running elsewhere (other
    /// hosts): their Zenoh endpoints, leader first, comma-separated
    /// (`tcp/10.0.0.11:7447,tcp/10.0.0.12:7447`). Nothing is launched.
    #[arg(long, value_name = "ENDPOINTS", value_delimiter = ',')]
    pub fleet_connect: Vec<String>,
}

/// The basic simulator or the Bluefin emulator over loopback TCP (the serial vehicles' demo is
/// `vehicle_sim::run_demo`; `main` picks). One root supervisor runs the simulator server, the
/// FrontSeatInterface and (with --web) the web scope, as `frontseat sim` and `frontseat
/// interface` do; the Huxley emulator runs beside it.
pub async fn run(args: DemoArgs) -> ExitCode {
    if !(args.warp.is_finite() && args.warp > 0.0 && args.warp <= 1000.0) {
        eprintln!("--warp must be in (0, 1000]");
        return ExitCode::from(2);
    }
    let bus = Bus::new();
    let mut cfg = InterfaceConfig {
        name: "demo-auv".into(),
        sim_warp_factor: args.warp,
        ..Default::default()
    };
    cfg.interprocess.enabled = false;
    cfg.goby3.enabled = false;
    if args.web {
        cfg.web = frontseat_config::WebConfig {
            enabled: true,
            listen: args.web_listen.clone(),
            ..Default::default()
        };
    }
    if let Some(path) = &args.record {
        cfg.record = frontseat_config::RecordConfig {
            enabled: true,
            path: Some(path.display().to_string()),
            ..Default::default()
        };
    }
    if let Err(held) = bus.claim(frontseat_actors::bus::BusRole::LiveDriver) {
        eprintln!("the bus is already claimed by {held:?}");
        return ExitCode::from(2);
    }
    let recorder = match &args.record {
        Some(path) => crate::record_cmd::start_demo_recorder(&bus, &cfg, path, args.force),
        None => crate::record_cmd::start_recorder(&bus, &cfg, "demo").map_err(|e| (1, e)),
    };
    let recorder = match recorder {
        Ok(r) => r,
        Err((code, e)) => {
            eprintln!("cannot record: {e}");
            return ExitCode::from(code);
        }
    };
    if let Some(p) = &args.record {
        eprintln!("frontseat demo: recording to {}", p.display());
    }
    let loopback = ([127, 0, 0, 1], 0).into();
    let mut children = Vec::new();
    let mut huxley = None;
    let vehicle_addr = match args.vehicle {
        // ArduPilot is flown by vehicle_sim::run_demo (main picks); the basic simulator stands in.
        VehicleKind::Basic
        | VehicleKind::Iver3
        | VehicleKind::WavegliderSv2
        | VehicleKind::Ardupilot
        | VehicleKind::Dune
        | VehicleKind::Ardusub => {
            let sim = match SimServer::bind(loopback, SimOptions::default()).await {
                Ok(s) => s,
                Err(e) => {
                    eprintln!("cannot start the simulator: {e}");
                    return ExitCode::from(1);
                }
            };
            let addr = sim.local_addr();
            cfg.driver.basic_simulator.tcp_port = addr.port();
            cfg.driver.basic_simulator.start.lat = cfg.origin.lat;
            cfg.driver.basic_simulator.start.lon = cfg.origin.lon;
            children.push(crate::service::sim_child(
                Some(sim),
                addr,
                SimOptions::default(),
                (&frontseat_config::RestartConfig::default()).into(),
                Default::default(),
                Some(bus.clone()),
            ));
            addr
        }
        VehicleKind::Bluefin => {
            let opts = crate::bluefin_sim::server_options(
                &frontseat_config::SimConfig::default(),
                crate::bluefin_sim::RefusalArg::None,
                args.warp,
            );
            let opts = frontseat_bluefin::HuxleyServerOptions {
                huxley: frontseat_bluefin::HuxleyOptions {
                    lat: cfg.origin.lat,
                    lon: cfg.origin.lon,
                    ..opts.huxley
                },
                ..opts
            };
            let h = match frontseat_bluefin::HuxleyServer::bind(loopback, opts).await {
                Ok(s) => s,
                Err(e) => {
                    eprintln!("cannot start the Huxley emulator: {e}");
                    return ExitCode::from(1);
                }
            };
            cfg.driver.name = frontseat_config::BLUEFIN.into();
            cfg.driver.bluefin.huxley_tcp_port = h.local_addr().port();
            let addr = h.local_addr();
            huxley = Some(h);
            addr
        }
    };
    children.extend(crate::service::interface_children(
        &cfg,
        &bus,
        Default::default(),
    ));
    let root = match SupervisorHandle::start("root", children, Some(&bus)).await {
        Ok(r) => r,
        Err(e) => {
            eprintln!("cannot start the demo: {e}");
            if let Some(h) = huxley {
                h.shutdown().await;
            }
            return ExitCode::from(1);
        }
    };
    if args.web {
        eprintln!("frontseat demo: web scope on http://{}/", args.web_listen);
    }
    eprintln!(
        "frontseat demo: {:?} vehicle on {}, warp {}, homework path east {} s, south {} s, then northwest",
        args.vehicle, vehicle_addr, args.warp, args.east, args.south
    );
    let live = std::io::stdout().is_terminal() && !args.lines;
    let params = DemoParams {
        east_s: args.east,
        south_s: args.south,
        ..Default::default()
    };
    let report = demo_helm::run(&bus, SimClock::new(args.warp), params, |s| {
        let mut out = std::io::stdout().lock();
        if live {
            let _ = write!(out, "\r{}", s.line());
        } else {
            let _ = writeln!(out, "{}", s.line());
        }
        let _ = out.flush();
    })
    .await;
    if live {
        println!();
    }
    if args.web {
        // The page stays useful after the path (history, map, commander): keep serving.
        eprintln!(
            "frontseat demo: path done; web scope still on http://{}/ — Ctrl-C to stop",
            args.web_listen
        );
        crate::service::shutdown_signal().await;
    }
    root.shutdown(SHUTDOWN_BOUND * 3).await;
    if let Some(h) = huxley {
        h.shutdown().await;
    }
    crate::record_cmd::stop_recorder(recorder).await;

    write_outputs(&args.out, &report)
}

/// Writes track.csv and track.svg into `out`, says where, and exits 0 only for a completed path.
pub fn write_outputs(out: &std::path::Path, report: &demo_helm::DemoReport) -> ExitCode {
    if let Err(e) = std::fs::create_dir_all(out) {
        eprintln!("cannot create {}: {e}", out.display());
        return ExitCode::from(1);
    }
    let csv = out.join("track.csv");
    let svg = out.join("track.svg");
    for (path, text) in [
        (&csv, demo_helm::track_csv_with_depth(&report.track)),
        (&svg, demo_helm::track_svg(&report.track)),
    ] {
        if let Err(e) = std::fs::write(path, text) {
            eprintln!("cannot write {}: {e}", path.display());
            return ExitCode::from(1);
        }
    }
    println!(
        "track: {} points; closest approach to the start on the way back: {:.1} m; wrote {} and {}",
        report.track.len(),
        report.closest_approach_m,
        csv.display(),
        svg.display()
    );
    if report.completed {
        ExitCode::SUCCESS
    } else {
        eprintln!(
            "demo did not complete the path (reached command: {})",
            report.reached_command
        );
        ExitCode::from(1)
    }
}
