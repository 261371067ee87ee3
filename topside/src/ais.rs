//! The topside's `[ais]`: every configured vehicle of the fleet reported to OpenCPN as an AIS
//! class B target. Fed by the node_status the fleet model takes in (the topside's observer, so
//! only what the model found plausible), reported by its own supervised child at the configured
//! rates (frontseat_opencpn: the encoder, the staleness rule, UDP and TCP outputs).

use std::sync::Arc;

use frontseat_actors::service_child::{BoxFuture, Service, service_child_with};
use frontseat_actors::supervisor::{ChildFailure, ChildSpec, Policy};
use frontseat_config::AisConfig;
use frontseat_opencpn::feed::{AisFleet, report};
use frontseat_opencpn::transport::Outputs;

use crate::Observer;

/// The targets of `cfg`'s vehicles (shared by the observer and the reporter across restarts).
pub fn fleet(cfg: &AisConfig) -> AisFleet {
    AisFleet::new(cfg)
}

/// What the fleet model calls with each node_status it took in.
pub fn observer(fleet: &AisFleet) -> Observer {
    let f = fleet.clone();
    Arc::new(move |platform, ns| f.on_node_status(platform, ns))
}

/// The running reporter.
pub struct AisService {
    task: tokio::task::JoinHandle<()>,
}

impl Service for AisService {
    fn ended(&mut self) -> BoxFuture<'_, Result<(), ChildFailure>> {
        Box::pin(async move {
            let r = (&mut self.task).await;
            Err(ChildFailure::new(format!("the AIS reporter ended: {r:?}")))
        })
    }
    fn stop(self: Box<Self>, _within: std::time::Duration) -> BoxFuture<'static, ()> {
        Box::pin(async move { self.task.abort() })
    }
}

/// The reporter as a child of the topside's root: restarted without end (it steers nothing).
pub fn child(cfg: AisConfig, fleet: AisFleet, policy: Policy) -> ChildSpec {
    service_child_with(
        "AisReporter",
        policy,
        (Arc::new(cfg), fleet),
        |(cfg, fleet)| async move {
            let out = Outputs::open(&cfg.udp, &cfg.tcp_listen, cfg.max_tcp_clients)
                .await
                .map_err(|e| format!("[ais]: {e}"))?;
            tracing::info!(udp = ?cfg.udp, tcp = ?out.tcp_addr(), vehicles = cfg.vehicle.len(), "topside AIS reporting");
            let task = tokio::spawn(report(fleet, (*cfg).clone(), out));
            Ok(Box::new(AisService { task }) as Box<dyn Service>)
        },
    )
    .noted("with [ais] enabled: the fleet as AIS targets (UDP, TCP); restarted without end")
}
