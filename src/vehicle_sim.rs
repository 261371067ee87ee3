//! `frontseat sim --vehicle iver3|waveglider_sv2|ardupilot|ardusub` (a vehicle emulator on a
//! pseudo-terminal or a loopback TCP port) and `frontseat demo --vehicle …` (the homework path
//! flown through the real driver over a real pty, or loopback TCP for ArduPilot): their options,
//! and the demo's flying. What each starts is in `compose::emulators` and `compose::demo`.

use std::io::{IsTerminal, Write};
use std::process::ExitCode;

use clap::ValueEnum;
use frontseat_actors::bus::Bus;
use frontseat_actors::clock::SimClock;
use frontseat_config::InterfaceConfig;
use frontseat_demo_helm::{self as demo_helm, DemoParams};

use crate::compose;
use crate::demo::DemoArgs;

pub use crate::vehicle_kind::VehicleKind;

/// The DUNE demo flies its triangle at this depth (m), as an AUV would.
const DUNE_DEMO_DEPTH: f64 = 2.0;

/// Options of the vehicle emulators (ignored by the basic simulator).
#[derive(clap::Args, Debug, Clone)]
pub struct EmulatorArgs {
    /// Vehicle protocol to emulate.
    #[arg(long, value_enum, default_value_t = VehicleKind::Basic)]
    pub vehicle: VehicleKind,
    /// Serve the emulator on this loopback TCP port. For iver3, waveglider_sv2, ardupilot and
    /// ardusub: serial-over-IP instead of a new pseudo-terminal; for dune: its BackSeat port
    /// instead of 6006. 0 picks a free port. (bluefin takes `--port`; the basic simulator, its
    /// config's port.)
    #[arg(long, value_name = "PORT")]
    pub tcp: Option<u16>,
    /// Iver3: Remote Helm major version (below 5 $OMS depth is feet).
    #[arg(long, default_value_t = 5)]
    pub remote_helm_version: i32,
    /// Run simulated time this many times faster.
    #[arg(long = "emulator-warp", default_value_t = 1.0)]
    pub emulator_warp: f64,
    /// Bluefin: how the emulated Huxley answers commands.
    #[arg(long, value_enum, default_value_t = crate::bluefin_sim::RefusalArg::None)]
    pub refusal: crate::bluefin_sim::RefusalArg,
}

/// `frontseat sim --vehicle iver3|waveglider_sv2`: prints where the driver connects, runs until
/// SIGINT/SIGTERM.
pub async fn run_emulator(args: EmulatorArgs) -> ExitCode {
    if !(args.emulator_warp.is_finite() && args.emulator_warp > 0.0 && args.emulator_warp <= 1000.0)
    {
        eprintln!("--emulator-warp must be in (0, 1000]");
        return ExitCode::from(2);
    }
    compose::emulators::run(
        args.vehicle,
        args.tcp,
        args.emulator_warp,
        args.remote_helm_version,
    )
    .await
}

/// `frontseat demo --vehicle iver3|waveglider_sv2`.
pub async fn run_demo(args: DemoArgs, kind: VehicleKind) -> ExitCode {
    if !(args.warp.is_finite() && args.warp > 0.0 && args.warp <= 1000.0) {
        eprintln!("--warp must be in (0, 1000]");
        return ExitCode::from(2);
    }
    let mavlink = matches!(kind, VehicleKind::Ardupilot | VehicleKind::Ardusub);
    let params = DemoParams {
        east_s: args.east,
        south_s: args.south,
        // The Sub dives: 5 m on the first leg, 10 m on the second, back to 5 m, at the 0.5 m/s
        // ArduSub's SITL was measured at; the DUNE LAUV flies the triangle at one depth.
        depths: match kind {
            VehicleKind::Ardusub => [5.0, 10.0, 5.0],
            VehicleKind::Dune => [DUNE_DEMO_DEPTH; 3],
            _ => [0.0; 3],
        },
        speed: if kind == VehicleKind::Ardusub {
            0.5
        } else {
            DemoParams::default().speed
        },
        ..Default::default()
    };
    let mut cfg = InterfaceConfig {
        name: format!(
            "demo-{}",
            kind.to_possible_value()
                .map(|v| v.get_name().to_string())
                .unwrap_or_default()
        ),
        sim_warp_factor: args.warp,
        ..Default::default()
    };
    if let Some(p) = &args.record {
        cfg.record = frontseat_config::RecordConfig {
            enabled: true,
            path: Some(p.display().to_string()),
            ..Default::default()
        };
    }
    let bus = Bus::new();
    let demo =
        match compose::demo::start_emulated(&mut cfg, &bus, kind, args.warp, params.speed).await {
            Ok(d) => d,
            Err(e) => {
                eprintln!("{e}");
                return ExitCode::from(1);
            }
        };
    let path = demo.path.clone();
    let pilot = mavlink.then(|| {
        let bus = bus.clone();
        tokio::spawn(async move { ardupilot_pilot(&bus).await })
    });
    eprintln!(
        "frontseat demo: {:?} emulator on {path}, driver {}, warp {}, homework path east {} s, south {} s, then northwest",
        kind, cfg.driver.name, args.warp, args.east, args.south
    );
    let live = std::io::stdout().is_terminal() && !args.lines;
    let report = demo_helm::run(&bus, SimClock::new(args.warp), params.clone(), |s| {
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
    if let Some(p) = pilot {
        p.abort();
    }
    demo.shutdown().await;

    if matches!(kind, VehicleKind::Ardusub | VehicleKind::Dune) {
        // The depth track's figures (the ArduSub and DUNE guide pages report them).
        for f in demo_helm::depth_figures(&report.track, &params) {
            let secs = |v: Option<f64>| v.map_or("never".to_string(), |s| format!("{s:.1} s"));
            println!(
                "depth {:<9} {:5.1} m → {:4.1} m: within 0.3 m after {}, overshoot {:.2} m; heading within 5° after {}, then at most {:.1}° off while diving",
                f.leg.name(),
                f.start_m,
                f.asked_m,
                secs(f.time_to_depth_s),
                f.overshoot_m,
                secs(f.time_to_heading_s),
                f.heading_error_diving_deg
            );
        }
    }
    crate::demo::write_outputs(&args.out, &report)
}

/// The person at the ground station of the ArduPilot demo: once the vehicle's navigation is
/// ready, arm and select GUIDED through the ArduPilot CommandRequest extension (the interface
/// never does either by itself). Retries until both are accepted; bounded by the demo.
pub async fn ardupilot_pilot(bus: &Bus) {
    use frontseat_actors::bus::Undeliverable;
    use frontseat_actors::ports::{ArdupilotPilotInbox, ArdupilotPilotPorts};
    use frontseat_actors::proto::frontseat::protobuf::ardupilot::{
        ArdupilotCommand, CommandRequest, ardupilot_command::Action,
    };
    let (tx, mut responses) = tokio::sync::mpsc::unbounded_channel();
    let _subs = ArdupilotPilotInbox::subscribe_all(bus, "ardupilot_pilot", 64, move |m| {
        let ArdupilotPilotInbox::CommandResponse(env) = m;
        tx.send(env).map_err(|_| Undeliverable)
    });
    let ports = ArdupilotPilotPorts::new(bus);
    let mut id = 90_000;
    for action in [Action::Arm, Action::Guided] {
        loop {
            id += 1;
            ports.publish_ardupilot_command_request(CommandRequest {
                response_requested: Some(true),
                request_id: Some(id),
                ardupilot_command: Some(ArdupilotCommand {
                    action: Some(action as i32),
                }),
                ..Default::default()
            });
            let answer = tokio::time::timeout(std::time::Duration::from_secs(5), async {
                while let Some(env) = responses.recv().await {
                    if env.msg.request_id == Some(id) {
                        return env.msg.request_successful();
                    }
                }
                false
            })
            .await;
            if answer == Ok(true) {
                tracing::info!(?action, "pilot: accepted");
                break;
            }
            tracing::info!(?action, "pilot: not yet (navigation not ready?); retrying");
            tokio::time::sleep(std::time::Duration::from_millis(200)).await;
        }
    }
}
