//! Bluefin Huxley as a frontseat: everything about the vehicle. [`codec`] is the "Standard
//! Payload Interface" sentence codec (pure, shared by the driver and the emulator), [`driver`]
//! Goby3's `BluefinFrontSeat` on the runtime's driver trait and kit (state inference, the
//! acknowledgement queue, the heartbeat), [`seawater`] the equations its CTD samples need,
//! [`emulator`] the Huxley's side as pure state on the simulator's vehicle model, [`server`] the
//! payload-port TCP server that runs it (`frontseat sim --vehicle bluefin`). See README.md for
//! what was verified against what.

#![forbid(unsafe_code)]

pub mod codec;
pub mod driver;
pub mod emulator;
pub mod seawater;
pub mod server;

pub use driver::{BluefinDriver, BluefinStats, Settings};

pub use emulator::{Huxley, HuxleyOptions, Refusal};
pub use server::{HuxleyHandle, HuxleyServer, HuxleyServerOptions, HuxleyStats};

/// The Huxley payload port Goby3's driver connects to by default.
pub const DEFAULT_PORT: u16 = 29500;

/// The built-in `bluefin` driver, as the registry (`vehicles/registry`) lists it.
pub const DRIVER: frontseat_actors::drivers::BuiltIn = frontseat_actors::drivers::BuiltIn {
    name: frontseat_config::BLUEFIN,
    factory: |cfg| {
        let settings = Settings::from_config(cfg);
        std::sync::Arc::new(move || {
            Box::new(BluefinDriver::new(settings.clone()))
                as Box<dyn frontseat_actors::driver::Driver>
        })
    },
    // Goby3's resend budget, as the driver reads it: nmea_resend_attempts writes,
    // nmea_resend_interval apart.
    ack_budget: |cfg| {
        let s = Settings::from_config(cfg);
        s.resend_interval.saturating_mul(s.resend_attempts)
    },
    raw_framing: frontseat_actors::raw_gate::RawFraming::Lines,
};
