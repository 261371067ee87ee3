//! The topside's `[ais]` end to end: vehicles publish node_status over a real Zenoh session on
//! loopback, the topside's supervised children (the page server and the AIS reporter, from
//! `frontseat_topside::children`, as `frontseat topside` starts them) report the configured ones
//! as AIS targets over UDP; a vehicle not in `[[ais.vehicle]]` is never reported, and a vehicle
//! that goes silent stops being reported.

use std::time::Duration;

use frontseat_actors::groups;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CartesianCoordinate, EulerAngles, NodeStatus,
};
use frontseat_actors::supervisor::SupervisorHandle;
use frontseat_config::AisVehicleConfig;
use frontseat_helm_side::{key_for, put_message, zenoh};
use frontseat_topside::TopsideConfig;

const BOUND: Duration = Duration::from_secs(20);

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// (message type, MMSI) of an `!AIVDM` sentence.
fn head(line: &str) -> Option<(u64, u64)> {
    let payload = line.split(',').nth(5)?;
    let mut bits = Vec::new();
    for c in payload.bytes().take(7) {
        let mut v = c.wrapping_sub(48);
        if v > 40 {
            v -= 8;
        }
        bits.extend((0..6).rev().map(|i| u64::from((v >> i) & 1)));
    }
    let uint = |o: usize, w: usize| {
        bits.get(o..o + w)
            .map(|b| b.iter().fold(0, |a, x| (a << 1) | x))
    };
    Some((uint(0, 6)?, uint(8, 30)?))
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn configured_vehicles_are_reported_and_a_silent_one_stops() {
    let port = free_port();
    let ip = frontseat_config::InterprocessConfig {
        enabled: true,
        listen: vec![format!("tcp/127.0.0.1:{port}")],
        ..Default::default()
    };
    let z = zenoh::open(frontseat_helm_side::zenoh_config(&ip, 65536).unwrap())
        .await
        .unwrap();
    let ais = tokio::net::UdpSocket::bind("127.0.0.1:0").await.unwrap();
    let mut cfg = TopsideConfig::default();
    cfg.zenoh.connect = vec![format!("tcp/127.0.0.1:{port}")];
    cfg.web.listen = "127.0.0.1:0".into();
    cfg.ais.enabled = true;
    cfg.ais.udp = vec![ais.local_addr().unwrap().to_string()];
    cfg.ais.position_interval_s = 0.2;
    cfg.ais.stale_after_s = 0.5;
    cfg.ais.vehicle = vec![AisVehicleConfig {
        name: "auv1".into(),
        mmsi: 299_000_001,
        label: None,
        ship_type: 33,
        call_sign: None,
        length_m: 4.0,
        beam_m: 2.0,
    }];
    let root = SupervisorHandle::start("topside", frontseat_topside::children(cfg, None), None)
        .await
        .unwrap();
    let mut ns = NodeStatus {
        local_fix: Some(CartesianCoordinate {
            x: 1.0,
            y: 2.0,
            ..Default::default()
        }),
        pose: EulerAngles {
            heading: Some(45.0),
            ..Default::default()
        },
        ..Default::default()
    };
    ns.global_fix.lat = 42.36;
    ns.global_fix.lon = -71.08;
    ns.speed.over_ground = 1.0;
    let g = &groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS;
    let mut buf = vec![0u8; 4096];
    let (mut position, mut name) = (false, false);
    let t0 = tokio::time::Instant::now();
    // Heard: reported (position and static data); `ghost` is not configured.
    while !(position && name) {
        assert!(t0.elapsed() < BOUND, "auv1 not reported within {BOUND:?}");
        for p in ["auv1", "ghost"] {
            put_message(&z, &key_for(p, g.name()), g.type_name(), &ns, None).unwrap();
        }
        let Ok(Ok(n)) = tokio::time::timeout(Duration::from_millis(100), ais.recv(&mut buf)).await
        else {
            continue;
        };
        for l in String::from_utf8_lossy(&buf[..n]).lines() {
            let (kind, mmsi) = head(l).unwrap();
            assert_eq!(mmsi, 299_000_001, "only the configured vehicle: {l}");
            position |= kind == 18;
            name |= kind == 24;
        }
    }
    // Silent: after stale_after_s nothing more is sent (the reports stop, they do not freeze).
    let quiet_since = loop {
        assert!(
            t0.elapsed() < BOUND * 2,
            "auv1 still reported long after it went silent"
        );
        match tokio::time::timeout(Duration::from_secs(1), ais.recv(&mut buf)).await {
            Err(_) => break t0.elapsed(),
            Ok(r) => {
                r.unwrap();
            }
        }
    };
    println!("reported, then quiet at {quiet_since:?}");
    root.shutdown(Duration::from_secs(3)).await;
}
