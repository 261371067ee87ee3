//! The chaos harness behind `frontseat chaos` and `tools/chaos/tests/chaos.rs`: the real simulator on
//! loopback TCP, the interface with its basic simulator driver, a helm on the bus and the MOOS
//! bridge against our broker; faults injected on a seeded schedule, invariants watched
//! throughout and reported at the end as a table.
//!
//! The seed fixes the sequence of faults, their parameters and hold times; how the system
//! reacts is timing and is what is measured. Runtime faults go through the chaos group to the
//! fault ports, so a config without `[chaos] enabled = true` is refused before anything starts.
//! Only one run per process at a time: counting panics needs the process-wide panic hook.
//!
//! A tool, not part of the runtime: it composes frontseat-actors, -sim and -moos from outside,
//! through their public API, as a deployment would. The runtime keeps only the hooks it must own
//! itself — the fault ports (`frontseat_actors::chaos`, opened only with `[chaos] enabled = true`)
//! of the interface, the driver and the translation; no production message carries a fault.
//!
//! Where each part lives:
//! - `options`: what to run (the embedded config, [`ChaosOptions`]) and what may refuse it.
//! - `plan`: the seeded fault schedule ([`FaultKind`], [`Planner`]).
//! - `world`: what stands around the interface — the simulator, the helm, the MOOS broker and
//!   bridge, gobyd and the Goby3 gateway, web clients — each restartable where a fault needs it.
//! - `monitor`: what the bus says (states, node_status, CommandResponses), counted as it passes.
//! - `panics`: the process-wide panic hook that tells injected panics from escaped ones.
//! - `resources`: RSS, fds, threads, tasks and bus subscriptions, sampled.
//! - `family`: the vehicle families (`--vehicle`): each one's emulator, driver settings,
//!   faults and command count.
//! - `link`: the chaos link, a loopback proxy between a family's emulator and its driver that
//!   drops, silences, delays and writes broken frames into the line.
//! - `run`: the run itself — start, faults, settle, shut down, the invariants table.
//! - `report`: the [`ChaosReport`] and its Markdown rendering.
#![forbid(unsafe_code)]

mod family;
mod link;
mod monitor;
mod options;
mod panics;
mod plan;
mod report;
mod resources;
mod run;
mod world;

pub use family::Family;
pub use options::{ChaosHarnessError, ChaosOptions, DEFAULT_CONFIG, default_config};
pub use plan::{FaultKind, PlannedFault, Planner, Rng, plan};
pub use report::{ChaosReport, Invariant, KindStats};
pub use resources::{Sample, open_fds, rss_kib, threads};
pub use run::family::run_family;
pub use run::invariants::soak_invariant;
pub use run::run;
pub use world::web::{course_body, send_request};
