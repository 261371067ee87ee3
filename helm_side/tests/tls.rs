//! Zenoh sessions built by `zenoh_config` from `[interprocess.tls]`/`[interprocess.access]`,
//! talking over real `tls/127.0.0.1` links with certificates made at test time: with mutual TLS
//! the interface's gateway and a topside session exchange node_status and desired_course; a peer without a certificate, or with one from
//! another CA, gets nothing; with access control a certificate whose common name is not listed
//! can neither publish to nor hear the vehicle; and the config checks on the section.

use frontseat_actors::bus::test_util::UntypedBus as _;
use std::time::Duration;

use frontseat_actors::bus::Bus;

use frontseat_actors::groups;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{DesiredCourse, NodeStatus};
use frontseat_config::{InterfaceConfig, InterprocessConfig, ServiceConfig, ZenohAccessConfig};
use frontseat_config::{ZenohTlsConfig, parse};
use frontseat_helm_side::{GatewayOptions, key_for, put_message, zenoh};
use prost::Message;
use tokio::sync::mpsc::{UnboundedReceiver, unbounded_channel};

#[path = "support/certs.rs"]
mod certs;
use certs::{Ca, TempDir, free_port};

const WAIT: Duration = Duration::from_secs(20);
/// How long a peer that must hear nothing is listened to after the control peer has heard.
const QUIET: Duration = Duration::from_secs(2);

fn ns_key(platform: &str) -> String {
    key_for(
        platform,
        groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS.name(),
    )
}

fn ns(name: &str, t: f64) -> NodeStatus {
    NodeStatus {
        name: Some(name.into()),
        time: t,
        ..Default::default()
    }
}

async fn session(
    listen: Vec<String>,
    connect: Vec<String>,
    tls: Option<ZenohTlsConfig>,
    access: Option<ZenohAccessConfig>,
) -> zenoh::Session {
    let ip = InterprocessConfig {
        enabled: true,
        listen,
        connect,
        tls,
        access,
        ..Default::default()
    };
    let cfg = frontseat_helm_side::zenoh_config(&ip, 65536).unwrap();
    zenoh::open(cfg).await.unwrap()
}

/// A subscriber on `key` forwarding each decoded node_status's name.
async fn names_on(
    s: &zenoh::Session,
    key: &str,
) -> (
    zenoh::pubsub::Subscriber<()>,
    UnboundedReceiver<(String, String)>,
) {
    let (tx, rx) = unbounded_channel();
    let sub = s
        .declare_subscriber(key)
        .callback(move |sample| {
            let bytes = sample.payload().to_bytes();
            if let Ok(m) = NodeStatus::decode(bytes.as_ref()) {
                let _ = tx.send((sample.key_expr().to_string(), m.name.unwrap_or_default()));
            }
        })
        .await
        .unwrap();
    (sub, rx)
}

/// Calls `send` until `rx` yields something (bounded by [`WAIT`]).
async fn until_received<T>(mut send: impl FnMut(), rx: &mut UnboundedReceiver<T>, what: &str) -> T {
    let deadline = tokio::time::Instant::now() + WAIT;
    loop {
        send();
        match tokio::time::timeout(Duration::from_millis(100), rx.recv()).await {
            Ok(Some(v)) => return v,
            Ok(None) => panic!("{what}: channel closed"),
            Err(_) if tokio::time::Instant::now() > deadline => {
                panic!("{what}: nothing within {WAIT:?}")
            }
            Err(_) => {}
        }
    }
}

/// Keeps calling `send` for [`QUIET`]; whatever `rx` got meanwhile.
async fn heard_while_sending<T>(mut send: impl FnMut(), rx: &mut UnboundedReceiver<T>) -> Vec<T> {
    let end = tokio::time::Instant::now() + QUIET;
    let mut got = Vec::new();
    while tokio::time::Instant::now() < end {
        send();
        if let Ok(Some(v)) = tokio::time::timeout(Duration::from_millis(100), rx.recv()).await {
            got.push(v);
        }
    }
    got
}

#[tokio::test(flavor = "multi_thread")]
async fn with_mutual_tls_the_topside_hears_the_vehicle() {
    let dir = TempDir::new("mtls");
    let ca = Ca::new(&dir.0, "fleet-ca");
    let port = free_port();
    let ep = format!("tls/127.0.0.1:{port}");
    // The vehicle side is the interface's own gateway, exporting what its bus carries.
    let bus = Bus::new();
    let ip = InterprocessConfig {
        enabled: true,
        listen: vec![ep.clone()],
        connect: vec![],
        tls: Some(ca.tls_for("auv1")),
        ..Default::default()
    };
    let gw = frontseat_helm_side::start(
        &bus,
        &ip,
        "auv1",
        &["FrontSeatInterface"],
        GatewayOptions::default(),
    )
    .await
    .unwrap();
    let topside = session(vec![], vec![ep], Some(ca.tls_for("topside")), None).await;
    let (_sub, mut rx) = names_on(&topside, &ns_key("*")).await;
    let got = until_received(
        || {
            let _ = bus.publish(
                &groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS,
                ns("auv1", 1.0),
            );
        },
        &mut rx,
        "node_status over mTLS",
    )
    .await;
    assert_eq!(got, (ns_key("auv1"), "auv1".to_string()));
    // And the other way, with put_message as the topside's commander relay or a remote helm
    // would: the interface's bus gets the desired_course.
    let (_s, mut course) =
        bus.subscribe_channel(&groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE, "t", 1000);
    let dc_key = key_for(
        "auv1",
        groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE.name(),
    );
    let dc_type = groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE.type_name();
    let dc = DesiredCourse {
        heading: Some(90.0),
        ..Default::default()
    };
    let env = until_received(
        || put_message(&topside, &dc_key, dc_type, &dc, None).unwrap(),
        &mut course,
        "desired_course over mTLS",
    )
    .await;
    assert_eq!(env.msg.heading, Some(90.0));
    assert!(gw.stats().exported >= 1);
    gw.close().await;
}

#[tokio::test(flavor = "multi_thread")]
async fn a_peer_without_a_certificate_or_from_another_ca_hears_nothing() {
    let dir = TempDir::new("reject");
    let ca = Ca::new(&dir.0, "fleet-ca");
    let other = Ca::new(&dir.0, "other-ca");
    let port = free_port();
    let ep = format!("tls/127.0.0.1:{port}");
    let vehicle = session(vec![ep.clone()], vec![], Some(ca.tls_for("auv1")), None).await;
    let good = session(vec![], vec![ep.clone()], Some(ca.tls_for("topside")), None).await;
    let no_cert = session(
        vec![],
        vec![ep.clone()],
        Some(ca.tls_without_certificate()),
        None,
    )
    .await;
    // Trusts the fleet's CA (so the vehicle's certificate passes) but presents another CA's.
    let mut foreign_tls = other.tls_for("topside");
    foreign_tls.root_ca_certificate = Some(ca.cert.display().to_string());
    let foreign = session(vec![], vec![ep], Some(foreign_tls), None).await;

    let (_g, mut good_rx) = names_on(&good, &ns_key("*")).await;
    let (_n, mut no_cert_rx) = names_on(&no_cert, &ns_key("*")).await;
    let (_f, mut foreign_rx) = names_on(&foreign, &ns_key("*")).await;
    let type_name = groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS.type_name();
    let send =
        || put_message(&vehicle, &ns_key("auv1"), type_name, &ns("auv1", 1.0), None).unwrap();
    // The control: a certificate from the fleet's CA works.
    until_received(send, &mut good_rx, "the fleet's certificate").await;
    heard_while_sending(send, &mut good_rx).await;
    assert!(
        no_cert_rx.try_recv().is_err(),
        "a peer without a certificate heard the vehicle"
    );
    assert!(
        foreign_rx.try_recv().is_err(),
        "another CA's certificate heard the vehicle"
    );
    let peers: Vec<_> = vehicle.info().peers_zid().await.collect();
    assert_eq!(
        peers,
        vec![good.zid()],
        "only the fleet's certificate joined"
    );
}

#[tokio::test(flavor = "multi_thread")]
async fn a_common_name_not_on_the_list_can_neither_publish_nor_hear() {
    let dir = TempDir::new("acl");
    let ca = Ca::new(&dir.0, "fleet-ca");
    let (tls_port, tcp_port) = (free_port(), free_port());
    let tls_ep = format!("tls/127.0.0.1:{tls_port}");
    let tcp_ep = format!("tcp/127.0.0.1:{tcp_port}");
    let access = ZenohAccessConfig {
        commanders: vec!["topside".into()],
        allow_local_tcp: true,
        ..Default::default()
    };
    let vehicle = session(
        vec![tls_ep.clone(), tcp_ep.clone()],
        vec![],
        Some(ca.tls_for("auv1")),
        Some(access),
    )
    .await;
    let topside = session(
        vec![],
        vec![tls_ep.clone()],
        Some(ca.tls_for("topside")),
        None,
    )
    .await;
    let intruder = session(vec![], vec![tls_ep], Some(ca.tls_for("intruder")), None).await;
    let helm = session(vec![], vec![tcp_ep], None, None).await;

    // Ingress: the vehicle hears the listed name and the local tcp helm, never the intruder.
    let (_v, mut vehicle_rx) = names_on(&vehicle, "*/goby/middleware/frontseat/**").await;
    let type_name = groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS.type_name();
    let put = |s: &zenoh::Session, who: &str| {
        put_message(s, &ns_key(who), type_name, &ns(who, 1.0), None).unwrap();
    };
    let all = || {
        put(&topside, "topside");
        put(&intruder, "intruder");
        put(&helm, "helm");
    };
    let mut heard = vec![until_received(all, &mut vehicle_rx, "puts at the vehicle").await];
    heard.extend(heard_while_sending(all, &mut vehicle_rx).await);
    let names: std::collections::BTreeSet<_> = heard.iter().map(|(_, n)| n.as_str()).collect();
    assert!(
        names.contains("topside"),
        "the listed name was not heard: {names:?}"
    );
    assert!(
        names.contains("helm"),
        "the local tcp helm was not heard: {names:?}"
    );
    assert!(
        !names.contains("intruder"),
        "an unlisted name published: {names:?}"
    );

    // Egress: the topside hears the vehicle, the intruder does not.
    let (_t, mut topside_rx) = names_on(&topside, &ns_key("auv1")).await;
    let (_i, mut intruder_rx) = names_on(&intruder, &ns_key("auv1")).await;
    let send = || put(&vehicle, "auv1");
    until_received(send, &mut topside_rx, "the vehicle at the topside").await;
    heard_while_sending(send, &mut topside_rx).await;
    assert!(
        intruder_rx.try_recv().is_err(),
        "an unlisted name heard the vehicle"
    );
}

/// The config rules on `[interprocess.tls]`/`[interprocess.access]`, each case against real
/// files: (config, the error paths it must give; none = valid).
#[test]
fn tls_section_checks() {
    let dir = TempDir::new("check");
    let ca = Ca::new(&dir.0, "fleet-ca");
    let (cert, key) = ca.issue("auv1");
    let (ca_f, cert_f, key_f) = (
        ca.cert.display().to_string(),
        cert.display().to_string(),
        key.display().to_string(),
    );
    let missing = dir.0.join("missing.pem").display().to_string();
    let tls = |root: &str, cert: &str, key: &str| {
        format!(
            "[interprocess.tls]\nroot_ca_certificate = {root:?}\ncertificate = {cert:?}\n\
             private_key = {key:?}\n"
        )
    };
    let on = "[interprocess]\nenabled = true\nlisten = [\"tls/127.0.0.1:7447\"]\n";
    let cases: Vec<(String, Vec<&str>)> = vec![
        (format!("{on}{}", tls(&ca_f, &cert_f, &key_f)), vec![]),
        (on.to_string(), vec!["interprocess.listen[0]"]),
        (
            "[interprocess]\nenabled = true\nconnect = [\"tls/127.0.0.1:7447\"]\n".into(),
            vec!["interprocess.connect[0]"],
        ),
        (
            format!("{on}{}", tls(&missing, &cert_f, &key_f)),
            vec!["interprocess.tls.root_ca_certificate"],
        ),
        // A key where a certificate belongs, and the other way round.
        (
            format!("{on}{}", tls(&ca_f, &key_f, &cert_f)),
            vec![
                "interprocess.tls.certificate",
                "interprocess.tls.private_key",
            ],
        ),
        (
            format!("{on}[interprocess.tls]\nroot_ca_certificate = {ca_f:?}\n"),
            vec![
                "interprocess.tls.certificate",
                "interprocess.tls.private_key",
            ],
        ),
        // Connecting only, without mutual TLS, needs no certificate of our own.
        (
            format!(
                "[interprocess]\nenabled = true\nlisten = []\nconnect = [\"tls/127.0.0.1:7447\"]\n\
                 [interprocess.tls]\nroot_ca_certificate = {ca_f:?}\nmutual = false\n"
            ),
            vec![],
        ),
        // Files are only read for a session that opens.
        (
            format!(
                "[interprocess]\nenabled = false\nlisten = [\"tls/127.0.0.1:7447\"]\n{}",
                tls(&missing, &missing, &missing)
            ),
            vec![],
        ),
        (
            format!(
                "{on}{}[interprocess.access]\ncommanders = [\"topside\"]\nvehicles = [\"auv2\"]\n",
                tls(&ca_f, &cert_f, &key_f)
            ),
            vec![],
        ),
        // The old all-or-nothing list is refused, naming the fields that replace it.
        (
            format!(
                "{on}{}[interprocess.access]\nallow_common_names = [\"topside\"]\n",
                tls(&ca_f, &cert_f, &key_f)
            ),
            vec!["interprocess.access.allow_common_names"],
        ),
        (
            format!(
                "{on}{}mutual = false\n[interprocess.access]\ncommanders = [\"topside\"]\n",
                tls(&ca_f, &cert_f, &key_f)
            ),
            vec!["interprocess.tls.mutual"],
        ),
        (
            format!(
                "{on}{}[interprocess.access]\nvehicles = []\n",
                tls(&ca_f, &cert_f, &key_f)
            ),
            vec!["interprocess.access"],
        ),
        (
            "[interprocess]\nenabled = true\n[interprocess.access]\ncommanders = [\"a\"]\n".into(),
            vec!["interprocess.access"],
        ),
    ];
    for (text, want) in cases {
        let got: Vec<String> = match parse::<InterfaceConfig>(&text, "t.toml") {
            Ok(_) => vec![],
            Err(frontseat_config::ConfigError::Invalid { errors, .. }) => {
                errors.into_iter().map(|e| e.path).collect()
            }
            Err(e) => panic!("{e}\n{text}"),
        };
        assert_eq!(got, want, "{text}");
    }
}

#[test]
fn tls_warnings() {
    let dir = TempDir::new("warn");
    let ca = Ca::new(&dir.0, "fleet-ca");
    let mut tls = ca.tls_for("auv1");
    let warnings = |ip: InterprocessConfig| {
        let cfg = InterfaceConfig {
            interprocess: ip,
            ..Default::default()
        };
        assert_eq!(cfg.validate(), vec![], "valid");
        cfg.warnings()
    };
    let ip = |listen: &str, tls: Option<ZenohTlsConfig>| InterprocessConfig {
        enabled: true,
        listen: vec![listen.into()],
        tls,
        ..Default::default()
    };
    // The default, and TLS beyond loopback, give no advice.
    assert_eq!(
        warnings(InterprocessConfig::default()),
        Vec::<String>::new()
    );
    assert_eq!(
        warnings(ip("tls/0.0.0.0:7447", Some(tls.clone()))),
        Vec::<String>::new()
    );
    let w = warnings(ip("tcp/0.0.0.0:7447", None));
    assert!(
        w.len() == 1 && w[0].contains("interprocess.listen[0]"),
        "{w:?}"
    );
    tls.mutual = false;
    let w = warnings(ip("tls/0.0.0.0:7447", Some(tls.clone())));
    assert!(
        w.len() == 1 && w[0].contains("interprocess.tls.mutual"),
        "{w:?}"
    );
    tls.mutual = true;
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let key = tls.private_key.clone().unwrap();
        std::fs::set_permissions(&key, std::fs::Permissions::from_mode(0o644)).unwrap();
        let w = warnings(ip("tls/0.0.0.0:7447", Some(tls.clone())));
        assert!(w.len() == 1 && w[0].contains("644"), "{w:?}");
    }
}

/// What reaches a vehicle from each peer, by key: `(key, sender, delete?)`.
async fn everything_on(
    s: &zenoh::Session,
) -> (
    zenoh::pubsub::Subscriber<()>,
    UnboundedReceiver<(String, String, bool)>,
) {
    let (tx, rx) = unbounded_channel();
    let sub = s
        .declare_subscriber("**")
        .callback(move |sample| {
            let from = String::from_utf8_lossy(&sample.payload().to_bytes()).into_owned();
            let delete = sample.kind() == zenoh::sample::SampleKind::Delete;
            let _ = tx.send((sample.key_expr().to_string(), from, delete));
        })
        .await
        .unwrap();
    (sub, rx)
}

/// Per-key authority, with Zenoh's own access control as `zenoh_config` generates it: a vehicle's
/// certificate publishes under its own platform only (not a helm state or course to another
/// vehicle, not another vehicle's status, not a platform whose name merely starts with its own),
/// while it still hears the other vehicle's node_status; a commander's certificate steers.
#[tokio::test(flavor = "multi_thread")]
async fn a_vehicle_certificate_speaks_only_for_its_own_platform_and_a_commander_steers() {
    let dir = TempDir::new("authority");
    let ca = Ca::new(&dir.0, "fleet-ca");
    let tls_ep = format!("tls/127.0.0.1:{}", free_port());
    let access = ZenohAccessConfig {
        vehicles: vec!["auv1".into(), "auv2".into()],
        commanders: vec!["topside".into()],
        allow_local_tcp: false,
        ..Default::default()
    };
    let auv1 = session(
        vec![tls_ep.clone()],
        vec![],
        Some(ca.tls_for("auv1")),
        Some(access),
    )
    .await;
    let auv2 = session(vec![], vec![tls_ep.clone()], Some(ca.tls_for("auv2")), None).await;
    let topside = session(vec![], vec![tls_ep], Some(ca.tls_for("topside")), None).await;
    let (_sub, mut at_auv1) = everything_on(&auv1).await;

    let helm_state = key_for("auv1", groups::GOBY_MIDDLEWARE_FRONTSEAT_HELM_STATE.name());
    let course = key_for(
        "auv1",
        groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE.name(),
    );
    let own = ns_key("auv2");
    let forbidden = [
        helm_state.clone(),
        course.clone(),
        ns_key("auv3"),
        ns_key("auv22"),
        ns_key("topside"),
    ];
    let attack = || {
        auv2.put(&own, "auv2").wait_now();
        for k in &forbidden {
            auv2.put(k, "auv2").wait_now();
        }
        auv2.delete(&course).wait_now();
    };
    let first = until_received(attack, &mut at_auv1, "auv2's own node_status").await;
    let mut heard = vec![first];
    heard.extend(heard_while_sending(attack, &mut at_auv1).await);
    assert!(
        heard.iter().any(|(k, f, _)| *k == own && f == "auv2"),
        "auv2's own key was not heard: {:?}",
        heard.iter().take(20).collect::<Vec<_>>()
    );
    let leaked: std::collections::BTreeSet<_> = heard
        .iter()
        .filter(|(k, _, _)| *k != own)
        .map(|(k, _, delete)| (k.as_str(), if *delete { "delete" } else { "put" }))
        .collect();
    assert!(
        leaked.is_empty(),
        "auv2's certificate published outside auv2/**: {leaked:?}"
    );

    // The trail: auv2 still hears auv1's node_status.
    let (_t, mut trail) = names_on(&auv2, &ns_key("auv1")).await;
    let type_name = groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS.type_name();
    let (k, name) = until_received(
        || put_message(&auv1, &ns_key("auv1"), type_name, &ns("auv1", 1.0), None).unwrap(),
        &mut trail,
        "auv1's node_status at auv2",
    )
    .await;
    assert_eq!(
        (k.as_str(), name.as_str()),
        (ns_key("auv1").as_str(), "auv1")
    );

    // The commander steers: its helm_state and course on auv1's keys arrive.
    let steer = || {
        topside.put(&helm_state, "topside").wait_now();
        topside.put(&course, "topside").wait_now();
    };
    let mut got = vec![until_received(steer, &mut at_auv1, "the topside's command").await];
    got.extend(heard_while_sending(steer, &mut at_auv1).await);
    for k in [&helm_state, &course] {
        assert!(
            got.iter().any(|(key, f, _)| key == k && f == "topside"),
            "the commander's {k} was not heard: {:?}",
            got.iter().take(20).collect::<Vec<_>>()
        );
    }
}

/// A put or delete, waited for; the test only looks at what arrives.
trait WaitNow {
    fn wait_now(self);
}

impl<T: zenoh::Wait<To = zenoh::Result<()>>> WaitNow for T {
    fn wait_now(self) {
        self.wait().unwrap();
    }
}
