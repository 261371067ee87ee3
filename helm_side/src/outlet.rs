//! A publisher that stands in for a vehicle's interface on one helm-side transport, for
//! `frontseat replay`: it exports what a FrontSeatInterface publishes (nothing comes in), onto
//! Zenoh or a Goby3 gobyd, waits (bounded) until gobyd can be published to, and on close lets what
//! was published leave the export queues (bounded) before the link goes, or a replay would lose its
//! end. The command only parses its arguments into an [`Onto`] and reports.

use std::time::Duration;

use frontseat_actors::bus::{Bus, BusRole};
use frontseat_config::{Goby3Config, InterprocessConfig};

use crate::goby3::{Goby3Handle, Goby3Settings};
use crate::{GatewayError, GatewayHandle, GatewayOptions};

/// What a FrontSeatInterface hosts: the outlet exports exactly its publications.
const STANDS_IN_FOR: &[&str] = &["FrontSeatInterface"];
/// How long [`Outlet::close`] waits for the export queue to empty.
const DRAIN: Duration = Duration::from_secs(5);

/// Where an outlet publishes.
#[derive(Clone, Debug)]
pub enum Onto {
    /// Zenoh, under the platform the config (or else `vehicle`) names.
    Zenoh {
        cfg: InterprocessConfig,
        vehicle: String,
    },
    /// A running gobyd, joined as a Goby3 client; given up when gobyd does not answer in `wait`.
    Gobyd {
        cfg: Goby3Config,
        vehicle: String,
        wait: Duration,
    },
}

#[derive(Debug, thiserror::Error)]
pub enum OutletError {
    /// The settings cannot work (a usage error: nothing was started).
    #[error("{0}")]
    Settings(GatewayError),
    /// The bus already carries something an outlet must not share it with.
    #[error("the bus is already claimed by {0:?}")]
    Claimed(BusRole),
    #[error("cannot start the Goby3 link: {0}")]
    Goby3(GatewayError),
    #[error("gobyd did not answer at {endpoint} within {wait:?}")]
    NoGobyd { endpoint: String, wait: Duration },
    #[error("cannot start Zenoh: {0}")]
    Zenoh(GatewayError),
}

impl OutletError {
    /// Whether the caller asked for something impossible (exit 2) rather than met a failure.
    pub fn is_usage(&self) -> bool {
        matches!(self, Self::Settings(_) | Self::Claimed(_))
    }
}

enum Link {
    Zenoh(GatewayHandle),
    Goby3(Goby3Handle),
}

/// An open outlet: publishing on the bus it was opened on reaches the transport.
pub struct Outlet {
    link: Link,
    description: String,
}

impl Outlet {
    pub async fn open(bus: &Bus, onto: Onto) -> Result<Self, OutletError> {
        match onto {
            Onto::Gobyd { cfg, vehicle, wait } => {
                // Claimed before gobyd is joined: a replay bus never carries a live driver.
                bus.claim(BusRole::Replay).map_err(OutletError::Claimed)?;
                let settings =
                    Goby3Settings::from_config(&cfg, &vehicle).map_err(OutletError::Settings)?;
                let endpoint = settings.transport.manager_endpoint();
                let h = crate::goby3::start_publisher(
                    bus,
                    settings,
                    STANDS_IN_FOR,
                    GatewayOptions::default(),
                )
                .map_err(OutletError::Goby3)?;
                // Messages published before gobyd is joined would be dropped: wait (bounded).
                let joined = tokio::time::timeout(wait, async {
                    while !h.link_up() {
                        tokio::time::sleep(Duration::from_millis(20)).await;
                    }
                })
                .await;
                if joined.is_err() {
                    h.close().await;
                    return Err(OutletError::NoGobyd { endpoint, wait });
                }
                Ok(Self {
                    link: Link::Goby3(h),
                    description: format!("publishing through gobyd at {endpoint}"),
                })
            }
            Onto::Zenoh { cfg, vehicle } => {
                let platform =
                    crate::resolve_platform(&cfg, &vehicle).map_err(OutletError::Settings)?;
                let g = crate::start(
                    bus,
                    &cfg,
                    &platform,
                    STANDS_IN_FOR,
                    GatewayOptions::default(),
                )
                .await
                .map_err(OutletError::Zenoh)?;
                Ok(Self {
                    link: Link::Zenoh(g),
                    description: format!("publishing on Zenoh platform {platform}"),
                })
            }
        }
    }

    /// "publishing through gobyd at …" / "publishing on Zenoh platform …".
    pub fn description(&self) -> &str {
        &self.description
    }

    /// Messages that left for the transport, or were given up (link down, refused).
    fn out(&self) -> u64 {
        match &self.link {
            Link::Zenoh(g) => {
                let st = g.stats();
                st.exported + st.export_errors
            }
            Link::Goby3(h) => {
                let st = h.stats();
                st.exported + st.dropped_link_down + st.export_errors
            }
        }
    }

    /// Closes the link. With `published` (what was put on the bus for it), first waits, at most
    /// 5 s, until that many left the export queue.
    pub async fn close(self, published: Option<u64>) {
        if let Some(n) = published {
            let deadline = tokio::time::Instant::now() + DRAIN;
            while self.out() < n && tokio::time::Instant::now() < deadline {
                tokio::time::sleep(Duration::from_millis(10)).await;
            }
        }
        match self.link {
            Link::Zenoh(g) => g.close().await,
            Link::Goby3(h) => {
                let st = h.stats();
                h.close().await;
                tracing::info!(?st, "Goby3 link closed");
            }
        }
    }
}
