//! `frontseat sim --vehicle iver3|waveglider_sv2|ardupilot|ardusub` (a vehicle emulator on a
//! pseudo-terminal or a loopback TCP port) and `frontseat demo --vehicle …` (the homework path
//! flown through the real driver over a real pty, or loopback TCP for ArduPilot). The emulators
//! themselves live in `frontseat_sim` and `frontseat_ardupilot`.

use std::io::{IsTerminal, Write};
use std::net::SocketAddr;
use std::process::ExitCode;

use clap::ValueEnum;
use frontseat_actors::bus::Bus;
use frontseat_actors::clock::SimClock;
use frontseat_actors::interface::InterfaceService;
use frontseat_ardupilot::emulator::{RoverOptions, RoverSession};
use frontseat_ardupilot::sub_emulator::{SubOptions, SubSession};
use frontseat_config::InterfaceConfig;
use frontseat_demo_helm::{self as demo_helm, DemoParams};
use frontseat_dune::emulator::{DuneOptions, DuneSession};
use frontseat_iver3::{IverOptions, IverSession};
use frontseat_sim::emulator::{Emulator, Endpoint};
use frontseat_waveglider_sv2::{Sv2Options, Sv2Session};

use crate::demo::DemoArgs;
use crate::service::{SHUTDOWN_BOUND, shutdown_signal};

pub use crate::vehicle_kind::VehicleKind;

/// The BackSeat TCP port of a DUNE LAUV (`etc/auv/transports.ini`).
const DUNE_BACKSEAT_PORT: u16 = 6006;

/// The DUNE demo flies its triangle at this depth (m), as an AUV would.
const DUNE_DEMO_DEPTH: f64 = 2.0;

/// Options of the vehicle emulators (ignored by the basic simulator).
#[derive(clap::Args, Debug, Clone)]
pub struct EmulatorArgs {
    /// Vehicle protocol to emulate.
    #[arg(long, value_enum, default_value_t = VehicleKind::Basic)]
    pub vehicle: VehicleKind,
    /// Serve the emulator on this loopback TCP port (serial-over-IP) instead of a new
    /// pseudo-terminal. 0 picks a free port.
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

enum Running {
    Iver(Emulator<IverSession>),
    Sv2(Emulator<Sv2Session>),
    Rover(Emulator<RoverSession>),
    Dune(Emulator<DuneSession>),
    Sub(Emulator<SubSession>),
}

impl Running {
    fn where_(&self) -> String {
        let (p, a) = match self {
            Running::Iver(e) => (e.pty_path().map(|p| p.display().to_string()), e.tcp_addr()),
            Running::Sv2(e) => (e.pty_path().map(|p| p.display().to_string()), e.tcp_addr()),
            Running::Rover(e) => (e.pty_path().map(|p| p.display().to_string()), e.tcp_addr()),
            Running::Dune(e) => (e.pty_path().map(|p| p.display().to_string()), e.tcp_addr()),
            Running::Sub(e) => (e.pty_path().map(|p| p.display().to_string()), e.tcp_addr()),
        };
        p.or(a.map(|a| a.to_string())).unwrap_or_default()
    }
}

async fn start(
    kind: VehicleKind,
    endpoint: Endpoint,
    warp: f64,
    rh: i32,
    cruise_speed: f64,
    origin: (f64, f64),
) -> std::io::Result<Running> {
    Ok(match kind {
        // The Huxley emulator is a TCP server of its own (bluefin_sim.rs), not a byte-link session.
        VehicleKind::Bluefin => {
            return Err(std::io::Error::other(
                "the Bluefin emulator is started by bluefin_sim",
            ));
        }
        VehicleKind::Iver3 | VehicleKind::Basic => Running::Iver(
            Emulator::start(
                IverSession::new(IverOptions {
                    lat: origin.0,
                    lon: origin.1,
                    remote_helm_version_major: rh,
                    ..Default::default()
                }),
                endpoint,
                warp,
            )
            .await?,
        ),
        VehicleKind::Ardupilot => Running::Rover(
            Emulator::start(
                RoverSession::new(RoverOptions {
                    lat: origin.0,
                    lon: origin.1,
                    ..Default::default()
                }),
                endpoint,
                warp,
            )
            .await?,
        ),
        VehicleKind::Dune => Running::Dune(
            Emulator::start(
                DuneSession::new(DuneOptions {
                    lat: origin.0,
                    lon: origin.1,
                    ..Default::default()
                }),
                endpoint,
                warp,
            )
            .await?,
        ),
        VehicleKind::Ardusub => Running::Sub(
            Emulator::start(
                SubSession::new(SubOptions {
                    lat: origin.0,
                    lon: origin.1,
                    ..Default::default()
                }),
                endpoint,
                warp,
            )
            .await?,
        ),
        VehicleKind::WavegliderSv2 => Running::Sv2(
            Emulator::start(
                Sv2Session::new(Sv2Options {
                    lat: origin.0,
                    lon: origin.1,
                    cruise_speed,
                    ..Default::default()
                }),
                endpoint,
                warp,
            )
            .await?,
        ),
    })
}

/// `frontseat sim --vehicle iver3|waveglider_sv2`: prints where the driver connects, runs until
/// SIGINT/SIGTERM.
pub async fn run_emulator(args: EmulatorArgs) -> ExitCode {
    if !(args.emulator_warp.is_finite() && args.emulator_warp > 0.0 && args.emulator_warp <= 1000.0)
    {
        eprintln!("--emulator-warp must be in (0, 1000]");
        return ExitCode::from(2);
    }
    let endpoint = match args.tcp {
        Some(port) => Endpoint::Tcp(SocketAddr::from(([127, 0, 0, 1], port))),
        // A DUNE vehicle's BackSeat server is TCP, on 6006 as on an LAUV.
        None if args.vehicle == VehicleKind::Dune => {
            Endpoint::Tcp(SocketAddr::from(([127, 0, 0, 1], DUNE_BACKSEAT_PORT)))
        }
        None => Endpoint::Pty,
    };
    let origin = (
        frontseat_config::DEFAULT_ORIGIN_LAT,
        frontseat_config::DEFAULT_ORIGIN_LON,
    );
    let running = match start(
        args.vehicle,
        endpoint,
        args.emulator_warp,
        args.remote_helm_version,
        1.5,
        origin,
    )
    .await
    {
        Ok(r) => r,
        Err(e) => {
            eprintln!("cannot start the {:?} emulator: {e}", args.vehicle);
            return ExitCode::from(1);
        }
    };
    // The one line a user or script needs: where the driver connects.
    println!("{}", running.where_());
    let _ = std::io::stdout().flush();
    tracing::info!(vehicle = ?args.vehicle, at = %running.where_(), "vehicle emulator running");
    shutdown_signal().await;
    ExitCode::SUCCESS
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
    let origin = (cfg.origin.lat, cfg.origin.lon);
    // ArduPilot speaks MAVLink over TCP as SITL does; the serial vehicles use a pty.
    let endpoint = if mavlink || kind == VehicleKind::Dune {
        Endpoint::Tcp(SocketAddr::from(([127, 0, 0, 1], 0)))
    } else {
        Endpoint::Pty
    };
    let running = match start(kind, endpoint, args.warp, 5, params.speed, origin).await {
        Ok(r) => r,
        Err(e) => {
            eprintln!("cannot start the emulator on a pseudo-terminal: {e}");
            return ExitCode::from(1);
        }
    };
    let path = running.where_();
    match kind {
        VehicleKind::Iver3 | VehicleKind::Basic => {
            cfg.driver.name = frontseat_config::IVER3.into();
            cfg.driver.iver3.serial_port = path.clone();
            cfg.driver.iver3.remote_helm_version_major = Some(5);
        }
        VehicleKind::WavegliderSv2 => {
            cfg.driver.name = frontseat_config::WAVEGLIDER_SV2.into();
            cfg.driver.waveglider_sv2.pm_serial_port = path.clone();
            // The glider's own position is the only navigation this demo has.
            cfg.driver.waveglider_sv2.publish_navigation = true;
        }
        VehicleKind::Ardupilot => {
            cfg.driver.name = frontseat_config::ARDUPILOT.into();
            cfg.driver.ardupilot.address = format!("tcpout:{path}");
            // The demo plays the pilot too: it arms and selects GUIDED through the extension.
            cfg.driver.ardupilot.allow_mode_commands = true;
        }
        VehicleKind::Dune => {
            cfg.driver.name = frontseat_config::DUNE.into();
            let (host, port) = path.rsplit_once(':').unwrap_or((path.as_str(), "0"));
            cfg.driver.dune.address = host.to_string();
            cfg.driver.dune.port = port.parse().unwrap_or_default();
            cfg.driver.dune.vehicle_imc_id = DuneOptions::default().imc_id;
        }
        VehicleKind::Ardusub => {
            cfg.driver.name = frontseat_config::ARDUPILOT.into();
            cfg.driver.ardupilot.vehicle = frontseat_config::ArdupilotVehicle::Sub;
            cfg.driver.ardupilot.address = format!("tcpout:{path}");
            cfg.driver.ardupilot.allow_mode_commands = true;
            // The emulated BlueROV2 has no RC: its pilot-input failsafe disarms it 3 s after
            // the last MANUAL_CONTROL unless we feed it (the documented choice for a Sub
            // without a topside joystick).
            cfg.driver.ardupilot.pilot_input_keepalive = true;
        }
        // Never reached: `start` refuses Bluefin, and demo.rs flies it itself.
        VehicleKind::Bluefin => {}
    }
    if let Some(p) = &args.record {
        cfg.record = frontseat_config::RecordConfig {
            enabled: true,
            path: Some(p.display().to_string()),
            ..Default::default()
        };
    }
    let bus = Bus::new();
    let _ = bus.claim(frontseat_actors::bus::BusRole::LiveDriver);
    let recorder = match crate::record_cmd::start_recorder(&bus, &cfg, "demo") {
        Ok(r) => r,
        Err(e) => {
            eprintln!("cannot record: {e}");
            return ExitCode::from(1);
        }
    };
    let service = match InterfaceService::start(&cfg, &bus, frontseat_drivers::BUILT_IN).await {
        Ok(s) => s,
        Err(e) => {
            eprintln!("cannot start the interface: {e}");
            return ExitCode::from(1);
        }
    };
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
    service.shutdown(SHUTDOWN_BOUND).await;
    drop(running);
    crate::record_cmd::stop_recorder(recorder).await;

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
