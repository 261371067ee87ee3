//! The MOOS side: a broker of ours standing in for the MOOSDB, and the FrontSeatTranslation
//! joined to it under a supervisor, as `frontseat interface` runs it.

use std::net::SocketAddr;
use std::time::Duration;

use frontseat_actors::bus::Bus;
use frontseat_actors::chaos::FaultPort;
use frontseat_actors::supervisor::SupervisorHandle;
use frontseat_config::InterfaceConfig;
use frontseat_helm_side::translation;
use frontseat_moos::{Broker, BrokerHandle};
use tokio::time::Instant;

use crate::options::ChaosHarnessError;

/// Our MOOSDB (a broker on loopback) and the interface's MOOS bridge joined to it.
pub(crate) struct Moos {
    pub(crate) addr: SocketAddr,
    pub(crate) broker: Option<BrokerHandle>,
    /// The translation runs under a supervisor, as in `frontseat interface`.
    pub(crate) root: SupervisorHandle,
    pub(crate) bridge: translation::TranslationObserver,
    pub(crate) app_name: String,
}

impl Moos {
    /// Binds the broker, points `config`'s MOOS section at it and starts the translation under
    /// a supervisor of its own, with the harness's fault port.
    pub(crate) async fn start(
        config: &mut InterfaceConfig,
        bus: &Bus,
        translation_faults: &FaultPort,
    ) -> Result<Self, ChaosHarnessError> {
        let broker = Broker::bind("127.0.0.1:0").await?;
        let addr = broker.local_addr();
        let mut mc = config.moos.clone().unwrap_or_default();
        mc.server = "127.0.0.1".into();
        mc.port = addr.port();
        mc.time_warp = 1.0;
        config.moos = Some(mc.clone());
        let bridge = translation::TranslationObserver::default();
        let root = SupervisorHandle::start(
            "root",
            vec![translation::child_spec(
                translation::TranslationArgs {
                    cfg: mc.clone(),
                    vehicle: config.name.clone(),
                    bus: bus.clone(),
                    faults: Some(translation_faults.clone()),
                    observer: bridge.clone(),
                },
                // The helm side, as in `frontseat interface`: restarted without end.
                frontseat_actors::supervisor::Policy::from(&config.supervision.translation)
                    .helm_side(),
            )],
            Some(bus),
        )
        .await
        .map_err(ChaosHarnessError::Translation)?;
        Ok(Moos {
            addr,
            broker: Some(broker),
            root,
            bridge,
            app_name: mc.app_name.clone(),
        })
    }

    pub(crate) fn counters(&self) -> translation::TranslationCounters {
        self.bridge.counters().unwrap_or_default()
    }

    pub(crate) async fn restarts(&self, within: Duration) -> u32 {
        self.root
            .snapshot(within)
            .await
            .map_or(0, |s| s.children.iter().map(|c| c.restarts).sum())
    }

    pub(crate) fn connected(&self) -> bool {
        self.bridge
            .status()
            .is_some_and(|s| s.moos_connected == Some(true))
    }

    pub(crate) async fn wait_connected(&self, within: Duration) -> bool {
        let deadline = Instant::now() + within;
        while Instant::now() < deadline {
            if self.connected() {
                return true;
            }
            tokio::time::sleep(Duration::from_millis(5)).await;
        }
        false
    }
}
