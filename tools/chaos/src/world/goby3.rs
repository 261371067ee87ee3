//! The Goby3 side: a gobyd (our stand-in) and this process's Goby3 gateway joined to it; the
//! gobyd can go away and come back on its port.

use std::time::Duration;

use frontseat_actors::bus::Bus;
use frontseat_helm_side::GatewayOptions;
use frontseat_helm_side::goby3::{
    self, Goby3Handle,
    standin::{StandinGobyd, StandinTransport},
};
use tokio::time::Instant;

use crate::options::ChaosHarnessError;

/// A gobyd (our stand-in, TCP on loopback) and this process's Goby3 gateway, joined to it as
/// `frontseat interface` is with `[goby3] enabled = true`. The gobyd can go away and come back
/// on the same manager port, as a restarted gobyd does.
pub(crate) struct Goby {
    pub(crate) port: u16,
    pub(crate) gobyd: Option<StandinGobyd>,
    pub(crate) gateway: Goby3Handle,
}

impl Goby {
    pub(crate) async fn start(bus: &Bus) -> Result<Self, ChaosHarnessError> {
        let e = |e: &dyn std::fmt::Display| ChaosHarnessError::Goby3(e.to_string());
        let gobyd = StandinGobyd::start(StandinTransport::Tcp { manager_port: 0 }, &[])
            .await
            .map_err(|x| e(&x))?;
        let port = gobyd
            .manager_port()
            .ok_or_else(|| ChaosHarnessError::Goby3("stand-in gobyd has no TCP port".into()))?;
        let cfg = frontseat_config::Goby3Config {
            enabled: true,
            transport: frontseat_config::Goby3Transport::Tcp,
            ip_address: "127.0.0.1".into(),
            tcp_port: port,
            settle_ms: 50,
            reconnect_initial_ms: 20,
            reconnect_max_ms: 200,
            manager_timeout_seconds: 1.0,
            ..Default::default()
        };
        let settings = goby3::Goby3Settings::from_config(&cfg, "chaos-auv").map_err(|x| e(&x))?;
        let gateway = goby3::start(
            bus,
            settings,
            &["FrontSeatInterface"],
            GatewayOptions::default(),
        )
        .map_err(|x| e(&x))?;
        Ok(Self {
            port,
            gobyd: Some(gobyd),
            gateway,
        })
    }

    /// Waits (bounded) until the gateway has joined gobyd more than `connects` times and the
    /// link is up; the time it took, or None.
    pub(crate) async fn until_joined(&self, connects: u64, within: Duration) -> Option<Duration> {
        let start = Instant::now();
        while start.elapsed() < within {
            let s = self.gateway.stats();
            if s.link_up && s.connects > connects {
                return Some(start.elapsed());
            }
            tokio::time::sleep(Duration::from_millis(5)).await;
        }
        None
    }
}
