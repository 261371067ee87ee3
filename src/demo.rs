//! `frontseat demo`: the simulator (real TCP on an ephemeral loopback port), the interface with
//! the basic simulator driver, and the example helm, in one process with no external service.
//! `--vehicle bluefin` swaps in the Huxley emulator and the real Bluefin driver.

use std::io::{IsTerminal, Write};
use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;
use frontseat_actors::bus::Bus;
use frontseat_actors::clock::SimClock;
use frontseat_config::InterfaceConfig;
use frontseat_demo_helm::{self as demo_helm, DemoParams};

use crate::compose;
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
    /// With --fleet: send the fleet's AIS (NMEA 0183 `!AIVDM`, class B targets) to this UDP
    /// address, e.g. OpenCPN's UDP input `127.0.0.1:10110`. The vehicles get MMSIs 299000001,
    /// 299000002, ... (the leader first), from the range for simulated vehicles.
    #[arg(long, value_name = "HOST:PORT", requires = "fleet")]
    pub ais: Option<String>,
}

/// The basic simulator or the Bluefin emulator over loopback TCP (the serial vehicles' demo is
/// `vehicle_sim::run_demo`; `main` picks). The demo's root (`compose::demo`) runs the simulator
/// server, the FrontSeatInterface and (with --web) the web scope, as `frontseat sim` and
/// `frontseat interface` do; this flies the example helm on its bus.
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
    let record = args.record.as_deref().map(|p| (p, args.force));
    let demo = match compose::demo::start(&mut cfg, &bus, args.vehicle, args.warp, record).await {
        Ok(d) => d,
        Err((code, e)) => {
            eprintln!("{e}");
            return ExitCode::from(code);
        }
    };
    let vehicle_addr = demo.vehicle_addr;
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
        crate::shutdown::shutdown_signal().await;
    }
    demo.shutdown().await;

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
