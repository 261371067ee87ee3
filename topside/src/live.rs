//! The topside's `[foxglove]`: what the fleet model takes in, served live to Foxglove or
//! Lichtblick over the Foxglove WebSocket protocol by the interface's own server
//! (`frontseat_record::foxglove`: read-only, loopback unless a token is set, the web crate's
//! bounded listener, a bounded queue per client). One channel per vehicle and group, topic
//! `<platform>/<group>` as in the topside's recording, advertised to every client when the
//! vehicle is first heard. Only samples the model took in (or refused as implausible, as the
//! recording keeps them) are served, so the channels are bounded by `max_vehicles`.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};
use std::time::SystemTime;

use frontseat_actors::groups;
use frontseat_record::foxglove::{FoxgloveError, FoxgloveOptions, FoxgloveServer, LiveFeed};

use crate::config::TopsideConfig;

/// (platform, group) → channel id (`None`: the server's channel limit was reached).
type Channels = Arc<Mutex<HashMap<(String, &'static str), Option<u32>>>>;

/// The running live server; dropping it closes it.
#[derive(Debug)]
pub struct Live {
    server: FoxgloveServer,
    feed: LiveFeed,
    channels: Channels,
}

/// Where one group's samples go: the live server, under `<platform>/<group>`.
#[derive(Clone, Debug)]
pub struct LiveTo {
    feed: LiveFeed,
    channels: Channels,
    group: &'static str,
    type_name: &'static str,
}

/// Starts the server of `[foxglove]` when enabled.
pub fn start(cfg: &TopsideConfig) -> Result<Option<Live>, FoxgloveError> {
    if !cfg.foxglove.enabled {
        return Ok(None);
    }
    let opts = FoxgloveOptions::from_config(&cfg.foxglove);
    let (server, feed) = FoxgloveServer::serve(&opts, "topside")?;
    tracing::info!(addr = %server.local_addr(), "topside foxglove live server (read-only) listening");
    Ok(Some(Live {
        server,
        feed,
        channels: Arc::default(),
    }))
}

impl Live {
    pub fn local_addr(&self) -> std::net::SocketAddr {
        self.server.local_addr()
    }

    pub fn stats(&self) -> frontseat_record::foxglove::FoxgloveStats {
        self.server.stats()
    }

    /// The sink of one of the topside's groups; `None` for a group that is not generated.
    pub fn to(&self, group: &'static str) -> Option<LiveTo> {
        let type_name = groups::ALL.iter().find(|g| g.name == group)?.type_name;
        Some(LiveTo {
            feed: self.feed.clone(),
            channels: self.channels.clone(),
            group,
            type_name,
        })
    }
}

impl LiveTo {
    /// Serves `payload` (the encoded message as heard) on `<platform>/<group>`; never waits.
    pub fn publish(&self, platform: &str, payload: &[u8]) {
        let channel = {
            let mut c = self.channels.lock().unwrap_or_else(|p| p.into_inner());
            match c.get(&(platform.to_string(), self.group)) {
                Some(id) => *id,
                None => {
                    // Advertised even with nobody watching: a client that connects later
                    // must see every vehicle heard so far.
                    let id = self
                        .feed
                        .add_channel(&format!("{platform}/{}", self.group), self.type_name);
                    if id.is_none() {
                        tracing::warn!(
                            platform,
                            group = self.group,
                            "topside foxglove: channel limit reached; this vehicle's group is not served"
                        );
                    }
                    c.insert((platform.to_string(), self.group), id);
                    id
                }
            }
        };
        if let Some(id) = channel
            && self.feed.watched()
        {
            let now = SystemTime::now()
                .duration_since(SystemTime::UNIX_EPOCH)
                .map(|d| u64::try_from(d.as_nanos()).unwrap_or(u64::MAX))
                .unwrap_or(0);
            self.feed.publish(id, now, payload.to_vec());
        }
    }
}
