//! A hostile vehicle cannot make the helm see impossible navigation: the test plays a basic
//! simulator frontseat and an Iver3 UVC (over loopback TCP, its serial-over-IP transport) that
//! mix impossible numbers into their navigation sentences — speed 1e308, −5.1e307 and 1e20,
//! heading 1e308, depth 1e308, pitch and roll ±1e100 — between good ones, and a good sentinel at
//! the end. Everything the interface publishes towards the helm (node_status, data_from_frontseat,
//! the Iver3's extended iver_data_from_frontseat) is collected until the sentinel arrives (the
//! driver and the interface handle lines in order, so by then every hostile line was handled);
//! none may carry a value outside `[limits.navigation]`, and the refusals are counted per field.

mod common;

use frontseat_actors::bus::test_util::UntypedBus as _;
use std::time::Duration;

use common::logcap::{accept_start, played_frontseat};
use frontseat_actors::bus::{Bus, Envelope};
use frontseat_actors::groups;
use frontseat_actors::interface::{InterfaceService, Snapshot};
use frontseat_actors::nav_gate::{NavField, NavLimits};
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::NodeStatus;
use frontseat_config::TransportKind;
use frontseat_iver3::codec::{Compass, Osi, Sentence};
use tokio::io::AsyncWriteExt;
use tokio::sync::mpsc::UnboundedReceiver;

const SENTINEL_LAT: f64 = 42.5;
const WAIT: Duration = Duration::from_secs(20);

/// Asserts what a helm may be shown; returns the message's latitude.
fn assert_fit_for_helm(ns: &NodeStatus, where_: &str) -> f64 {
    let l = NavLimits::default();
    let ok = |v: f64, lo: f64, hi: f64| v.is_finite() && (lo..=hi).contains(&v);
    assert!(
        ok(ns.speed.over_ground, -l.max_abs_speed, l.max_abs_speed),
        "{where_}: speed {ns:?}"
    );
    if let Some(h) = ns.pose.heading {
        assert!(ok(h, 0.0, 359.999_999), "{where_}: heading {ns:?}");
    }
    if let Some(d) = ns.global_fix.depth {
        assert!(ok(d, l.min_depth, l.max_depth), "{where_}: depth {ns:?}");
    }
    for v in [ns.pose.pitch, ns.pose.roll].into_iter().flatten() {
        assert!(ok(v, -180.0, 180.0), "{where_}: pose {ns:?}");
    }
    if let Some(a) = ns.global_fix.altitude {
        assert!(ok(a, 0.0, l.max_altitude), "{where_}: altitude {ns:?}");
    }
    ns.global_fix.lat
}

/// Collects node_status until the sentinel's arrives, checking every one.
async fn until_sentinel(rx: &mut UnboundedReceiver<Envelope<NodeStatus>>) -> Vec<NodeStatus> {
    let mut seen = Vec::new();
    tokio::time::timeout(WAIT, async {
        while let Some(env) = rx.recv().await {
            let lat = assert_fit_for_helm(&env.msg, "node_status");
            seen.push((*env.msg).clone());
            if (lat - SENTINEL_LAT).abs() < 1e-6 {
                return;
            }
        }
        panic!("node_status channel closed");
    })
    .await
    .expect("the sentinel's node_status reaches the bus");
    seen
}

fn count(s: &Snapshot, f: NavField) -> u64 {
    s.nav_field_violations[f.index()]
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_hostile_basic_simulator_never_puts_impossible_navigation_on_the_bus() {
    let (listener, cfg) = played_frontseat("hostile-auv").await;
    let bus = Bus::new();
    let (_s1, mut nav) =
        bus.subscribe_channel(&groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS, "t", 1000);
    let (_s2, mut data) = bus.subscribe_channel(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_DATA_FROM_FRONTSEAT,
        "t",
        1000,
    );
    let service = InterfaceService::start(&cfg, &bus, frontseat_drivers::BUILT_IN)
        .await
        .unwrap();
    let (_rd, mut wr) = accept_start(&listener).await;

    let good = |lat: f64| format!("NAV,LAT:{lat},LON:-71.08,DEPTH:2,HEADING:90,SPEED:1.5\r\n");
    let mut lines = good(42.358);
    for speed in ["1e308", "-5.1e307", "1e20"] {
        lines.push_str(&format!(
            "NAV,LAT:42.358,LON:-71.08,DEPTH:2,HEADING:90,SPEED:{speed}\r\n"
        ));
    }
    lines.push_str("NAV,LAT:42.358,LON:-71.08,DEPTH:2,HEADING:1e308,SPEED:1.5\r\n");
    lines.push_str("NAV,LAT:42.358,LON:-71.08,DEPTH:1e308,HEADING:90,SPEED:1.5\r\n");
    lines.push_str("NAV,LAT:42.358,LON:-71.08,DEPTH:2,HEADING:-90,SPEED:1.5\r\n");
    lines.push_str(&good(SENTINEL_LAT));
    wr.write_all(lines.as_bytes()).await.unwrap();

    let seen = until_sentinel(&mut nav).await;
    assert_eq!(seen.len(), 3, "the good ones, and only them: {seen:?}");
    assert_eq!(seen[1].pose.heading, Some(270.0), "−90 wrapped");
    while let Ok(env) = data.try_recv() {
        if let Some(ns) = &env.msg.node_status {
            assert_fit_for_helm(ns, "data_from_frontseat");
        }
    }
    let snap = service.snapshot(WAIT).await.expect("a snapshot");
    assert_eq!(snap.nav_refused, 5);
    assert_eq!(count(&snap, NavField::SpeedOverGround), 3);
    assert_eq!(count(&snap, NavField::Heading), 1);
    assert_eq!(count(&snap, NavField::Depth), 1);
    let _ = service.shutdown(Duration::from_secs(3)).await;
}

fn osi(lat: f64, speed_kn: f64, heading: f64, depth_ft: f64) -> String {
    let o = Osi {
        fin_motor: "7F7F7F7F80".into(),
        mode: "N".into(),
        next_wp: "0".into(),
        lat,
        lon: -71.08,
        speed_kn,
        dist_to_next: "0.0".into(),
        error: "N".into(),
        altimeter_ft: 100.0,
        park_time: "P0".into(),
        mag_declination: "-14.5".into(),
        mission: "none".into(),
        remaining_time: "0".into(),
        heading,
        depth_ft,
    };
    format!("{}\r\n", Sentence::Osi(Box::new(o)).to_line())
}

fn compass(pitch: f64, roll: f64) -> String {
    let c = Compass {
        heading: 90.0,
        pitch,
        roll,
        temperature: 10.0,
        depth_ft: 6.0,
    };
    format!("{}\r\n", Sentence::Compass(c).to_line())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_hostile_iver3_never_puts_impossible_navigation_on_the_bus() {
    let (listener, mut cfg) = played_frontseat("hostile-iver").await;
    cfg.driver.name = "iver3".into();
    cfg.driver.iver3.remote_helm_version_major = Some(5);
    cfg.driver.iver3.link.transport = TransportKind::Tcp;
    cfg.driver.iver3.link.tcp_port = listener.local_addr().unwrap().port();
    let bus = Bus::new();
    let (_s1, mut nav) =
        bus.subscribe_channel(&groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS, "t", 1000);
    let (_s2, mut iver) =
        bus.subscribe_channel(&groups::FRONTSEAT_IVER_IVER_DATA_FROM_FRONTSEAT, "t", 1000);
    let service = InterfaceService::start(&cfg, &bus, frontseat_drivers::BUILT_IN)
        .await
        .unwrap();
    let (sock, _) = tokio::time::timeout(WAIT, listener.accept())
        .await
        .expect("the driver connects")
        .unwrap();
    let (_rd, mut wr) = sock.into_split();

    let mut lines = osi(42.358, 2.0, 90.0, 6.0);
    for speed_kn in [1e308, -5.1e307, 1e20] {
        lines.push_str(&osi(42.358, speed_kn, 90.0, 6.0));
    }
    lines.push_str(&osi(42.358, 2.0, 1e308, 6.0));
    lines.push_str(&osi(42.358, 2.0, 90.0, 1e308));
    lines.push_str(&osi(42.359, 2.0, 90.0, 6.0));
    // A compass string republishes the last $OSI with its pitch and roll: impossible ones are
    // dropped, the rest of the navigation goes on.
    lines.push_str(&compass(1e100, -1e100));
    lines.push_str(&osi(SENTINEL_LAT, 2.0, 90.0, 6.0));
    wr.write_all(lines.as_bytes()).await.unwrap();

    let seen = until_sentinel(&mut nav).await;
    assert_eq!(seen.len(), 4, "three good $OSI and the compass: {seen:?}");
    assert_eq!((seen[2].pose.pitch, seen[2].pose.roll), (None, None));
    assert_eq!(
        seen[2].global_fix.lat, 42.359,
        "the rest of the compass's navigation"
    );
    let mut extended = 0;
    while let Ok(env) = iver.try_recv() {
        if let Some(ns) = &env.msg.node_status {
            assert_fit_for_helm(ns, "iver_data_from_frontseat");
            extended += 1;
        }
    }
    assert_eq!(extended, 3, "the three good $OSI, extended");
    let snap = service.snapshot(WAIT).await.expect("a snapshot");
    assert_eq!(snap.nav_refused, 5);
    assert_eq!(count(&snap, NavField::SpeedOverGround), 3);
    assert_eq!(count(&snap, NavField::Heading), 1);
    assert_eq!(count(&snap, NavField::Depth), 1);
    // The driver carries the last pitch and roll into the next $OSI (the sentinel): dropped there
    // too. The extended copies are gated but not counted twice.
    assert_eq!(count(&snap, NavField::Pitch), 2);
    assert_eq!(count(&snap, NavField::Roll), 2);
    assert_eq!(snap.nav_fields_dropped, 4);
    let _ = service.shutdown(Duration::from_secs(3)).await;
}
