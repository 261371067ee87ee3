//! The vehicle families `frontseat chaos --vehicle <family>` runs: for each, its emulator (the
//! one `frontseat sim --vehicle` starts, through the vehicle crate's public API), where its real
//! driver is pointed (at the chaos link in front of the emulator), how long a silence it must
//! notice, which faults it takes, and how many commands reached the vehicle — the count the
//! command-gate invariant watches. The vehicle's own fault hooks (refusing commands, changing
//! mode on its own) are called here.

use std::net::SocketAddr;

use frontseat_ardupilot::dialect::MavResult;
use frontseat_ardupilot::emulator::{RoverOptions, RoverSession, SubOptions, SubSession};
use frontseat_ardupilot::modes;
use frontseat_bluefin::{HuxleyHandle, HuxleyServer};
use frontseat_config::InterfaceConfig;
use frontseat_dune::emulator::{DuneOptions, DuneSession};
use frontseat_iver3::{IverOptions, IverSession};
use frontseat_sim::emulator::{Emulator, Endpoint};
use frontseat_waveglider_sv2::{Sv2Options, Sv2Session};

use crate::options::ChaosHarnessError;
use crate::plan::FaultKind;

/// A vehicle family the harness can run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Family {
    Bluefin,
    Iver3,
    WavegliderSv2,
    /// ArduPilot Rover (motorboat frame) over MAVLink 2.
    Ardupilot,
    /// ArduSub (BlueROV2) over MAVLink 2.
    Ardusub,
    Dune,
}

impl Family {
    pub const ALL: [Family; 6] = [
        Family::Bluefin,
        Family::Iver3,
        Family::WavegliderSv2,
        Family::Ardupilot,
        Family::Ardusub,
        Family::Dune,
    ];

    /// The name `--vehicle` takes (as `frontseat sim --vehicle`).
    pub fn key(self) -> &'static str {
        match self {
            Family::Bluefin => "bluefin",
            Family::Iver3 => "iver3",
            Family::WavegliderSv2 => "waveglider_sv2",
            Family::Ardupilot => "ardupilot",
            Family::Ardusub => "ardusub",
            Family::Dune => "dune",
        }
    }

    pub fn from_key(key: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|f| f.key() == key)
    }

    /// The faults this family is put through: the driver's crashes, the link's faults in the
    /// vehicle's protocol, the helm side's, and the vehicle's own where its emulator has hooks.
    pub fn kinds(self) -> Vec<FaultKind> {
        let mut k = vec![
            FaultKind::DriverPanic,
            FaultKind::DriverKill,
            FaultKind::LinkDrop,
            FaultKind::LinkGarbage,
            FaultKind::TruncatedFrame,
            FaultKind::SilentVehicle,
            FaultKind::SlowLink,
            FaultKind::HelmPark,
            FaultKind::StalledSubscriber,
        ];
        if matches!(self, Family::Dune | Family::Ardupilot | Family::Ardusub) {
            k.extend([FaultKind::VehicleRefuses, FaultKind::VehicleModeChange]);
        }
        k
    }

    /// A line the bytes the driver writes are counted by, for families whose emulator does not
    /// count the commands it gets.
    pub(crate) fn command_marker(self) -> Option<&'static [u8]> {
        match self {
            Family::Bluefin => Some(b"$BPRMB"),
            _ => None,
        }
    }

    /// The bytes a frame of the vehicle's protocol starts with: the garbage and truncated frames
    /// are single frames cut from the vehicle's stream at them (so no complete old frame is
    /// replayed beside the broken one).
    pub(crate) fn frame_start(self) -> &'static [u8] {
        match self {
            Family::Bluefin | Family::Iver3 => b"$",
            Family::WavegliderSv2 => &[0x7E],
            // MAVLink 2's STX.
            Family::Ardupilot | Family::Ardusub => &[0xFD],
            // IMC's sync number 0xFE54, little-endian as the emulator writes it.
            Family::Dune => &[0x54, 0xFE],
        }
    }

    /// Points `config`'s driver at `addr` (the chaos link) with short reconnect delays.
    pub(crate) fn point_driver(self, config: &mut InterfaceConfig, addr: SocketAddr) {
        let host = addr.ip().to_string();
        let port = addr.port();
        let d = &mut config.driver;
        match self {
            Family::Bluefin => {
                d.name = frontseat_config::BLUEFIN.into();
                d.bluefin.huxley_tcp_address = host;
                d.bluefin.huxley_tcp_port = port;
                d.bluefin.reconnect_interval = 1;
            }
            Family::Iver3 => {
                d.name = frontseat_config::IVER3.into();
                d.iver3.remote_helm_version_major = Some(5);
                let l = &mut d.iver3.link;
                l.transport = frontseat_config::TransportKind::Tcp;
                (l.tcp_address, l.tcp_port) = (host, port);
                (l.reconnect_initial_ms, l.reconnect_max_ms) = (10, 100);
            }
            Family::WavegliderSv2 => {
                d.name = frontseat_config::WAVEGLIDER_SV2.into();
                // The glider's own position is the only navigation it has here.
                d.waveglider_sv2.publish_navigation = true;
                let l = &mut d.waveglider_sv2.link;
                l.transport = frontseat_config::TransportKind::Tcp;
                (l.tcp_address, l.tcp_port) = (host, port);
                (l.reconnect_initial_ms, l.reconnect_max_ms) = (10, 100);
            }
            Family::Ardupilot | Family::Ardusub => {
                d.name = frontseat_config::ARDUPILOT.into();
                let a = &mut d.ardupilot;
                a.address = format!("tcpout:{host}:{port}");
                // The harness's pilot arms and selects GUIDED through the extension, as the
                // person at the ground station does (the driver never does either by itself).
                a.allow_mode_commands = true;
                (a.reconnect_initial_ms, a.reconnect_max_ms) = (10, 100);
                if self == Family::Ardusub {
                    a.vehicle = frontseat_config::ArdupilotVehicle::Sub;
                    // No RC: the Sub's pilot-input failsafe disarms it 3 s after the last
                    // MANUAL_CONTROL unless we feed it (as the demo does).
                    a.pilot_input_keepalive = true;
                }
            }
            Family::Dune => {
                d.name = frontseat_config::DUNE.into();
                d.dune.address = host;
                d.dune.port = port;
                d.dune.vehicle_imc_id = DuneOptions::default().imc_id;
                (d.dune.reconnect_initial_ms, d.dune.reconnect_max_ms) = (10, 100);
            }
        }
    }

    /// The driver's bound for a silent vehicle (simulated seconds): a silence drawn around it
    /// is sometimes shorter, sometimes longer.
    pub(crate) fn silence_timeout(self, config: &InterfaceConfig) -> f64 {
        let d = &config.driver;
        match self {
            Family::Bluefin => f64::from(d.bluefin.allow_missing_nav_interval),
            Family::Iver3 => d.iver3.providing_data_timeout,
            Family::WavegliderSv2 => d.waveglider_sv2.providing_data_timeout,
            Family::Ardupilot | Family::Ardusub => d.ardupilot.heartbeat_timeout,
            Family::Dune => d.dune.vehicle_state_timeout.max(d.dune.navigation_timeout),
        }
    }

    /// Whether a pilot must arm the vehicle and select GUIDED before the backseat commands it.
    pub(crate) fn needs_pilot(self) -> bool {
        matches!(self, Family::Ardupilot | Family::Ardusub)
    }
}

/// A family's emulator, running on a loopback TCP port.
pub(crate) enum Vehicle {
    Bluefin(HuxleyHandle),
    Iver3(Emulator<IverSession>),
    WavegliderSv2(Emulator<Sv2Session>),
    Rover(Emulator<RoverSession>),
    Sub(Emulator<SubSession>),
    Dune(Emulator<DuneSession>),
}

impl Vehicle {
    /// Starts `family`'s emulator at `warp` at the config's origin.
    pub(crate) async fn start(
        family: Family,
        config: &InterfaceConfig,
    ) -> Result<Self, ChaosHarnessError> {
        let warp = config.sim_warp_factor;
        let (lat, lon) = (config.origin.lat, config.origin.lon);
        let tcp = Endpoint::Tcp(SocketAddr::from(([127, 0, 0, 1], 0)));
        let io = |e: std::io::Error| ChaosHarnessError::Vehicle(e.to_string());
        Ok(match family {
            Family::Bluefin => {
                let opts = frontseat_bluefin::HuxleyServerOptions {
                    huxley: frontseat_bluefin::HuxleyOptions {
                        lat,
                        lon,
                        ..Default::default()
                    },
                    warp,
                    ..Default::default()
                };
                let h = HuxleyServer::bind(SocketAddr::from(([127, 0, 0, 1], 0)), opts).await?;
                Vehicle::Bluefin(h)
            }
            Family::Iver3 => {
                let o = IverOptions {
                    lat,
                    lon,
                    remote_helm_version_major: 5,
                    ..Default::default()
                };
                Vehicle::Iver3(
                    Emulator::start(IverSession::new(o), tcp, warp)
                        .await
                        .map_err(io)?,
                )
            }
            Family::WavegliderSv2 => {
                let o = Sv2Options {
                    lat,
                    lon,
                    ..Default::default()
                };
                Vehicle::WavegliderSv2(
                    Emulator::start(Sv2Session::new(o), tcp, warp)
                        .await
                        .map_err(io)?,
                )
            }
            Family::Ardupilot => {
                let o = RoverOptions {
                    lat,
                    lon,
                    ..Default::default()
                };
                Vehicle::Rover(
                    Emulator::start(RoverSession::new(o), tcp, warp)
                        .await
                        .map_err(io)?,
                )
            }
            Family::Ardusub => {
                let o = SubOptions {
                    lat,
                    lon,
                    ..Default::default()
                };
                Vehicle::Sub(
                    Emulator::start(SubSession::new(o), tcp, warp)
                        .await
                        .map_err(io)?,
                )
            }
            Family::Dune => {
                let o = DuneOptions {
                    lat,
                    lon,
                    ..Default::default()
                };
                Vehicle::Dune(
                    Emulator::start(DuneSession::new(o), tcp, warp)
                        .await
                        .map_err(io)?,
                )
            }
        })
    }

    /// Where the emulator listens.
    pub(crate) fn addr(&self) -> SocketAddr {
        let unbound = SocketAddr::from(([127, 0, 0, 1], 0));
        match self {
            Vehicle::Bluefin(h) => h.local_addr(),
            Vehicle::Iver3(e) => e.tcp_addr().unwrap_or(unbound),
            Vehicle::WavegliderSv2(e) => e.tcp_addr().unwrap_or(unbound),
            Vehicle::Rover(e) => e.tcp_addr().unwrap_or(unbound),
            Vehicle::Sub(e) => e.tcp_addr().unwrap_or(unbound),
            Vehicle::Dune(e) => e.tcp_addr().unwrap_or(unbound),
        }
    }

    /// Commands the vehicle got from the driver (setpoints, plan starts), as its emulator
    /// counts them; None where it does not (the link counts them then).
    pub(crate) fn commands(&self) -> Option<u64> {
        match self {
            Vehicle::Bluefin(_) => None,
            Vehicle::Iver3(e) => Some(e.session().stats.oms),
            Vehicle::WavegliderSv2(e) => Some(e.session().stats.commands),
            // Every target frame, followed or not (one outside GUIDED is dropped by the vehicle,
            // but it reached it).
            Vehicle::Rover(e) => {
                let s = &e.session().stats;
                Some(s.targets_followed + s.targets_ignored + s.targets_refused)
            }
            Vehicle::Sub(e) => {
                let s = &e.session().stats;
                Some(s.targets_followed + s.targets_dropped + s.attitude_targets)
            }
            Vehicle::Dune(e) => {
                let s = &e.session().stats;
                // A MANDONE Reference ends our maneuver: not a command to move.
                Some(s.references.saturating_sub(s.mandone) + s.plans_started)
            }
        }
    }

    /// Commands the vehicle refused on its own (the refusal hook at work), where it counts them.
    pub(crate) fn refused(&self) -> Option<u64> {
        match self {
            Vehicle::Dune(e) => Some(e.session().stats.plans_refused),
            Vehicle::Rover(e) => Some(e.session().fault_counters().commands_refused),
            Vehicle::Sub(e) => Some(e.session().fault_counters().commands_refused),
            _ => None,
        }
    }

    /// An ArduPilot's (armed, in GUIDED); None for the other families.
    pub(crate) fn armed_guided(&self) -> Option<(bool, bool)> {
        match self {
            Vehicle::Rover(e) => {
                let s = e.session();
                Some((s.armed(), s.mode() == s.firmware().guided()))
            }
            Vehicle::Sub(e) => {
                let s = e.session();
                Some((s.armed(), s.mode() == s.firmware().guided()))
            }
            _ => None,
        }
    }

    /// The vehicle refuses commands (true) or takes them again (false).
    /// An ArduPilot also leaves GUIDED for HOLD as the refusal starts, so the pilot's and the
    /// driver's commands meet it (each answered DENIED).
    pub(crate) fn refuse(&self, on: bool) {
        let denied = on.then_some(MavResult::MAV_RESULT_DENIED);
        match self {
            Vehicle::Dune(e) => e.session().refuse_plans(on),
            Vehicle::Rover(e) => {
                let mut s = e.session();
                s.refuse_commands(denied);
                if on {
                    s.change_mode(modes::rover::HOLD);
                }
            }
            Vehicle::Sub(e) => {
                let mut s = e.session();
                s.refuse_commands(denied);
                if on {
                    s.change_mode(modes::sub::POSHOLD);
                }
            }
            _ => {}
        }
    }

    /// The vehicle changes mode on its own (true: out of the backseat's control), or is given
    /// back (false).
    /// An ArduPilot switches to MANUAL (a pilot's RC switch); it is given back by the
    /// harness's pilot selecting GUIDED again.
    pub(crate) fn take_control(&self, on: bool) {
        match self {
            Vehicle::Dune(e) => {
                let mut s = e.session();
                if on {
                    s.take_control(frontseat_dune::imc::consts::op_mode::EXTERNAL);
                } else {
                    s.release_control();
                }
            }
            Vehicle::Rover(e) if on => e.session().change_mode(modes::rover::MANUAL),
            Vehicle::Sub(e) if on => e.session().change_mode(modes::sub::MANUAL),
            _ => {}
        }
    }

    /// Stops a server-type emulator (the Huxley); the others stop when the last holder drops.
    pub(crate) async fn shutdown(&self) {
        if let Vehicle::Bluefin(h) = self {
            h.shutdown().await;
        }
    }
}
