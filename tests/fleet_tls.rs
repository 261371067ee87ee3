//! The real `frontseat interface` binary over Zenoh mutual TLS: a `frontseat sim` and a
//! `frontseat interface` child whose `[interprocess]` listens on `tls/127.0.0.1` with
//! `[interprocess.tls]` (mutual by default) and `[interprocess.access]`, certificates made at test
//! time with rcgen. A topside (in this process, `[zenoh.tls]` + `[zenoh.access]`) that lists the
//! vehicle's common name hears its node_status; one that lists only another vehicle hears that
//! other vehicle (so its TLS link works) and never this one. Every wait is bounded.

#[path = "../helm_side/tests/support/certs.rs"]
mod certs;
mod common;

use std::process::{Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use certs::{Ca, TempDir};
use common::procs::{Kill, free_port, wait_for_tcp};
use frontseat_actors::groups;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CartesianCoordinate, NodeStatus,
};
use frontseat_config::{InterprocessConfig, ServiceConfig, ZenohAccessConfig, ZenohTlsConfig};
use frontseat_helm_side::{key_for, put_message, zenoh};
use frontseat_topside::{Topside, TopsideConfig};

const BIN: &str = env!("CARGO_BIN_EXE_frontseat");
const WAIT: Duration = Duration::from_secs(30);
/// How long a topside must go on not hearing a vehicle its access list leaves out, while it
/// hears a listed one and the vehicle publishes (status_period 0.2 s, NAV at 10 Hz).
const QUIET: Duration = Duration::from_secs(3);

fn tls_toml(t: &ZenohTlsConfig) -> String {
    let q = |v: &Option<String>| format!("{:?}", v.as_deref().unwrap_or_default());
    format!(
        "root_ca_certificate = {}\ncertificate = {}\nprivate_key = {}\n",
        q(&t.root_ca_certificate),
        q(&t.certificate),
        q(&t.private_key)
    )
}

/// A topside over TLS connected to `endpoints`, admitting `allow`; the platform of every
/// node_status its fleet model took in, in order.
async fn topside(
    ca: &Ca,
    endpoints: Vec<String>,
    allow: &[&str],
) -> (Topside, Arc<Mutex<Vec<String>>>) {
    let mut cfg = TopsideConfig::default();
    cfg.web.listen = "127.0.0.1:0".into();
    cfg.zenoh.connect = endpoints;
    cfg.zenoh.tls = Some(ca.tls_for("topside"));
    cfg.zenoh.access = Some(ZenohAccessConfig {
        vehicles: allow.iter().map(|s| s.to_string()).collect(),
        ..Default::default()
    });
    assert_eq!(cfg.validate(), vec![], "the topside's config is valid");
    let seen = Arc::new(Mutex::new(Vec::<String>::new()));
    let s = seen.clone();
    let observer: frontseat_topside::Observer = Arc::new(move |platform: &str, _: &NodeStatus| {
        s.lock().unwrap().push(platform.to_string());
    });
    let top = Topside::start_observed(&cfg, Some(observer))
        .await
        .expect("topside");
    (top, seen)
}

fn heard(seen: &Mutex<Vec<String>>, name: &str) -> bool {
    seen.lock().unwrap().iter().any(|p| p == name)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_interface_binary_reaches_a_topside_over_mutual_tls_only_when_its_name_is_admitted() {
    let dir = TempDir::new("fleet-binary");
    let ca = Ca::new(&dir.0, "fleet-ca");

    let sim_port = free_port();
    let _sim = Kill(
        Command::new(BIN)
            .args(["sim", "--port", &sim_port.to_string()])
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(dir.0.join("sim.log")).unwrap())
            .spawn()
            .unwrap(),
    );
    wait_for_tcp(sim_port).await;
    let zport = free_port();
    let cfg = format!(
        r#"name = "auv1"
status_period = 0.2
[driver]
name = "basic_simulator"
[driver.basic_simulator]
tcp_port = {sim_port}
[interprocess]
enabled = true
listen = ["tls/127.0.0.1:{zport}"]
[interprocess.tls]
{}[interprocess.access]
commanders = ["topside"]
"#,
        tls_toml(&ca.tls_for("auv1"))
    );
    let cfg_path = dir.0.join("auv1.toml");
    std::fs::write(&cfg_path, cfg).unwrap();
    let check = Command::new(BIN)
        .args(["interface", "--check", "-c"])
        .arg(&cfg_path)
        .output()
        .unwrap();
    assert!(
        check.status.success(),
        "{}",
        String::from_utf8_lossy(&check.stderr)
    );
    let log = dir.0.join("interface.log");
    let _interface = Kill(
        Command::new(BIN)
            .arg("interface")
            .arg("-c")
            .arg(&cfg_path)
            .env("RUST_LOG", "info")
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(&log).unwrap())
            .spawn()
            .unwrap(),
    );
    wait_for_tcp(zport).await;
    let vehicle_ep = format!("tls/127.0.0.1:{zport}");
    let interface_log = || std::fs::read_to_string(&log).unwrap_or_default();

    // A topside that admits auv1 hears the binary's node_status over mutual TLS.
    let (admitting, admitted) = topside(&ca, vec![vehicle_ep.clone()], &["auv1"]).await;
    let deadline = tokio::time::Instant::now() + WAIT;
    while !heard(&admitted, "auv1") {
        assert!(
            tokio::time::Instant::now() < deadline,
            "the admitting topside never heard auv1; interface log:\n{}",
            interface_log()
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    }

    // A topside that admits only auv2: it hears auv2 (another vehicle, over the same kind of
    // link, so its TLS works), and not the binary, which goes on publishing meanwhile.
    let auv2_port = free_port();
    let auv2 = zenoh::open(
        frontseat_helm_side::zenoh_config(
            &InterprocessConfig {
                enabled: true,
                listen: vec![format!("tls/127.0.0.1:{auv2_port}")],
                tls: Some(ca.tls_for("auv2")),
                ..Default::default()
            },
            65536,
        )
        .unwrap(),
    )
    .await
    .unwrap();
    let (top, seen) = topside(
        &ca,
        vec![vehicle_ep, format!("tls/127.0.0.1:{auv2_port}")],
        &["auv2"],
    )
    .await;
    let key = key_for("auv2", groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS.name());
    let type_name = groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS.type_name();
    let ns = NodeStatus {
        name: Some("auv2".into()),
        local_fix: Some(CartesianCoordinate {
            x: 1.0,
            y: 2.0,
            ..Default::default()
        }),
        ..Default::default()
    };
    // Zenoh drops a put made before the subscription matched: sent until heard.
    let deadline = tokio::time::Instant::now() + WAIT;
    while !heard(&seen, "auv2") {
        assert!(
            tokio::time::Instant::now() < deadline,
            "the topside never heard the admitted auv2"
        );
        put_message(&auv2, &key, type_name, &ns, None).unwrap();
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    let before = admitted.lock().unwrap().len();
    let quiet_end = tokio::time::Instant::now() + QUIET;
    while tokio::time::Instant::now() < quiet_end {
        assert!(
            !heard(&seen, "auv1"),
            "a topside whose access list leaves auv1 out heard it"
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    // The binary was publishing all along: the admitting topside kept hearing it.
    assert!(
        admitted.lock().unwrap().len() > before,
        "auv1 fell silent during the quiet window; interface log:\n{}",
        interface_log()
    );
    top.shutdown().await;
    admitting.shutdown().await;
    auv2.close().await.unwrap();
}
