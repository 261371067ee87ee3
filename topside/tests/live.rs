//! The topside's `[foxglove]` against a real Zenoh session and a real WebSocket client on
//! loopback, the client speaking `foxglove.websocket.v1` as Foxglove does: two vehicles publish
//! node_status, each is advertised as `<platform>/<group>` (as the topside records it) with a
//! self-contained schema, and a subscription to both yields frames that decode, with that schema
//! alone, to each vehicle's own node_status. Beyond loopback without a token is refused by the
//! config check, and a wrong token by the server.

mod common;

use std::collections::BTreeMap;
use std::time::Duration;

use base64::Engine as _;
use common::{free_port, publisher};
use frontseat_actors::groups;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::NodeStatus;
use frontseat_config::ServiceConfig as _;
use frontseat_helm_side::{key_for, put_message};
use frontseat_topside::{Topside, TopsideConfig};
use futures_util::{SinkExt, StreamExt};
use prost_reflect::{DescriptorPool, DynamicMessage};
use tokio_tungstenite::tungstenite::Message;
use tokio_tungstenite::tungstenite::client::IntoClientRequest;

const BOUND: Duration = Duration::from_secs(20);

type Ws =
    tokio_tungstenite::WebSocketStream<tokio_tungstenite::MaybeTlsStream<tokio::net::TcpStream>>;

async fn connect(url: &str) -> Result<Ws, tokio_tungstenite::tungstenite::Error> {
    let mut req = url.into_client_request().unwrap();
    req.headers_mut().insert(
        "Sec-WebSocket-Protocol",
        "foxglove.websocket.v1".parse().unwrap(),
    );
    Ok(tokio_tungstenite::connect_async(req).await?.0)
}

async fn next(ws: &mut Ws) -> Message {
    tokio::time::timeout(BOUND, ws.next())
        .await
        .expect("a message in time")
        .expect("open")
        .expect("no error")
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_foxglove_client_decodes_node_status_of_two_platforms_from_the_topside() {
    let port = free_port();
    let z = publisher(port).await;
    let mut cfg = TopsideConfig::default();
    cfg.zenoh.connect = vec![format!("tcp/127.0.0.1:{port}")];
    cfg.web.listen = "127.0.0.1:0".into();
    cfg.foxglove.enabled = true;
    cfg.foxglove.bind = "127.0.0.1:0".into();
    assert!(cfg.validate().is_empty(), "{:?}", cfg.validate());
    let top = Topside::start(&cfg).await.unwrap();
    let addr = top.foxglove_addr().expect("[foxglove] enabled");
    assert!(addr.ip().is_loopback());

    let group = groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS.name();
    let ns_type = groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS.type_name();
    // Both vehicles publish until the test ends (Zenoh drops puts made before the topside's
    // subscription matched); auv1's x is positive, auv2's negative, so a frame says whose it is.
    let feeder = {
        let z = z.clone();
        tokio::spawn(async move {
            let mut iv = tokio::time::interval(Duration::from_millis(20));
            for i in 1u32.. {
                iv.tick().await;
                for (p, x) in [("auv1", f64::from(i)), ("auv2", -f64::from(i))] {
                    let mut n = NodeStatus {
                        name: Some(p.into()),
                        ..Default::default()
                    };
                    n.global_fix.lat = 42.0;
                    n.global_fix.lon = x;
                    put_message(&z, &key_for(p, group), ns_type, &n, None).unwrap();
                }
            }
        })
    };

    let mut ws = connect(&format!("ws://{addr}/")).await.unwrap();
    let info = match next(&mut ws).await {
        Message::Text(t) => serde_json::from_str::<serde_json::Value>(&t).unwrap(),
        m => panic!("serverInfo first, got {m:?}"),
    };
    assert_eq!(info["op"], "serverInfo");
    assert_eq!(info["capabilities"], serde_json::json!([]), "read-only");

    // Channels are advertised as vehicles are heard: read advertise ops until both are known.
    let mut channels: BTreeMap<String, serde_json::Value> = BTreeMap::new();
    let want = |p: &str| format!("{p}/{group}");
    while !(channels.contains_key(&want("auv1")) && channels.contains_key(&want("auv2"))) {
        if let Message::Text(t) = next(&mut ws).await {
            let v: serde_json::Value = serde_json::from_str(&t).unwrap();
            assert_eq!(v["op"], "advertise", "{v}");
            for c in v["channels"].as_array().unwrap() {
                let topic = c["topic"].as_str().unwrap().to_string();
                assert!(
                    channels.insert(topic.clone(), c.clone()).is_none(),
                    "{topic} advertised twice"
                );
            }
        }
    }
    // Subscription id 10 + i for platform i, so a frame names its channel.
    let platforms = ["auv1", "auv2"];
    let subs: Vec<serde_json::Value> = platforms
        .iter()
        .enumerate()
        .map(|(i, p)| serde_json::json!({"id": 10 + i, "channelId": channels[&want(p)]["id"]}))
        .collect();
    ws.send(Message::Text(
        serde_json::json!({"op": "subscribe", "subscriptions": subs})
            .to_string()
            .into(),
    ))
    .await
    .unwrap();

    let mut decoded: BTreeMap<&str, DynamicMessage> = BTreeMap::new();
    while decoded.len() < 2 {
        let Message::Binary(b) = next(&mut ws).await else {
            continue;
        };
        assert_eq!(b[0], 0x01, "message data opcode");
        let sub = u32::from_le_bytes(b[1..5].try_into().unwrap());
        let p = platforms[(sub - 10) as usize];
        let ch = &channels[&want(p)];
        assert_eq!(ch["encoding"], "protobuf");
        assert_eq!(ch["schemaName"], ns_type);
        let schema = base64::engine::general_purpose::STANDARD
            .decode(ch["schema"].as_str().unwrap())
            .unwrap();
        let pool = DescriptorPool::decode(schema.as_slice()).expect("a FileDescriptorSet");
        let desc = pool.get_message_by_name(ns_type).unwrap();
        let m = DynamicMessage::decode(desc, &b[13..]).expect("decodes with the schema alone");
        decoded.insert(p, m);
    }
    feeder.abort();
    for (p, sign) in [("auv1", 1.0), ("auv2", -1.0)] {
        let m = &decoded[p];
        assert_eq!(m.get_field_by_name("name").unwrap().as_str(), Some(p));
        let fix = m.get_field_by_name("global_fix").unwrap();
        let lon = fix.as_message().unwrap().get_field_by_name("lon").unwrap();
        assert!(lon.as_f64().unwrap() * sign > 0.0, "{p}: {lon:?}");
    }
    let _ = ws.close(None).await;
    top.shutdown().await;
    z.close().await.unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_topside_foxglove_needs_a_token_beyond_loopback_and_checks_it() {
    let mut cfg = TopsideConfig::default();
    cfg.web.listen = "127.0.0.1:0".into();
    cfg.foxglove.enabled = true;
    cfg.foxglove.bind = "0.0.0.0:0".into();
    let e: Vec<String> = cfg.validate().iter().map(|e| e.to_string()).collect();
    assert!(e.join("\n").contains("foxglove.bind"), "{e:?}");
    // With a token: served, and a client without it (or with another) is refused.
    cfg.foxglove.bind = "127.0.0.1:0".into();
    cfg.foxglove.token = Some("a-long-enough-random-token".into());
    assert!(cfg.validate().is_empty(), "{:?}", cfg.validate());
    let top = Topside::start(&cfg).await.unwrap();
    let addr = top.foxglove_addr().unwrap();
    for url in [
        format!("ws://{addr}/"),
        format!("ws://{addr}/?token=not-the-token-at-all-no"),
    ] {
        match connect(&url).await {
            Err(tokio_tungstenite::tungstenite::Error::Http(r)) => {
                assert_eq!(r.status().as_u16(), 401)
            }
            other => panic!("expected 401, got {:?}", other.map(|_| ())),
        }
    }
    let mut ws = connect(&format!("ws://{addr}/?token=a-long-enough-random-token"))
        .await
        .unwrap();
    assert!(matches!(next(&mut ws).await, Message::Text(_)));
    top.shutdown().await;
}

/// The example config the README points to loads and checks, with `[foxglove]` on loopback.
#[test]
fn the_example_topside_config_checks() {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../deploy/examples/topside.toml");
    let (cfg, _notes) = frontseat_config::load_with_notes::<TopsideConfig>(&path).unwrap();
    assert!(cfg.foxglove.enabled && cfg.record.enabled);
    assert_eq!(cfg.foxglove.bind, "127.0.0.1:8765");
    assert!(cfg.validate().is_empty(), "{:?}", cfg.validate());
}
