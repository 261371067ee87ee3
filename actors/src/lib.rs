//! The frontseat runtime, and only the runtime: the in-process bus (`bus`) and the generated
//! wiring (messages, groups, ports, and the vehicle extension table `extensions`, all from
//! `interface_yaml/`), the FrontSeatInterface with its state machine and its two gates
//! (`interface`, `state_machine`, `command_gate`, `nav_gate`, `raw_gate`, and `extension` for
//! any vehicle's extension groups), the DriverActor under its nested supervisor (`driver_actor`,
//! `supervisor`, `service_child`), the driver contract (`driver`), driver selection and the
//! driver kit every vehicle's driver uses (`drivers`), the byte links drivers read through
//! (`link`), goby_coroner's health answer (`health`), systemd notification (`systemd`), the
//! embedded simulator's place on the bus for the demo and tests (`sim_glue`) and the
//! fault ports (`chaos`). It names no vehicle and no helm transport: the drivers live in their
//! vehicle crates under `vehicles/` (listed by `vehicles/registry`), the transports to helms
//! (Zenoh, gobyd, the MOOS translation) in `helm_side/`, telemetry in `telemetry/`.
//! `docs/ARCHITECTURE.md` follows the data through these modules. Pure logic lives in plain
//! modules; actors are thin shells around it. What only exercises the runtime — the chaos
//! harness (`tools/chaos`), the benchmark (`tools/bench`), the demo helm
//! (`examples/demo_helm`) — lives outside it; their ports are generated here with every
//! application's, and generated ports are the only way any other crate publishes or subscribes
//! (the bus's own publish/subscribe are `pub(crate)`; tests use `bus::test_util` behind the
//! `test-util` feature). Fault injection reaches the interface, driver and translation only
//! through their fault ports (`chaos`), opened only with `[chaos] enabled`.
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
pub mod setpoint_lane;
pub mod sim_glue;
pub mod state_machine;
pub mod supervisor;
pub mod systemd;

pub use generated::{extensions, groups, ports, proto};
