//! The composition roots of `frontseat demo`. With the basic simulator or the Bluefin (Huxley)
//! emulator over loopback TCP ([`start`]): the bus claimed for a live driver, the recorder, the
//! vehicle bound on an ephemeral port and the interface's driver pointed at it, then one root
//! supervisor over the simulator server ([`simulator::sim_child`]) and the interface's own
//! children ([`interface::children`]) — the `frontseat sim` and `frontseat interface` roots under
//! one root; the Huxley emulator runs beside that root, not under it. With a byte-link vehicle
//! ([`start_emulated`]): its emulator ([`emulators::start`]), the recorder and the interface with
//! the vehicle's real driver. The demo's helm flies on the bus given (`src/demo.rs`,
//! `src/vehicle_sim.rs`).

use std::net::SocketAddr;
use std::path::Path;

use frontseat_actors::bus::Bus;
use frontseat_actors::interface::InterfaceService;
use frontseat_actors::supervisor::SupervisorHandle;
use frontseat_config::InterfaceConfig;
use frontseat_dune::emulator::DuneOptions;
use frontseat_record::service::RecordService;
use frontseat_sim::emulator::Endpoint;
use frontseat_sim::{SimOptions, SimServer};

use super::{emulators, interface, recording, simulator};
use crate::shutdown::SHUTDOWN_BOUND;
use crate::vehicle_kind::VehicleKind;

/// The running demo: its root, the Huxley emulator beside it, its recorder.
pub struct Demo {
    root: SupervisorHandle,
    huxley: Option<frontseat_bluefin::HuxleyHandle>,
    recorder: Option<RecordService>,
    /// Where the vehicle listens.
    pub vehicle_addr: SocketAddr,
}

/// Starts the demo's processes on `bus` for `vehicle` at `warp`, recording to `record` (the
/// file, and whether to replace it) or as `cfg.record` says. `cfg`'s driver is pointed at the
/// vehicle started here. Errs with the exit code and the line to print.
pub async fn start(
    cfg: &mut InterfaceConfig,
    bus: &Bus,
    vehicle: VehicleKind,
    warp: f64,
    record: Option<(&Path, bool)>,
) -> Result<Demo, (u8, String)> {
    if let Err(held) = bus.claim(frontseat_actors::bus::BusRole::LiveDriver) {
        return Err((2, format!("the bus is already claimed by {held:?}")));
    }
    let recorder = match record {
        Some((path, force)) => recording::start_demo_recorder(bus, cfg, path, force),
        None => recording::start_recorder(bus, cfg, "demo").map_err(|e| (1, e)),
    };
    let recorder = recorder.map_err(|(code, e)| (code, format!("cannot record: {e}")))?;
    if let Some((p, _)) = record {
        eprintln!("frontseat demo: recording to {}", p.display());
    }
    let loopback = ([127, 0, 0, 1], 0).into();
    let mut children = Vec::new();
    let mut huxley = None;
    let vehicle_addr = match vehicle {
        // ArduPilot is flown by vehicle_sim::run_demo (main picks); the basic simulator stands in.
        VehicleKind::Basic
        | VehicleKind::Iver3
        | VehicleKind::WavegliderSv2
        | VehicleKind::Ardupilot
        | VehicleKind::Dune
        | VehicleKind::Ardusub => {
            let sim = SimServer::bind(loopback, SimOptions::default())
                .await
                .map_err(|e| (1, format!("cannot start the simulator: {e}")))?;
            let addr = sim.local_addr();
            cfg.driver.basic_simulator.tcp_port = addr.port();
            cfg.driver.basic_simulator.start.lat = cfg.origin.lat;
            cfg.driver.basic_simulator.start.lon = cfg.origin.lon;
            children.push(simulator::sim_child(
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
            let opts = emulators::huxley_options(
                &frontseat_config::SimConfig::default(),
                frontseat_bluefin::Refusal::None,
                warp,
            );
            let opts = frontseat_bluefin::HuxleyServerOptions {
                huxley: frontseat_bluefin::HuxleyOptions {
                    lat: cfg.origin.lat,
                    lon: cfg.origin.lon,
                    ..opts.huxley
                },
                ..opts
            };
            let h = frontseat_bluefin::HuxleyServer::bind(loopback, opts)
                .await
                .map_err(|e| (1, format!("cannot start the Huxley emulator: {e}")))?;
            cfg.driver.name = frontseat_config::BLUEFIN.into();
            cfg.driver.bluefin.huxley_tcp_port = h.local_addr().port();
            let addr = h.local_addr();
            huxley = Some(h);
            addr
        }
    };
    children.extend(interface::children(cfg, bus, Default::default()));
    let root = match SupervisorHandle::start("root", children, Some(bus)).await {
        Ok(r) => r,
        Err(e) => {
            if let Some(h) = huxley {
                h.shutdown().await;
            }
            return Err((1, format!("cannot start the demo: {e}")));
        }
    };
    Ok(Demo {
        root,
        huxley,
        recorder,
        vehicle_addr,
    })
}

impl Demo {
    /// Stops the root's children in reverse start order, then the emulator, then the recorder
    /// (so the file holds the children's last words).
    pub async fn shutdown(self) {
        self.root.shutdown(SHUTDOWN_BOUND * 3).await;
        if let Some(h) = self.huxley {
            h.shutdown().await;
        }
        recording::stop_recorder(self.recorder).await;
    }
}

/// The demo of a byte-link vehicle (`--vehicle iver3|waveglider_sv2|ardupilot|ardusub|dune`):
/// its emulator, the recorder, and the interface with that vehicle's real driver, reached over
/// a pseudo-terminal (or loopback TCP for MAVLink and DUNE).
pub struct EmulatedDemo {
    service: InterfaceService,
    running: emulators::Running,
    recorder: Option<RecordService>,
    /// Where the driver reaches the emulator.
    pub path: String,
}

/// Starts `kind`'s emulator at `warp` (a Wave Glider cruising at `cruise_speed`), points `cfg`'s
/// driver at it, then the recorder and the interface on `bus`. Errs with the line to print
/// (exit 1).
pub async fn start_emulated(
    cfg: &mut InterfaceConfig,
    bus: &Bus,
    kind: VehicleKind,
    warp: f64,
    cruise_speed: f64,
) -> Result<EmulatedDemo, String> {
    let mavlink = matches!(kind, VehicleKind::Ardupilot | VehicleKind::Ardusub);
    let origin = (cfg.origin.lat, cfg.origin.lon);
    // ArduPilot speaks MAVLink over TCP as SITL does; the serial vehicles use a pty.
    let endpoint = if mavlink || kind == VehicleKind::Dune {
        Endpoint::Tcp(SocketAddr::from(([127, 0, 0, 1], 0)))
    } else {
        Endpoint::Pty
    };
    let running = emulators::start(kind, endpoint, warp, 5, cruise_speed, origin)
        .await
        .map_err(|e| format!("cannot start the emulator on a pseudo-terminal: {e}"))?;
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
    let _ = bus.claim(frontseat_actors::bus::BusRole::LiveDriver);
    let recorder =
        recording::start_recorder(bus, cfg, "demo").map_err(|e| format!("cannot record: {e}"))?;
    let service = InterfaceService::start(cfg, bus, frontseat_drivers::BUILT_IN)
        .await
        .map_err(|e| format!("cannot start the interface: {e}"))?;
    Ok(EmulatedDemo {
        service,
        running,
        recorder,
        path,
    })
}

impl EmulatedDemo {
    /// Stops the interface, then the emulator, then the recorder.
    pub async fn shutdown(self) {
        self.service.shutdown(SHUTDOWN_BOUND).await;
        drop(self.running);
        recording::stop_recorder(self.recorder).await;
    }
}
