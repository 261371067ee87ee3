//! ArduPilot (Rover with a boat frame; Sub) as a frontseat, over MAVLink: everything about the
//! vehicle. Read top to bottom: [`codec`] (the wire: bounded deframing, CRC, decode/encode
//! through the `mavlink` crate), [`modes`] (the autopilot's mode numbers), [`infer`] (what a
//! backseat concludes from what the vehicle says, and what it sends for a course — pure
//! functions), [`driver`] (the state, the I/O and the glue to the runtime's driver trait),
//! [`emulator`] (what the autopilot answers, on the simulator's vehicle model: one emulator with
//! a firmware switch, Rover or Sub). See README.md.

#![forbid(unsafe_code)]

pub mod codec;
pub mod driver;
pub mod emulator;
pub mod infer;
pub mod modes;

/// The Sub's path of old: the one emulator's Sub firmware ([`emulator::SubSession`]).
pub mod sub_emulator {
    pub use crate::emulator::{SubOptions, SubSession, SubStats, heading_error};
}

pub use mavlink::dialects::ardupilotmega as dialect;

pub use driver::{ArdupilotCounters, ArdupilotDriver, Settings};

/// The built-in `ardupilot` driver, as the registry (`vehicles/registry`) lists it.
pub const DRIVER: frontseat_actors::drivers::BuiltIn = frontseat_actors::drivers::BuiltIn {
    name: frontseat_config::ARDUPILOT,
    factory: |cfg| {
        let settings = Settings::from_config(cfg);
        std::sync::Arc::new(move || {
            Box::new(ArdupilotDriver::new(settings.clone()))
                as Box<dyn frontseat_actors::driver::Driver>
        })
    },
    // A mode or arming command waits for COMMAND_ACK this long (3 s by default, within the
    // interface's own 5 s; a longer one is now waited for too).
    ack_budget: |cfg| Settings::from_config(cfg).ack_timeout,
    raw_framing: frontseat_actors::raw_gate::RawFraming::Frames,
};
