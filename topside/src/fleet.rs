//! What the topside knows of the fleet, as plain data with the clock passed in: per vehicle its
//! last navigation, its track (bounded), its interface's state and errors, its helm's last
//! commanded course, when it was last heard, and so whether it is stale. Vehicles are never
//! removed; the number of vehicles and of track points is bounded.
//!
//! Every track point carries a fleet-wide sequence number, so that a page polling the fleet asks
//! only for the points it has not seen (`snapshot(.., Some(after))`): with 1 000 vehicles of
//! thousands of points each, sending every track every second was megabytes a poll.

use std::collections::{BTreeMap, VecDeque};
use std::time::Duration;

use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    DesiredCourse, InterfaceStatus, NodeStatus,
};
use frontseat_actors::state_machine::state_words;
use serde_json::{Value, json};
use tokio::time::Instant;

/// A track point is kept when the vehicle moved at least this far from the last one. Unit: m.
const TRACK_STEP_M: f64 = 1.0;

/// One point of a track: x and y on the vehicle's local grid (m) and its fleet-wide number.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackPoint {
    pub x: f64,
    pub y: f64,
    pub seq: u64,
}

#[derive(Debug, Clone, Default)]
pub struct Vehicle {
    pub nav: Option<Nav>,
    pub track: VecDeque<TrackPoint>,
    pub status: Option<InterfaceStatus>,
    pub course: Option<(f64, f64)>,
    pub last_heard: Option<Instant>,
    pub node_status_count: u64,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Nav {
    pub x: f64,
    pub y: f64,
    pub lat: Option<f64>,
    pub lon: Option<f64>,
    pub heading: f64,
    pub speed: f64,
}

/// Why a publication was not taken in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Refused {
    /// A new platform past `max_vehicles`.
    TooManyVehicles,
    /// A value outside physical bounds (NaN, a speed of 1e308).
    Implausible,
}

#[derive(Debug)]
pub struct Fleet {
    vehicles: BTreeMap<String, Vehicle>,
    /// The newest track point's number (0: none yet).
    track_seq: u64,
    max_vehicles: usize,
    track_points: usize,
    stale_after: Duration,
}

fn finite_within(v: f64, bound: f64) -> bool {
    v.is_finite() && v.abs() <= bound
}

impl Fleet {
    pub fn new(max_vehicles: usize, track_points: usize, stale_after: Duration) -> Self {
        Self {
            vehicles: BTreeMap::new(),
            track_seq: 0,
            max_vehicles: max_vehicles.max(1),
            track_points: track_points.max(2),
            stale_after,
        }
    }

    fn vehicle(&mut self, platform: &str) -> Result<&mut Vehicle, Refused> {
        // Looked up before inserting: the name is copied once per vehicle, not per sample.
        if !self.vehicles.contains_key(platform) {
            if self.vehicles.len() >= self.max_vehicles {
                return Err(Refused::TooManyVehicles);
            }
            self.vehicles
                .insert(platform.to_string(), Vehicle::default());
        }
        self.vehicles
            .get_mut(platform)
            .ok_or(Refused::TooManyVehicles)
    }

    pub fn len(&self) -> usize {
        self.vehicles.len()
    }

    pub fn is_empty(&self) -> bool {
        self.vehicles.is_empty()
    }

    pub fn get(&self, platform: &str) -> Option<&Vehicle> {
        self.vehicles.get(platform)
    }

    pub fn on_node_status(
        &mut self,
        platform: &str,
        ns: &NodeStatus,
        now: Instant,
    ) -> Result<(), Refused> {
        let Some(l) = &ns.local_fix else {
            return Err(Refused::Implausible);
        };
        let heading = ns.pose.heading();
        let speed = ns.speed.over_ground;
        let ok = finite_within(l.x, 1e7)
            && finite_within(l.y, 1e7)
            && finite_within(heading, 3600.0)
            && finite_within(speed, 100.0);
        if !ok {
            return Err(Refused::Implausible);
        }
        let g = &ns.global_fix;
        let (lat, lon) = if finite_within(g.lat, 90.0) && finite_within(g.lon, 180.0) {
            (Some(g.lat), Some(g.lon))
        } else {
            (None, None)
        };
        let cap = self.track_points;
        let seq = self.track_seq + 1;
        let v = self.vehicle(platform)?;
        v.nav = Some(Nav {
            x: l.x,
            y: l.y,
            lat,
            lon,
            heading: heading.rem_euclid(360.0),
            speed,
        });
        let moved = v
            .track
            .back()
            .is_none_or(|p| (l.x - p.x).hypot(l.y - p.y) >= TRACK_STEP_M);
        if moved {
            if v.track.len() >= cap {
                v.track.pop_front();
            }
            v.track.push_back(TrackPoint {
                x: l.x,
                y: l.y,
                seq,
            });
        }
        v.last_heard = Some(now);
        v.node_status_count += 1;
        if moved {
            self.track_seq = seq;
        }
        Ok(())
    }

    pub fn on_status(
        &mut self,
        platform: &str,
        s: &InterfaceStatus,
        now: Instant,
    ) -> Result<(), Refused> {
        let v = self.vehicle(platform)?;
        v.status = Some(*s);
        v.last_heard = Some(now);
        Ok(())
    }

    /// A helm's setpoint to the vehicle: what it was told to do (not proof that it is heard).
    pub fn on_course(&mut self, platform: &str, c: &DesiredCourse) -> Result<(), Refused> {
        let (Some(h), Some(s)) = (c.heading, c.speed) else {
            // A course without heading or speed shows nothing new on the map.
            return Ok(());
        };
        if !(finite_within(h, 3600.0) && finite_within(s, 100.0)) {
            return Err(Refused::Implausible);
        }
        let v = self.vehicle(platform)?;
        v.course = Some((h.rem_euclid(360.0), s));
        Ok(())
    }

    /// The page's view of the fleet at `now`. Without `tracks_after`, every vehicle's whole track
    /// as `[x, y]` points; with it, only the points numbered after it, as `[x, y, number]`, and
    /// each vehicle's `track_from` (its oldest point kept: a page drops what is older). The
    /// newest number is `track_seq`.
    pub fn snapshot(
        &self,
        now: Instant,
        links: &BTreeMap<String, String>,
        tracks_after: Option<u64>,
    ) -> Value {
        self.view(now, tracks_after).json(links)
    }

    /// What [`snapshot`](Self::snapshot) shows, copied out (only the track points asked for),
    /// so that the caller renders it after letting go of the lock the Zenoh callbacks take.
    pub fn view(&self, now: Instant, tracks_after: Option<u64>) -> View {
        let vehicles = self
            .vehicles
            .iter()
            .map(|(name, v)| {
                let age = v.last_heard.map(|t| now.saturating_duration_since(t));
                // Numbers grow along a track: the new points are its tail.
                let from = tracks_after.map_or(0, |a| v.track.partition_point(|p| p.seq <= a));
                VehicleView {
                    name: name.clone(),
                    stale: age.is_none_or(|a| a > self.stale_after),
                    age_s: age.map(|a| a.as_secs_f64()),
                    nav: v.nav,
                    course: v.course,
                    status: v.status,
                    track: v.track.range(from..).copied().collect(),
                    track_from: v.track.front().map(|p| p.seq),
                    node_status_count: v.node_status_count,
                }
            })
            .collect();
        View {
            vehicles,
            stale_after_s: self.stale_after.as_secs_f64(),
            track_seq: self.track_seq,
            numbered: tracks_after.is_some(),
        }
    }
}

/// A copy of the fleet for the page (see [`Fleet::view`]).
#[derive(Debug, Clone)]
pub struct View {
    vehicles: Vec<VehicleView>,
    stale_after_s: f64,
    track_seq: u64,
    /// Track points with their numbers (a page asked for the new ones only).
    numbered: bool,
}

#[derive(Debug, Clone)]
struct VehicleView {
    name: String,
    stale: bool,
    age_s: Option<f64>,
    nav: Option<Nav>,
    course: Option<(f64, f64)>,
    status: Option<InterfaceStatus>,
    track: Vec<TrackPoint>,
    track_from: Option<u64>,
    node_status_count: u64,
}

impl View {
    pub fn json(&self, links: &BTreeMap<String, String>) -> Value {
        let vehicles: Vec<Value> = self
            .vehicles
            .iter()
            .map(|v| {
                let status = v.status.as_ref().map(|s| {
                    json!({
                        "state": state_words(s.state()),
                        "frontseat": s.frontseat_state().as_str_name(),
                        "helm": s.helm_state().as_str_name(),
                        "helm_error": s.helm_error.map(|_| s.helm_error().as_str_name()),
                        "frontseat_error": s.frontseat_error.map(|_| s.frontseat_error().as_str_name()),
                    })
                });
                let track: Vec<Value> = if self.numbered {
                    v.track.iter().map(|p| json!([p.x, p.y, p.seq])).collect()
                } else {
                    v.track.iter().map(|p| json!([p.x, p.y])).collect()
                };
                json!({
                    "name": v.name,
                    "stale": v.stale,
                    "age_s": v.age_s,
                    "nav": v.nav.map(|n| json!({
                        "x": n.x, "y": n.y, "lat": n.lat, "lon": n.lon,
                        "heading": n.heading, "speed": n.speed,
                    })),
                    "course": v.course.map(|(h, s)| json!({"heading": h, "speed": s})),
                    "status": status,
                    "track": track,
                    "track_from": v.track_from,
                    "node_status_count": v.node_status_count,
                    "page": links.get(&v.name),
                })
            })
            .collect();
        json!({
            "vehicles": vehicles,
            "stale_after_s": self.stale_after_s,
            "track_seq": self.track_seq,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use frontseat_actors::proto::goby::middleware::frontseat::protobuf::CartesianCoordinate;
    use frontseat_actors::proto::goby::middleware::frontseat::protobuf::InterfaceState;

    fn ns(x: f64, y: f64) -> NodeStatus {
        NodeStatus {
            local_fix: Some(CartesianCoordinate {
                x,
                y,
                ..Default::default()
            }),
            ..Default::default()
        }
    }

    #[test]
    fn a_silent_vehicle_turns_stale_and_stays() {
        let t0 = Instant::now();
        let mut f = Fleet::new(10, 100, Duration::from_secs(5));
        f.on_node_status("auv1", &ns(1.0, 2.0), t0).unwrap();
        let links = BTreeMap::new();
        let fresh = f.snapshot(t0 + Duration::from_secs(1), &links, None);
        assert_eq!(fresh["vehicles"][0]["stale"], false);
        let later = f.snapshot(t0 + Duration::from_secs(6), &links, None);
        assert_eq!(later["vehicles"][0]["stale"], true);
        assert_eq!(later["vehicles"][0]["nav"]["x"], 1.0);
    }

    #[test]
    fn vehicles_and_track_points_are_bounded() {
        let t0 = Instant::now();
        let mut f = Fleet::new(2, 3, Duration::from_secs(5));
        f.on_node_status("a", &ns(0.0, 0.0), t0).unwrap();
        f.on_node_status("b", &ns(0.0, 0.0), t0).unwrap();
        assert_eq!(
            f.on_node_status("c", &ns(0.0, 0.0), t0),
            Err(Refused::TooManyVehicles)
        );
        for i in 1..10 {
            f.on_node_status("a", &ns(i as f64 * 2.0, 0.0), t0).unwrap();
        }
        assert_eq!(f.get("a").unwrap().track.len(), 3);
        let last = f.get("a").unwrap().track.back().copied().unwrap();
        assert_eq!((last.x, last.y), (18.0, 0.0));
    }

    #[test]
    fn impossible_navigation_is_refused_and_keeps_the_last_good_one() {
        let t0 = Instant::now();
        let mut f = Fleet::new(2, 3, Duration::from_secs(5));
        f.on_node_status("a", &ns(5.0, 5.0), t0).unwrap();
        assert_eq!(
            f.on_node_status("a", &ns(f64::NAN, 0.0), t0),
            Err(Refused::Implausible)
        );
        let mut fast = ns(1.0, 1.0);
        fast.speed.over_ground = 1e308;
        assert_eq!(f.on_node_status("a", &fast, t0), Err(Refused::Implausible));
        assert_eq!(f.get("a").unwrap().nav.unwrap().x, 5.0);
    }

    #[test]
    fn status_and_course_show_up_in_the_snapshot() {
        let t0 = Instant::now();
        let mut f = Fleet::new(2, 3, Duration::from_secs(5));
        let s = InterfaceStatus {
            state: Some(InterfaceState::InterfaceCommand as i32),
            ..Default::default()
        };
        f.on_status("a", &s, t0).unwrap();
        f.on_course(
            "a",
            &DesiredCourse {
                heading: Some(450.0),
                speed: Some(1.5),
                ..Default::default()
            },
        )
        .unwrap();
        let snap = f.snapshot(t0, &BTreeMap::new(), None);
        assert_eq!(snap["vehicles"][0]["status"]["state"], "running:command");
        assert_eq!(snap["vehicles"][0]["course"]["heading"], 90.0);
    }

    #[test]
    fn a_page_gets_only_the_track_points_it_has_not_seen() {
        let t0 = Instant::now();
        let mut f = Fleet::new(2, 3, Duration::from_secs(5));
        let links = BTreeMap::new();
        // a: points 1, 3, 5, 6 (the first dropped by the bound of 3); b: points 2, 4.
        f.on_node_status("a", &ns(0.0, 0.0), t0).unwrap();
        f.on_node_status("b", &ns(0.0, 0.0), t0).unwrap();
        f.on_node_status("a", &ns(2.0, 0.0), t0).unwrap();
        // Not a metre: no point, no number taken.
        f.on_node_status("a", &ns(2.5, 0.0), t0).unwrap();
        f.on_node_status("b", &ns(2.0, 0.0), t0).unwrap();
        f.on_node_status("a", &ns(4.0, 0.0), t0).unwrap();
        f.on_node_status("a", &ns(6.0, 0.0), t0).unwrap();
        let full = f.snapshot(t0, &links, None);
        assert_eq!(full["track_seq"], 6);
        assert_eq!(
            full["vehicles"][0]["track"],
            json!([[2.0, 0.0], [4.0, 0.0], [6.0, 0.0]])
        );
        assert_eq!(full["vehicles"][0]["track_from"], 3);
        let since = f.snapshot(t0, &links, Some(4));
        assert_eq!(
            since["vehicles"][0]["track"],
            json!([[4.0, 0.0, 5], [6.0, 0.0, 6]])
        );
        assert_eq!(since["vehicles"][1]["track"], json!([]));
        assert_eq!(since["vehicles"][1]["track_from"], 2);
        let none_new = f.snapshot(t0, &links, Some(6));
        assert_eq!(none_new["vehicles"][0]["track"], json!([]));
    }
}
