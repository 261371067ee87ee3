//! The vehicle: the basic simulator on loopback TCP, with the simulated vehicle's fault port on
//! the bus, and a restart that comes back on the same port as a restarted simulator does.

use std::net::SocketAddr;
use std::time::Duration;

use frontseat_actors::bus::Bus;
use frontseat_actors::sim_glue::{self, EmbeddedSimulator};
use frontseat_sim::{SimHandle, SimOptions, SimServer};

use super::rebind::rebind;
use crate::options::ChaosHarnessError;

/// The simulator on loopback TCP, embedded on the bus (its fault port), restartable on its port.
pub(crate) struct Sim {
    pub(crate) addr: SocketAddr,
    pub(crate) handle: SimHandle,
    pub(crate) embedded: Option<EmbeddedSimulator>,
}

impl Sim {
    pub(crate) async fn start(bus: &Bus) -> Result<Self, ChaosHarnessError> {
        let handle = SimServer::bind(([127, 0, 0, 1], 0).into(), SimOptions::default()).await?;
        let embedded = Some(sim_glue::embed(&handle, bus));
        Ok(Self {
            addr: handle.local_addr(),
            handle,
            embedded,
        })
    }

    pub(crate) async fn restart(
        &mut self,
        bus: &Bus,
        down: Duration,
    ) -> Result<(), ChaosHarnessError> {
        self.embedded = None;
        self.handle.shutdown().await;
        tokio::time::sleep(down).await;
        self.handle = rebind(|| SimServer::bind(self.addr, SimOptions::default())).await?;
        self.embedded = Some(sim_glue::embed(&self.handle, bus));
        Ok(())
    }
}
