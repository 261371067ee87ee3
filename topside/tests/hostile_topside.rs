//! A hostile fleet link (issue 31, item 6): a Zenoh peer on loopback floods the topside's keys
//! with thousands of platforms, undecodable payloads, impossible positions and a vehicle that
//! never stops moving. The topside's model stays inside its bounds (`max_vehicles` vehicles, a
//! track of `track_points`), everything refused is counted, what the page shows is only what
//! passed, and the HTTP server keeps answering.

use std::time::Duration;

use frontseat_actors::groups;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CartesianCoordinate, NodeStatus,
};
use frontseat_helm_side::{key_for, put_message, zenoh};
use frontseat_topside::{Topside, TopsideConfig};
use serde_json::Value;
use tokio::io::{AsyncReadExt, AsyncWriteExt};

const BOUND: Duration = Duration::from_secs(30);
const MAX_VEHICLES: usize = 8;
const TRACK_POINTS: usize = 32;
const FLOOD: u32 = 3000;

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

async fn fleet(addr: std::net::SocketAddr) -> Value {
    let mut s = tokio::net::TcpStream::connect(addr).await.unwrap();
    let req = format!(
        "GET /api/fleet HTTP/1.1\r\nHost: 127.0.0.1:{}\r\nConnection: close\r\n\r\n",
        addr.port()
    );
    s.write_all(req.as_bytes()).await.unwrap();
    let mut buf = Vec::new();
    tokio::time::timeout(BOUND, s.read_to_end(&mut buf))
        .await
        .expect("the topside answers within the bound")
        .unwrap();
    let text = String::from_utf8_lossy(&buf).into_owned();
    assert!(text.starts_with("HTTP/1.1 200"), "{text}");
    let body = text.split_once("\r\n\r\n").map(|(_, b)| b).unwrap_or("");
    serde_json::from_str(body).unwrap()
}

fn vehicles(f: &Value) -> Vec<Value> {
    f["vehicles"].as_array().cloned().unwrap_or_default()
}

fn node_status(x: f64, y: f64) -> NodeStatus {
    NodeStatus {
        local_fix: Some(CartesianCoordinate {
            x,
            y,
            ..Default::default()
        }),
        ..Default::default()
    }
}

#[tokio::test(flavor = "multi_thread")]
async fn a_flood_on_the_fleet_keys_stays_inside_the_topsides_bounds() {
    let port = free_port();
    let ip = frontseat_config::InterprocessConfig {
        enabled: true,
        listen: vec![format!("tcp/127.0.0.1:{port}")],
        ..Default::default()
    };
    let z = zenoh::open(frontseat_helm_side::zenoh_config(&ip, 65536).unwrap())
        .await
        .unwrap();
    let mut cfg = TopsideConfig::default();
    cfg.zenoh.connect = vec![format!("tcp/127.0.0.1:{port}")];
    cfg.web.listen = "127.0.0.1:0".into();
    cfg.max_vehicles = MAX_VEHICLES;
    cfg.track_points = TRACK_POINTS;
    let top = Topside::start(&cfg).await.unwrap();
    let addr = top.local_addr();
    let ns = groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS;
    let put = |platform: &str, m: &NodeStatus| {
        put_message(&z, &key_for(platform, ns.name()), ns.type_name(), m, None).unwrap();
    };

    // The legitimate vehicle first (re-sent until the topside's subscription has matched).
    let deadline = tokio::time::Instant::now() + BOUND;
    let mut x = 0.0;
    loop {
        x += 2.0;
        put("auv1", &node_status(x, 0.0));
        if vehicles(&fleet(addr).await)
            .iter()
            .any(|v| v["name"] == "auv1")
        {
            break;
        }
        assert!(
            tokio::time::Instant::now() < deadline,
            "auv1 never appeared"
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    }

    // The flood: a new platform per message, garbage and impossible positions under auv1's own
    // key, and auv1 moving all the while (a track point per message).
    for i in 0..FLOOD {
        put(&format!("flood{i}"), &node_status(1.0, 1.0));
        z.put(key_for("auv1", ns.name()), vec![0xffu8; 64])
            .await
            .unwrap();
        put("auv1", &node_status(f64::NAN, 1e308));
        x += 2.0;
        put("auv1", &node_status(x, 0.0));
        if i % 200 == 0 {
            // Interleaved reads: the page keeps answering while the flood lasts.
            let _ = fleet(addr).await;
        }
    }

    // Zenoh may shed some of a flood (best effort): wait for a part of each kind to arrive.
    let deadline = tokio::time::Instant::now() + BOUND;
    let c = &top.counters;
    let load = |a: &std::sync::atomic::AtomicU64| a.load(std::sync::atomic::Ordering::Relaxed);
    while load(&c.too_many_vehicles) == 0 || load(&c.undecodable) == 0 || load(&c.implausible) == 0
    {
        assert!(
            tokio::time::Instant::now() < deadline,
            "refusals not counted: too_many {} undecodable {} implausible {}",
            load(&c.too_many_vehicles),
            load(&c.undecodable),
            load(&c.implausible)
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    }

    let f = fleet(addr).await;
    let vs = vehicles(&f);
    assert!(
        vs.len() <= MAX_VEHICLES,
        "{} vehicles on the page, max_vehicles {MAX_VEHICLES}",
        vs.len()
    );
    let auv1 = vs
        .iter()
        .find(|v| v["name"] == "auv1")
        .expect("the legitimate vehicle kept its place");
    let track = auv1["track"].as_array().unwrap();
    assert!(
        !track.is_empty() && track.len() <= TRACK_POINTS,
        "track of {} points, bound {TRACK_POINTS}",
        track.len()
    );
    // Only what passed is shown: a finite position, never the NaN / 1e308 sent beside it.
    let nx = auv1["nav"]["x"].as_f64().expect("a finite x");
    let ny = auv1["nav"]["y"].as_f64().expect("a finite y");
    assert!(nx > 0.0 && ny.abs() < 1.0, "auv1 at ({nx}, {ny})");
    for v in &vs {
        for p in v["track"].as_array().unwrap() {
            assert!(
                p.as_array()
                    .is_none_or(|xy| xy.iter().all(|c| c.as_f64().is_some_and(|c| c.abs() < 1e7)))
            );
        }
    }
    // The refusals are accounted for: at most what was sent, and the platforms past the cap
    // are the bulk of them.
    let refused = load(&c.too_many_vehicles);
    assert!(
        refused <= u64::from(FLOOD),
        "{refused} refusals for {FLOOD} new platforms"
    );
    assert!(
        f["counters"]["too_many_vehicles"].as_u64() >= Some(1),
        "the page counts the refusals: {}",
        f["counters"]
    );
}
