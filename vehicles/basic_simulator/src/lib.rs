//! The basic frontseat simulator as a vehicle: [`driver`] is the built-in `basic_simulator` driver
//! (Goby3's `BasicSimulatorFrontSeatInterface`) on the runtime's driver trait and kit. Its wire
//! codec and the simulator itself stay in `frontseat-sim` (`sim/src/codec.rs`), which the
//! simulator server, the bench and the recorder also use without any driver; this crate adds
//! only what a backseat needs. README.md says what lives where.

#![forbid(unsafe_code)]

pub mod driver;

pub use driver::{BasicSimulatorDriver, Settings, parse_nav};

/// The built-in `basic_simulator` driver, as the registry (`vehicles/registry`) lists it.
pub const DRIVER: frontseat_actors::drivers::BuiltIn = frontseat_actors::drivers::BuiltIn {
    name: frontseat_config::BASIC_SIMULATOR,
    factory: |cfg| {
        let settings = Settings::from_config(cfg);
        std::sync::Arc::new(move || {
            Box::new(BasicSimulatorDriver::new(settings.clone()))
                as Box<dyn frontseat_actors::driver::Driver>
        })
    },
    // The simulator answers every command at once.
    ack_budget: frontseat_actors::drivers::no_ack_budget,
    raw_framing: frontseat_actors::raw_gate::RawFraming::Lines,
};
