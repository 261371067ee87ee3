//! Row W1: NAV → the web page's model. node_status published on the bus at the vehicle's rate
//! (10 Hz) while the web scope serves an event stream on loopback; the client here reads the
//! stream and parses each event's JSON, as the page does, and stamps its arrival. The issue's
//! target is p99 within 100 ms.

use std::collections::HashMap;
use std::time::{Duration, Instant};

use frontseat_actors::bus::Bus;
use frontseat_actors::groups;
use frontseat_actors::ports::BenchVehiclePorts;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CartesianCoordinate, EulerAngles, NodeStatus, Speed,
};
use frontseat_config::WebConfig;
use frontseat_web::WebService;
use serde_json::{Value, json};
use tokio::io::{AsyncBufReadExt, AsyncWriteExt, BufReader};
use tokio::net::TcpStream;

use super::inproc::latency_row;
use super::report::{Hist, Row};

pub const W1: &str = "NAV (node_status, 10 Hz) → web page model over SSE (target p99 < 100 ms)";

#[derive(Clone, Copy, Debug)]
pub struct Plan {
    pub count: usize,
    pub rate_hz: f64,
}

/// W1's hops: the bus delivers to the hub's subscription (on the publisher's thread), which
/// casts it to the hub actor; the hub makes the event's JSON and hands it to each tab's queue;
/// the tab's event stream takes it and hyper writes it.
const W1_HOPS: [super::hops::Hop; 4] = [
    super::hops::hop("delivered to the hub", "web.delivered", NODE_STATUS),
    super::hops::hop("the hub actor", "web.hub", NODE_STATUS),
    super::hops::hop("its JSON made, to the tab's queue", "web.fanout", None),
    super::hops::hop("the tab's event stream", "web.sse", None),
];
const NODE_STATUS: Option<&str> = Some("goby::middleware::frontseat::node_status");

pub async fn run(plan: Plan) -> Row {
    match run_inner(plan).await {
        Ok(r) => r,
        Err(why) => Row::failed("W1", W1, why),
    }
}

async fn run_inner(plan: Plan) -> Result<Row, String> {
    let bus = Bus::new();
    let vehicle = BenchVehiclePorts::new(&bus);
    let cfg = WebConfig {
        enabled: true,
        listen: "127.0.0.1:0".into(),
        ..Default::default()
    };
    let web = WebService::start_with(&cfg, &Default::default(), None, &bus, "bench")
        .await
        .map_err(|e| e.to_string())?;
    let addr = web.local_addr();
    let mut s = TcpStream::connect(addr).await.map_err(|e| e.to_string())?;
    s.write_all(format!("GET /api/events HTTP/1.1\r\nHost: {addr}\r\n\r\n").as_bytes())
        .await
        .map_err(|e| e.to_string())?;
    let mut reader = BufReader::new(s);
    // The page's model: the snapshot first, then each NAV as it comes.
    let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel::<(u64, Instant)>();
    let reading = tokio::spawn(async move {
        let mut line = String::new();
        loop {
            line.clear();
            match reader.read_line(&mut line).await {
                Ok(0) | Err(_) => break,
                Ok(_) => {}
            }
            let Some(data) = line.trim_end().strip_prefix("data: ") else {
                continue;
            };
            let Ok(ev) = serde_json::from_str::<Value>(data) else {
                continue;
            };
            let at = Instant::now();
            if ev["kind"] == "snapshot" {
                let _ = tx.send((u64::MAX, at));
            } else if ev["group"] == groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS.name()
                && let Some(seq) = ev["msg"]["time"].as_f64()
            {
                let _ = tx.send((seq as u64, at));
            }
        }
    });
    match tokio::time::timeout(Duration::from_secs(5), rx.recv()).await {
        Ok(Some((u64::MAX, _))) => {}
        _ => return Err("no snapshot from the event stream".into()),
    }
    let period = Duration::from_secs_f64(1.0 / plan.rate_hz);
    let mut sent = HashMap::with_capacity(plan.count);
    let mut parsed = HashMap::with_capacity(plan.count);
    super::hops::clear();
    let mut tick = tokio::time::interval(period);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    for i in 0..plan.count as u64 {
        tick.tick().await;
        let ns = NodeStatus {
            time: i as f64,
            name: Some("bench".into()),
            local_fix: Some(CartesianCoordinate {
                x: i as f64,
                y: 0.0,
                z: None,
            }),
            pose: EulerAngles {
                heading: Some(90.0),
                ..Default::default()
            },
            speed: Speed::default(),
            ..Default::default()
        };
        sent.insert(i, Instant::now());
        vehicle.publish_node_status(ns);
    }
    let mut h = Hist::new();
    let mut got = 0usize;
    let deadline = tokio::time::Instant::now() + Duration::from_secs(2);
    while got < plan.count {
        match tokio::time::timeout_at(deadline, rx.recv()).await {
            Ok(Some((seq, at))) => {
                if let Some(t0) = sent.get(&seq) {
                    h.record(at.saturating_duration_since(*t0));
                    parsed.insert(seq, at);
                    got += 1;
                }
            }
            _ => break,
        }
    }
    reading.abort();
    let dropped = web
        .hub_counters
        .events_dropped
        .load(std::sync::atomic::Ordering::Relaxed);
    web.shutdown(Duration::from_secs(2)).await;
    let lost = plan.count - got;
    let mut row = latency_row(
        "W1",
        W1,
        &h,
        format!(
            "{} node_status at {} Hz on the bus → hub (JSON by reflection) → SSE on loopback → parsed; lost {lost}, dropped for the tab {dropped}",
            plan.count, plan.rate_hz
        ),
        plan.count,
        lost,
    );
    row.extra = json!({"written": plan.count, "lost": lost, "dropped": dropped});
    let b = super::hops::breakdown(
        plan.count,
        |i| sent.get(&(i as u64)).copied(),
        |i| parsed.get(&(i as u64)).copied(),
        &W1_HOPS,
        "the client has parsed it (end)",
    );
    super::hops::add_to(&mut row, b);
    Ok(row)
}

pub const L3: &str = "floor: an SSE event written by a server task on loopback → the reading client parses it (W1's rate)";

/// Measures L3, W1's floor: a bare event stream with nothing in between — a server task that
/// takes each event from a channel and writes it as `data: {json}` on its HTTP/1.1 connection
/// (as the web scope's stream writer does), a client task that reads and parses it (as W1's
/// does). No bus, no hub, no reflection: what any "event over SSE → the page's model" path costs
/// here at least.
pub async fn run_floor(plan: Plan) -> Row {
    match floor_inner(plan).await {
        Ok(r) => r,
        Err(why) => Row::failed("L3", L3, why),
    }
}

async fn floor_inner(plan: Plan) -> Result<Row, String> {
    let listener = tokio::net::TcpListener::bind(("127.0.0.1", 0))
        .await
        .map_err(|e| format!("bind: {e}"))?;
    let addr = listener.local_addr().map_err(|e| e.to_string())?;
    let (ev_tx, mut ev_rx) = tokio::sync::mpsc::unbounded_channel::<u64>();
    let server = tokio::spawn(async move {
        let Ok((s, _)) = listener.accept().await else {
            return;
        };
        let _ = s.set_nodelay(true);
        let mut s = BufReader::new(s);
        // The request, up to its blank line.
        let mut line = String::new();
        loop {
            line.clear();
            match s.read_line(&mut line).await {
                Ok(0) | Err(_) => return,
                Ok(_) if line.trim_end().is_empty() => break,
                Ok(_) => {}
            }
        }
        let mut s = s.into_inner();
        let head =
            "HTTP/1.1 200 OK\r\ncontent-type: text/event-stream\r\ncache-control: no-cache\r\n\r\n";
        if s.write_all(head.as_bytes()).await.is_err() {
            return;
        }
        while let Some(seq) = ev_rx.recv().await {
            let ev = format!("data: {}\n\n", json!({ "seq": seq }));
            if s.write_all(ev.as_bytes()).await.is_err() {
                return;
            }
        }
    });
    let mut s = TcpStream::connect(addr).await.map_err(|e| e.to_string())?;
    let _ = s.set_nodelay(true);
    s.write_all(format!("GET /events HTTP/1.1\r\nHost: {addr}\r\n\r\n").as_bytes())
        .await
        .map_err(|e| e.to_string())?;
    let mut reader = BufReader::new(s);
    let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel::<(u64, Instant)>();
    let reading = tokio::spawn(async move {
        let mut line = String::new();
        loop {
            line.clear();
            match reader.read_line(&mut line).await {
                Ok(0) | Err(_) => break,
                Ok(_) => {}
            }
            let Some(data) = line.trim_end().strip_prefix("data: ") else {
                continue;
            };
            let Ok(ev) = serde_json::from_str::<Value>(data) else {
                continue;
            };
            let at = Instant::now();
            if let Some(seq) = ev["seq"].as_u64() {
                let _ = tx.send((seq, at));
            }
        }
    });
    let period = Duration::from_secs_f64(1.0 / plan.rate_hz);
    let mut sent = HashMap::with_capacity(plan.count);
    let mut tick = tokio::time::interval(period);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    for i in 0..plan.count as u64 {
        tick.tick().await;
        sent.insert(i, Instant::now());
        if ev_tx.send(i).is_err() {
            break;
        }
    }
    let mut h = Hist::new();
    let mut got = 0usize;
    let deadline = tokio::time::Instant::now() + Duration::from_secs(2);
    while got < plan.count {
        match tokio::time::timeout_at(deadline, rx.recv()).await {
            Ok(Some((seq, at))) => {
                if let Some(t0) = sent.get(&seq) {
                    h.record(at.saturating_duration_since(*t0));
                    got += 1;
                }
            }
            _ => break,
        }
    }
    reading.abort();
    server.abort();
    let lost = plan.count - got;
    Ok(latency_row(
        "L3",
        L3,
        &h,
        format!(
            "{} events at {} Hz: a channel → the server task's write on loopback → the client task reads and parses; lost {lost}",
            plan.count, plan.rate_hz
        ),
        plan.count,
        lost,
    ))
}
