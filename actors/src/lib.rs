//! The frontseat runtime: the in-process bus, the generated wiring (messages, groups, ports), the
//! FrontSeatInterface and its supervised DriverActor, the driver contract (`driver`), driver
//! selection and the driver kit every vehicle's driver uses (`drivers`; the drivers themselves
//! live in their vehicle crates under `vehicles/`, listed by `vehicles/registry`), the glue that
//! embeds the simulator and systemd notification. `docs/ARCHITECTURE.md` follows the data through these modules. Pure logic lives
//! in plain modules; actors are thin shells around it. What only exercises the runtime lives
//! outside it and uses this crate's public API:
//! the chaos harness (`tools/chaos`), the benchmark (`tools/bench`) and the demo helm
//! (`examples/demo_helm`); their ports are still generated here with every application's, and
//! generated ports are the only way any other crate publishes or subscribes (the bus's own
//! publish/subscribe are `pub(crate)`; tests use `bus::test_util` behind the `test-util`
//! feature). Fault injection reaches the interface, driver and translation only through their
//! fault ports (`chaos`), opened only with `[chaos] enabled`.
#![forbid(unsafe_code)]

pub mod bus;
pub mod chaos;
pub mod clock;
pub mod command_gate;
pub mod driver;
pub mod driver_actor;
pub mod drivers;
pub mod extension;
pub mod generated;
pub mod health;
pub mod interface;
pub mod link;
pub mod nav_gate;
pub mod ratelog;
pub mod raw_gate;
pub mod service_child;
pub mod sim_glue;
pub mod state_machine;
pub mod supervisor;
pub mod systemd;

/// Telemetry and metrics are their own crate (`frontseat-telemetry`); these two paths stay for
/// the drivers, which report bad lines and truncate raw lines through them while they move to
/// `vehicles/` (issue 26, in parallel). New code uses `frontseat_telemetry` directly.
pub use frontseat_telemetry::{self as telemetry, metrics};
pub use generated::{extensions, groups, ports, proto};
