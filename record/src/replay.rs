//! `frontseat replay`: a recording published onto a bus as it was recorded — same groups, same
//! order, the same intervals divided by `speed` — so a helm under test meets last Tuesday's
//! vehicle. What it may publish is what a vehicle's interface publishes (node_status, status,
//! command responses, ...): the groups that command a vehicle (desired_course, command requests,
//! helm_state) are never replayed, every replayed message carries `Origin::Replayed`, and the
//! bus is claimed for replay so no live driver can share it.

use std::collections::HashMap;
use std::path::Path;
use std::sync::Arc;

use frontseat_actors::bus::{Bus, BusRole, Layer, Origin, PublishMeta};
use frontseat_actors::groups::{ALL, GroupInfo};
use regex::Regex;

use crate::reader::{ReadError, Recording};

/// The interface application whose publications a replay stands in for.
const VEHICLE_APP: &str = "FrontSeatInterface";

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Speed {
    /// Recorded intervals divided by this factor (> 0).
    Factor(f64),
    /// As fast as the bus takes them.
    Max,
}

#[derive(Clone, Debug)]
pub struct ReplayOptions {
    pub speed: Speed,
    /// Seconds after the first message of the file.
    pub from_s: Option<f64>,
    pub to_s: Option<f64>,
    /// Only groups matching this regex (within those a replay may publish).
    pub groups: Option<Regex>,
    /// Start again from the beginning at the end, until stopped.
    pub looped: bool,
}

impl Default for ReplayOptions {
    fn default() -> Self {
        Self {
            speed: Speed::Factor(1.0),
            from_s: None,
            to_s: None,
            groups: None,
            looped: false,
        }
    }
}

#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ReplayStats {
    pub published: u64,
    /// Messages of groups a replay never publishes (commands to a vehicle, interthread groups)
    /// or outside `--groups`.
    pub skipped: u64,
    /// Messages whose bytes did not decode as the group's type (the file is untrusted).
    pub undecodable: u64,
    /// Passes over the file.
    pub passes: u64,
    pub truncated: Option<String>,
}

#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    #[error(
        "refused: this process's bus drives a live vehicle ({0:?}); a replay never shares a bus with a driver"
    )]
    LiveDriver(BusRole),
    #[error("--speed must be a number greater than 0, or max")]
    BadSpeed,
    #[error(transparent)]
    Read(#[from] ReadError),
}

/// The groups a replay may publish: the interprocess groups the vehicle's interface publishes
/// and no vehicle subscribes to (so nothing replayed can command a vehicle).
pub fn replayable(groups: &[GroupInfo]) -> Vec<&'static str> {
    groups
        .iter()
        .filter(|g| {
            g.layer == Layer::Interprocess
                && g.publishers.contains(&VEHICLE_APP)
                && !g.subscribers.contains(&VEHICLE_APP)
        })
        .map(|g| g.name)
        .collect()
}

/// Replays the file at `path` onto `bus` until its end (or forever with `looped`; drop the
/// future to stop). Pacing uses tokio's clock, so tests may pause time.
pub async fn replay(
    bus: &Bus,
    path: &Path,
    opts: &ReplayOptions,
) -> Result<ReplayStats, ReplayError> {
    if let Speed::Factor(f) = opts.speed
        && !(f.is_finite() && f > 0.0)
    {
        return Err(ReplayError::BadSpeed);
    }
    bus.claim(BusRole::Replay)
        .map_err(ReplayError::LiveDriver)?;
    let allowed = replayable(ALL);
    let mut stats = ReplayStats::default();
    loop {
        stats.passes += 1;
        let rec = Recording::open(path)?;
        pass(bus, rec, opts, &allowed, &mut stats).await?;
        if !opts.looped {
            return Ok(stats);
        }
        if stats.published == 0 {
            // Looping over nothing would spin: an empty window ends the replay.
            return Ok(stats);
        }
    }
}

async fn pass<R: std::io::Read>(
    bus: &Bus,
    mut rec: Recording<R>,
    opts: &ReplayOptions,
    allowed: &[&'static str],
    stats: &mut ReplayStats,
) -> Result<(), ReplayError> {
    let from_ns = opts.from_s.map(|s| (s.max(0.0) * 1e9) as u64).unwrap_or(0);
    let to_ns = opts.to_s.map(|s| (s.max(0.0) * 1e9) as u64);
    let mut file_start: Option<u64> = None;
    let mut first_sent: Option<(u64, tokio::time::Instant)> = None;
    let mut since_yield = 0u32;
    // What each channel id resolves to (its group, or skip), decided once per channel rather
    // than per message; keyed by the channel's topic allocation, so a channel the file
    // redefines is decided again.
    let mut routes: HashMap<u16, (Arc<str>, Option<&'static str>)> = HashMap::new();
    while let Some(m) = rec.next_message_ref()? {
        let start = *file_start.get_or_insert(m.log_time);
        let rel = m.log_time.saturating_sub(start);
        if rel < from_ns {
            continue;
        }
        if to_ns.is_some_and(|t| rel > t) {
            break;
        }
        let Some(channel) = m.channel else {
            stats.skipped += 1;
            continue;
        };
        let route = match routes.get(&m.channel_id) {
            Some((topic, route)) if Arc::ptr_eq(topic, &channel.topic) => *route,
            _ => {
                let route = allowed
                    .iter()
                    .find(|g| **g == &*channel.topic)
                    .copied()
                    .filter(|g| opts.groups.as_ref().is_none_or(|r| r.is_match(g)));
                routes.insert(m.channel_id, (channel.topic.clone(), route));
                route
            }
        };
        let Some(group) = route else {
            stats.skipped += 1;
            continue;
        };
        match opts.speed {
            Speed::Factor(f) => {
                let (t0, w0) = *first_sent.get_or_insert((m.log_time, tokio::time::Instant::now()));
                let offset = m.log_time.saturating_sub(t0) as f64 / 1e9 / f;
                // A tiny speed overflows to infinity: that means "wait (nearly) forever", not "now".
                let offset = if offset.is_finite() {
                    offset.min(1e9)
                } else {
                    1e9
                };
                if offset > 0.0 {
                    tokio::time::sleep_until(w0 + std::time::Duration::from_secs_f64(offset)).await;
                }
            }
            Speed::Max => {
                since_yield += 1;
                if since_yield >= 1024 {
                    since_yield = 0;
                    tokio::task::yield_now().await;
                }
            }
        }
        let meta = PublishMeta {
            trace: None,
            origin: Origin::Replayed,
        };
        match frontseat_actors::generated::interprocess_publish_encoded(bus, group, m.data, meta) {
            Ok(_) => stats.published += 1,
            Err(e) => {
                stats.undecodable += 1;
                let n = stats.undecodable;
                if n == 1 || (n.is_power_of_two() && n >= 8) {
                    tracing::warn!(error = %e, count = n, "replay: a recorded message does not decode; skipped");
                }
            }
        }
    }
    stats.truncated = rec.truncated().map(str::to_string);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nothing_that_commands_a_vehicle_is_replayable() {
        let r = replayable(ALL);
        assert!(r.contains(&"goby::middleware::frontseat::node_status"));
        assert!(r.contains(&"goby::middleware::frontseat::status"));
        for g in [
            "goby::middleware::frontseat::desired_course",
            "goby::middleware::frontseat::helm_state",
            "goby::middleware::frontseat::command_request",
        ] {
            assert!(!r.contains(&g), "{g} must never be replayed");
        }
    }

    #[tokio::test]
    async fn a_bus_with_a_live_driver_refuses_replay() {
        let bus = Bus::new();
        bus.claim(BusRole::LiveDriver).unwrap();
        let e = replay(
            &bus,
            Path::new("/nonexistent.mcap"),
            &ReplayOptions::default(),
        )
        .await
        .unwrap_err();
        assert!(
            matches!(e, ReplayError::LiveDriver(BusRole::LiveDriver)),
            "{e}"
        );
    }
}
