//! The real topside (`Topside::start`) reaching a vehicle over `tls/127.0.0.1` with mutual TLS
//! and access by certificate common name, from its `[zenoh.tls]`/`[zenoh.access]` sections:
//! the vehicle it lists appears; a vehicle whose certificate's common name is not listed does
//! not, though it reaches the same topside over the same kind of link.

use std::sync::{Arc, Mutex};
use std::time::Duration;

use frontseat_actors::groups;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CartesianCoordinate, NodeStatus,
};
use frontseat_config::{InterprocessConfig, ServiceConfig, ZenohAccessConfig, ZenohTlsConfig};
use frontseat_helm_side::{key_for, put_message, zenoh};
use frontseat_topside::{Topside, TopsideConfig};

#[path = "../../helm_side/tests/support/certs.rs"]
mod certs;
use certs::{Ca, TempDir, free_port};

const WAIT: Duration = Duration::from_secs(20);
const QUIET: Duration = Duration::from_secs(2);

async fn vehicle(port: u16, tls: ZenohTlsConfig) -> zenoh::Session {
    let ip = InterprocessConfig {
        enabled: true,
        listen: vec![format!("tls/127.0.0.1:{port}")],
        tls: Some(tls),
        ..Default::default()
    };
    zenoh::open(frontseat_helm_side::zenoh_config(&ip, 65536).unwrap())
        .await
        .unwrap()
}

/// Starts a topside connected to both vehicles with `access`, and sends from both until auv1 is
/// heard (bounded), then for [`QUIET`] more; whether the rogue was heard.
async fn rogue_heard(
    ca: &Ca,
    ports: (u16, u16),
    vehicles: (&zenoh::Session, &zenoh::Session),
    access: Option<ZenohAccessConfig>,
) -> bool {
    let mut cfg = TopsideConfig::default();
    cfg.web.listen = "127.0.0.1:0".into();
    cfg.zenoh.connect = vec![
        format!("tls/127.0.0.1:{}", ports.0),
        format!("tls/127.0.0.1:{}", ports.1),
    ];
    cfg.zenoh.tls = Some(ca.tls_for("topside"));
    cfg.zenoh.access = access;
    assert_eq!(cfg.validate(), vec![], "the topside's config is valid");
    let seen = Arc::new(Mutex::new(Vec::<String>::new()));
    let s = seen.clone();
    let observer: frontseat_topside::Observer = Arc::new(move |platform: &str, _: &NodeStatus| {
        s.lock().unwrap().push(platform.to_string());
    });
    let top = Topside::start_observed(&cfg, Some(observer)).await.unwrap();

    let type_name = groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS.type_name();
    let send = || {
        for (s, name) in [(vehicles.0, "auv1"), (vehicles.1, "rogue")] {
            let key = key_for(name, groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS.name());
            // The topside takes only a node_status with a position.
            let msg = NodeStatus {
                name: Some(name.into()),
                local_fix: Some(CartesianCoordinate {
                    x: 1.0,
                    y: 2.0,
                    ..Default::default()
                }),
                ..Default::default()
            };
            put_message(s, &key, type_name, &msg, None).unwrap();
        }
    };
    let heard = |name: &str| seen.lock().unwrap().iter().any(|p| p == name);
    let deadline = tokio::time::Instant::now() + WAIT;
    while !heard("auv1") {
        assert!(
            tokio::time::Instant::now() < deadline,
            "auv1 never reached the topside"
        );
        send();
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    let end = tokio::time::Instant::now() + QUIET;
    while tokio::time::Instant::now() < end && !heard("rogue") {
        send();
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    top.shutdown().await;
    heard("rogue")
}

#[tokio::test(flavor = "multi_thread")]
async fn the_topside_sees_a_listed_vehicle_over_mutual_tls_and_not_an_unlisted_one() {
    let dir = TempDir::new("topside");
    let ca = Ca::new(&dir.0, "fleet-ca");
    let ports = (free_port(), free_port());
    let auv1 = vehicle(ports.0, ca.tls_for("auv1")).await;
    let rogue = vehicle(ports.1, ca.tls_for("rogue")).await;
    let access = ZenohAccessConfig {
        vehicles: vec!["auv1".into()],
        allow_local_tcp: false,
        ..Default::default()
    };
    assert!(
        !rogue_heard(&ca, ports, (&auv1, &rogue), Some(access)).await,
        "an unlisted common name reached the topside"
    );
    // The control: the same rogue, with its valid certificate, is heard when no list is set.
    assert!(
        rogue_heard(&ca, ports, (&auv1, &rogue), None).await,
        "without [zenoh.access] every fleet certificate is heard"
    );
}
