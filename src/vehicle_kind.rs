//! Which vehicle protocol `frontseat sim` and `frontseat demo` speak: shared by the demo and the
//! emulator commands so that neither imports the other.

use clap::ValueEnum;

/// Which vehicle `sim` and `demo` speak for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, ValueEnum)]
pub enum VehicleKind {
    /// The basic simulator's line protocol over TCP (the default).
    #[default]
    Basic,
    /// Iver3 UVC Remote Helm NMEA.
    Iver3,
    /// Wave Glider SV2 C&C binary frames.
    #[value(name = "waveglider_sv2")]
    WavegliderSv2,
    /// Bluefin Huxley payload NMEA over TCP (port 29500 unless `--port`; see bluefin_sim.rs).
    Bluefin,
    /// ArduPilot Rover (motorboat) over MAVLink 2.
    Ardupilot,
    /// An LSTS DUNE LAUV over IMC on its BackSeat TCP server (port 6006 unless `--tcp`).
    Dune,
    /// ArduSub (BlueROV2) over MAVLink 2: dives to the depths the helm asks for.
    Ardusub,
}
