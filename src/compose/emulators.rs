//! The composition roots of `frontseat sim --vehicle <v>`: a vehicle's emulator instead of the
//! basic simulator — the Huxley emulator (Bluefin) as a TCP server of its own, the serial,
//! MAVLink and DUNE emulators on a pseudo-terminal or a loopback TCP port. None runs under a
//! supervisor: each is one server that ends with the process. The emulators themselves live in
//! `frontseat_sim` and the vehicles' crates; the demo starts them through [`start`].

use std::io::Write;
use std::net::SocketAddr;
use std::process::ExitCode;

use frontseat_ardupilot::emulator::{RoverOptions, RoverSession};
use frontseat_ardupilot::sub_emulator::{SubOptions, SubSession};
use frontseat_bluefin::{HuxleyOptions, HuxleyServer, HuxleyServerOptions, Refusal};
use frontseat_config::SimConfig;
use frontseat_dune::emulator::{DuneOptions, DuneSession};
use frontseat_iver3::{IverOptions, IverSession};
use frontseat_sim::emulator::{Emulator, Endpoint};
use frontseat_waveglider_sv2::{Sv2Options, Sv2Session};

use crate::shutdown::shutdown_signal;
use crate::vehicle_kind::VehicleKind;

/// The BackSeat TCP port of a DUNE LAUV (`etc/auv/transports.ini`).
const DUNE_BACKSEAT_PORT: u16 = 6006;

/// A started emulator of one of the byte-link vehicles: where its driver connects, and the
/// emulator, which stops when this is dropped.
pub struct Running {
    at: String,
    _emulator: Box<dyn Send>,
}

impl Running {
    fn new<S: frontseat_sim::emulator::Session>(e: Emulator<S>) -> Self {
        let at = e
            .pty_path()
            .map(|p| p.display().to_string())
            .or(e.tcp_addr().map(|a| a.to_string()))
            .unwrap_or_default();
        Self {
            at,
            _emulator: Box::new(e),
        }
    }

    /// Where its driver connects: the pseudo-terminal's path, or the TCP address.
    pub fn where_(&self) -> String {
        self.at.clone()
    }
}

/// Starts `kind`'s emulator on `endpoint` at `warp`, starting at `origin` (lat, lon); `rh` is the
/// Iver3's Remote Helm major version, `cruise_speed` the Wave Glider's.
pub async fn start(
    kind: VehicleKind,
    endpoint: Endpoint,
    warp: f64,
    rh: i32,
    cruise_speed: f64,
    origin: (f64, f64),
) -> std::io::Result<Running> {
    let (lat, lon) = origin;
    match kind {
        // The Huxley emulator is a TCP server of its own (serve_huxley), not a byte-link session.
        VehicleKind::Bluefin => Err(std::io::Error::other(
            "the Bluefin emulator is started by bluefin_sim",
        )),
        VehicleKind::Iver3 | VehicleKind::Basic => {
            let options = IverOptions {
                lat,
                lon,
                remote_helm_version_major: rh,
                ..Default::default()
            };
            started(IverSession::new(options), endpoint, warp).await
        }
        VehicleKind::Ardupilot => {
            let options = RoverOptions {
                lat,
                lon,
                ..Default::default()
            };
            started(RoverSession::new(options), endpoint, warp).await
        }
        VehicleKind::Dune => {
            let options = DuneOptions {
                lat,
                lon,
                ..Default::default()
            };
            started(DuneSession::new(options), endpoint, warp).await
        }
        VehicleKind::Ardusub => {
            let options = SubOptions {
                lat,
                lon,
                ..Default::default()
            };
            started(SubSession::new(options), endpoint, warp).await
        }
        VehicleKind::WavegliderSv2 => {
            let options = Sv2Options {
                lat,
                lon,
                cruise_speed,
                ..Default::default()
            };
            started(Sv2Session::new(options), endpoint, warp).await
        }
    }
}

async fn started<S: frontseat_sim::emulator::Session>(
    session: S,
    endpoint: Endpoint,
    warp: f64,
) -> std::io::Result<Running> {
    Ok(Running::new(
        Emulator::start(session, endpoint, warp).await?,
    ))
}

/// `frontseat sim --vehicle iver3|waveglider_sv2|ardupilot|ardusub|dune`: starts the emulator
/// (on `tcp`, or a pseudo-terminal; DUNE on its BackSeat port), prints where the driver connects,
/// runs until SIGINT/SIGTERM.
pub async fn run(
    vehicle: VehicleKind,
    tcp: Option<u16>,
    warp: f64,
    remote_helm_version: i32,
) -> ExitCode {
    let endpoint = match tcp {
        Some(port) => Endpoint::Tcp(SocketAddr::from(([127, 0, 0, 1], port))),
        // A DUNE vehicle's BackSeat server is TCP, on 6006 as on an LAUV.
        None if vehicle == VehicleKind::Dune => {
            Endpoint::Tcp(SocketAddr::from(([127, 0, 0, 1], DUNE_BACKSEAT_PORT)))
        }
        None => Endpoint::Pty,
    };
    let origin = (
        frontseat_config::DEFAULT_ORIGIN_LAT,
        frontseat_config::DEFAULT_ORIGIN_LON,
    );
    let running = match start(vehicle, endpoint, warp, remote_helm_version, 1.5, origin).await {
        Ok(r) => r,
        Err(e) => {
            eprintln!("cannot start the {:?} emulator: {e}", vehicle);
            return ExitCode::from(1);
        }
    };
    // The one line a user or script needs: where the driver connects.
    println!("{}", running.where_());
    let _ = std::io::stdout().flush();
    tracing::info!(vehicle = ?vehicle, at = %running.where_(), "vehicle emulator running");
    shutdown_signal().await;
    ExitCode::SUCCESS
}

/// The Huxley emulator's options from the sim config: its line bound, vehicle count and current.
pub fn huxley_options(config: &SimConfig, refusal: Refusal, warp: f64) -> HuxleyServerOptions {
    HuxleyServerOptions {
        huxley: HuxleyOptions {
            refusal,
            current: (config.current.east, config.current.north),
            ..Default::default()
        },
        warp,
        max_line_bytes: config.max_line_bytes,
        max_vehicles: config.max_vehicles,
    }
}

/// `frontseat sim --vehicle bluefin`: the Huxley emulator on the payload port (29500 unless
/// `port`), with the sim config's bind address, until SIGINT/SIGTERM.
pub async fn serve_huxley(
    config: SimConfig,
    port: Option<u16>,
    refusal: Refusal,
    warp: f64,
) -> ExitCode {
    let port = port.unwrap_or(frontseat_bluefin::DEFAULT_PORT);
    let addr: SocketAddr = match format!("{}:{port}", config.bind)
        .parse()
        .or_else(|_| format!("[{}]:{port}", config.bind).parse())
    {
        Ok(a) => a,
        Err(e) => {
            eprintln!("bind address `{}`: {e}", config.bind);
            return ExitCode::from(2);
        }
    };
    let server = match HuxleyServer::bind(addr, huxley_options(&config, refusal, warp)).await {
        Ok(s) => s,
        Err(e) => {
            tracing::error!(error = %e, %addr, "cannot start the Huxley emulator");
            return ExitCode::from(2);
        }
    };
    tracing::info!(addr = %server.local_addr(), ?refusal, warp, "Bluefin Huxley emulator listening");
    shutdown_signal().await;
    server.shutdown().await;
    tracing::info!(stats = ?server.stats(), "Huxley emulator stopped");
    ExitCode::SUCCESS
}
