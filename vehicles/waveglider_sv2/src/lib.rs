//! The Liquid Robotics Wave Glider SV2 as a frontseat, over the binary payload protocol of its
//! Command & Control board: everything about the vehicle. [`codec`] is the wire (CRC-16/ARC,
//! byte stuffing, a bounded resynchronising frame decoder, the typed messages, the C&C's units),
//! [`edge`] those mapped onto Goby's NodeStatus, [`driver`] the state and I/O on the runtime's
//! driver trait and kit (and the SV2 framing its byte link uses), [`emulator`] the C&C board's
//! side on the simulator's vehicle model (`frontseat sim --vehicle waveglider_sv2`). README.md
//! says what was verified against what.

#![forbid(unsafe_code)]

pub mod codec;
pub mod driver;
pub mod edge;
pub mod emulator;

pub use driver::{Settings, WavegliderSv2Driver};

pub use emulator::{Sv2Options, Sv2Session};

/// The built-in `waveglider_sv2` driver, as the registry (`vehicles/registry`) lists it.
pub const DRIVER: frontseat_actors::drivers::BuiltIn = frontseat_actors::drivers::BuiltIn {
    name: frontseat_config::WAVEGLIDER_SV2,
    factory: |cfg| {
        let settings = Settings::from_config(cfg);
        std::sync::Arc::new(move || {
            Box::new(WavegliderSv2Driver::new(settings.clone()))
                as Box<dyn frontseat_actors::driver::Driver>
        })
    },
    // The driver's own ack timeout, as it reads it.
    ack_budget: |cfg| Settings::from_config(cfg).ack_timeout,
    raw_framing: frontseat_actors::raw_gate::RawFraming::Frames,
};
