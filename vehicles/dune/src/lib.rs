//! LSTS DUNE vehicles (OceanScan LAUVs and the research vehicles built on DUNE) as a frontseat,
//! over IMC. Read top to bottom: [`imc`] (the wire: header, CRC, the messages a frontseat needs,
//! a bounded deframer), [`infer`] (what a backseat concludes from what the vehicle says, and what
//! it sends for a course — pure functions), [`driver`] (the state, the I/O and the glue to the
//! runtime's driver trait), [`emulator`] (a DUNE LAUV's BackSeat TCP face on the simulator's
//! vehicle model). See README.md.

#![forbid(unsafe_code)]

pub mod driver;
pub mod emulator;
pub mod imc;
pub mod infer;

pub use driver::{DuneCounters, DuneDriver, Settings};

/// The built-in `dune` driver, as the registry (`vehicles/registry`) lists it.
pub const DRIVER: frontseat_actors::drivers::BuiltIn = frontseat_actors::drivers::BuiltIn {
    name: frontseat_config::DUNE,
    factory: |cfg| {
        let settings = Settings::from_config(cfg);
        std::sync::Arc::new(move || {
            Box::new(DuneDriver::new(settings.clone())) as Box<dyn frontseat_actors::driver::Driver>
        })
    },
    // A course is answered at once; the vehicle's verdict comes as its state.
    ack_budget: frontseat_actors::drivers::no_ack_budget,
    raw_framing: frontseat_actors::raw_gate::RawFraming::Frames,
};
