//! Gateways and raw Zenoh sessions talking over real loopback TCP inside one test process (each
//! with its own bus, as separate processes would have): routing driven by the generated
//! interface, trace context in the attachment, no echo, and bad payloads counted and survived.

use frontseat_actors::bus::test_util::UntypedBus as _;
use std::time::Duration;

use frontseat_actors::bus::{Bus, Origin, PublishMeta, TraceContext};
use frontseat_actors::groups;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{DesiredCourse, NodeStatus};
use frontseat_config::InterprocessConfig;
use frontseat_helm_side::{GatewayOptions, GatewayStats, client_config, put_message};
use prost::Message;
use std::sync::Arc;
use zenoh::Wait;

const TP: &str = "00-0af7651916cd43dd8448eb211c80319c-b7ad6b7169203331-01";
const WAIT: Duration = Duration::from_secs(15);
const DC_TYPE: &str = "goby.middleware.frontseat.protobuf.DesiredCourse";

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

fn peer(listen: Option<u16>, connect: Option<u16>) -> InterprocessConfig {
    InterprocessConfig {
        enabled: true,
        listen: listen
            .map(|p| vec![format!("tcp/127.0.0.1:{p}")])
            .unwrap_or_default(),
        connect: connect
            .map(|p| vec![format!("tcp/127.0.0.1:{p}")])
            .unwrap_or_default(),
        ..Default::default()
    }
}

fn ns(x: f64) -> NodeStatus {
    NodeStatus {
        name: Some("auv1".into()),
        time: x,
        ..Default::default()
    }
}

fn dc(heading: f64) -> DesiredCourse {
    DesiredCourse {
        heading: Some(heading),
        speed: Some(1.5),
        ..Default::default()
    }
}

/// Re-sends until the other side got one: declarations take a moment to propagate, and a
/// message published before that is (correctly) not delivered.
async fn until_received<T>(
    mut send: impl FnMut(),
    rx: &mut tokio::sync::mpsc::UnboundedReceiver<T>,
) -> T {
    let deadline = tokio::time::Instant::now() + WAIT;
    loop {
        send();
        match tokio::time::timeout(Duration::from_millis(100), rx.recv()).await {
            Ok(Some(v)) => return v,
            Ok(None) => panic!("channel closed"),
            Err(_) if tokio::time::Instant::now() > deadline => panic!("nothing received"),
            Err(_) => {}
        }
    }
}

async fn wait_stats(
    gw: &frontseat_helm_side::GatewayHandle,
    what: &str,
    pred: impl Fn(&GatewayStats) -> bool,
) -> GatewayStats {
    let deadline = tokio::time::Instant::now() + WAIT;
    loop {
        let s = gw.stats();
        if pred(&s) {
            return s;
        }
        assert!(
            tokio::time::Instant::now() < deadline,
            "timed out waiting for {what}: {s:?}"
        );
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn interface_and_translation_processes_exchange_their_groups_with_trace() {
    let port = free_port();
    let bus_if = Bus::new();
    let bus_tr = Bus::new();
    let gw_if = frontseat_helm_side::start(
        &bus_if,
        &peer(Some(port), None),
        "auv1",
        &["FrontSeatInterface"],
        GatewayOptions::default(),
    )
    .await
    .unwrap();
    let gw_tr = frontseat_helm_side::start(
        &bus_tr,
        &peer(None, Some(port)),
        "auv1",
        &["FrontSeatTranslation"],
        GatewayOptions::default(),
    )
    .await
    .unwrap();

    // interface → translation: node_status, with its trace.
    let (_s, mut rx) =
        bus_tr.subscribe_channel(&groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS, "t", 1000);
    let meta = PublishMeta {
        trace: Some(TraceContext {
            traceparent: TP.into(),
        }),
        origin: Origin::Local,
    };
    let env = until_received(
        || {
            bus_if.publish_with(
                &groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS,
                Arc::new(ns(7.0)),
                meta.clone(),
            );
        },
        &mut rx,
    )
    .await;
    assert_eq!(*env.msg, ns(7.0));
    assert_eq!(env.origin, Origin::Imported);
    assert_eq!(env.trace.as_ref().map(|t| t.traceparent.as_str()), Some(TP));

    // translation → interface: desired_course, without a trace.
    let (_s2, mut rx2) =
        bus_if.subscribe_channel(&groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE, "t", 1000);
    let env = until_received(
        || {
            bus_tr.publish(&groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE, dc(45.0));
        },
        &mut rx2,
    )
    .await;
    assert_eq!(*env.msg, dc(45.0));
    assert_eq!(env.origin, Origin::Imported);
    assert_eq!(env.trace, None);

    // node_status is not something the interface imports, so a node_status from the
    // translation side must not arrive (it does not even export it).
    let (_s3, mut rx3) =
        bus_if.subscribe_channel(&groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS, "t", 1000);
    bus_tr.publish(&groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS, ns(1.0));
    tokio::time::sleep(Duration::from_millis(200)).await;
    // The only node_status on bus_if may be the interface's own re-sends above, all Local.
    while let Ok(e) = rx3.try_recv() {
        assert_eq!(e.origin, Origin::Local);
    }
    assert!(gw_if.stats().exported >= 1);
    assert!(gw_tr.stats().imported >= 1);
    assert_eq!(gw_if.stats().rejected(), 0);
    gw_tr.close().await;
    gw_if.close().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn imported_messages_are_not_exported_again_but_local_ones_are() {
    let port = free_port();
    let bus = Bus::new();
    // Both actors in one process: desired_course is exported (translation publishes it) and
    // imported (the interface subscribes it) — the case where an echo could happen.
    let gw = frontseat_helm_side::start(
        &bus,
        &peer(Some(port), None),
        "auv1",
        &["FrontSeatInterface", "FrontSeatTranslation"],
        GatewayOptions::default(),
    )
    .await
    .unwrap();
    let (_s, mut local) =
        bus.subscribe_channel(&groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE, "t", 1000);

    let helm = zenoh::open(client_config(&[format!("tcp/127.0.0.1:{port}")]).unwrap())
        .await
        .unwrap();
    let (tx, mut seen) = tokio::sync::mpsc::unbounded_channel();
    let _zsub = helm
        .declare_subscriber("auv1/goby/middleware/frontseat/desired_course")
        // Only what comes back from the gateway, not the helm's own puts.
        .allowed_origin(zenoh::sample::Locality::Remote)
        .callback(move |s| {
            let _ = tx.send(DesiredCourse::decode(&*s.payload().to_bytes()).unwrap());
        })
        .await
        .unwrap();

    // A local publish goes out (so the check below can fail).
    let got = until_received(
        || {
            bus.publish(&groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE, dc(10.0));
        },
        &mut seen,
    )
    .await;
    assert_eq!(got, dc(10.0));
    tokio::time::sleep(Duration::from_millis(200)).await;
    while local.try_recv().is_ok() {}
    while seen.try_recv().is_ok() {}
    let exported_before = gw.stats().exported;

    // What the helm sends arrives on the bus, and is not sent back out.
    let key = "auv1/goby/middleware/frontseat/desired_course";
    let env = until_received(
        || put_message(&helm, key, DC_TYPE, &dc(200.0), None).unwrap(),
        &mut local,
    )
    .await;
    assert_eq!(env.origin, Origin::Imported);
    drop(env);
    wait_stats(&gw, "one not echoed", |s| s.not_echoed >= 1).await;
    tokio::time::sleep(Duration::from_millis(300)).await;
    assert!(seen.try_recv().is_err(), "the imported course came back");
    let s = gw.stats();
    assert_eq!(
        s.exported, exported_before,
        "an imported message was exported: {s:?}"
    );
    helm.close().await.unwrap();
    gw.close().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn garbage_wrong_type_oversized_and_bad_trace_are_counted_and_survived() {
    let port = free_port();
    let bus = Bus::new();
    let opts = GatewayOptions {
        max_payload: 1024,
        ..Default::default()
    };
    let gw = frontseat_helm_side::start(
        &bus,
        &peer(Some(port), None),
        "auv1",
        &["FrontSeatInterface"],
        opts,
    )
    .await
    .unwrap();
    let (_s, mut rx) =
        bus.subscribe_channel(&groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE, "t", 1000);
    let tool = zenoh::open(client_config(&[format!("tcp/127.0.0.1:{port}")]).unwrap())
        .await
        .unwrap();
    let key = "auv1/goby/middleware/frontseat/desired_course";
    // Connected and routed: a valid message gets through first.
    until_received(
        || put_message(&tool, key, DC_TYPE, &dc(1.0), None).unwrap(),
        &mut rx,
    )
    .await;
    let before = gw.stats();

    // Garbage that cannot be protobuf: a field header with wire type 7.
    tool.put(key, vec![0x0f, 0xff, 0xff, 0xff]).wait().unwrap();
    // Another message type named in the encoding.
    tool.put(key, dc(2.0).encode_to_vec())
        .encoding("application/protobuf;goby.middleware.frontseat.protobuf.NodeStatus")
        .wait()
        .unwrap();
    tool.put(key, "hello")
        .encoding("text/plain")
        .wait()
        .unwrap();
    // Too big for max_payload (but under Zenoh's own link limit).
    tool.put(key, vec![0u8; 2048]).wait().unwrap();
    // A valid message with an attachment that is not a traceparent: imported without a trace.
    tool.put(key, dc(3.0).encode_to_vec())
        .attachment("not a traceparent")
        .wait()
        .unwrap();

    let s = wait_stats(&gw, "every bad sample counted", |s| {
        s.undecodable > before.undecodable
            && s.wrong_type >= before.wrong_type + 2
            && s.oversized > before.oversized
            && s.bad_traceparent > before.bad_traceparent
    })
    .await;
    assert_eq!(s.undecodable, before.undecodable + 1, "{s:?}");
    assert_eq!(s.oversized, before.oversized + 1, "{s:?}");
    let mut got = Vec::new();
    let deadline = tokio::time::Instant::now() + WAIT;
    while got.last() != Some(&dc(3.0)) {
        let e = tokio::time::timeout_at(deadline, rx.recv())
            .await
            .unwrap()
            .unwrap();
        if *e.msg != dc(1.0) {
            assert_eq!(e.trace, None);
            got.push(*e.msg);
        }
    }
    assert_eq!(got, vec![dc(3.0)], "only the valid message reached the bus");

    // Still alive: a good one with a good trace passes.
    tool.put(key, dc(4.0).encode_to_vec())
        .encoding(format!("application/protobuf;{DC_TYPE}"))
        .attachment(TP)
        .wait()
        .unwrap();
    let e = tokio::time::timeout(WAIT, rx.recv())
        .await
        .unwrap()
        .unwrap();
    assert_eq!(*e.msg, dc(4.0));
    assert_eq!(e.trace.unwrap().traceparent, TP);
    tool.close().await.unwrap();
    gw.close().await;
}
