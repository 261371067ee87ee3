//! The web server over real loopback sockets: the page from the binary, pushed events, the
//! commander's path onto the bus, and the security rules and bounds at the HTTP level.

mod common;

use frontseat_actors::bus::test_util::UntypedBus as _;
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::Duration;

use common::{Sse, TIMEOUT, flood, get, post_json, request};
use frontseat_actors::bus::Bus;
use frontseat_actors::groups;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CartesianCoordinate, DesiredCourse, EulerAngles, NodeStatus, Raw, Speed,
};
use frontseat_actors::proto::goby::middleware::protobuf::LatLonPoint;
use frontseat_config::WebConfig;
use frontseat_web::WebService;
use serde_json::json;
use tokio::io::{AsyncReadExt, AsyncWriteExt};

const TOKEN: &str = "a-long-enough-test-token";
const DESIRED: &str = "goby::middleware::frontseat::desired_course";
const NODE_STATUS: &str = "goby::middleware::frontseat::node_status";

fn cfg() -> WebConfig {
    WebConfig {
        enabled: true,
        listen: "127.0.0.1:0".into(),
        ..Default::default()
    }
}

async fn start(cfg: WebConfig, token: Option<&str>) -> (Bus, WebService) {
    let bus = Bus::new();
    let web = WebService::start_with(
        &cfg,
        &Default::default(),
        token.map(String::from),
        &bus,
        "test-auv",
    )
    .await
    .expect("web starts on an ephemeral loopback port");
    (bus, web)
}

fn nav(x: f64) -> NodeStatus {
    NodeStatus {
        time: 1.0,
        name: Some("test-auv".into()),
        global_fix: LatLonPoint::default(),
        local_fix: Some(CartesianCoordinate {
            x,
            y: -2.0,
            z: None,
        }),
        pose: EulerAngles {
            heading: Some(45.0),
            ..Default::default()
        },
        speed: Speed::default(),
        ..Default::default()
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn page_and_assets_come_from_the_binary() {
    let (_bus, web) = start(cfg(), None).await;
    let addr = web.local_addr();
    let page = get(addr, "/").await;
    assert_eq!(page.status, 200);
    assert!(
        page.body.contains("<script src=\"app.js\">"),
        "{}",
        page.body
    );
    assert!(!page.body.contains("http://") && !page.body.contains("https://"));
    let js = get(addr, "/app.js").await;
    assert_eq!(js.status, 200);
    assert!(js.head.to_ascii_lowercase().contains("text/javascript"));
    assert!(js.body.contains("EventSource"));
    assert_eq!(get(addr, "/app.css").await.status, 200);
    assert_eq!(get(addr, "/nope").await.status, 404);
    web.shutdown(Duration::from_secs(2)).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn events_push_a_snapshot_then_every_message_decoded() {
    let (bus, web) = start(cfg(), None).await;
    let addr = web.local_addr();
    bus.publish(&groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS, nav(1.0));
    let mut sse = Sse::open(addr, "/api/events").await;
    assert_eq!(sse.status, 200);
    let snap = sse.next().await.expect("snapshot");
    assert_eq!(snap["kind"], "snapshot");
    // Every group of interface_yaml is listed, with its declared publishers.
    let listed: Vec<&str> = snap["groups"]
        .as_array()
        .unwrap()
        .iter()
        .map(|g| g["group"].as_str().unwrap())
        .collect();
    for g in groups::ALL {
        assert!(listed.contains(&g.name), "{} missing", g.name);
    }
    assert_eq!(snap["latest"][0]["msg"]["local_fix"]["x"], json!(1.0));
    assert_eq!(snap["track"], json!([[1.0, -2.0]]));
    bus.publish(&groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS, nav(5.0));
    let ev = sse.next_on(NODE_STATUS).await;
    assert_eq!(ev["type"], "goby.middleware.frontseat.protobuf.NodeStatus");
    assert_eq!(ev["origin"], "local");
    assert_eq!(ev["msg"]["local_fix"]["x"], json!(5.0));
    assert_eq!(ev["msg"]["pose"]["heading"], json!(45.0));
    assert!(
        ev["time"].as_f64().unwrap() > 1.0e12,
        "publish time in ms: {ev}"
    );
    // An interthread group shows up too, with no web code for it.
    bus.publish(
        &groups::FRONTSEAT_DRIVER_RAW_FROM_FRONTSEAT,
        Raw {
            raw: Some(b"NAV,X:1".to_vec()),
            ..Default::default()
        },
    );
    let ev = sse.next_on("frontseat::driver::raw_from_frontseat").await;
    assert_eq!(ev["msg"]["raw"], json!("TkFWLFg6MQ=="));
    let h = get(addr, &format!("/api/history?group={NODE_STATUS}")).await;
    assert_eq!(h.status, 200);
    assert_eq!(h.json()["history"].as_array().unwrap().len(), 2);
    assert_eq!(get(addr, "/api/history?group=no::such").await.status, 404);
    web.shutdown(Duration::from_secs(2)).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn commander_publishes_on_the_helm_group_and_refuses_anything_else() {
    let (bus, web) = start(cfg(), None).await;
    let addr = web.local_addr();
    let (_s, mut rx) =
        bus.subscribe_channel(&groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE, "t", 16);
    let list = get(addr, "/api/commander").await.json();
    let names: Vec<&str> = list["groups"]
        .as_array()
        .unwrap()
        .iter()
        .map(|g| g["group"].as_str().unwrap())
        .collect();
    assert_eq!(names.len(), 6, "{names:?}");
    // The command gate's envelope, for the forms.
    assert_eq!(
        list["limits"][DESIRED]["speed"],
        json!({"min": 0.0, "max": 5.0})
    );
    assert_eq!(
        list["limits"]["goby::middleware::frontseat::command_request"]["desired_course.depth"]["max"],
        json!(300.0)
    );
    for g in [
        DESIRED,
        "goby::middleware::frontseat::helm_state",
        "goby::middleware::frontseat::command_request",
        "goby::middleware::frontseat::data_to_frontseat",
        "goby::middleware::frontseat::raw_send_request",
        "goby::datum_update",
    ] {
        assert!(names.contains(&g), "{g} missing from {names:?}");
    }
    let r = post_json(
        addr,
        "/api/send",
        &[],
        &json!({"group": DESIRED, "message": {"time": 3.0, "heading": 90, "speed": 1.5}}),
    )
    .await;
    assert_eq!(r.status, 200, "{}", r.body);
    // This test's subscriber and the scope's own.
    assert_eq!(r.json()["sent"]["delivered"], json!(2));
    let env = tokio::time::timeout(TIMEOUT, rx.recv())
        .await
        .unwrap()
        .unwrap();
    assert_eq!(
        *env.msg,
        DesiredCourse {
            time: 3.0,
            heading: Some(90.0),
            speed: Some(1.5),
            ..Default::default()
        }
    );
    // Not a group a helm sends on.
    let r = post_json(
        addr,
        "/api/send",
        &[],
        &json!({"group": NODE_STATUS, "message": {}}),
    )
    .await;
    assert_eq!(r.status, 400, "{}", r.body);
    // Missing required field, unknown field, wrong type.
    for bad in [
        json!({"heading": 1}),
        json!({"time": 1, "headng": 1}),
        json!({"time": "soon"}),
    ] {
        let r = post_json(
            addr,
            "/api/send",
            &[],
            &json!({"group": DESIRED, "message": bad}),
        )
        .await;
        assert_eq!(r.status, 422, "{bad}: {}", r.body);
    }
    // Not JSON; not declared JSON (a cross-site form post).
    let r = request(
        addr,
        "POST",
        "/api/send",
        &[("Content-Type", "application/json")],
        b"{not json",
    )
    .await;
    assert_eq!(r.status, 400);
    let r = request(
        addr,
        "POST",
        "/api/send",
        &[("Content-Type", "text/plain")],
        json!({"group": DESIRED, "message": {"time": 1}})
            .to_string()
            .as_bytes(),
    )
    .await;
    assert_eq!(r.status, 415);
    assert!(rx.try_recv().is_err(), "nothing refused reached the bus");
    assert!(web.server_counters.sends_refused.load(Ordering::Relaxed) >= 6);
    web.shutdown(Duration::from_secs(2)).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn with_a_token_every_api_request_needs_it_and_sends_need_it_in_a_header() {
    let (bus, web) = start(cfg(), Some(TOKEN)).await;
    let addr = web.local_addr();
    let (_s, mut rx) =
        bus.subscribe_channel(&groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE, "t", 16);
    // The page itself is public (it holds no data); the data is not.
    assert_eq!(get(addr, "/").await.status, 200);
    assert_eq!(
        get(addr, "/api/info").await.json()["token_required"],
        json!(true)
    );
    assert_eq!(get(addr, "/api/events").await.status, 401);
    assert_eq!(get(addr, "/api/commander").await.status, 401);
    assert_eq!(
        get(addr, &format!("/api/history?group={DESIRED}"))
            .await
            .status,
        401
    );
    assert_eq!(
        get(addr, "/api/commander?token=wrong-wrong-wrong-wrong")
            .await
            .status,
        401
    );
    assert_eq!(
        get(addr, &format!("/api/commander?token={TOKEN}"))
            .await
            .status,
        200
    );
    let mut sse = Sse::open(addr, &format!("/api/events?token={TOKEN}")).await;
    assert_eq!(sse.status, 200);
    assert_eq!(sse.next().await.unwrap()["kind"], "snapshot");
    let body = json!({"group": DESIRED, "message": {"time": 1}});
    let bearer = format!("Bearer {TOKEN}");
    assert_eq!(post_json(addr, "/api/send", &[], &body).await.status, 401);
    let wrong = format!("Bearer {TOKEN}x");
    assert_eq!(
        post_json(addr, "/api/send", &[("Authorization", &wrong)], &body)
            .await
            .status,
        401
    );
    // A token in the query string does not authorize a send.
    assert_eq!(
        post_json(addr, &format!("/api/send?token={TOKEN}"), &[], &body)
            .await
            .status,
        401
    );
    assert!(rx.try_recv().is_err());
    let r = post_json(addr, "/api/send", &[("Authorization", &bearer)], &body).await;
    assert_eq!(r.status, 200, "{}", r.body);
    assert!(
        tokio::time::timeout(TIMEOUT, rx.recv())
            .await
            .unwrap()
            .is_some()
    );
    web.shutdown(Duration::from_secs(2)).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn another_site_cannot_reach_a_loopback_server() {
    let (bus, web) = start(cfg(), None).await;
    let addr = web.local_addr();
    let (_s, mut rx) =
        bus.subscribe_channel(&groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE, "t", 16);
    let body = json!({"group": DESIRED, "message": {"time": 1}});
    // DNS rebinding: the browser sends the attacker's host name.
    let r = request(
        addr,
        "GET",
        "/api/events",
        &[("Host", "evil.example:50001")],
        b"",
    )
    .await;
    assert_eq!(r.status, 403);
    let r = post_json(addr, "/api/send", &[("Host", "evil.example")], &body).await;
    assert_eq!(r.status, 403);
    // A page of another origin posting to localhost.
    let r = post_json(
        addr,
        "/api/send",
        &[("Origin", "http://evil.example")],
        &body,
    )
    .await;
    assert_eq!(r.status, 403);
    assert!(rx.try_recv().is_err());
    let own = format!("http://{addr}");
    let r = post_json(addr, "/api/send", &[("Origin", &own)], &body).await;
    assert_eq!(r.status, 200, "{}", r.body);
    web.shutdown(Duration::from_secs(2)).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn bodies_connections_and_event_streams_are_bounded() {
    let (_bus, web) = start(
        WebConfig {
            max_connections: 3,
            max_clients: 1,
            max_body_bytes: 1024,
            ..cfg()
        },
        None,
    )
    .await;
    let addr = web.local_addr();
    let big = json!({"group": DESIRED, "message": {"time": 1, "pad": "x".repeat(4096)}});
    let r = post_json(addr, "/api/send", &[], &big).await;
    assert_eq!(r.status, 413, "{}", r.body);
    // One tab: a second event stream is refused while the first is open.
    let mut first = Sse::open(addr, "/api/events").await;
    assert_eq!(first.status, 200);
    assert_eq!(first.next().await.unwrap()["kind"], "snapshot");
    // A second tab is refused, and the server closes that connection itself: a refused client
    // that keeps its socket open does not hold one of max_connections until the idle timeout.
    let mut second = tokio::net::TcpStream::connect(addr).await.unwrap();
    second
        .write_all(format!("GET /api/events HTTP/1.1\r\nHost: {addr}\r\n\r\n").as_bytes())
        .await
        .unwrap();
    let mut answer = Vec::new();
    tokio::time::timeout(TIMEOUT, second.read_to_end(&mut answer))
        .await
        .expect("the refused event stream's connection is closed by the server, not kept alive")
        .unwrap();
    let answer = String::from_utf8_lossy(&answer).to_ascii_lowercase();
    assert!(answer.starts_with("http/1.1 503"), "{answer}");
    assert!(answer.contains("connection: close"), "{answer}");
    assert!(answer.contains("max_clients"), "{answer}");
    // The server frees the slot as it closes: wait (bounded) for its count to drop, or one of
    // the idle sockets below would be the one refused.
    let deadline = tokio::time::Instant::now() + TIMEOUT;
    while web.server_counters.connections_open.load(Ordering::Relaxed) > 1 {
        assert!(
            tokio::time::Instant::now() < deadline,
            "the refused event stream's connection was never released"
        );
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    // Connections: `first` holds one (answered); two idle sockets fill the bound. The next
    // connection closes the oldest idle one (never the open stream) and is served.
    let mut a = tokio::net::TcpStream::connect(addr).await.unwrap();
    let _b = tokio::net::TcpStream::connect(addr).await.unwrap();
    let evicted_before = web.server_counters.evicted.load(Ordering::Relaxed);
    assert_eq!(get(addr, "/api/info").await.status, 200);
    let mut buf = [0u8; 16];
    let n = tokio::time::timeout(TIMEOUT, a.read(&mut buf))
        .await
        .expect("the oldest idle socket is closed in time")
        .unwrap_or(0);
    assert_eq!(n, 0, "closed without a reply");
    assert!(web.server_counters.evicted.load(Ordering::Relaxed) > evicted_before);
    first
        .next()
        .await
        .expect("the open stream is not what gave way");
    web.shutdown(Duration::from_secs(2)).await;

    // When every slot is being answered (here the one open stream), a new connection is closed
    // at once without an answer, and counted.
    let (_bus, web) = start(
        WebConfig {
            max_connections: 1,
            ..cfg()
        },
        None,
    )
    .await;
    let addr = web.local_addr();
    let mut only = Sse::open(addr, "/api/events").await;
    assert_eq!(only.next().await.unwrap()["kind"], "snapshot");
    let mut c = tokio::net::TcpStream::connect(addr).await.unwrap();
    let n = tokio::time::timeout(TIMEOUT, c.read(&mut buf))
        .await
        .expect("the extra connection is closed in time")
        .unwrap_or(0);
    assert_eq!(n, 0, "closed without a reply");
    assert!(
        web.server_counters
            .connections_refused
            .load(Ordering::Relaxed)
            >= 1
    );
    only.next().await.expect("the open stream stays");
    web.shutdown(Duration::from_secs(2)).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_tab_that_does_not_read_never_slows_the_bus() {
    let (bus, web) = start(
        WebConfig {
            client_queue: 8,
            ..cfg()
        },
        None,
    )
    .await;
    let addr = web.local_addr();
    // A tab that reads its snapshot and then nothing: its socket buffers fill, its queue fills.
    let mut stalled = Sse::open(addr, "/api/events").await;
    assert_eq!(stalled.next().await.unwrap()["kind"], "snapshot");
    const N: usize = 5_000;
    let (_s, mut fast) =
        bus.subscribe_channel(&groups::GOBY_MIDDLEWARE_FRONTSEAT_RAW_IN, "fast", N);
    let payload = vec![b'x'; 8 * 1024];
    for _ in 0..N {
        bus.publish(
            &groups::GOBY_MIDDLEWARE_FRONTSEAT_RAW_IN,
            Raw {
                raw: Some(payload.clone()),
                ..Default::default()
            },
        );
    }
    let mut got = 0;
    while fast.try_recv().is_ok() {
        got += 1;
    }
    assert_eq!(got, N, "another subscriber got every message");
    // Every message reached the hub or was dropped at its bus bound; the stalled tab's share
    // beyond its queue was dropped and counted.
    let hub = web.hub_counters.clone();
    let scope_dropped = || {
        bus.stats()
            .iter()
            .filter(|s| s.subscriber == frontseat_web::hub::SUBSCRIBER)
            .map(|s| s.dropped)
            .sum::<u64>()
    };
    let all_accounted = async {
        loop {
            let seen = hub.messages.load(Ordering::Relaxed) + scope_dropped();
            if seen >= N as u64 && hub.events_dropped.load(Ordering::Relaxed) > 0 {
                break;
            }
            tokio::task::yield_now().await;
            tokio::time::sleep(Duration::from_millis(10)).await;
        }
    };
    tokio::time::timeout(TIMEOUT, all_accounted)
        .await
        .expect("the hub accounted for every message and counted the stalled tab's drops");
    drop(stalled);
    web.shutdown(Duration::from_secs(2)).await;
    let _ = Arc::strong_count(&hub);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_failed_hub_is_restarted_and_tabs_get_a_new_stream() {
    let (bus, web) = start(cfg(), None).await;
    let addr = web.local_addr();
    let mut tab = Sse::open(addr, "/api/events").await;
    assert_eq!(tab.next().await.unwrap()["kind"], "snapshot");
    let first = web.hub().expect("a hub runs");
    first.kill();
    // The tab's stream ends (the browser's EventSource then reconnects by itself).
    while tab.next().await.is_some() {}
    let restarted = async {
        loop {
            if let Some(h) = web.hub()
                && h.get_id() != first.get_id()
            {
                break;
            }
            tokio::time::sleep(Duration::from_millis(10)).await;
        }
    };
    tokio::time::timeout(TIMEOUT, restarted)
        .await
        .expect("the supervisor restarts the hub");
    let mut again = Sse::open(addr, "/api/events").await;
    assert_eq!(again.status, 200);
    assert_eq!(again.next().await.unwrap()["kind"], "snapshot");
    bus.publish(&groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS, nav(7.0));
    assert_eq!(
        again.next_on(NODE_STATUS).await["msg"]["local_fix"]["x"],
        json!(7.0)
    );
    web.shutdown(Duration::from_secs(2)).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_idle_socket_is_closed_and_frees_its_slot() {
    let (_bus, web) = start(
        WebConfig {
            max_connections: 1,
            idle_timeout_s: 2,
            ..cfg()
        },
        None,
    )
    .await;
    let addr = web.local_addr();
    // Connects and never sends a request: closed after the idle timeout.
    let mut idle = tokio::net::TcpStream::connect(addr).await.unwrap();
    let mut buf = [0u8; 16];
    let n = tokio::time::timeout(TIMEOUT, idle.read(&mut buf))
        .await
        .expect("the idle socket is closed in time")
        .unwrap_or(0);
    assert_eq!(n, 0);
    // Its slot is free again.
    assert_eq!(get(addr, "/api/info").await.status, 200);
    // An open tab stays: keep-alives count as traffic.
    let mut tab = Sse::open(addr, "/api/events").await;
    assert_eq!(tab.next().await.unwrap()["kind"], "snapshot");
    let mut stats = 0;
    while stats < 3 {
        if tab.next().await.expect("the tab stays open")["kind"] == "stats" {
            stats += 1;
        }
    }
    web.shutdown(Duration::from_secs(2)).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_request_trickled_a_byte_at_a_time_is_cut_at_the_idle_timeout() {
    let (_bus, web) = start(
        WebConfig {
            max_connections: 1,
            idle_timeout_s: 2,
            ..cfg()
        },
        None,
    )
    .await;
    let addr = web.local_addr();
    // Slowloris: a request line, then one header byte every 300 ms, never the blank line. Every
    // byte resets the idle timer; the request's own deadline (2 s from its first byte) does not
    // move. Closed within 3 × that, or never without the bound.
    let mut slow = tokio::net::TcpStream::connect(addr).await.unwrap();
    slow.write_all(b"GET /api/info HTTP/1.1\r\nX-Slow: ")
        .await
        .unwrap();
    let first_byte = tokio::time::Instant::now();
    let mut buf = [0u8; 64];
    let closed = tokio::time::timeout(Duration::from_secs(6), async {
        loop {
            tokio::select! {
                r = slow.read(&mut buf) => match r {
                    Ok(0) | Err(_) => return,
                    Ok(_) => panic!("an answer to an incomplete request"),
                },
                () = tokio::time::sleep(Duration::from_millis(300)) => {
                    if slow.write_all(b"a").await.is_err() {
                        return;
                    }
                }
            }
        }
    })
    .await;
    assert!(
        closed.is_ok(),
        "the trickling client still holds its slot after 6 s"
    );
    assert!(
        first_byte.elapsed() >= Duration::from_secs(2),
        "not before its deadline"
    );
    // Its slot is free again.
    assert_eq!(get(addr, "/api/info").await.status, 200);
    web.shutdown(Duration::from_secs(2)).await;
}

/// Anyone on the host opens 300 sockets (silent, or trickling a request head a byte a second)
/// against the default 64 connections: a new tab still gets the page, its event stream and the
/// commander, within a bounded wait; and a second flood does not take the open event stream.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn hundreds_of_idle_and_trickling_sockets_do_not_lock_out_a_new_tab() {
    let (bus, web) = start(cfg(), None).await;
    let addr = web.local_addr();
    let bound = Duration::from_secs(10);
    let _first = flood(addr, 300).await;
    let page = tokio::time::timeout(bound, get(addr, "/"))
        .await
        .expect("the page within the bound");
    assert_eq!(page.status, 200, "{page:?}");
    let mut tab = tokio::time::timeout(bound, Sse::open(addr, "/api/events"))
        .await
        .expect("the event stream within the bound");
    assert_eq!(tab.status, 200);
    assert_eq!(tab.next().await.unwrap()["kind"], "snapshot");
    // The tab, open and answered, is not what gives way to the next flood.
    let _second = flood(addr, 300).await;
    bus.publish(&groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS, nav(3.0));
    assert_eq!(
        tokio::time::timeout(bound, tab.next_on(NODE_STATUS))
            .await
            .expect("the open tab still streams")["msg"]["local_fix"]["x"],
        json!(3.0)
    );
    let (_s, mut rx) =
        bus.subscribe_channel(&groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE, "t", 16);
    let sent = tokio::time::timeout(
        bound,
        post_json(
            addr,
            "/api/send",
            &[],
            &json!({"group": DESIRED, "message": {"time": 1, "heading": 90}}),
        ),
    )
    .await
    .expect("a send within the bound");
    assert_eq!(sent.status, 200, "{}", sent.body);
    assert!(rx.try_recv().is_ok());
    web.shutdown(Duration::from_secs(2)).await;
}

/// A socket that sends one byte a second and never ends its request head is closed at the
/// header timeout (5 s by default), not kept while it trickles; one that sends nothing too.
#[tokio::test(start_paused = true)]
async fn a_request_head_trickled_a_byte_a_second_is_closed_at_the_header_timeout() {
    let (_bus, web) = start(cfg(), None).await;
    let addr = web.local_addr();
    let mut silent = tokio::net::TcpStream::connect(addr).await.unwrap();
    let mut slow = tokio::net::TcpStream::connect(addr).await.unwrap();
    let t0 = tokio::time::Instant::now();
    let mut buf = [0u8; 64];
    let mut bytes = b"GET /api/info HTTP/1.1\r\nX-Slow: ".iter().copied();
    let slow_held = tokio::time::timeout(Duration::from_secs(60), async {
        loop {
            tokio::select! {
                r = slow.read(&mut buf) => match r {
                    Ok(0) | Err(_) => return t0.elapsed(),
                    Ok(_) => panic!("an answer to an incomplete request"),
                },
                () = tokio::time::sleep(Duration::from_secs(1)) => {
                    if slow.write_all(&[bytes.next().unwrap_or(b'a')]).await.is_err() {
                        return t0.elapsed();
                    }
                }
            }
        }
    })
    .await
    .expect("closed at all");
    assert!(
        slow_held <= Duration::from_secs(6),
        "a trickled head held its connection {slow_held:?}"
    );
    let n = tokio::time::timeout(Duration::from_secs(60), silent.read(&mut buf))
        .await
        .expect("the silent socket is closed")
        .unwrap_or(0);
    assert_eq!(n, 0);
    assert!(
        t0.elapsed() <= Duration::from_secs(6),
        "a silent socket held its connection {:?}",
        t0.elapsed()
    );
    web.shutdown(Duration::from_secs(2)).await;
}
