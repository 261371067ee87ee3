//! The topside against a real Zenoh session on loopback and its real HTTP server: vehicles
//! appear from their publications under their platform's key, a silent one turns stale and stays,
//! garbage is counted not fatal, and the token and Host rules hold.

use frontseat_actors::bus::test_util::UntypedBus as _;
use std::time::Duration;

use frontseat_actors::groups;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CartesianCoordinate, DesiredCourse, InterfaceState, InterfaceStatus, NodeStatus,
};
use frontseat_helm_side::{key_for, put_message, zenoh};
use frontseat_topside::{Topside, TopsideConfig};
use serde_json::Value;
use tokio::io::{AsyncReadExt, AsyncWriteExt};

const BOUND: Duration = Duration::from_secs(15);

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// GET `path` with these extra header lines; the status code and the body.
async fn get(addr: std::net::SocketAddr, path: &str, headers: &str) -> (u16, String) {
    let mut s = tokio::net::TcpStream::connect(addr).await.unwrap();
    let req = format!(
        "GET {path} HTTP/1.1\r\nHost: 127.0.0.1:{}\r\n{headers}Connection: close\r\n\r\n",
        addr.port()
    );
    s.write_all(req.as_bytes()).await.unwrap();
    let mut buf = Vec::new();
    tokio::time::timeout(BOUND, s.read_to_end(&mut buf))
        .await
        .unwrap()
        .unwrap();
    let text = String::from_utf8_lossy(&buf).into_owned();
    let code = text[9..12].parse().unwrap();
    let body = text
        .split_once("\r\n\r\n")
        .map(|(_, b)| b.to_string())
        .unwrap_or_default();
    (code, body)
}

async fn fleet(addr: std::net::SocketAddr) -> Value {
    let (code, body) = get(addr, "/api/fleet", "").await;
    assert_eq!(code, 200, "{body}");
    serde_json::from_str(&body).unwrap()
}

fn vehicle<'a>(f: &'a Value, name: &str) -> Option<&'a Value> {
    f["vehicles"]
        .as_array()
        .unwrap()
        .iter()
        .find(|v| v["name"] == name)
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

async fn publisher(port: u16) -> zenoh::Session {
    let ip = frontseat_config::InterprocessConfig {
        enabled: true,
        listen: vec![format!("tcp/127.0.0.1:{port}")],
        ..Default::default()
    };
    let cfg = frontseat_helm_side::zenoh_config(&ip, 65536).unwrap();
    zenoh::open(cfg).await.unwrap()
}

fn topside_config(zenoh_port: u16) -> TopsideConfig {
    let mut cfg = TopsideConfig::default();
    cfg.zenoh.connect = vec![format!("tcp/127.0.0.1:{zenoh_port}")];
    cfg.web.listen = "127.0.0.1:0".into();
    cfg.stale_after_s = 0.5;
    cfg
}

/// Polls the page model until `ok` holds (bounded).
async fn until(
    addr: std::net::SocketAddr,
    what: &str,
    mut ok: impl FnMut(&Value) -> bool,
    mut tick: impl FnMut(),
) -> Value {
    let deadline = tokio::time::Instant::now() + BOUND;
    loop {
        tick();
        let f = fleet(addr).await;
        if ok(&f) {
            return f;
        }
        assert!(tokio::time::Instant::now() < deadline, "{what}: {f:#}");
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

#[tokio::test(flavor = "multi_thread")]
async fn every_vehicle_appears_a_silent_one_turns_stale_and_garbage_is_counted() {
    let port = free_port();
    let z = publisher(port).await;
    let top = Topside::start(&topside_config(port)).await.unwrap();
    let addr = top.local_addr();
    let ns_key = |p: &str| key_for(p, groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS.name());
    let ns_type = groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS.type_name();
    let put = |p: &str, x: f64| {
        put_message(&z, &ns_key(p), ns_type, &node_status(x, 2.0 * x), None).unwrap();
    };
    // Zenoh drops a put made before the topside's subscription has matched, so every message
    // the first wait needs is re-sent on each poll rather than once up front.
    let put_status = || {
        put_message(
            &z,
            &key_for("auv1", groups::GOBY_MIDDLEWARE_FRONTSEAT_STATUS.name()),
            groups::GOBY_MIDDLEWARE_FRONTSEAT_STATUS.type_name(),
            &InterfaceStatus {
                state: Some(InterfaceState::InterfaceCommand as i32),
                ..Default::default()
            },
            None,
        )
        .unwrap();
    };
    let mut x = 0.0;
    let f = until(
        addr,
        "both vehicles on the page",
        |f| {
            // auv2 may first appear by its desired_course alone (its node_status puts can
            // still be dropped before the subscription matches): wait for a fresh fix too.
            vehicle(f, "auv1").is_some_and(|v| v["status"]["state"] == "running:command")
                && vehicle(f, "auv2").is_some_and(|v| {
                    v["stale"] == false && v["track"].as_array().is_some_and(|t| !t.is_empty())
                })
        },
        || {
            x += 1.0;
            put_status();
            put("auv1", x);
            put("auv2", x);
            put_message(
                &z,
                &key_for(
                    "auv2",
                    groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE.name(),
                ),
                groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE.type_name(),
                &DesiredCourse {
                    heading: Some(135.0),
                    speed: Some(1.5),
                    ..Default::default()
                },
                None,
            )
            .unwrap();
        },
    )
    .await;
    let auv2 = vehicle(&f, "auv2").unwrap();
    assert_eq!(auv2["stale"], false);
    assert!(!auv2["track"].as_array().unwrap().is_empty());
    assert!(auv2["nav"]["y"].as_f64().unwrap() > 0.0);

    // Garbage under a third platform, and an impossible position: counted, nothing else.
    z.put(ns_key("auv3"), vec![0xffu8; 40]).await.unwrap();
    put_message(
        &z,
        &ns_key("auv1"),
        ns_type,
        &node_status(f64::NAN, 0.0),
        None,
    )
    .unwrap();
    // auv2 falls silent; auv1 keeps talking.
    let f = until(
        addr,
        "auv2 stale, auv1 fresh, the garbage counted",
        |f| {
            vehicle(f, "auv2").is_some_and(|v| v["stale"] == true)
                && vehicle(f, "auv1").is_some_and(|v| v["stale"] == false)
                && f["counters"]["undecodable"].as_u64() >= Some(1)
                && f["counters"]["implausible"].as_u64() >= Some(1)
        },
        || {
            x += 1.0;
            put("auv1", x);
        },
    )
    .await;
    assert!(vehicle(&f, "auv3").is_none(), "garbage made no vehicle");
    let auv2 = vehicle(&f, "auv2").unwrap();
    assert_eq!(
        auv2["course"]["heading"], 135.0,
        "stale keeps what was known"
    );
    // The page itself is served.
    let (code, body) = get(addr, "/", "").await;
    assert_eq!(code, 200);
    assert!(body.contains("frontseat topside"));
    top.shutdown().await;
    z.close().await.unwrap();
}

#[tokio::test(flavor = "multi_thread")]
async fn with_a_token_every_read_needs_it_and_a_foreign_host_is_refused() {
    let port = free_port();
    let mut cfg = topside_config(port);
    cfg.web.token = Some("a-topside-token-of-some-length".into());
    let top = Topside::start(&cfg).await.unwrap();
    let addr = top.local_addr();
    let (code, _) = get(addr, "/api/fleet", "").await;
    assert_eq!(code, 401);
    let (code, _) = get(
        addr,
        "/api/fleet",
        "Authorization: Bearer wrong-token-wrong-token\r\n",
    )
    .await;
    assert_eq!(code, 401);
    let (code, body) = get(
        addr,
        "/api/fleet",
        "Authorization: Bearer a-topside-token-of-some-length\r\n",
    )
    .await;
    assert_eq!(code, 200, "{body}");
    // A page elsewhere that rebinds its name to 127.0.0.1 sends its own Host.
    let mut s = tokio::net::TcpStream::connect(addr).await.unwrap();
    s.write_all(b"GET /api/fleet HTTP/1.1\r\nHost: evil.example:80\r\nAuthorization: Bearer a-topside-token-of-some-length\r\nConnection: close\r\n\r\n")
        .await
        .unwrap();
    let mut buf = Vec::new();
    tokio::time::timeout(BOUND, s.read_to_end(&mut buf))
        .await
        .unwrap()
        .unwrap();
    assert!(String::from_utf8_lossy(&buf).starts_with("HTTP/1.1 403"));
    top.shutdown().await;
}

#[test]
fn the_config_refuses_a_short_token_and_warns_about_an_open_page() {
    use frontseat_config::ServiceConfig;
    let mut cfg = TopsideConfig::default();
    cfg.web.token = Some("short".into());
    assert!(cfg.validate().iter().any(|e| e.path == "web.token"));
    cfg.web.token = None;
    cfg.web.listen = "0.0.0.0:50080".into();
    assert!(cfg.validate().is_empty());
    assert!(cfg.warnings()[0].contains("without a token"));
}

/// POST `body` to `path` with these extra header lines; the status code and the body.
async fn post(addr: std::net::SocketAddr, path: &str, headers: &str, body: &str) -> (u16, String) {
    let mut s = tokio::net::TcpStream::connect(addr).await.unwrap();
    let req = format!(
        "POST {path} HTTP/1.1\r\nHost: 127.0.0.1:{}\r\nContent-Type: application/json\r\nContent-Length: {}\r\n{headers}Connection: close\r\n\r\n{body}",
        addr.port(),
        body.len()
    );
    s.write_all(req.as_bytes()).await.unwrap();
    let mut buf = Vec::new();
    tokio::time::timeout(BOUND, s.read_to_end(&mut buf))
        .await
        .unwrap()
        .unwrap();
    let text = String::from_utf8_lossy(&buf).into_owned();
    let code = text[9..12].parse().unwrap();
    let body = text
        .split_once("\r\n\r\n")
        .map(|(_, b)| b.to_string())
        .unwrap_or_default();
    (code, body)
}

/// A vehicle's own web commander (the real one, on its bus) with or without a token.
async fn vehicle_page(
    bus: &frontseat_actors::bus::Bus,
    token: Option<&str>,
) -> frontseat_web::WebService {
    let cfg = frontseat_config::WebConfig {
        enabled: true,
        listen: "127.0.0.1:0".into(),
        ..Default::default()
    };
    frontseat_web::WebService::start_with(
        &cfg,
        &Default::default(),
        token.map(str::to_string),
        bus,
        "auv1",
    )
    .await
    .unwrap()
}

#[tokio::test(flavor = "multi_thread")]
async fn commanding_a_vehicle_from_the_topside_needs_that_vehicles_token() {
    let vehicle_token = "auv1-vehicle-token-0123456789";
    let bus = frontseat_actors::bus::Bus::new();
    let (_sub, mut courses) = bus.subscribe_channel(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE,
        "test",
        16,
    );
    let page = vehicle_page(&bus, Some(vehicle_token)).await;
    let open_bus = frontseat_actors::bus::Bus::new();
    let open_page = vehicle_page(&open_bus, None).await;
    let mut cfg = topside_config(free_port());
    cfg.vehicle = vec![
        frontseat_topside::config::VehicleLink {
            name: "auv1".into(),
            page: format!("http://{}/", page.local_addr()),
        },
        frontseat_topside::config::VehicleLink {
            name: "auv2".into(),
            page: format!("http://{}/", open_page.local_addr()),
        },
    ];
    let top = Topside::start(&cfg).await.unwrap();
    let addr = top.local_addr();
    let cmd = r#"{"group":"goby::middleware::frontseat::desired_course","message":{"time":1,"heading":42,"speed":1.5}}"#;

    let (code, _) = post(addr, "/api/vehicle/auv1/send", "", cmd).await;
    assert_eq!(code, 401, "no vehicle token");
    let (code, _) = post(
        addr,
        "/api/vehicle/auv1/send",
        "X-Vehicle-Token: wrong-token-wrong-token\r\n",
        cmd,
    )
    .await;
    assert_eq!(code, 401, "the vehicle's page refuses a wrong token");
    assert!(
        courses.try_recv().is_err(),
        "nothing reached the vehicle's bus"
    );
    let (code, body) = post(
        addr,
        "/api/vehicle/auv1/send",
        &format!("X-Vehicle-Token: {vehicle_token}\r\n"),
        cmd,
    )
    .await;
    assert_eq!(code, 200, "{body}");
    let env = tokio::time::timeout(BOUND, courses.recv())
        .await
        .unwrap()
        .unwrap();
    assert_eq!(env.msg.heading, Some(42.0));
    // A vehicle whose page has no token is never commanded through the topside.
    let (code, body) = post(
        addr,
        "/api/vehicle/auv2/send",
        "X-Vehicle-Token: anything-at-all-here\r\n",
        cmd,
    )
    .await;
    assert_eq!(code, 403, "{body}");
    // Another site's page cannot post through the topside.
    let (code, _) = post(
        addr,
        "/api/vehicle/auv1/send",
        &format!("Origin: http://evil.example\r\nX-Vehicle-Token: {vehicle_token}\r\n"),
        cmd,
    )
    .await;
    assert_eq!(code, 403);
    let (code, _) = post(
        addr,
        "/api/vehicle/nobody/send",
        &format!("X-Vehicle-Token: {vehicle_token}\r\n"),
        cmd,
    )
    .await;
    assert_eq!(code, 404);
    top.shutdown().await;
    page.shutdown(Duration::from_secs(3)).await;
    open_page.shutdown(Duration::from_secs(3)).await;
}
