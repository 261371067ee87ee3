//! Rows F1 and F2: a fleet's scale. F1 — N vehicles' node_status at 10 Hz each, put on Zenoh
//! over loopback under N platforms, reaching the topside's fleet model (latency from the put,
//! stamped in NodeStatus.time, to the model taking it in; CPU and RSS of the process, which also
//! runs the publishers, so an upper bound for the topside). F2 — the simulator with 1000
//! vehicles at 10 Hz (frontseat_sim::capacity_bench: CPU, tick lateness).

use std::sync::{Arc, Mutex};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use frontseat_actors::groups;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CartesianCoordinate, NodeStatus,
};
use frontseat_gateway::{key_for, put_message, zenoh};
use frontseat_topside::{Topside, TopsideConfig};
use serde_json::json;

use super::inproc::latency_row;
use super::report::{Figures, Hist, Row};

pub const F1: &str = "fleet: node_status of N vehicles at 10 Hz → topside model over Zenoh (goal N = 100: p99 < 5 ms, < 20 % of one core)";
pub const F2: &str = "fleet: the simulator with 1000 vehicles at 10 Hz (FREQ 10, WARP 1)";

#[derive(Clone, Copy, Debug)]
pub struct Plan {
    pub f1_fleets: &'static [usize],
    pub f1_window: Duration,
    pub f2_vehicles: usize,
    pub f2_window: Duration,
}

fn unix_now() -> f64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64())
}

/// The process's resident memory. Unit: KiB.
fn rss_kib() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    s.lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))?
        .split_whitespace()
        .next()?
        .parse()
        .ok()
}

pub async fn run(plan: Plan, want_f1: bool, want_f2: bool) -> Vec<Row> {
    let mut rows = Vec::new();
    if want_f1 {
        for &n in plan.f1_fleets {
            rows.push(match f1(n, plan.f1_window).await {
                Ok(r) => r,
                Err(why) => Row::failed("F1", format!("{F1} (N = {n})"), why),
            });
        }
    }
    if want_f2 {
        rows.push(f2(plan.f2_vehicles, plan.f2_window).await);
    }
    rows
}

async fn f1(n: usize, window: Duration) -> Result<Row, String> {
    let port = super::procs::free_port()?;
    let ip = frontseat_config::InterprocessConfig {
        enabled: true,
        listen: vec![format!("tcp/127.0.0.1:{port}")],
        ..Default::default()
    };
    let zcfg = frontseat_gateway::zenoh_config(&ip, frontseat_gateway::DEFAULT_MAX_PAYLOAD)
        .map_err(|e| e.to_string())?;
    let vehicles = zenoh::open(zcfg).await.map_err(|e| e.to_string())?;
    let mut cfg = TopsideConfig::default();
    cfg.zenoh.connect = vec![format!("tcp/127.0.0.1:{port}")];
    cfg.web.listen = "127.0.0.1:0".into();
    cfg.max_vehicles = n.max(1);
    let hist = Arc::new(Mutex::new((Hist::new(), 0u64)));
    let seen = hist.clone();
    let observer: frontseat_topside::Observer = Arc::new(move |_p, ns: &NodeStatus| {
        let lat = (unix_now() - ns.time).max(0.0);
        let mut h = seen.lock().unwrap_or_else(|p| p.into_inner());
        h.0.record(Duration::from_secs_f64(lat));
        h.1 += 1;
    });
    let top = Topside::start_observed(&cfg, Some(observer))
        .await
        .map_err(|e| e.to_string())?;
    let keys: Vec<String> = (0..n)
        .map(|i| {
            key_for(
                &format!("v{i}"),
                groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS.name(),
            )
        })
        .collect();
    let type_name = groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS.type_name();
    // Every vehicle at 10 Hz, spread over the 100 ms period.
    let period = Duration::from_millis(100);
    let mut tick = tokio::time::interval(period / n.max(1) as u32);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Burst);
    let publish = |i: usize, k: u64| {
        let ns = NodeStatus {
            time: unix_now(),
            local_fix: Some(CartesianCoordinate {
                x: k as f64,
                y: i as f64,
                ..Default::default()
            }),
            ..Default::default()
        };
        put_message(&vehicles, &keys[i], type_name, &ns, None)
    };
    // Warm up until the topside hears the first vehicle (the session must connect first).
    let warm = tokio::time::timeout(Duration::from_secs(10), async {
        loop {
            let _ = publish(0, 0);
            if hist.lock().unwrap_or_else(|p| p.into_inner()).1 > 0 {
                break;
            }
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
    })
    .await;
    if warm.is_err() {
        top.shutdown().await;
        return Err("the topside never heard the publisher".into());
    }
    *hist.lock().unwrap_or_else(|p| p.into_inner()) = (Hist::new(), 0);
    let cpu0 = super::procs::cpu_time(std::process::id());
    let rss0 = rss_kib();
    let t0 = tokio::time::Instant::now();
    let (mut sent, mut errors, mut k) = (0u64, 0u64, 0u64);
    while t0.elapsed() < window {
        for i in 0..n {
            tick.tick().await;
            match publish(i, k) {
                Ok(()) => sent += 1,
                Err(_) => errors += 1,
            }
        }
        k += 1;
    }
    let secs = t0.elapsed().as_secs_f64();
    let cpu1 = super::procs::cpu_time(std::process::id());
    // Let the last ones arrive (after the CPU window: waiting costs nothing).
    tokio::time::sleep(Duration::from_millis(200)).await;
    let rss1 = rss_kib();
    top.shutdown().await;
    let _ = vehicles.close().await;
    let (h, received) = {
        let mut g = hist.lock().unwrap_or_else(|p| p.into_inner());
        (std::mem::replace(&mut g.0, Hist::new()), g.1)
    };
    let cpu = match (cpu0, cpu1) {
        (Some(a), Some(b)) => format!("{:.1} % of one core", 100.0 * (b - a).as_secs_f64() / secs),
        _ => "CPU unknown".into(),
    };
    let rss = match (rss0, rss1) {
        (Some(a), Some(b)) => format!(
            "RSS {} MiB (+{} KiB over the run)",
            b / 1024,
            b.saturating_sub(a)
        ),
        _ => "RSS unknown".into(),
    };
    let mut row = latency_row(
        "F1",
        &format!("{F1} (N = {n})"),
        &h,
        format!(
            "{n} platforms × 10 Hz for {secs:.1} s: sent {sent}, put errors {errors}, taken in {received}; process (publishers + topside) {cpu}, {rss}"
        ),
        sent as usize,
        sent.saturating_sub(received) as usize,
    );
    if let serde_json::Value::Object(m) = &mut row.extra {
        m.insert("vehicles".into(), json!(n));
    }
    Ok(row)
}

async fn f2(vehicles: usize, window: Duration) -> Row {
    let r = frontseat_sim::capacity_bench(vehicles, 10.0, 1.0, window).await;
    let what = format!("{F2} ({vehicles} vehicles)");
    if r.failed_vehicles == vehicles || r.window.is_zero() {
        return Row::failed("F2", what, "no vehicle started");
    }
    let cpu = r
        .cpu_percent
        .map(|c| format!("{c:.0} % of one core"))
        .unwrap_or_else(|| "CPU unknown".into());
    let pct = |v: f64| 100.0 * v / r.expected_nav_per_s.max(f64::MIN_POSITIVE);
    Row {
        id: "F2",
        what,
        figures: Figures::Result(format!(
            "ticks {:.2} % of {} NAV/s; worst tick lateness {:.1} ms; late {} skipped {}; failed vehicles {}; {cpu}",
            pct(r.ticks_per_s),
            r.expected_nav_per_s,
            r.worst_lateness.as_secs_f64() * 1e3,
            r.late_ticks,
            r.skipped_ticks,
            r.failed_vehicles,
        )),
        detail: format!(
            "frontseat_sim::capacity_bench over {:.1} s, clients in the same process over loopback (CPU counts both)",
            r.window.as_secs_f64()
        ),
        extra: json!({
            "vehicles": r.vehicles,
            "ticks_per_s": r.ticks_per_s,
            "worst_lateness_us": r.worst_lateness.as_secs_f64() * 1e6,
            "late_ticks": r.late_ticks,
            "skipped_ticks": r.skipped_ticks,
            "cpu_percent": r.cpu_percent,
        }),
    }
}
