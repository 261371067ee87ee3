//! The system under test as the run holds it — the bus, the interface service, the world around
//! it, the fault ports — and the tallies the faults add to; with the small questions the run
//! asks of it (a snapshot, the driver's restarts, the simulator's connections).

use std::sync::Arc;
use std::time::Duration;

use frontseat_actors::bus::Bus;
use frontseat_actors::chaos::FaultPort;
use frontseat_actors::interface::{InterfaceService, Snapshot};
use frontseat_actors::ports::{ChaosMonkeyPorts, ChaosSimMonkeyPorts};
use frontseat_actors::proto::frontseat::protobuf::{SimFault, sim_fault};
use frontseat_config::InterfaceConfig;
use tokio::time::Instant;

use super::tally::Tally;
use crate::monitor::Monitor;
use crate::options::ChaosOptions;
use crate::world::goby3::Goby;
use crate::world::helm::Helm;
use crate::world::moos::Moos;
use crate::world::sim::Sim;

/// One run: built by `run::start`, driven by `run::faults`; its tally is what `run::invariants`
/// reads.
pub(super) struct Run {
    pub(super) opts: ChaosOptions,
    pub(super) config: InterfaceConfig,
    pub(super) bus: Bus,
    pub(super) monkey: ChaosMonkeyPorts,
    pub(super) sim_monkey: ChaosSimMonkeyPorts,
    pub(super) service: InterfaceService,
    pub(super) web: Option<frontseat_web::WebService>,
    /// The translation's fault port, held for the whole run (the translation's restarts take
    /// clones of it; the last holder takes its subscriptions off the bus).
    pub(super) _translation_faults: FaultPort,
    pub(super) sim: Sim,
    pub(super) moos: Option<Moos>,
    pub(super) goby: Option<Goby>,
    pub(super) helm: Helm,
    pub(super) monitor: Arc<Monitor>,
    pub(super) warp: f64,
    /// What the faults measured, for the invariants.
    pub(super) tally: Tally,
}

impl Run {
    pub(super) async fn snapshot(&self) -> Option<Snapshot> {
        self.service.snapshot(Duration::from_secs(2)).await
    }

    pub(super) fn sim_fault(&self, f: sim_fault::Fault) {
        self.sim_monkey.publish_fault(SimFault {
            vehicle: None,
            fault: Some(f),
        });
    }

    pub(super) fn ctrl(&self, c: sim_fault::Ctrl) {
        self.sim_fault(sim_fault::Fault::Ctrl(c as i32));
    }

    /// The driver's restart count; a snapshot not answered at once (a starved machine) is asked
    /// again within the recovery bound before it counts as unknown.
    pub(super) async fn driver_restarts(&self) -> Option<u32> {
        let deadline = Instant::now() + self.opts.recovery_bound;
        loop {
            if let Some(s) = self.snapshot().await {
                return Some(s.driver_restarts);
            }
            if Instant::now() >= deadline {
                return None;
            }
        }
    }

    pub(super) fn connections(&self) -> u64 {
        self.sim.handle.stats().connections
    }

    /// A fault that closes the frontseat connection takes effect a little later (the driver
    /// reads the oversized line, the simulator task ends): wait (bounded) until the driver has
    /// connected again, so the effect cannot land inside the next fault's window and be blamed
    /// on it. Not reconnecting is caught by the recovery check that follows.
    pub(super) async fn until_reconnected(&self, before: u64) {
        let deadline = Instant::now() + self.opts.recovery_bound;
        while self.connections() <= before && Instant::now() < deadline {
            tokio::time::sleep(Duration::from_millis(2)).await;
        }
    }
}
