//! The OceanServer/L3Harris Iver3 as a frontseat, over the UVC's "Remote Helm" NMEA sentences:
//! everything about the vehicle. [`codec`] is the wire (sentences, checksums, in the UVC's feet
//! and knots), [`units`] the UVC's units and mode letters, [`edge`] those mapped onto Goby's
//! protobuf types, [`driver`] the state and I/O on the runtime's driver trait and kit,
//! [`emulator`] the UVC's side on the simulator's vehicle model (`frontseat sim --vehicle iver3`).
//! README.md says what was verified against what.

#![forbid(unsafe_code)]

pub mod codec;
pub mod driver;
pub mod edge;
pub mod emulator;
pub mod units;

pub use driver::{Iver3Driver, Settings};

pub use emulator::{IverOptions, IverSession};

/// The built-in `iver3` driver, as the registry (`vehicles/registry`) lists it.
pub const DRIVER: frontseat_actors::drivers::BuiltIn = frontseat_actors::drivers::BuiltIn {
    name: frontseat_config::IVER3,
    factory: |cfg| {
        let settings = Settings::from_config(cfg);
        std::sync::Arc::new(move || {
            Box::new(Iver3Driver::new(settings.clone()))
                as Box<dyn frontseat_actors::driver::Driver>
        })
    },
    // The driver's own ack timeout, as it reads it.
    ack_budget: |cfg| Settings::from_config(cfg).ack_timeout,
    raw_framing: frontseat_actors::raw_gate::RawFraming::Lines,
};
