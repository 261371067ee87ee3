//! The Foxglove live server with a real WebSocket client over loopback, speaking
//! `foxglove.websocket.v1` as Foxglove does: serverInfo and advertise arrive, a subscription to
//! node_status yields message-data frames that decode with the advertised schema alone; the
//! server is read-only, refuses clients without the subprotocol or the token, refuses another
//! site's page (foreign Origin or Host) unless its origin is allowed, binds loopback only unless a
//! token is set, and serves a new client through hundreds of idle and trickling sockets.

use frontseat_actors::bus::test_util::UntypedBus as _;
use std::time::Duration;

use base64::Engine as _;
use frontseat_actors::bus::Bus;
use frontseat_actors::groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS as NODE_STATUS;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::NodeStatus;
use frontseat_config::RecordConfig;
use frontseat_record::recorder::RecordMeta;
use frontseat_record::service::RecordService;
use futures_util::{SinkExt, StreamExt};
use prost_reflect::{DescriptorPool, DynamicMessage};
use tokio_tungstenite::tungstenite::Message;
use tokio_tungstenite::tungstenite::client::IntoClientRequest;

const WAIT: Duration = Duration::from_secs(20);

fn live_only(token: Option<&str>) -> RecordConfig {
    let mut c = RecordConfig::default();
    c.foxglove.enabled = true;
    c.foxglove.bind = "127.0.0.1:0".into();
    c.foxglove.token = token.map(str::to_string);
    c
}

type Ws =
    tokio_tungstenite::WebSocketStream<tokio_tungstenite::MaybeTlsStream<tokio::net::TcpStream>>;

async fn connect(
    url: &str,
    subprotocol: bool,
) -> Result<Ws, tokio_tungstenite::tungstenite::Error> {
    let mut req = url.into_client_request().unwrap();
    if subprotocol {
        req.headers_mut().insert(
            "Sec-WebSocket-Protocol",
            "foxglove.websocket.v1".parse().unwrap(),
        );
    }
    let (ws, resp) = tokio_tungstenite::connect_async(req).await?;
    if subprotocol {
        assert_eq!(
            resp.headers()
                .get("Sec-WebSocket-Protocol")
                .and_then(|v| v.to_str().ok()),
            Some("foxglove.websocket.v1"),
            "the server selects the subprotocol"
        );
    }
    Ok(ws)
}

async fn next_text(ws: &mut Ws) -> serde_json::Value {
    loop {
        let m = tokio::time::timeout(WAIT, ws.next())
            .await
            .expect("a message in time")
            .expect("open")
            .expect("no error");
        if let Message::Text(t) = m {
            return serde_json::from_str(&t).unwrap();
        }
    }
}

fn http_status(e: tokio_tungstenite::tungstenite::Error) -> u16 {
    match e {
        tokio_tungstenite::tungstenite::Error::Http(r) => r.status().as_u16(),
        e => panic!("expected an HTTP refusal, got {e}"),
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_foxglove_client_decodes_node_status_with_the_advertised_schema() {
    let bus = Bus::new();
    let svc = RecordService::spawn(&bus, &live_only(None), "auv1", RecordMeta::default())
        .unwrap()
        .expect("live server on");
    assert!(svc.recorder().is_none(), "live only: no file");
    let addr = svc.foxglove_addr().unwrap();
    let url = format!("ws://{addr}/");
    let mut ws = connect(&url, true).await.unwrap();

    let info = next_text(&mut ws).await;
    assert_eq!(info["op"], "serverInfo");
    assert_eq!(
        info["capabilities"],
        serde_json::json!([]),
        "read-only: no client publish"
    );
    let adv = next_text(&mut ws).await;
    assert_eq!(adv["op"], "advertise");
    let ch = adv["channels"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["topic"] == NODE_STATUS.name())
        .expect("node_status advertised")
        .clone();
    assert_eq!(ch["encoding"], "protobuf");
    assert_eq!(ch["schemaEncoding"], "protobuf");
    let schema = base64::engine::general_purpose::STANDARD
        .decode(ch["schema"].as_str().unwrap())
        .unwrap();
    let pool = DescriptorPool::decode(schema.as_slice()).expect("a FileDescriptorSet");
    let desc = pool
        .get_message_by_name(ch["schemaName"].as_str().unwrap())
        .expect("the advertised schema describes its type");

    ws.send(Message::Text(
        serde_json::json!({"op": "subscribe", "subscriptions": [{"id": 7, "channelId": ch["id"]}]})
            .to_string()
            .into(),
    ))
    .await
    .unwrap();
    // A write attempt is answered with an error status, and nothing reaches the bus.
    ws.send(Message::Text(
        r#"{"op":"advertise","channels":[{"id":1,"topic":"goby::middleware::frontseat::desired_course"}]}"#.into(),
    ))
    .await
    .unwrap();
    ws.send(Message::Binary(vec![1, 1, 0, 0, 0, 9].into()))
        .await
        .unwrap();

    // Publish until the subscription is in place and a frame arrives (bounded by WAIT).
    let publisher = {
        let bus = bus.clone();
        tokio::spawn(async move {
            let mut iv = tokio::time::interval(Duration::from_millis(20));
            for i in 0u32.. {
                iv.tick().await;
                let mut n = NodeStatus {
                    time: 1000.0 + f64::from(i),
                    name: Some("auv1".into()),
                    ..Default::default()
                };
                n.global_fix.lat = 42.5;
                n.global_fix.lon = -70.25;
                bus.publish(&NODE_STATUS, n);
            }
        })
    };
    // Frames and the two refusals may interleave: read until both are in.
    let mut statuses = 0;
    let mut first = None;
    let frame = loop {
        if statuses == 2
            && let Some(f) = first.take()
        {
            break f;
        }
        let m = tokio::time::timeout(WAIT, ws.next())
            .await
            .expect("a frame in time")
            .unwrap()
            .unwrap();
        match m {
            Message::Binary(b) => {
                first.get_or_insert(b);
            }
            Message::Text(t) => {
                let v: serde_json::Value = serde_json::from_str(&t).unwrap();
                assert_eq!(v["op"], "status");
                assert_eq!(v["level"], 2);
                statuses += 1;
            }
            _ => {}
        }
    };
    publisher.abort();
    assert_eq!(frame[0], 0x01, "message data opcode");
    assert_eq!(u32::from_le_bytes(frame[1..5].try_into().unwrap()), 7);
    let ts = u64::from_le_bytes(frame[5..13].try_into().unwrap());
    assert!(ts > 1_600_000_000_000_000_000, "wall-clock ns: {ts}");
    let msg = DynamicMessage::decode(desc, &frame[13..]).expect("decodes with the schema");
    assert_eq!(
        msg.get_field_by_name("name").unwrap().as_str(),
        Some("auv1")
    );
    let fix = msg.get_field_by_name("global_fix").unwrap();
    let lat = fix.as_message().unwrap().get_field_by_name("lat").unwrap();
    assert_eq!(lat.as_f64(), Some(42.5));
    assert_eq!(statuses, 2, "both write attempts refused with a status");

    // No subprotocol: refused before the upgrade.
    assert_eq!(http_status(connect(&url, false).await.unwrap_err()), 400);
    let (_, fox) = svc.stop().await;
    let fox = fox.unwrap();
    assert!(
        fox.sent >= 1 && fox.bad_requests == 2 && fox.refused == 1,
        "{fox:?}"
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_token_gates_every_client_and_an_open_bind_needs_one() {
    let bus = Bus::new();
    let token = "a-long-enough-random-token";
    let svc = RecordService::spawn(&bus, &live_only(Some(token)), "auv1", RecordMeta::default())
        .unwrap()
        .unwrap();
    let addr = svc.foxglove_addr().unwrap();
    assert_eq!(
        http_status(connect(&format!("ws://{addr}/"), true).await.unwrap_err()),
        401
    );
    assert_eq!(
        http_status(
            connect(&format!("ws://{addr}/?token=wrong-token-of-any-len"), true)
                .await
                .unwrap_err()
        ),
        401
    );
    let mut ws = connect(&format!("ws://{addr}/?token={token}"), true)
        .await
        .unwrap();
    assert_eq!(next_text(&mut ws).await["op"], "serverInfo");
    svc.stop().await;

    // Not loopback, no token: refused at start, never listening.
    let mut open = live_only(None);
    open.foxglove.bind = "0.0.0.0:0".into();
    if std::env::var_os(frontseat_config::FOXGLOVE_TOKEN_ENV).is_none() {
        let e = RecordService::spawn(&bus, &open, "auv1", RecordMeta::default()).unwrap_err();
        assert!(e.to_string().contains("token"), "{e}");
    }
}

/// A client that sends its upgrade request a byte every 50 ms (never completing it in time);
/// returns how long the server let it trickle before it closed the connection.
async fn trickle(addr: std::net::SocketAddr) -> Duration {
    use tokio::io::{AsyncReadExt, AsyncWriteExt};
    let req = format!(
        "GET / HTTP/1.1\r\nHost: {addr}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n\
         Sec-WebSocket-Version: 13\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n\
         Sec-WebSocket-Protocol: foxglove.websocket.v1\r\n\r\n"
    );
    let mut s = tokio::net::TcpStream::connect(addr).await.unwrap();
    let t0 = tokio::time::Instant::now();
    let mut buf = [0u8; 256];
    let mut bytes = req.bytes();
    loop {
        tokio::select! {
            // End of stream or a reset: the server closed it. (No answer comes before that: the
            // request is never complete.)
            r = s.read(&mut buf) => {
                assert!(!matches!(r, Ok(n) if n > 0), "an answer to an incomplete request");
                return t0.elapsed();
            }
            _ = tokio::time::sleep(Duration::from_millis(50)) => {
                let b = bytes.next().expect("the request outlasted the bound");
                if s.write_all(&[b]).await.is_err() {
                    return t0.elapsed();
                }
            }
        }
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn trickling_clients_are_closed_within_the_bound_and_a_real_client_still_connects() {
    use frontseat_record::foxglove::{FoxgloveOptions, FoxgloveServer};
    let bound = Duration::from_millis(600);
    let bus = Bus::new();
    let opts = FoxgloveOptions {
        bind: "127.0.0.1:0".into(),
        max_clients: 1,
        request_timeout: bound,
        ..Default::default()
    };
    let server =
        FoxgloveServer::start(&bus, frontseat_actors::groups::ALL, |_| true, &opts, "auv1")
            .unwrap();
    let addr = server.local_addr();
    // More tricklers than the server has connection slots (max_clients + 8): each one past
    // them closes the oldest unfinished connection; the others are cut at the bound.
    let tricklers: Vec<_> = (0..12).map(|_| tokio::spawn(trickle(addr))).collect();
    for t in tricklers {
        let held = tokio::time::timeout(WAIT, t).await.unwrap().unwrap();
        // Those evicted are closed at once; the others at the bound.
        assert!(
            held < bound + Duration::from_secs(2),
            "a trickling client held its connection {held:?}"
        );
    }
    let st = server.stats();
    // Past the slots, each new one closed the oldest unfinished; the rest were cut at the bound.
    assert!(
        st.slow_requests >= 1
            && st.slow_requests + st.evicted + st.header_timeouts + st.connections_refused >= 12,
        "{st:?}"
    );

    // A real client connects now and stays connected past the bound while quiet: the server's
    // pings keep it open (the bound is on the request, not on the websocket).
    let mut ws = connect(&format!("ws://{addr}/"), true).await.unwrap();
    assert_eq!(next_text(&mut ws).await["op"], "serverInfo");
    assert_eq!(next_text(&mut ws).await["op"], "advertise");
    let t0 = tokio::time::Instant::now();
    let mut pings = 0;
    while t0.elapsed() < bound * 3 {
        let m = tokio::time::timeout(WAIT, ws.next())
            .await
            .expect("a ping in time")
            .expect("still open")
            .expect("no error");
        if matches!(m, Message::Ping(_)) {
            pings += 1;
        }
    }
    assert!(pings >= 3, "{pings} pings in {:?}", t0.elapsed());
    ws.close(None).await.unwrap();
    server.stop();
}

/// Opens `n` sockets that hold a connection without finishing an upgrade: every other one
/// silent, the rest trickling the upgrade request a byte a second while open. Dropping the set
/// closes them.
async fn flood(addr: std::net::SocketAddr, n: usize) -> tokio::task::JoinSet<()> {
    use tokio::io::{AsyncReadExt, AsyncWriteExt};
    let mut set = tokio::task::JoinSet::new();
    for i in 0..n {
        let mut s = tokio::time::timeout(WAIT, tokio::net::TcpStream::connect(addr))
            .await
            .expect("connect in time")
            .expect("connect");
        set.spawn(async move {
            let req = format!(
                "GET / HTTP/1.1\r\nHost: {addr}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
            );
            let mut bytes = req.into_bytes().into_iter();
            let mut buf = [0u8; 256];
            loop {
                tokio::select! {
                    r = s.read(&mut buf) => match r {
                        Ok(0) | Err(_) => return,
                        // Whatever the server says (nothing, or an error status), the flood goes on.
                        Ok(_) => {}
                    },
                    () = tokio::time::sleep(Duration::from_secs(1)), if i % 2 == 1 => {
                        if s.write_all(&[bytes.next().unwrap_or(b'a')]).await.is_err() {
                            return;
                        }
                    }
                }
            }
        });
    }
    set
}

/// 300 idle and trickling sockets against the default 8 clients (16 connections): a Foxglove
/// client still connects within a bounded wait, and a second flood does not take it.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn hundreds_of_idle_and_trickling_sockets_do_not_lock_out_a_foxglove_client() {
    let bus = Bus::new();
    let svc = RecordService::spawn(&bus, &live_only(None), "auv1", RecordMeta::default())
        .unwrap()
        .unwrap();
    let addr = svc.foxglove_addr().unwrap();
    let bound = Duration::from_secs(10);
    let _first = flood(addr, 300).await;
    let mut ws = tokio::time::timeout(bound, connect(&format!("ws://{addr}/"), true))
        .await
        .expect("a client connects within the bound")
        .expect("upgraded");
    assert_eq!(next_text(&mut ws).await["op"], "serverInfo");
    let adv = next_text(&mut ws).await;
    let ch = adv["channels"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["topic"] == NODE_STATUS.name())
        .expect("node_status advertised")["id"]
        .clone();
    ws.send(Message::Text(
        serde_json::json!({"op": "subscribe", "subscriptions": [{"id": 1, "channelId": ch}]})
            .to_string()
            .into(),
    ))
    .await
    .unwrap();
    // The connected client, upgraded, is not what gives way to the next flood.
    let _second = flood(addr, 300).await;
    let publisher = {
        let bus = bus.clone();
        tokio::spawn(async move {
            let mut iv = tokio::time::interval(Duration::from_millis(50));
            loop {
                iv.tick().await;
                bus.publish(&NODE_STATUS, NodeStatus::default());
            }
        })
    };
    let got = tokio::time::timeout(bound, async {
        loop {
            match ws.next().await {
                Some(Ok(Message::Binary(b))) => return b.first().copied(),
                Some(Ok(_)) => continue,
                other => panic!("the client was closed: {other:?}"),
            }
        }
    })
    .await
    .expect("the open client still streams");
    assert_eq!(got, Some(0x01), "a message-data frame");
    publisher.abort();
    // And a new one still connects.
    let mut again = tokio::time::timeout(bound, connect(&format!("ws://{addr}/"), true))
        .await
        .expect("a second client connects within the bound")
        .expect("upgraded");
    assert_eq!(next_text(&mut again).await["op"], "serverInfo");
    svc.stop().await;
}

async fn connect_with(
    url: &str,
    headers: &[(&'static str, &str)],
) -> Result<Ws, tokio_tungstenite::tungstenite::Error> {
    let mut req = url.into_client_request().unwrap();
    req.headers_mut().insert(
        "Sec-WebSocket-Protocol",
        "foxglove.websocket.v1".parse().unwrap(),
    );
    for (k, v) in headers {
        req.headers_mut().insert(*k, v.parse().unwrap());
    }
    Ok(tokio_tungstenite::connect_async(req).await?.0)
}

/// Another site's page in the operator's browser opens a WebSocket to the loopback server
/// (its Origin is its own), or rebinds its name to 127.0.0.1 (its Host is its own): refused with
/// 403 before any data, as the web pages refuse them; the server's own origin streams.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_foreign_origin_or_host_is_refused_and_the_own_origin_streams() {
    let bus = Bus::new();
    let svc = RecordService::spawn(&bus, &live_only(None), "auv1", RecordMeta::default())
        .unwrap()
        .unwrap();
    let addr = svc.foxglove_addr().unwrap();
    let url = format!("ws://{addr}/");
    let rebound = format!("evil.example:{}", addr.port());
    for headers in [
        vec![("Origin", "http://evil.example")],
        vec![("Origin", "null")],
        vec![("Host", rebound.as_str())],
        vec![
            ("Host", rebound.as_str()),
            ("Origin", "http://evil.example"),
        ],
    ] {
        let e = connect_with(&url, &headers).await.err();
        let status = e.map(http_status);
        assert_eq!(status, Some(403), "{headers:?}");
    }
    let own = format!("http://{addr}");
    let mut ws = connect_with(&url, &[("Origin", own.as_str())])
        .await
        .expect("the server's own origin");
    assert_eq!(next_text(&mut ws).await["op"], "serverInfo");
    svc.stop().await;
}

/// `allowed_origins` admits a web Foxglove's page and nothing else; the Host check still holds
/// for it; an entry that is not an origin is refused by the config check.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_allowed_origin_streams_and_others_stay_refused() {
    let bus = Bus::new();
    let mut cfg = live_only(None);
    cfg.foxglove.allowed_origins = vec!["https://app.foxglove.dev".into()];
    assert!(cfg.errors_at("record").is_empty());
    let svc = RecordService::spawn(&bus, &cfg, "auv1", RecordMeta::default())
        .unwrap()
        .unwrap();
    let addr = svc.foxglove_addr().unwrap();
    let url = format!("ws://{addr}/");
    let mut ws = connect_with(&url, &[("Origin", "https://app.foxglove.dev")])
        .await
        .expect("an allowed origin");
    assert_eq!(next_text(&mut ws).await["op"], "serverInfo");
    let rebound = format!("evil.example:{}", addr.port());
    for headers in [
        vec![("Origin", "https://evil.example")],
        vec![
            ("Origin", "https://app.foxglove.dev"),
            ("Host", rebound.as_str()),
        ],
    ] {
        let status = connect_with(&url, &headers).await.err().map(http_status);
        assert_eq!(status, Some(403), "{headers:?}");
    }
    svc.stop().await;

    cfg.foxglove.allowed_origins = vec!["https://ok.example".into(), "bad origin".into()];
    let e: Vec<String> = cfg
        .errors_at("record")
        .iter()
        .map(|e| e.to_string())
        .collect();
    assert!(
        e.len() == 1 && e[0].contains("record.foxglove.allowed_origins[1]"),
        "{e:?}"
    );
}

/// An upgrade request trickled a byte a second is closed at `header_timeout` (here 2 s, with a
/// minute of idle allowance), counted; in paused time.
#[tokio::test(start_paused = true)]
async fn an_upgrade_head_trickled_a_byte_a_second_is_closed_at_the_header_timeout() {
    use frontseat_record::foxglove::{FoxgloveOptions, FoxgloveServer};
    use tokio::io::{AsyncReadExt, AsyncWriteExt};
    let bus = Bus::new();
    let opts = FoxgloveOptions {
        bind: "127.0.0.1:0".into(),
        request_timeout: Duration::from_secs(60),
        header_timeout: Duration::from_secs(2),
        ..Default::default()
    };
    let server =
        FoxgloveServer::start(&bus, frontseat_actors::groups::ALL, |_| true, &opts, "auv1")
            .unwrap();
    let mut s = tokio::net::TcpStream::connect(server.local_addr())
        .await
        .unwrap();
    let t0 = tokio::time::Instant::now();
    let mut bytes = b"GET / HTTP/1.1\r\nUpgrade: websocket\r\n".iter().copied();
    let mut buf = [0u8; 64];
    let held = tokio::time::timeout(Duration::from_secs(120), async {
        loop {
            tokio::select! {
                r = s.read(&mut buf) => match r {
                    Ok(0) | Err(_) => return t0.elapsed(),
                    Ok(_) => panic!("an answer to an incomplete request"),
                },
                () = tokio::time::sleep(Duration::from_secs(1)) => {
                    if s.write_all(&[bytes.next().unwrap_or(b'a')]).await.is_err() {
                        return t0.elapsed();
                    }
                }
            }
        }
    })
    .await
    .expect("closed at all");
    assert!(held <= Duration::from_secs(3), "held {held:?}");
    assert_eq!(server.stats().header_timeouts, 1, "{:?}", server.stats());
    server.stop();
}
