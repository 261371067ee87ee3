//! The vehicles reported as AIS targets: each configured vehicle's static data and its newest
//! node_status (with when it was heard), and the reporter that turns them into sentences at the
//! configured rates. A vehicle not heard within `stale_after_s` is not reported, so OpenCPN
//! marks it lost instead of drawing it frozen. Only configured vehicles are reported (their
//! MMSIs are the config's); others are logged once each (bounded) and skipped.

use std::collections::{BTreeMap, BTreeSet};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use frontseat_actors::proto::goby::middleware::frontseat::protobuf::NodeStatus;
use frontseat_config::{AisConfig, AisVehicleConfig};
use tokio::time::Instant;

use crate::ais::{KNOTS_PER_MPS, Position, Static};
use crate::transport::Outputs;

/// Unknown platforms remembered (to log each once); past this they are only counted.
const MAX_UNKNOWN: usize = 256;

struct Target {
    stat: Static,
    last: Option<(NodeStatus, Instant)>,
    /// Whether it was fresh at the last report (a vehicle coming back gets its static data at once).
    fresh: bool,
}

#[derive(Default)]
struct Inner {
    targets: BTreeMap<String, Target>,
    unknown: BTreeSet<String>,
}

/// What the reporter counts besides the outputs' counters.
#[derive(Debug, Default)]
pub struct FeedCounters {
    pub heard: AtomicU64,
    pub unknown: AtomicU64,
    pub stale_skipped: AtomicU64,
}

/// The targets, shared between whoever hears node_status and the reporter.
#[derive(Clone)]
pub struct AisFleet {
    inner: Arc<Mutex<Inner>>,
    pub counters: Arc<FeedCounters>,
}

/// A configured vehicle's static data.
pub fn static_of(v: &AisVehicleConfig) -> Static {
    let len = v.length_m.clamp(0.0, 1022.0);
    let beam = v.beam_m.clamp(0.0, 126.0);
    let half = |x: f64| (x / 2.0).round();
    Static {
        mmsi: v.mmsi,
        name: v
            .label
            .clone()
            .unwrap_or_else(|| v.name.to_uppercase())
            .chars()
            .take(20)
            .collect(),
        ship_type: v.ship_type,
        call_sign: v
            .call_sign
            .clone()
            .unwrap_or_default()
            .chars()
            .take(7)
            .collect(),
        vendor: String::new(),
        to_bow: half(len) as u16,
        to_stern: (len - half(len)).max(0.0) as u16,
        to_port: half(beam) as u8,
        to_starboard: (beam - half(beam)).max(0.0) as u8,
    }
}

/// A node_status as a position report of `mmsi`. Speed is m/s in Goby3, knots in AIS. COG is
/// the node_status's own when given; else the heading when moving (an AUV's heading is its course
/// through the water), else not available, so a stopped target draws no stale vector.
pub fn position_of(mmsi: u32, ns: &NodeStatus) -> Position {
    let sog = Some(ns.speed.over_ground)
        .filter(|s| s.is_finite())
        .map(|s| s.abs() * KNOTS_PER_MPS);
    let heading = ns.pose.heading.filter(|h| h.is_finite());
    let cog = ns
        .pose
        .course_over_ground
        .filter(|c| c.is_finite())
        .or_else(|| heading.filter(|_| sog.is_some_and(|s| s >= 0.05)));
    let g = &ns.global_fix;
    let fix = g.lat.is_finite() && g.lon.is_finite() && g.lat.abs() <= 90.0 && g.lon.abs() <= 180.0;
    Position {
        mmsi,
        lat: fix.then_some(g.lat),
        lon: fix.then_some(g.lon),
        sog_kn: sog,
        cog,
        heading,
        second: (ns.time.is_finite() && ns.time >= 0.0).then_some((ns.time as u64 % 60) as u8),
        accuracy_high: false,
    }
}

impl AisFleet {
    pub fn new(cfg: &AisConfig) -> Self {
        let targets = cfg
            .vehicle
            .iter()
            .map(|v| {
                (
                    v.name.clone(),
                    Target {
                        stat: static_of(v),
                        last: None,
                        fresh: false,
                    },
                )
            })
            .collect();
        Self {
            inner: Arc::new(Mutex::new(Inner {
                targets,
                unknown: BTreeSet::new(),
            })),
            counters: Arc::default(),
        }
    }

    /// A node_status of `platform`, heard now.
    pub fn on_node_status(&self, platform: &str, ns: &NodeStatus) {
        let mut g = self.inner.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(t) = g.targets.get_mut(platform) {
            t.last = Some((ns.clone(), Instant::now()));
            self.counters.heard.fetch_add(1, Ordering::Relaxed);
            return;
        }
        self.counters.unknown.fetch_add(1, Ordering::Relaxed);
        if g.unknown.len() < MAX_UNKNOWN && g.unknown.insert(platform.chars().take(64).collect()) {
            tracing::warn!(platform = %platform.chars().take(64).collect::<String>(), "AIS: vehicle heard but not in the AIS vehicle list (no MMSI): not reported");
        }
    }

    /// The sentences of one reporting round at `now`: a position report of every fresh vehicle,
    /// with its static data when `with_static` or when it has just become fresh.
    pub fn round(&self, now: Instant, stale_after: Duration, with_static: bool) -> Vec<String> {
        let mut g = self.inner.lock().unwrap_or_else(|p| p.into_inner());
        let mut out = Vec::new();
        for t in g.targets.values_mut() {
            let fresh = t
                .last
                .as_ref()
                .filter(|(_, at)| now.saturating_duration_since(*at) <= stale_after);
            let Some((ns, _)) = fresh else {
                if t.last.is_some() {
                    self.counters.stale_skipped.fetch_add(1, Ordering::Relaxed);
                    if t.fresh {
                        tracing::warn!(mmsi = t.stat.mmsi, name = %t.stat.name, "AIS: vehicle stale, no longer reported");
                    }
                }
                t.fresh = false;
                continue;
            };
            out.push(position_of(t.stat.mmsi, ns).type18());
            if with_static || !t.fresh {
                out.push(t.stat.type24a());
                out.push(t.stat.type24b());
            }
            t.fresh = true;
        }
        out
    }
}

/// Reports `fleet` to `out` until dropped: a round every `position_interval_s`, static data
/// every `static_interval_s`.
pub async fn report(fleet: AisFleet, cfg: AisConfig, out: Outputs) {
    let period = Duration::from_secs_f64(cfg.position_interval_s.clamp(0.1, 60.0));
    let static_every = Duration::from_secs_f64(cfg.static_interval_s.clamp(1.0, 360.0));
    let stale = Duration::from_secs_f64(cfg.stale_after_s.clamp(0.1, 3600.0));
    let mut tick = tokio::time::interval(period);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
    let mut last_static: Option<Instant> = None;
    loop {
        tick.tick().await;
        let now = Instant::now();
        let with_static =
            last_static.is_none_or(|t| now.saturating_duration_since(t) >= static_every);
        if with_static {
            last_static = Some(now);
        }
        out.send(&fleet.round(now, stale, with_static));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use frontseat_actors::proto::goby::middleware::frontseat::protobuf::EulerAngles;

    fn cfg() -> AisConfig {
        AisConfig {
            enabled: true,
            vehicle: vec![AisVehicleConfig {
                name: "auv1".into(),
                mmsi: 299_000_001,
                label: None,
                ship_type: 33,
                call_sign: None,
                length_m: 4.0,
                beam_m: 2.0,
            }],
            ..Default::default()
        }
    }

    #[tokio::test(start_paused = true)]
    async fn a_stale_vehicle_stops_being_reported_and_comes_back_named() {
        let f = AisFleet::new(&cfg());
        let stale = Duration::from_secs(5);
        assert!(
            f.round(Instant::now(), stale, true).is_empty(),
            "never heard: nothing"
        );
        let mut ns = NodeStatus {
            time: 30.0,
            pose: EulerAngles {
                heading: Some(90.0),
                ..Default::default()
            },
            ..Default::default()
        };
        ns.global_fix.lat = 42.0;
        ns.global_fix.lon = -71.0;
        ns.speed.over_ground = 1.0;
        f.on_node_status("auv1", &ns);
        f.on_node_status("ghost", &ns);
        let first = f.round(Instant::now(), stale, false);
        assert_eq!(first.len(), 3, "position and, newly fresh, static A and B");
        assert_eq!(f.round(Instant::now(), stale, false).len(), 1);
        tokio::time::advance(Duration::from_secs(6)).await;
        assert!(
            f.round(Instant::now(), stale, true).is_empty(),
            "stale: not reported"
        );
        f.on_node_status("auv1", &ns);
        assert_eq!(f.round(Instant::now(), stale, false).len(), 3);
        assert_eq!(f.counters.unknown.load(Ordering::Relaxed), 1);
    }

    #[test]
    fn a_stopped_vehicle_has_no_course_vector() {
        let mut ns = NodeStatus {
            pose: EulerAngles {
                heading: Some(10.0),
                ..Default::default()
            },
            ..Default::default()
        };
        ns.speed.over_ground = 0.0;
        let p = position_of(299_000_001, &ns);
        assert_eq!((p.cog, p.sog_kn, p.heading), (None, Some(0.0), Some(10.0)));
        ns.speed.over_ground = 1.0;
        assert_eq!(position_of(299_000_001, &ns).cog, Some(10.0));
    }
}
