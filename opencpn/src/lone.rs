//! A lone vehicle's own AIS (`[opencpn.ais]` of the interface): its node_status, heard on its
//! bus through the generated `AisReporter` ports, reported as the one configured AIS vehicle.

use std::time::Duration;

use frontseat_actors::bus::{Bus, Subscription};
use frontseat_actors::ports::AisReporterInbox;
use frontseat_actors::service_child::{BoxFuture, Service};
use frontseat_actors::supervisor::ChildFailure;
use frontseat_config::AisConfig;

use crate::feed::{AisFleet, report};
use crate::transport::Outputs;

/// The running reporter of one vehicle.
pub struct LoneAis {
    task: tokio::task::JoinHandle<()>,
    _subs: Vec<Subscription>,
    pub fleet: AisFleet,
    pub tcp_addr: Option<std::net::SocketAddr>,
}

impl LoneAis {
    pub async fn start(cfg: &AisConfig, bus: &Bus) -> std::io::Result<Self> {
        let Some(name) = cfg.vehicle.first().map(|v| v.name.clone()) else {
            return Err(std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                "[opencpn.ais] lists no vehicle",
            ));
        };
        let out = Outputs::open(&cfg.udp, &cfg.tcp_listen, cfg.max_tcp_clients).await?;
        let tcp_addr = out.tcp_addr();
        let fleet = AisFleet::new(cfg);
        let f = fleet.clone();
        let subs = AisReporterInbox::subscribe_all(bus, "AisReporter", 64, move |m| {
            let AisReporterInbox::NodeStatus(e) = m;
            f.on_node_status(&name, &e.msg);
            Ok(())
        });
        let task = tokio::spawn(report(fleet.clone(), cfg.clone(), out));
        Ok(Self {
            task,
            _subs: subs,
            fleet,
            tcp_addr,
        })
    }
}

impl Service for LoneAis {
    fn ended(&mut self) -> BoxFuture<'_, Result<(), ChildFailure>> {
        Box::pin(async move {
            let r = (&mut self.task).await;
            Err(ChildFailure::new(format!("the AIS reporter ended: {r:?}")))
        })
    }
    fn stop(self: Box<Self>, _within: Duration) -> BoxFuture<'static, ()> {
        Box::pin(async move { self.task.abort() })
    }
}
