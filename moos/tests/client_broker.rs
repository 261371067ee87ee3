//! Client ↔ broker over real loopback TCP: double/string/binary round trips, reconnect with
//! re-registration across a broker restart, the offline queue policy, type lock, duplicate
//! names, silent clients, and the client's heartbeat/held-mail poll seen by a scripted fake DB.

use std::time::Duration;

use bytes::BytesMut;
use frontseat_moos::codec::{self, BANNER, MoosMessage, MsgType, PacketDecoder};
use frontseat_moos::{
    Broker, BrokerConfig, BrokerHandle, DataType, MoosClient, MoosClientConfig, MoosEvent,
    MoosValue,
};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::mpsc::Receiver;
use tokio::time::timeout;

const WAIT: Duration = Duration::from_secs(5);

fn cfg(name: &str, broker: &BrokerHandle) -> MoosClientConfig {
    MoosClientConfig {
        server: broker.local_addr().to_string(),
        reconnect_initial: Duration::from_millis(20),
        reconnect_max: Duration::from_millis(200),
        ..MoosClientConfig::new(name)
    }
}

async fn broker() -> BrokerHandle {
    Broker::bind("127.0.0.1:0").await.unwrap()
}

async fn next_event(rx: &mut Receiver<MoosEvent>) -> MoosEvent {
    timeout(WAIT, rx.recv())
        .await
        .expect("no event within 5 s")
        .expect("event channel closed")
}

async fn wait_connected(rx: &mut Receiver<MoosEvent>) {
    loop {
        if next_event(rx).await == MoosEvent::Connected {
            return;
        }
    }
}

async fn wait_disconnected(rx: &mut Receiver<MoosEvent>) -> String {
    loop {
        if let MoosEvent::Disconnected(r) = next_event(rx).await {
            return r;
        }
    }
}

async fn next_mail(rx: &mut Receiver<MoosEvent>, key: &str) -> MoosMessage {
    loop {
        if let MoosEvent::Mail(m) = next_event(rx).await
            && m.key == key
        {
            return m;
        }
    }
}

/// Register `key`, post to it ourselves and wait for it to come back: proves the DB has
/// processed everything we sent before.
async fn sync(client: &MoosClient, rx: &mut Receiver<MoosEvent>, key: &str) {
    client.register(key, 0.0).unwrap();
    client.notify_double(key, 1.0, None).unwrap();
    next_mail(rx, key).await;
}

#[tokio::test]
async fn double_string_and_binary_round_trip() {
    let b = broker().await;
    let (sub, mut srx) = MoosClient::start(cfg("sub", &b)).unwrap();
    for k in ["RT_DBL", "RT_STR", "RT_BIN"] {
        sub.register(k, 0.0).unwrap();
    }
    wait_connected(&mut srx).await;
    sync(&sub, &mut srx, "SUB_SYNC").await;

    let (publ, mut prx) = MoosClient::start(cfg("pub", &b)).unwrap();
    wait_connected(&mut prx).await;
    let t = publ.moos_time();
    let bin: Vec<u8> = (0..=255u8).chain([0, 0, 255]).collect();
    publ.notify_double("RT_DBL", -12.625, Some(t)).unwrap();
    publ.notify_string("RT_STR", "héllo, moos", Some(t + 1.0))
        .unwrap();
    publ.notify_binary("RT_BIN", &bin, None).unwrap();

    let d = next_mail(&mut srx, "RT_DBL").await;
    assert_eq!(d.as_double(), Some(-12.625));
    assert_eq!(d.data_type, DataType::Double);
    assert_eq!(d.source, "pub");
    assert_eq!(d.community, "frontseat");
    assert_eq!(d.time, t);
    let s = next_mail(&mut srx, "RT_STR").await;
    assert_eq!(s.as_str(), Some("héllo, moos"));
    assert_eq!(s.time, t + 1.0);
    assert_eq!(s.source, "pub");
    let x = next_mail(&mut srx, "RT_BIN").await;
    assert_eq!(x.data_type, DataType::Binary);
    assert_eq!(x.as_binary(), Some(bin.as_slice()));
    let now = publ.moos_time();
    assert!(
        (now - x.time).abs() < 5.0,
        "binary stamped with now: {} vs {now}",
        x.time
    );
    assert!(publ.counters().messages_sent >= 3);
    assert!(sub.counters().mail_received >= 3);

    // Unregister stops deliveries; the sync var still flows.
    sub.unregister("RT_DBL").unwrap();
    sync(&sub, &mut srx, "SUB_SYNC2").await;
    publ.notify_double("RT_DBL", 1.0, None).unwrap();
    publ.notify_string("RT_STR", "after", None).unwrap();
    loop {
        match next_event(&mut srx).await {
            MoosEvent::Mail(m) if m.key == "RT_STR" => {
                assert_eq!(m.as_str(), Some("after"));
                break;
            }
            MoosEvent::Mail(m) => assert_ne!(m.key, "RT_DBL", "mail after unregister"),
            _ => {}
        }
    }
    sub.shutdown().await;
    publ.shutdown().await;
    assert!(publ.notify_double("X", 1.0, None).is_err());
    b.shutdown().await;
}

/// The translation's mode: each packet's mail arrives as one event, in the order posted, so a
/// trigger (DESIRED_SPEED) is handled with the rest of its helm iteration in one wake-up.
#[tokio::test]
async fn mail_by_packet_reports_each_packet_as_one_event() {
    let b = broker().await;
    let (sub, mut srx) = MoosClient::start(MoosClientConfig {
        mail_by_packet: true,
        ..cfg("sub", &b)
    })
    .unwrap();
    for k in ["P_HEADING", "P_DEPTH", "P_SPEED", "P_SYNC"] {
        sub.register(k, 0.0).unwrap();
    }
    wait_connected(&mut srx).await;
    sub.notify_double("P_SYNC", 1.0, None).unwrap();
    let packet = loop {
        match next_event(&mut srx).await {
            MoosEvent::Packet(ms) if ms.iter().any(|m| m.key == "P_SYNC") => break ms,
            MoosEvent::Mail(m) => panic!("a Mail event in mail_by_packet mode: {m:?}"),
            _ => {}
        }
    };
    assert_eq!(packet.len(), 1);

    let (publ, mut prx) = MoosClient::start(cfg("pub", &b)).unwrap();
    wait_connected(&mut prx).await;
    publ.notify_doubles(
        &[("P_HEADING", 90.0), ("P_DEPTH", 7.0), ("P_SPEED", 1.5)],
        None,
    )
    .unwrap();
    let packet = match next_event(&mut srx).await {
        MoosEvent::Packet(ms) => ms,
        other => panic!("expected one Packet event, got {other:?}"),
    };
    let got: Vec<(String, Option<f64>)> = packet
        .iter()
        .map(|m| (m.key.to_string_lossy().into_owned(), m.as_double()))
        .collect();
    assert_eq!(
        got,
        [
            ("P_HEADING".to_string(), Some(90.0)),
            ("P_DEPTH".to_string(), Some(7.0)),
            ("P_SPEED".to_string(), Some(1.5)),
        ]
    );
    assert_eq!(sub.counters().mail_received, 4);
    sub.shutdown().await;
    publ.shutdown().await;
    b.shutdown().await;
}

/// The translation's NAV_* posts: values of mixed types posted as one batch arrive as one
/// packet, in order, each with its type (issue 49: one packet per node_status, not one per post).
#[tokio::test]
async fn notify_values_leave_in_one_packet_in_order() {
    let b = broker().await;
    let (sub, mut srx) = MoosClient::start(MoosClientConfig {
        mail_by_packet: true,
        ..cfg("vsub", &b)
    })
    .unwrap();
    for k in ["V_X", "V_TIME", "V_BLOB", "V_SYNC"] {
        sub.register(k, 0.0).unwrap();
    }
    wait_connected(&mut srx).await;
    sub.notify_double("V_SYNC", 1.0, None).unwrap();
    loop {
        match next_event(&mut srx).await {
            MoosEvent::Packet(ms) if ms.iter().any(|m| m.key == "V_SYNC") => break,
            _ => {}
        }
    }
    let (publ, mut prx) = MoosClient::start(cfg("vpub", &b)).unwrap();
    wait_connected(&mut prx).await;
    publ.notify_values(
        &[
            ("V_X", MoosValue::Double(12.5)),
            ("V_TIME", MoosValue::String(b"Timestamp=1.5")),
            ("V_BLOB", MoosValue::Binary(&[0, 1, 2])),
        ],
        None,
    )
    .unwrap();
    let packet = match next_event(&mut srx).await {
        MoosEvent::Packet(ms) => ms,
        other => panic!("expected one Packet event, got {other:?}"),
    };
    let keys: Vec<String> = packet
        .iter()
        .map(|m| m.key.to_string_lossy().into_owned())
        .collect();
    assert_eq!(keys, ["V_X", "V_TIME", "V_BLOB"]);
    assert_eq!(packet[0].as_double(), Some(12.5));
    assert_eq!(&packet[1].string_val[..], b"Timestamp=1.5");
    assert_eq!(packet[1].data_type, DataType::String);
    assert_eq!(&packet[2].string_val[..], &[0u8, 1, 2][..]);
    assert_eq!(packet[2].data_type, DataType::Binary);
    // A bad key refuses the whole batch before any of it is queued.
    assert!(
        publ.notify_values(
            &[
                ("V_X", MoosValue::Double(1.0)),
                ("", MoosValue::Double(2.0))
            ],
            None
        )
        .is_err()
    );
    sub.shutdown().await;
    publ.shutdown().await;
    b.shutdown().await;
}

#[tokio::test]
async fn shutdown_flushes_queued_notifications() {
    let b = broker().await;
    let (sub, mut srx) = MoosClient::start(cfg("flush_sub", &b)).unwrap();
    sub.register("FLUSH", 0.0).unwrap();
    wait_connected(&mut srx).await;
    sync(&sub, &mut srx, "FLUSH_SYNC").await;
    let (publ, mut prx) = MoosClient::start(cfg("flush_pub", &b)).unwrap();
    wait_connected(&mut prx).await;
    publ.notify_double("FLUSH", 7.0, None).unwrap();
    publ.shutdown().await;
    assert_eq!(next_mail(&mut srx, "FLUSH").await.as_double(), Some(7.0));
    sub.shutdown().await;
    b.shutdown().await;
}

#[tokio::test]
async fn reconnect_re_registers_after_broker_restart() {
    let b = broker().await;
    let addr = b.local_addr();
    let (sub, mut srx) = MoosClient::start(cfg("resub", &b)).unwrap();
    sub.register("RESTART_VAR", 0.0).unwrap();
    sub.register("RESTART_STR", 0.0).unwrap();
    wait_connected(&mut srx).await;
    assert!(sub.is_connected());

    b.shutdown().await;
    let why = wait_disconnected(&mut srx).await;
    assert!(!why.is_empty());
    assert!(!sub.is_connected());

    let b = Broker::bind(addr).await.unwrap();
    assert_eq!(b.local_addr(), addr);
    wait_connected(&mut srx).await;
    let (publ, mut prx) = MoosClient::start(cfg("repub", &b)).unwrap();
    wait_connected(&mut prx).await;
    publ.notify_double("RESTART_VAR", 2.5, None).unwrap();
    publ.notify_string("RESTART_STR", "back", None).unwrap();
    assert_eq!(
        next_mail(&mut srx, "RESTART_VAR").await.as_double(),
        Some(2.5)
    );
    assert_eq!(
        next_mail(&mut srx, "RESTART_STR").await.as_str(),
        Some("back")
    );
    let c = sub.counters();
    assert_eq!((c.connects, c.disconnects), (2, 1));
    sub.shutdown().await;
    publ.shutdown().await;
    b.shutdown().await;
}

#[tokio::test]
async fn offline_queue_keeps_the_newest_and_counts_drops() {
    let b = broker().await;
    let (sub, mut srx) = MoosClient::start(cfg("qsub", &b)).unwrap();
    sub.register("QVAR", 0.0).unwrap();
    wait_connected(&mut srx).await;
    sync(&sub, &mut srx, "QSYNC").await;

    let (publ, _prx) = MoosClient::start(MoosClientConfig {
        queue_limit: 3,
        ..cfg("qpub", &b)
    })
    .unwrap();
    // Current-thread runtime: the client task has not run yet, so this is all "offline".
    assert!(!publ.is_connected());
    for v in 1..=5 {
        publ.notify_double("QVAR", v as f64, None).unwrap();
    }
    assert_eq!(publ.counters().dropped_queue_full, 2);
    let mut got = vec![];
    while got.last() != Some(&5.0) {
        got.push(next_mail(&mut srx, "QVAR").await.as_double().unwrap());
    }
    assert_eq!(got, vec![3.0, 4.0, 5.0]);
    sub.shutdown().await;
    publ.shutdown().await;
    b.shutdown().await;
}

#[tokio::test]
async fn variable_keeps_the_type_of_its_first_write() {
    let b = broker().await;
    let (c, mut rx) = MoosClient::start(cfg("typer", &b)).unwrap();
    c.register("TL_VAR", 0.0).unwrap();
    wait_connected(&mut rx).await;
    c.notify_double("TL_VAR", 1.5, None).unwrap();
    c.notify_string("TL_VAR", "now a string", None).unwrap();
    c.notify_double("TL_VAR", 2.5, None).unwrap();
    assert_eq!(next_mail(&mut rx, "TL_VAR").await.as_double(), Some(1.5));
    let m = next_mail(&mut rx, "TL_VAR").await;
    assert_eq!(m.as_double(), Some(2.5));
    assert_eq!(b.counters().type_rejected, 1);
    c.shutdown().await;
    b.shutdown().await;
}

#[tokio::test]
async fn register_delivers_current_value_and_interval_limits() {
    let b = broker().await;
    let (publ, mut prx) = MoosClient::start(cfg("ivpub", &b)).unwrap();
    wait_connected(&mut prx).await;
    sync(&publ, &mut prx, "IV").await; // IV now exists with value 1.0
    let (sub, mut srx) = MoosClient::start(cfg("ivsub", &b)).unwrap();
    sub.register("IV", 3600.0).unwrap();
    let first = next_mail(&mut srx, "IV").await;
    assert_eq!((first.as_double(), first.id), (Some(1.0), -1));
    // Within the hour-long interval nothing else is forwarded; a second var proves the DB
    // processed the later writes.
    sub.register("IV_DONE", 0.0).unwrap();
    sync(&sub, &mut srx, "IV_SYNC").await;
    publ.notify_double("IV", 2.0, None).unwrap();
    publ.notify_double("IV_DONE", 1.0, None).unwrap();
    loop {
        match next_event(&mut srx).await {
            MoosEvent::Mail(m) if m.key == "IV_DONE" => break,
            MoosEvent::Mail(m) => assert_ne!(m.key, "IV", "interval not honoured"),
            _ => {}
        }
    }
    sub.shutdown().await;
    publ.shutdown().await;
    b.shutdown().await;
}

#[tokio::test]
async fn duplicate_name_is_refused_until_the_first_leaves() {
    let b = broker().await;
    let (a, mut arx) = MoosClient::start(cfg("twin", &b)).unwrap();
    wait_connected(&mut arx).await;
    let (dup, mut drx) = MoosClient::start(cfg("twin", &b)).unwrap();
    timeout(WAIT, async {
        while dup.counters().connect_failures == 0 {
            tokio::time::sleep(Duration::from_millis(10)).await;
        }
    })
    .await
    .unwrap();
    assert!(!dup.is_connected());
    assert!(b.counters().clients_refused >= 1);
    a.shutdown().await;
    wait_connected(&mut drx).await;
    assert_eq!(b.client_names(), vec!["twin".to_owned()]);
    dup.shutdown().await;
    b.shutdown().await;
}

async fn raw_handshake(addr: std::net::SocketAddr, name: &str) -> (TcpStream, Vec<MoosMessage>) {
    let mut s = TcpStream::connect(addr).await.unwrap();
    let mut out = BytesMut::new();
    out.extend_from_slice(&BANNER);
    codec::encode_packet([&codec::handshake_message(name, 0.0)], &mut out).unwrap();
    s.write_all(&out).await.unwrap();
    let msgs = read_packet(&mut s, &mut BytesMut::new()).await.unwrap();
    (s, msgs)
}

async fn read_packet(s: &mut TcpStream, buf: &mut BytesMut) -> Option<Vec<MoosMessage>> {
    let dec = PacketDecoder::default();
    loop {
        if let Some(m) = dec.decode(buf).unwrap() {
            return Some(m);
        }
        if timeout(WAIT, s.read_buf(buf))
            .await
            .expect("read timed out")
            .unwrap()
            == 0
        {
            return None;
        }
    }
}

#[tokio::test]
async fn broker_welcomes_refuses_bad_banner_and_drops_silent_clients() {
    let b = Broker::bind_with(
        "127.0.0.1:0",
        BrokerConfig {
            client_timeout: Duration::from_millis(300),
            community: "cap".into(),
            hostname: "vm".into(),
            ..BrokerConfig::default()
        },
    )
    .await
    .unwrap();
    let (mut s, welcome) = raw_handshake(b.local_addr(), "rawsilent").await;
    let w = codec::parse_handshake_reply(&welcome).unwrap();
    assert_eq!(
        (w.community.as_str(), w.db_host.as_deref(), w.asynchronous),
        ("cap", Some("vm"), true)
    );
    assert!(w.skew > 1e9, "skew = DB time - client time 0");
    let t0 = std::time::Instant::now();
    assert!(
        read_packet(&mut s, &mut BytesMut::new()).await.is_none(),
        "DB must close"
    );
    assert!(t0.elapsed() >= Duration::from_millis(250));
    assert_eq!(b.counters().clients_timed_out, 1);

    let mut bad = TcpStream::connect(b.local_addr()).await.unwrap();
    bad.write_all(b"NOT THE MOOS BANNER\0\0\0\0\0\0\0\0\0\0\0\0\0")
        .await
        .unwrap();
    let mut buf = vec![];
    let n = timeout(WAIT, bad.read_to_end(&mut buf))
        .await
        .unwrap()
        .unwrap_or(0);
    assert_eq!(n, 0, "nothing is sent back for a wrong banner");
    b.shutdown().await;
}

/// A scripted DB: checks what our client sends when idle.
#[tokio::test]
async fn idle_client_sends_timing_plus_null_poll_every_heartbeat() {
    for poll in [true, false] {
        let l = TcpListener::bind("127.0.0.1:0").await.unwrap();
        let (c, _rx) = MoosClient::start(MoosClientConfig {
            server: l.local_addr().unwrap().to_string(),
            heartbeat: Duration::from_millis(100),
            poll_held_mail: poll,
            ..MoosClientConfig::new("idle")
        })
        .unwrap();
        c.register("IDLE_VAR", 0.5).unwrap();
        let (mut s, _) = timeout(WAIT, l.accept()).await.unwrap().unwrap();
        let mut banner = [0u8; 32];
        s.read_exact(&mut banner).await.unwrap();
        assert_eq!(banner, BANNER);
        let mut buf = BytesMut::new();
        let hello = read_packet(&mut s, &mut buf).await.unwrap();
        assert_eq!(hello[0].msg_type, MsgType::Data);
        assert_eq!(&hello[0].string_val[..], b"idle");
        let mut w = MoosMessage::new(MsgType::Welcome, DataType::Double, "");
        w.string_val = bytes::Bytes::from_static(b"asynchronous");
        let mut out = BytesMut::new();
        codec::encode_packet([&w], &mut out).unwrap();
        s.write_all(&out).await.unwrap();

        let first = read_packet(&mut s, &mut buf).await.unwrap();
        let types: Vec<MsgType> = first.iter().map(|m| m.msg_type).collect();
        assert_eq!(types, vec![MsgType::Timing, MsgType::Register]);
        assert_eq!(
            (first[1].key.to_str(), first[1].double_val),
            (Some("IDLE_VAR"), 0.5)
        );
        assert_eq!(first[1].source, "idle");
        assert_eq!(first[0].key, "_async_timing");
        let t0 = tokio::time::Instant::now();
        for _ in 0..3 {
            let p = read_packet(&mut s, &mut buf).await.unwrap();
            let types: Vec<MsgType> = p.iter().map(|m| m.msg_type).collect();
            if poll {
                assert_eq!(types, vec![MsgType::Timing, MsgType::Null]);
                assert_eq!(p[1].source, "idle");
            } else {
                assert_eq!(types, vec![MsgType::Timing]);
            }
        }
        let el = t0.elapsed();
        assert!(
            el >= Duration::from_millis(250) && el < Duration::from_secs(2),
            "{el:?}"
        );
        c.shutdown().await;
    }
}

/// A DB that stops reading while the client posts far more than the socket holds: posts written
/// straight from the posting thread stop part-way through a packet, the writer task sends the
/// rest first, and every post reaches the DB whole and in order once it reads again (issue 49's
/// direct writes).
#[tokio::test]
async fn posts_past_a_full_socket_arrive_whole_and_in_order() {
    const POSTS: usize = 6000;
    let l = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let (c, _rx) = MoosClient::start(MoosClientConfig {
        server: l.local_addr().unwrap().to_string(),
        queue_limit: POSTS * 2,
        ..MoosClientConfig::new("filler")
    })
    .unwrap();
    let (mut s, _) = timeout(WAIT, l.accept()).await.unwrap().unwrap();
    let mut banner = [0u8; 32];
    s.read_exact(&mut banner).await.unwrap();
    let mut buf = BytesMut::new();
    read_packet(&mut s, &mut buf).await.unwrap();
    let mut w = MoosMessage::new(MsgType::Welcome, DataType::Double, "");
    w.string_val = bytes::Bytes::from_static(b"asynchronous");
    let mut out = BytesMut::new();
    codec::encode_packet([&w], &mut out).unwrap();
    s.write_all(&out).await.unwrap();
    // The first packet (TIMING) proves the session is up and the writer has gone idle.
    read_packet(&mut s, &mut buf).await.unwrap();
    timeout(WAIT, async {
        while !c.is_connected() {
            tokio::time::sleep(Duration::from_millis(5)).await;
        }
    })
    .await
    .unwrap();
    // 24 MiB, more than loopback's socket buffers on both sides: the DB reads nothing meanwhile.
    let mut value = vec![0u8; 4096];
    for i in 0..POSTS {
        value[..8].copy_from_slice(&(i as u64).to_le_bytes());
        c.notify_binary("FILL", &value, None).unwrap();
        if i % 500 == 0 {
            tokio::task::yield_now().await;
        }
    }
    let mut next = 0usize;
    while next < POSTS {
        let packet = read_packet(&mut s, &mut buf)
            .await
            .expect("the client closed the connection");
        for m in packet.into_iter().filter(|m| m.msg_type == MsgType::Notify) {
            assert_eq!(m.key, "FILL");
            assert_eq!(m.string_val.len(), 4096);
            let mut seq = [0u8; 8];
            seq.copy_from_slice(&m.string_val[..8]);
            assert_eq!(u64::from_le_bytes(seq), next as u64, "out of order or lost");
            next += 1;
        }
    }
    assert_eq!(c.counters().dropped_queue_full, 0);
    c.shutdown().await;
}

/// A subscriber that stops reading while another client posts far more than the sockets hold:
/// the broker's packets written straight from the routing thread stop part-way, its writer task
/// sends the rest first, a full queue drops whole packets (counted), and what arrives is whole
/// and in order (issue 49's direct writes in the broker).
#[tokio::test]
async fn broker_to_a_stalled_client_sends_whole_packets_in_order() {
    const POSTS: u64 = 6000;
    let b = Broker::bind_with(
        "127.0.0.1:0",
        BrokerConfig {
            client_queue: 16,
            ..BrokerConfig::default()
        },
    )
    .await
    .unwrap();
    // Its event channel full, the subscriber's client stops reading from the broker.
    let (sub, mut srx) = MoosClient::start(MoosClientConfig {
        event_capacity: 1,
        ..cfg("stalled", &b)
    })
    .unwrap();
    wait_connected(&mut srx).await;
    sync(&sub, &mut srx, "STALL_SYNC").await;
    sub.register("FILL", 0.0).unwrap();
    let (publ, mut prx) = MoosClient::start(MoosClientConfig {
        queue_limit: POSTS as usize * 2,
        ..cfg("filler", &b)
    })
    .unwrap();
    wait_connected(&mut prx).await;
    sync(&publ, &mut prx, "FILL_SYNC").await;
    let mut value = vec![0u8; 4096];
    for i in 0..POSTS {
        value[..8].copy_from_slice(&i.to_le_bytes());
        publ.notify_binary("FILL", &value, None).unwrap();
        if i % 500 == 0 {
            tokio::task::yield_now().await;
        }
    }
    // Until the broker has taken every post in (or dropped it for the stalled client).
    timeout(Duration::from_secs(30), async {
        while b.counters().notifies < POSTS {
            tokio::time::sleep(Duration::from_millis(10)).await;
        }
    })
    .await
    .expect("the broker did not take the posts in");
    let mut last = None;
    let mut got = 0u64;
    loop {
        let ev = match timeout(Duration::from_millis(500), srx.recv()).await {
            Ok(Some(ev)) => ev,
            _ => break,
        };
        if let MoosEvent::Disconnected(why) = &ev {
            panic!("the stream broke: {why}");
        }
        if let MoosEvent::Mail(m) = ev
            && m.key == "FILL"
        {
            assert_eq!(m.string_val.len(), 4096);
            let mut seq = [0u8; 8];
            seq.copy_from_slice(&m.string_val[..8]);
            let seq = u64::from_le_bytes(seq);
            assert!(last.is_none_or(|l| seq > l), "{seq} after {last:?}");
            last = Some(seq);
            got += 1;
        }
    }
    assert!(got > 0, "nothing arrived");
    assert!(
        b.counters().dropped_packets > 0,
        "the stall never filled the queue: the test measured nothing"
    );
    sub.shutdown().await;
    publ.shutdown().await;
    b.shutdown().await;
}

/// A DB that sends garbage after the WELCOME: typed error, counted, connection dropped, retried.
#[tokio::test]
async fn malformed_packet_from_db_closes_and_reconnects() {
    let l = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let (c, mut rx) = MoosClient::start(MoosClientConfig {
        server: l.local_addr().unwrap().to_string(),
        reconnect_initial: Duration::from_millis(10),
        reconnect_max: Duration::from_millis(50),
        ..MoosClientConfig::new("victim")
    })
    .unwrap();
    for round in 0..2 {
        let (mut s, _) = timeout(WAIT, l.accept()).await.unwrap().unwrap();
        let mut buf = BytesMut::new();
        let mut banner = [0u8; 32];
        s.read_exact(&mut banner).await.unwrap();
        read_packet(&mut s, &mut buf).await.unwrap();
        let mut w = MoosMessage::new(MsgType::Welcome, DataType::Double, "");
        w.string_val = bytes::Bytes::from_static(b"asynchronous");
        let mut out = BytesMut::new();
        codec::encode_packet([&w], &mut out).unwrap();
        // A 2 GB length prefix: must be refused without allocating it.
        out.extend_from_slice(&0x7fff_fff0i32.to_le_bytes());
        out.extend_from_slice(&[0u8; 16]);
        s.write_all(&out).await.unwrap();
        wait_connected(&mut rx).await;
        let why = wait_disconnected(&mut rx).await;
        assert!(why.contains("exceeds the maximum"), "{why}");
        assert_eq!(c.counters().decode_errors, round + 1);
    }
    c.shutdown().await;
}

#[test]
fn start_outside_a_runtime_and_bad_config_are_errors() {
    assert!(MoosClient::start(MoosClientConfig::new("x")).is_err());
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    rt.block_on(async {
        for bad in [
            MoosClientConfig::new(""),
            MoosClientConfig {
                time_warp: 0.0,
                ..MoosClientConfig::new("x")
            },
            MoosClientConfig {
                heartbeat: Duration::from_secs(6),
                ..MoosClientConfig::new("x")
            },
            MoosClientConfig {
                max_packet: 10,
                ..MoosClientConfig::new("x")
            },
            MoosClientConfig {
                queue_limit: 0,
                ..MoosClientConfig::new("x")
            },
        ] {
            assert!(matches!(
                MoosClient::start(bad),
                Err(frontseat_moos::MoosError::InvalidArgument(_))
            ));
        }
        let (c, _rx) = MoosClient::start(MoosClientConfig {
            server: "127.0.0.1:1".into(),
            max_packet: 4096,
            ..MoosClientConfig::new("x")
        })
        .unwrap();
        assert!(c.notify_double("", 1.0, None).is_err());
        assert!(c.register("K", -1.0).is_err());
        assert!(matches!(
            c.notify_binary("K", &[0u8; 5000], None),
            Err(frontseat_moos::MoosError::MessageTooLarge { .. })
        ));
        c.shutdown().await;
    });
}
