//! The Goby3 transport against a stand-in gobyd (the manager handshake and XPUB/XSUB proxy as
//! recorded from gobyd 3.1.5a) over real sockets — IPC in a scratch directory, TCP on 127.0.0.1
//! — each gateway with its own bus, as separate processes would have: groups flow both ways,
//! nothing is echoed, malformed frames are counted and dropped, a hold is honoured, and gobyd
//! absent, stopped and restarted (on new ports) is survived. Every wait has a deadline.

use frontseat_actors::bus::test_util::UntypedBus as _;
use std::path::PathBuf;
use std::time::Duration;

use frontseat_actors::bus::{Bus, GOBY3_LINK, Origin};
use frontseat_actors::groups;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    DesiredCourse, NodeStatus, Raw,
};
use frontseat_config::{Goby3Config, Goby3Transport};
use frontseat_helm_side::GatewayOptions;
use frontseat_helm_side::goby3::standin::{StandinGobyd, StandinTransport};
use frontseat_helm_side::goby3::{self, Goby3Handle, Goby3Settings, Goby3Stats, frame, manager};
use prost::Message;
use zeromq::{PubSocket, ReqSocket, Socket, SocketRecv, SocketSend, ZmqMessage};

const WAIT: Duration = Duration::from_secs(20);
const RAW_T: &str = "goby.middleware.frontseat.protobuf.Raw";
const RAW_SEND: &str = "goby::middleware::frontseat::raw_send_request";

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("fs-goby3-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

fn ipc_settings(base: &str) -> Goby3Settings {
    let cfg = Goby3Config {
        enabled: true,
        socket_name: base.to_string(),
        settle_ms: 100,
        reconnect_initial_ms: 20,
        reconnect_max_ms: 200,
        manager_timeout_seconds: 1.0,
        ..Default::default()
    };
    Goby3Settings::from_config(&cfg, "auv1").unwrap()
}

fn tcp_settings(port: u16) -> Goby3Settings {
    let cfg = Goby3Config {
        enabled: true,
        transport: Goby3Transport::Tcp,
        tcp_port: port,
        settle_ms: 100,
        reconnect_initial_ms: 20,
        reconnect_max_ms: 200,
        manager_timeout_seconds: 1.0,
        ..Default::default()
    };
    Goby3Settings::from_config(&cfg, "auv1").unwrap()
}

fn start(bus: &Bus, s: Goby3Settings, hosted: &[&str]) -> Goby3Handle {
    goby3::start(bus, s, hosted, GatewayOptions::default()).unwrap()
}

async fn wait_stats(h: &Goby3Handle, what: &str, pred: impl Fn(&Goby3Stats) -> bool) -> Goby3Stats {
    let deadline = tokio::time::Instant::now() + WAIT;
    loop {
        let s = h.stats();
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

/// Re-sends until the other side got one: a PUB learns its peers' subscriptions a moment after
/// connecting (the slow joiner), and what it sends before that is correctly not delivered.
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

fn ns(t: f64) -> NodeStatus {
    NodeStatus {
        name: Some("auv1".into()),
        time: t,
        ..Default::default()
    }
}

fn dc(h: f64) -> DesiredCourse {
    DesiredCourse {
        heading: Some(h),
        speed: Some(1.5),
        ..Default::default()
    }
}

/// Interface and helm in two "processes" exchange node_status and desired_course through gobyd.
async fn exchange(bus_if: &Bus, bus_helm: &Bus) {
    let (_s, mut rx) =
        bus_helm.subscribe_channel(&groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS, "t", 1000);
    let env = until_received(
        || {
            bus_if.publish(&groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS, ns(7.0));
        },
        &mut rx,
    )
    .await;
    assert_eq!(*env.msg, ns(7.0));
    assert_eq!(env.origin, Origin::Goby3);

    let (_s2, mut rx2) =
        bus_if.subscribe_channel(&groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE, "t", 1000);
    let env = until_received(
        || {
            bus_helm.publish(&groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE, dc(45.0));
        },
        &mut rx2,
    )
    .await;
    assert_eq!(*env.msg, dc(45.0));
    assert_eq!(env.origin, Origin::Goby3);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn interface_and_helm_exchange_groups_through_gobyd_over_ipc_without_echo() {
    let dir = scratch("ipc");
    let base = dir.join("goby_auv1").display().to_string();
    let gobyd = StandinGobyd::start(StandinTransport::Ipc { base: base.clone() }, &[])
        .await
        .unwrap();
    let bus_if = Bus::new();
    let bus_helm = Bus::new();
    // Both actors in the interface process: desired_course is exported (translation) and
    // imported (interface) there — the case where an echo could happen.
    let gw_if = start(
        &bus_if,
        ipc_settings(&base),
        &["FrontSeatInterface", "FrontSeatTranslation"],
    );
    let gw_helm = start(&bus_helm, ipc_settings(&base), &["FrontSeatTranslation"]);
    wait_stats(&gw_if, "link up", |s| s.link_up).await;
    wait_stats(&gw_helm, "link up", |s| s.link_up).await;
    assert_eq!(bus_if.link_up(GOBY3_LINK), Some(true));

    exchange(&bus_if, &bus_helm).await;

    // The helm's desired_course reached the interface process once, as Imported, and was not
    // sent back to gobyd.
    let s = wait_stats(&gw_if, "imported course not re-exported", |s| {
        s.imported >= 1 && s.not_echoed >= 1
    })
    .await;
    assert_eq!(s.rejected(), 0, "{s:?}");
    // A local desired_course goes out, comes back from gobyd with our pid/thread, and is dropped.
    let (_s, mut local) =
        bus_if.subscribe_channel(&groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE, "t", 1000);
    let before = gw_if.stats();
    bus_if.publish(&groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE, dc(90.0));
    wait_stats(&gw_if, "own frame back", |s| s.own_echo > before.own_echo).await;
    let env = local.recv().await.unwrap();
    assert_eq!(env.origin, Origin::Local);
    assert!(local.try_recv().is_err(), "no second copy from gobyd");
    assert!(gobyd.forwarded() >= 3);
    // The yaml's group names are Goby3's wire strings (datum_update is `goby::datum_update`).
    assert!(
        gw_if
            .plan()
            .imports
            .iter()
            .any(|r| r.group == "goby::datum_update")
    );

    gw_helm.close().await;
    gw_if.close().await;
    gobyd.stop().await;
    let _ = std::fs::remove_dir_all(&dir);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn gobyd_absent_stopped_and_restarted_on_new_ports_is_survived_over_tcp() {
    let port = free_port();
    let bus_if = Bus::new();
    let bus_helm = Bus::new();
    let gw_if = start(&bus_if, tcp_settings(port), &["FrontSeatInterface"]);
    let gw_helm = start(&bus_helm, tcp_settings(port), &["FrontSeatTranslation"]);

    // No gobyd yet: attempts fail, local publications are dropped and counted, nothing blocks.
    wait_stats(&gw_if, "failed attempts", |s| s.connect_failures >= 2).await;
    for i in 0..50 {
        bus_if.publish(&groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS, ns(i as f64));
    }
    let s = wait_stats(&gw_if, "drops while down", |s| s.dropped_link_down >= 50).await;
    assert!(!s.link_up);
    assert_eq!(bus_if.link_up(GOBY3_LINK), Some(false));

    // gobyd starts: both join and traffic flows.
    let gobyd = StandinGobyd::start(StandinTransport::Tcp { manager_port: port }, &[])
        .await
        .unwrap();
    wait_stats(&gw_if, "link up", |s| s.link_up).await;
    wait_stats(&gw_helm, "link up", |s| s.link_up).await;
    exchange(&bus_if, &bus_helm).await;

    // gobyd goes away: the link goes down, is reported, and the interface side keeps running.
    gobyd.stop().await;
    wait_stats(&gw_if, "link lost", |s| !s.link_up && s.link_losses == 1).await;
    wait_stats(&gw_helm, "link lost", |s| !s.link_up && s.link_losses == 1).await;
    assert_eq!(bus_if.link_up(GOBY3_LINK), Some(false));

    // A new gobyd on the same manager port hands out new XPUB/XSUB ports: both join again.
    let gobyd = StandinGobyd::start(StandinTransport::Tcp { manager_port: port }, &[])
        .await
        .unwrap();
    wait_stats(&gw_if, "rejoined", |s| s.link_up && s.connects == 2).await;
    wait_stats(&gw_helm, "rejoined", |s| s.link_up && s.connects == 2).await;
    exchange(&bus_if, &bus_helm).await;

    gw_helm.close().await;
    gw_if.close().await;
    gobyd.stop().await;
}

/// A raw client of gobyd: handshake on REQ, then a PUB on the socket it hands out.
async fn raw_publisher(manager_ep: &str, transport: &manager::Transport) -> PubSocket {
    let mut req = ReqSocket::new();
    req.connect(manager_ep).await.unwrap();
    req.send(ZmqMessage::from(manager::sockets_request("naive", 4242)))
        .await
        .unwrap();
    let answer = req.recv().await.unwrap();
    let body = answer.get(0).unwrap().to_vec();
    let (ps, _) = manager::parse_sockets_response(&body, "naive", 4242, transport).unwrap();
    let mut publ = PubSocket::new();
    publ.connect(&ps.publish).await.unwrap();
    publ
}

fn raw_frame(text: &str) -> Vec<u8> {
    let raw = Raw {
        raw: Some(text.as_bytes().to_vec()),
        ..Default::default()
    };
    frame::encode(RAW_SEND, RAW_T, 4242, 0xbeef, &raw.encode_to_vec())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn malformed_frames_are_counted_and_dropped_and_the_link_stays_up() {
    let dir = scratch("naive");
    let base = dir.join("g").display().to_string();
    let gobyd = StandinGobyd::start(StandinTransport::Ipc { base: base.clone() }, &[])
        .await
        .unwrap();
    let bus = Bus::new();
    let gw = start(&bus, ipc_settings(&base), &["FrontSeatInterface"]);
    wait_stats(&gw, "link up", |s| s.link_up).await;
    let (_s, mut rx) = bus.subscribe_channel(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_RAW_SEND_REQUEST,
        "t",
        1000,
    );
    let transport = manager::Transport::Ipc { base: base.clone() };
    let mut publ = raw_publisher(gobyd.manager_endpoint(), &transport).await;

    // A good frame first, until the subscription has reached our PUB.
    let deadline = tokio::time::Instant::now() + WAIT;
    loop {
        publ.send(ZmqMessage::from(raw_frame("FIRST")))
            .await
            .unwrap();
        if let Ok(Some(env)) = tokio::time::timeout(Duration::from_millis(100), rx.recv()).await {
            assert_eq!(env.msg.raw(), b"FIRST");
            break;
        }
        assert!(tokio::time::Instant::now() < deadline, "nothing received");
    }
    while rx.try_recv().is_ok() {}
    let before = gw.stats();

    // The frames that made goby_frontseat_interface abort, each starting with our prefix.
    let prefix = frame::subscription_prefix(RAW_SEND, RAW_T);
    let bad: Vec<Vec<u8>> = vec![
        format!("{prefix}\0\x0a\x01x").into_bytes(), // no pid or thread
        format!("{prefix}4242/beef/\x0a\x01x").into_bytes(), // no NUL
        format!("{prefix}4242/main/\0\x0a\x01x").into_bytes(), // thread not hex
        format!("{prefix}python/beef/\0\x0a\x01x").into_bytes(), // pid not decimal
    ];
    for b in &bad {
        publ.send(ZmqMessage::from(b.clone())).await.unwrap();
    }
    // Two parts: identifier + NUL, then the payload.
    let mut two = ZmqMessage::from(format!("{prefix}4242/beef/\0").into_bytes());
    two.push_back(Raw::default().encode_to_vec().into());
    publ.send(two).await.unwrap();
    // A good identifier with a payload that is not a Raw.
    let mut garbage = frame::identifier(RAW_SEND, RAW_T, 4242, 0xbeef).into_bytes();
    garbage.extend_from_slice(&[0, 0xff, 0xff, 0xff]);
    publ.send(ZmqMessage::from(garbage)).await.unwrap();
    // One publisher's frames arrive in order: once this one is in, every bad one was handled.
    publ.send(ZmqMessage::from(raw_frame("LAST")))
        .await
        .unwrap();
    // Nothing of the bad frames reached the bus: only late copies of FIRST, then LAST.
    loop {
        let env = tokio::time::timeout(WAIT, rx.recv())
            .await
            .unwrap()
            .unwrap();
        match env.msg.raw() {
            b"LAST" => break,
            b"FIRST" => {}
            other => panic!("{:?} reached the bus", String::from_utf8_lossy(other)),
        }
    }

    // The counter moves just after the bus delivery: wait for it rather than race it.
    let s = wait_stats(&gw, "LAST counted", |s| s.imported > before.imported).await;
    assert_eq!(s.malformed - before.malformed, 5, "{s:?}");
    assert_eq!(s.undecodable - before.undecodable, 1, "{s:?}");
    assert!(s.link_up && s.link_losses == 0, "{s:?}");
    gw.close().await;
    gobyd.stop().await;
    let _ = std::fs::remove_dir_all(&dir);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_gobyd_hold_keeps_the_link_down_until_the_required_client_is_ready() {
    let dir = scratch("hold");
    let base = dir.join("g").display().to_string();
    let gobyd = StandinGobyd::start(StandinTransport::Ipc { base: base.clone() }, &["helm"])
        .await
        .unwrap();
    let bus = Bus::new();
    let gw = start(&bus, ipc_settings(&base), &["FrontSeatInterface"]);
    // Held: gobyd is asked again and again (every 100 ms), the link is not up.
    let deadline = tokio::time::Instant::now() + WAIT;
    while gobyd.requests() < 4 {
        assert!(tokio::time::Instant::now() < deadline, "no hold polling");
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    assert!(!gw.link_up());
    assert_eq!(gw.stats().connects, 0);

    // The required client reports ready: the hold lifts for everyone.
    let mut req = ReqSocket::new();
    req.connect(gobyd.manager_endpoint()).await.unwrap();
    req.send(ZmqMessage::from(manager::hold_request("helm", 7, true)))
        .await
        .unwrap();
    let answer = req.recv().await.unwrap();
    assert!(!manager::parse_hold_response(answer.get(0).unwrap(), "helm", 7).unwrap());
    wait_stats(&gw, "link up after the hold", |s| s.link_up).await;
    gw.close().await;
    gobyd.stop().await;
    let _ = std::fs::remove_dir_all(&dir);
}

/// A "gobyd" that answers the ZMTP greeting and then announces a frame of 2^40 bytes. Without
/// the length guard the zeromq decoder reserves that much and the whole process aborts; with it
/// the connection is closed before the header reaches the socket, counted, and joining goes on.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_gobyd_announcing_a_huge_frame_is_cut_off_and_the_process_lives() {
    use tokio::io::{AsyncReadExt, AsyncWriteExt};
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let port = listener.local_addr().unwrap().port();
    let hostile = tokio::spawn(async move {
        loop {
            let Ok((mut s, _)) = listener.accept().await else {
                return;
            };
            tokio::spawn(async move {
                let mut greeting = vec![0xff, 0, 0, 0, 0, 0, 0, 0, 0, 0x7f, 3, 0];
                greeting.extend_from_slice(b"NULL");
                greeting.resize(64, 0);
                let mut header = vec![0x02];
                header.extend_from_slice(&(1u64 << 40).to_be_bytes());
                let _ = s.write_all(&greeting).await;
                let _ = s.write_all(&header).await;
                let _ = s.write_all(&[0u8; 4096]).await;
                let mut sink = [0u8; 1024];
                while matches!(s.read(&mut sink).await, Ok(n) if n > 0) {}
            });
        }
    });
    let bus = Bus::new();
    let gw = start(&bus, tcp_settings(port), &["FrontSeatInterface"]);
    let s = wait_stats(&gw, "oversized frames cut off, joins retried", |s| {
        s.oversized >= 2 && s.connect_failures >= 2
    })
    .await;
    assert!(!s.link_up, "{s:?}");
    assert_eq!(s.imported, 0);
    gw.close().await;
    hostile.abort();
}

/// `max_message_bytes = 0` takes the length guard out (the sockets connect to gobyd itself):
/// the link still joins and exchanges, here with one side guarded and the other not.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn with_the_length_guard_off_the_link_still_joins_and_exchanges() {
    let gobyd = StandinGobyd::start(StandinTransport::Tcp { manager_port: 0 }, &[])
        .await
        .unwrap();
    let port = gobyd.manager_port().unwrap();
    let mut unguarded = tcp_settings(port);
    unguarded.max_message_bytes = 0;
    let bus_if = Bus::new();
    let bus_helm = Bus::new();
    let gw_if = start(&bus_if, unguarded, &["FrontSeatInterface"]);
    let gw_helm = start(&bus_helm, tcp_settings(port), &["FrontSeatTranslation"]);
    wait_stats(&gw_if, "link up", |s| s.link_up).await;
    wait_stats(&gw_helm, "link up", |s| s.link_up).await;
    exchange(&bus_if, &bus_helm).await;
    assert_eq!(gw_if.stats().oversized, 0);
    gw_helm.close().await;
    gw_if.close().await;
    gobyd.stop().await;
}

/// The outlet `frontseat replay --onto gobyd` publishes through: no gobyd at its socket is a
/// failure after the wait it was given (not a usage error), a bus that carries a live driver is
/// refused before anything starts, and with gobyd up everything it published before `close`
/// reaches a Goby3 client, in order, the last message included.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_replay_outlet_waits_for_gobyd_refuses_a_live_bus_and_delivers_its_last_message() {
    use frontseat_actors::bus::BusRole;
    use frontseat_helm_side::outlet::{Onto, Outlet, OutletError};

    let dir = scratch("outlet");
    let base = dir.join("goby_auv1").display().to_string();
    let onto = |wait: Duration| Onto::Gobyd {
        cfg: Goby3Config {
            enabled: true,
            socket_name: base.clone(),
            client_name: "frontseat_replay".into(),
            manager_timeout_seconds: 0.2,
            ..Default::default()
        },
        vehicle: "auv1".into(),
        wait,
    };
    let absent = Outlet::open(&Bus::new(), onto(Duration::from_millis(500))).await;
    match absent {
        Err(e @ OutletError::NoGobyd { .. }) => assert!(!e.is_usage(), "{e}"),
        Err(e) => panic!("{e}"),
        Ok(_) => panic!("an outlet opened with no gobyd"),
    }

    let live = Bus::new();
    live.claim(BusRole::LiveDriver).unwrap();
    match Outlet::open(&live, onto(WAIT)).await {
        Err(e @ OutletError::Claimed(BusRole::LiveDriver)) => assert!(e.is_usage(), "{e}"),
        Err(e) => panic!("{e}"),
        Ok(_) => panic!("an outlet shared a bus with a live driver"),
    }

    let gobyd = StandinGobyd::start(StandinTransport::Ipc { base: base.clone() }, &[])
        .await
        .unwrap();
    let helm_bus = Bus::new();
    let helm = start(&helm_bus, ipc_settings(&base), &["FrontSeatTranslation"]);
    let (_s, mut nav) =
        helm_bus.subscribe_channel(&groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS, "t", 64);
    wait_stats(&helm, "helm link up", |_| helm.link_up()).await;

    let bus = Bus::new();
    let outlet = Outlet::open(&bus, onto(WAIT)).await.unwrap();
    assert!(
        outlet.description().contains("gobyd"),
        "{}",
        outlet.description()
    );
    for i in 0..5 {
        bus.publish(
            &groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS,
            ns(f64::from(i)),
        );
    }
    outlet.close(Some(5)).await;
    let mut times = Vec::new();
    while times.len() < 5 {
        let env = tokio::time::timeout(WAIT, nav.recv())
            .await
            .unwrap_or_else(|_| panic!("only {times:?} arrived"))
            .unwrap();
        times.push(env.msg.time);
    }
    assert_eq!(times, [0.0, 1.0, 2.0, 3.0, 4.0]);
    helm.close().await;
    gobyd.stop().await;
    let _ = std::fs::remove_dir_all(&dir);
}
