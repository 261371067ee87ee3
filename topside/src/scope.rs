//! Each vehicle's scope on the topside: for every interprocess group of `interface_yaml/` heard
//! under a platform's key, the newest payload, how many came, their rate and the newest one's age.
//! Payloads are kept as bytes and decoded (by reflection, as the vehicle's own scope does) only
//! when the page asks for that vehicle, so the Zenoh callbacks pay a copy, never a decode.
//!
//! Bounded: vehicles (`max_vehicles`, further platforms refused), groups (only those the
//! generated table knows, one subscription each), bytes kept per message ([`MAX_KEPT_BYTES`];
//! a larger one is shown by its size only) and fields shown per message ([`MAX_FIELDS`]).

use std::collections::{BTreeMap, VecDeque};

use frontseat_actors::groups::GroupInfo;
use serde_json::{Value, json};
use tokio::time::Instant;

use crate::fleet::Refused;

/// Largest payload kept for the page; larger ones are counted and shown by size. Unit: bytes.
pub const MAX_KEPT_BYTES: usize = 16 * 1024;
/// Most values (leaves) shown of one message; the rest is summarised.
pub const MAX_FIELDS: usize = 256;
/// The rate is taken over this many newest arrivals.
const RATE_WINDOW: usize = 16;

#[derive(Debug)]
struct Latest {
    info: &'static GroupInfo,
    /// None when the newest payload was larger than [`MAX_KEPT_BYTES`].
    bytes: Option<Vec<u8>>,
    size: usize,
    count: u64,
    arrivals: VecDeque<Instant>,
}

/// What one group of one vehicle shows, copied out of the lock to be decoded.
#[derive(Debug, Clone)]
pub struct Row {
    pub info: &'static GroupInfo,
    pub bytes: Option<Vec<u8>>,
    pub size: usize,
    pub count: u64,
    pub rate_hz: Option<f64>,
    pub age_s: Option<f64>,
}

#[derive(Debug)]
pub struct Scope {
    vehicles: BTreeMap<String, BTreeMap<&'static str, Latest>>,
    max_vehicles: usize,
}

impl Scope {
    pub fn new(max_vehicles: usize) -> Self {
        Self {
            vehicles: BTreeMap::new(),
            max_vehicles: max_vehicles.max(1),
        }
    }

    /// Takes one sample of `info`'s group for `platform` (the payload already size-checked).
    /// True when this is the first sample of that group of that platform.
    pub fn on_sample(
        &mut self,
        platform: &str,
        info: &'static GroupInfo,
        payload: &[u8],
        now: Instant,
    ) -> Result<bool, Refused> {
        // Looked up before inserting: the name is copied once per vehicle, not per sample.
        if !self.vehicles.contains_key(platform) {
            if self.vehicles.len() >= self.max_vehicles {
                return Err(Refused::TooManyVehicles);
            }
            self.vehicles.insert(platform.to_string(), BTreeMap::new());
        }
        let Some(groups) = self.vehicles.get_mut(platform) else {
            return Err(Refused::TooManyVehicles);
        };
        let first = !groups.contains_key(info.name);
        let l = groups.entry(info.name).or_insert_with(|| Latest {
            info,
            bytes: None,
            size: 0,
            count: 0,
            arrivals: VecDeque::with_capacity(RATE_WINDOW),
        });
        l.size = payload.len();
        if payload.len() <= MAX_KEPT_BYTES {
            // The buffer is reused: no allocation per sample once it has grown.
            let b = l.bytes.get_or_insert_with(Vec::new);
            b.clear();
            b.extend_from_slice(payload);
        } else {
            l.bytes = None;
        }
        l.count += 1;
        if l.arrivals.len() >= RATE_WINDOW {
            l.arrivals.pop_front();
        }
        l.arrivals.push_back(now);
        Ok(first)
    }

    /// The groups heard of `platform`, by name; None for a platform never heard.
    pub fn rows(&self, platform: &str, now: Instant) -> Option<Vec<Row>> {
        let groups = self.vehicles.get(platform)?;
        Some(
            groups
                .values()
                .map(|l| {
                    let (first, last) = (l.arrivals.front(), l.arrivals.back());
                    let rate_hz = match (first, last) {
                        (Some(f), Some(t)) if l.arrivals.len() >= 2 && t > f => {
                            Some((l.arrivals.len() - 1) as f64 / (*t - *f).as_secs_f64())
                        }
                        _ => None,
                    };
                    Row {
                        info: l.info,
                        bytes: l.bytes.clone(),
                        size: l.size,
                        count: l.count,
                        rate_hz,
                        age_s: last.map(|t| now.saturating_duration_since(*t).as_secs_f64()),
                    }
                })
                .collect(),
        )
    }
}

/// Cuts `v` to at most `budget` leaves, depth first: what is left out of an object or array is
/// replaced by one `"…"` entry saying how many values were not shown.
fn bound_fields(v: &mut Value, budget: &mut usize) {
    match v {
        Value::Object(m) => {
            let keys: Vec<String> = m.keys().cloned().collect();
            let mut cut = 0usize;
            for k in keys {
                if *budget == 0 {
                    m.remove(&k);
                    cut += 1;
                    continue;
                }
                if let Some(x) = m.get_mut(&k) {
                    bound_fields(x, budget);
                }
            }
            if cut > 0 {
                m.insert("…".into(), json!(format!("{cut} more fields not shown")));
            }
        }
        Value::Array(a) => {
            let mut keep = 0usize;
            for x in a.iter_mut() {
                if *budget == 0 {
                    break;
                }
                bound_fields(x, budget);
                keep += 1;
            }
            let cut = a.len() - keep;
            if cut > 0 {
                a.truncate(keep);
                a.push(json!(format!("… {cut} more values not shown")));
            }
        }
        _ => *budget = budget.saturating_sub(1),
    }
}

/// The page's view of one vehicle's scope: each group decoded field by field (bounded).
pub fn render(platform: &str, rows: Vec<Row>) -> Value {
    let groups: Vec<Value> = rows
        .into_iter()
        .map(|r| {
            let mut g = json!({
                "group": r.info.name,
                "type": r.info.type_name,
                "count": r.count,
                "rate_hz": r.rate_hz,
                "age_s": r.age_s,
                "bytes": r.size,
            });
            match r.bytes {
                None => {
                    g["error"] = json!(format!(
                        "{} bytes: larger than the {MAX_KEPT_BYTES} bytes the topside keeps",
                        r.size
                    ));
                }
                Some(b) => match frontseat_web::reflect::to_json(r.info.type_name, &b) {
                    Ok(mut m) => {
                        let mut budget = MAX_FIELDS;
                        bound_fields(&mut m, &mut budget);
                        g["msg"] = m;
                    }
                    Err(e) => g["error"] = json!(e.to_string()),
                },
            }
            g
        })
        .collect();
    json!({ "vehicle": platform, "groups": groups })
}

#[cfg(test)]
mod tests {
    use super::*;
    use frontseat_actors::groups;
    use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
        CartesianCoordinate, NodeStatus,
    };
    use prost::Message as _;
    use std::time::Duration;

    fn info(name: &str) -> &'static GroupInfo {
        groups::ALL.iter().find(|g| g.name == name).unwrap()
    }

    #[test]
    fn the_newest_message_is_decoded_with_count_rate_and_age() {
        let t0 = Instant::now();
        let mut s = Scope::new(4);
        let info = info(groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS.name());
        for i in 0..11 {
            let ns = NodeStatus {
                local_fix: Some(CartesianCoordinate {
                    x: i as f64,
                    ..Default::default()
                }),
                ..Default::default()
            };
            let at = t0 + Duration::from_millis(100 * i);
            s.on_sample("auv1", info, &ns.encode_to_vec(), at).unwrap();
        }
        let rows = s.rows("auv1", t0 + Duration::from_secs(2)).unwrap();
        let v = render("auv1", rows);
        let g = &v["groups"][0];
        assert_eq!(g["count"], 11);
        assert!((g["rate_hz"].as_f64().unwrap() - 10.0).abs() < 1e-6, "{g}");
        assert!((g["age_s"].as_f64().unwrap() - 1.0).abs() < 1e-6, "{g}");
        assert_eq!(g["msg"]["local_fix"]["x"], 10.0);
        assert!(s.rows("auv9", t0).is_none());
    }

    #[test]
    fn vehicles_bytes_and_fields_are_bounded() {
        let t0 = Instant::now();
        let mut s = Scope::new(1);
        let raw = info(groups::GOBY_MIDDLEWARE_FRONTSEAT_RAW_IN.name());
        // The first sample of a platform's group says so (the topside then declares its key).
        assert_eq!(s.on_sample("a", raw, b"", t0), Ok(true));
        assert_eq!(
            s.on_sample("b", raw, b"", t0),
            Err(Refused::TooManyVehicles)
        );
        assert_eq!(
            s.on_sample("a", raw, &vec![0u8; MAX_KEPT_BYTES + 1], t0),
            Ok(false)
        );
        let v = render("a", s.rows("a", t0).unwrap());
        assert!(v["groups"][0]["error"].as_str().unwrap().contains("larger"));
        assert!(v["groups"][0].get("msg").is_none());

        let mut wide = json!({"a": (0..1000).collect::<Vec<_>>(), "b": {"c": 1, "d": 2}});
        bound_fields(&mut wide, &mut 10);
        let a = wide["a"].as_array().unwrap();
        assert_eq!(a.len(), 11);
        assert!(a[10].as_str().unwrap().contains("990 more"));
        assert!(wide["…"].as_str().unwrap().contains("1 more"), "{wide}");
    }
}
