//! A hostile web client (issue 31, item 6), the whole path over real loopback sockets: the web
//! commander (with its token), the interface with its basic simulator driver, the simulator.
//! Eight clients flood POST /api/send — setpoints of 1e308, −5.1e307, headings past any turn,
//! sends without the token, from a foreign Origin, broken JSON — while twelve event streams are
//! opened and never read. What reaches the vehicle is only in bounds (every CMD line the
//! interface sent is finite and inside `[limits]`, the simulator refused none), a plain
//! setpoint still gets through, the server's connections and tabs stay within their bounds and
//! come back down when the clients go, and the server answers afterwards.

use frontseat_actors::bus::test_util::UntypedBus as _;
use std::net::SocketAddr;
use std::time::Duration;

use frontseat_actors::bus::Bus;
use frontseat_actors::groups;
use frontseat_actors::interface::InterfaceService;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    HelmState, HelmStateReport, InterfaceState,
};
use frontseat_sim::{SimOptions, SimServer};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::time::Instant;

const TOKEN: &str = "hostile-web-token-0123456789";
const CLIENTS: usize = 8;
const PER_CLIENT: usize = 60;
const STREAMS: usize = 12;
const MAX_CONNECTIONS: usize = 32;
const MAX_CLIENTS: usize = 4;
const BOUND: Duration = Duration::from_secs(20);

use frontseat_chaos::course_body as course;

/// The `n`th request: mostly hostile, one in eight a plain setpoint.
fn request(addr: SocketAddr, n: usize) -> String {
    let (auth, origin, body) = match n % 8 {
        0 => (true, None, course("1e308", "1.5")),
        1 => (true, None, course("90", "1e308")),
        2 => (true, None, course("-5.1e307", "-1e20")),
        3 => (true, None, course("7200", "1.5")),
        4 => (false, None, course("90", "1.5")),
        5 => (true, Some("http://evil.example"), course("90", "1.5")),
        6 => (true, None, "{\"group\": [1, 2, {".to_string()),
        _ => (true, None, course("90", "1.5")),
    };
    frontseat_chaos::send_request(addr, auth.then_some(TOKEN), origin, &body)
}

/// One request on its own connection: the status code, or None (refused or cut).
async fn exchange(addr: SocketAddr, req: &str) -> Option<u16> {
    let go = async {
        let mut s = tokio::net::TcpStream::connect(addr).await.ok()?;
        s.write_all(req.as_bytes()).await.ok()?;
        let mut buf = Vec::new();
        let mut chunk = [0u8; 1024];
        while buf.len() < 64 * 1024 {
            match s.read(&mut chunk).await {
                Ok(0) | Err(_) => break,
                Ok(n) => buf.extend_from_slice(&chunk[..n]),
            }
        }
        std::str::from_utf8(buf.get(9..12)?).ok()?.parse().ok()
    };
    tokio::time::timeout(Duration::from_secs(5), go)
        .await
        .ok()
        .flatten()
}

/// The CMD fields of a basic simulator command line: `CMD,HEADING:h,SPEED:s,DEPTH:d`.
fn cmd_fields(line: &str) -> Vec<(String, f64)> {
    line.trim()
        .split(',')
        .skip(1)
        .filter_map(|kv| kv.split_once(':'))
        .map(|(k, v)| (k.to_string(), v.parse().unwrap_or(f64::NAN)))
        .collect()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_client_flooding_the_web_commander_reaches_nothing_bad() {
    let sim = SimServer::bind(([127, 0, 0, 1], 0).into(), SimOptions::default())
        .await
        .unwrap();
    let mut cfg = frontseat_chaos::default_config().unwrap();
    cfg.chaos.enabled = false;
    cfg.sim_warp_factor = 10.0;
    cfg.driver.basic_simulator.tcp_address = "127.0.0.1".into();
    cfg.driver.basic_simulator.tcp_port = sim.local_addr().port();
    let bus = Bus::new();
    let (_raw_sub, mut raw_out) =
        bus.subscribe_channel(&groups::GOBY_MIDDLEWARE_FRONTSEAT_RAW_OUT, "test", 1 << 20);
    let drive = {
        let bus = bus.clone();
        tokio::spawn(async move {
            loop {
                bus.publish(
                    &groups::GOBY_MIDDLEWARE_FRONTSEAT_HELM_STATE,
                    HelmStateReport {
                        state: HelmState::HelmDrive as i32,
                    },
                );
                tokio::time::sleep(Duration::from_millis(50)).await;
            }
        })
    };
    let service = InterfaceService::start(&cfg, &bus, frontseat_drivers::BUILT_IN)
        .await
        .unwrap();
    let web_cfg = frontseat_config::WebConfig {
        enabled: true,
        listen: "127.0.0.1:0".into(),
        token: Some(TOKEN.into()),
        max_connections: MAX_CONNECTIONS,
        max_clients: MAX_CLIENTS,
        ..Default::default()
    };
    let web = frontseat_web::WebService::start_with(
        &web_cfg,
        &cfg.limits,
        Some(TOKEN.into()),
        &bus,
        "auv",
    )
    .await
    .unwrap();
    let addr = web.local_addr();
    // In COMMAND before the flood, so that a plain setpoint has a way to the vehicle.
    let deadline = Instant::now() + BOUND;
    loop {
        let snap = service.snapshot(Duration::from_secs(2)).await;
        if snap.is_some_and(|s| s.status.state == Some(InterfaceState::InterfaceCommand as i32)) {
            break;
        }
        assert!(
            Instant::now() < deadline,
            "the interface never reached COMMAND"
        );
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    let cmd_errors = sim.stats().cmd_errors;

    // Twelve tabs (three times max_clients) that open their event stream and never read it.
    let mut streams = Vec::new();
    for _ in 0..STREAMS {
        if let Ok(mut s) = tokio::net::TcpStream::connect(addr).await {
            let req = format!(
                "GET /api/events HTTP/1.1\r\nHost: {addr}\r\nAuthorization: Bearer {TOKEN}\r\n\r\n"
            );
            let _ = s.write_all(req.as_bytes()).await;
            streams.push(s);
        }
    }
    let mut peak_open = web
        .server_counters
        .connections_open
        .load(std::sync::atomic::Ordering::Relaxed);
    let mut tasks = tokio::task::JoinSet::new();
    for c in 0..CLIENTS {
        tasks.spawn(async move {
            let mut codes = Vec::new();
            for k in 0..PER_CLIENT {
                let n = c + k * CLIENTS;
                codes.push((n % 8, exchange(addr, &request(addr, n)).await));
            }
            codes
        });
    }
    let mut answered = 0;
    let mut plain_ok = 0;
    let mut codes_seen = std::collections::BTreeMap::new();
    while let Some(r) = tasks.join_next().await {
        for (kind, code) in r.unwrap() {
            if code.is_some() {
                answered += 1;
            }
            *codes_seen.entry((kind, code)).or_insert(0u32) += 1;
            match (kind, code) {
                (7, Some(200)) => plain_ok += 1,
                // No token, a foreign site, broken JSON: refused by the server itself.
                (4..=6, Some(200)) => panic!("request kind {kind} was accepted"),
                _ => {}
            }
        }
        peak_open = peak_open.max(
            web.server_counters
                .connections_open
                .load(std::sync::atomic::Ordering::Relaxed),
        );
    }
    eprintln!("codes by kind: {codes_seen:?}");
    assert!(answered > 0, "the server answered nothing");
    assert!(plain_ok > 0, "no plain setpoint got through the flood");
    assert!(
        peak_open <= MAX_CONNECTIONS as u64,
        "{peak_open} connections open, bound {MAX_CONNECTIONS}"
    );

    // What reached the vehicle: CMD lines, every field finite and within [limits].
    let deadline = Instant::now() + Duration::from_secs(2);
    let mut cmds = 0;
    let mut bad = Vec::new();
    while Instant::now() < deadline {
        match tokio::time::timeout(Duration::from_millis(200), raw_out.recv()).await {
            Ok(Some(env)) => {
                let line = String::from_utf8_lossy(env.msg.raw.as_deref().unwrap_or_default())
                    .into_owned();
                if !line.starts_with("CMD") {
                    continue;
                }
                cmds += 1;
                for (k, v) in cmd_fields(&line) {
                    let ok = v.is_finite()
                        && match k.as_str() {
                            "HEADING" => (0.0..=360.0).contains(&v),
                            "SPEED" => (0.0..=cfg.limits.max_speed).contains(&v),
                            "DEPTH" => (0.0..=cfg.limits.max_depth).contains(&v),
                            _ => v.abs() <= 12_000.0,
                        };
                    if !ok {
                        bad.push(line.clone());
                    }
                }
            }
            Ok(None) => break,
            Err(_) => {}
        }
    }
    assert!(cmds > 0, "no CMD reached the vehicle");
    assert!(bad.is_empty(), "out of bounds at the vehicle: {bad:?}");
    assert_eq!(
        sim.stats().cmd_errors,
        cmd_errors,
        "the simulator refused a CMD"
    );

    // The clients go: the server's slots come back down, and it answers.
    drop(streams);
    let deadline = Instant::now() + BOUND;
    while web
        .server_counters
        .connections_open
        .load(std::sync::atomic::Ordering::Relaxed)
        > 0
    {
        assert!(
            Instant::now() < deadline,
            "connections still held after every client left"
        );
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    assert_eq!(exchange(addr, &request(addr, 7)).await, Some(200));

    drive.abort();
    web.shutdown(Duration::from_secs(2)).await;
    service.shutdown(Duration::from_secs(5)).await;
    sim.shutdown().await;
}
