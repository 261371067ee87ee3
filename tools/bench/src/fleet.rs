//! Rows F1 and F2: a fleet's scale. F1 — N vehicles' node_status at 10 Hz each, put on Zenoh
//! over loopback under N platforms by a child process (this very executable, started with
//! [`PUBLISHER_ENV`]), reaching the topside's fleet model in this process (latency from the put,
//! stamped in NodeStatus.time, to the model taking it in; CPU and RSS of this process, which
//! runs the topside and nothing else meanwhile, and the child's CPU apart). F2 — the simulator
//! with 1000 vehicles at 10 Hz (frontseat_sim::capacity_bench: CPU, tick lateness). The full
//! run also measures F1 at F2's fleet size, so the topside is measured with the fleet the
//! simulator flies.

use std::io::Write;
use std::path::Path;
use std::process::ExitCode;
use std::sync::{Arc, Mutex};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use frontseat_actors::bus::BusMessage;
use frontseat_actors::groups;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CartesianCoordinate, NodeStatus,
};
use frontseat_helm_side::key_for;
use frontseat_helm_side::zenoh::Wait as _;
use frontseat_topside::{Topside, TopsideConfig};
use serde_json::json;

use super::inproc::latency_row;
use super::report::{Figures, Hist, Row};

pub const F1: &str = "fleet: node_status of N vehicles at 10 Hz → topside model over Zenoh (goal N = 1000: p99 < 5 ms, < 50 % of one core)";
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

/// The bytes a gateway puts (prost's `encode_to_vec`, reached through the bus's trait).
fn encode<T: BusMessage>(m: &T) -> Vec<u8> {
    m.encode_to_vec()
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

/// Set (to `<port> <vehicles> <window_ms>`) in the environment of the F1 publishing child.
pub const PUBLISHER_ENV: &str = "FRONTSEAT_BENCH_F1_PUBLISHER";

/// The F1 publishers, as the child process: listens for the topside on the port, says
/// `listening`, puts vehicle 0 until `go` arrives on stdin, then every vehicle at 10 Hz for the
/// window, and says `sent S errors E secs T`.
pub fn publisher_main(spec: &str) -> ExitCode {
    let parts: Vec<u64> = spec
        .split_whitespace()
        .filter_map(|p| p.parse().ok())
        .collect();
    let [port, n, window_ms] = parts[..] else {
        eprintln!("{PUBLISHER_ENV}: expected `<port> <vehicles> <window_ms>`, got {spec:?}");
        return ExitCode::from(2);
    };
    super::procs::role_main(
        "F1 publisher",
        publish(port as u16, n as usize, Duration::from_millis(window_ms)),
    )
}

async fn publish(port: u16, n: usize, window: Duration) -> Result<(), String> {
    let vehicles = super::procs::gateway_session(port).await?;
    let go = super::procs::listening();
    // One declared publisher per vehicle, as each vehicle's gateway declares its export: a
    // fleet's node_status reaches the topside as each vehicle's gateway sends it.
    let mut publishers = Vec::with_capacity(n);
    for i in 0..n {
        let key = key_for(
            &format!("v{i}"),
            groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS.name(),
        );
        publishers.push(super::procs::node_status_publisher(&vehicles, key).await?);
    }
    // Round `k` of vehicle `i`; a warm-up put (`None`) has y = -1, which the bench leaves out
    // (one still in flight when the window opens would otherwise count as taken in).
    let publish = |i: usize, k: Option<u64>| {
        let ns = NodeStatus {
            time: unix_now(),
            local_fix: Some(CartesianCoordinate {
                x: k.unwrap_or(0) as f64,
                y: if k.is_some() { i as f64 } else { -1.0 },
                ..Default::default()
            }),
            ..Default::default()
        };
        publishers[i].put(encode(&ns)).wait()
    };
    // Warm up until the bench has heard vehicle 0 (the session must connect first).
    // Every vehicle now and then (the topside must hear each once before the window: its first
    // sample of a key is when the topside declares it), vehicle 0 often.
    let warm = tokio::time::timeout(Duration::from_secs(60), async {
        for round in 0u64.. {
            if round % 25 == 0 {
                for i in 0..n {
                    let _ = publish(i, None);
                }
            } else {
                let _ = publish(0, None);
            }
            match go.try_recv() {
                Ok(()) => return true,
                Err(std::sync::mpsc::TryRecvError::Disconnected) => return false,
                Err(std::sync::mpsc::TryRecvError::Empty) => {}
            }
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
        false
    })
    .await;
    if warm != Ok(true) {
        let _ = vehicles.close().await;
        return Err("no `go` from the bench".into());
    }
    // Every vehicle at 10 Hz, spread over the 100 ms period.
    let period = Duration::from_millis(100);
    let mut tick = tokio::time::interval(period / n.max(1) as u32);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Burst);
    let t0 = tokio::time::Instant::now();
    let (mut sent, mut errors, mut k) = (0u64, 0u64, 0u64);
    while t0.elapsed() < window {
        for i in 0..n {
            tick.tick().await;
            match publish(i, Some(k)) {
                Ok(()) => sent += 1,
                Err(_) => errors += 1,
            }
        }
        k += 1;
    }
    println!(
        "sent {sent} errors {errors} secs {}",
        t0.elapsed().as_secs_f64()
    );
    let _ = std::io::stdout().flush();
    // Let the last puts leave before the session closes.
    tokio::time::sleep(Duration::from_millis(200)).await;
    let _ = vehicles.close().await;
    Ok(())
}

pub async fn run(plan: Plan, bench_exe: &Path, want_f1: bool, want_f2: bool) -> Vec<Row> {
    let mut rows = Vec::new();
    if want_f1 {
        for n in f1_fleets(&plan) {
            rows.push(match f1(bench_exe, n, plan.f1_window).await {
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

/// F1's fleet sizes: the plan's, and F2's own when the plan measures several sizes and F2's is
/// larger, so that a run that measures how the topside scales goes on to the fleet the
/// simulator flies (1 000). `--quick` measures one size (one row per id) and stays at it.
fn f1_fleets(plan: &Plan) -> Vec<usize> {
    let mut fleets = plan.f1_fleets.to_vec();
    if fleets.len() > 1 && fleets.iter().all(|&n| n < plan.f2_vehicles) {
        fleets.push(plan.f2_vehicles);
    }
    fleets
}

async fn f1(bench_exe: &Path, n: usize, window: Duration) -> Result<Row, String> {
    let port = super::procs::free_port()?;
    let mut publisher = super::procs::RoleChild::spawn(
        bench_exe,
        PUBLISHER_ENV,
        format!("{port} {n} {}", window.as_millis()),
        "the F1 publisher",
    )?;
    let said = publisher.line(Duration::from_secs(10)).await?;
    if said != "listening" {
        return Err(format!("the F1 publisher said {said:?}"));
    }
    let mut cfg = TopsideConfig::default();
    cfg.zenoh.connect = vec![format!("tcp/127.0.0.1:{port}")];
    cfg.web.listen = "127.0.0.1:0".into();
    cfg.max_vehicles = n.max(1);
    let hist = Arc::new(Mutex::new((Hist::new(), 0u64)));
    let seen = hist.clone();
    let heard = Arc::new(std::sync::atomic::AtomicBool::new(false));
    let heard_in = heard.clone();
    let observer: frontseat_topside::Observer = Arc::new(move |_p, ns: &NodeStatus| {
        heard_in.store(true, std::sync::atomic::Ordering::Relaxed);
        if ns.local_fix.as_ref().is_some_and(|l| l.y < 0.0) {
            return; // a warm-up put
        }
        let lat = (unix_now() - ns.time).max(0.0);
        let mut h = seen.lock().unwrap_or_else(|p| p.into_inner());
        h.0.record(Duration::from_secs_f64(lat));
        h.1 += 1;
    });
    let top = Topside::start_observed(&cfg, Some(observer))
        .await
        .map_err(|e| e.to_string())?;
    // Warm up until the topside hears the first vehicle (the session must connect first).
    let warm = tokio::time::timeout(Duration::from_secs(10), async {
        while !heard.load(std::sync::atomic::Ordering::Relaxed) {
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
    })
    .await;
    if warm.is_err() {
        top.shutdown().await;
        return Err("the topside never heard the publisher".into());
    }
    // Then until it has heard every vehicle and declared its key: the window measures the fleet
    // in flight, and how long a whole fleet took to appear is said apart.
    let appearing = std::time::Instant::now();
    let all = tokio::time::timeout(Duration::from_secs(30), async {
        while top.declared_keys() < n as u64 {
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
    })
    .await;
    let appeared = appearing.elapsed();
    if all.is_err() {
        let declared = top.declared_keys();
        top.shutdown().await;
        return Err(format!(
            "the topside declared {declared} of {n} vehicles' keys within 30 s"
        ));
    }
    *hist.lock().unwrap_or_else(|p| p.into_inner()) = (Hist::new(), 0);
    let me = std::process::id();
    let child = publisher.pid();
    let (cpu0, child0) = (super::procs::cpu_time(me), super::procs::cpu_time(child));
    let rss0 = rss_kib();
    let t0 = std::time::Instant::now();
    publisher.go()?;
    let report = publisher.line(window + Duration::from_secs(10)).await;
    let secs = t0.elapsed().as_secs_f64();
    let (cpu1, child1) = (super::procs::cpu_time(me), super::procs::cpu_time(child));
    // Let the last ones arrive (after the CPU window: waiting costs nothing).
    tokio::time::sleep(Duration::from_millis(200)).await;
    let rss1 = rss_kib();
    top.shutdown().await;
    drop(publisher);
    let report = report?;
    let field = |name: &str| -> Option<f64> {
        let mut it = report.split_whitespace();
        it.find(|w| *w == name)?;
        it.next()?.parse().ok()
    };
    let (Some(sent), Some(errors)) = (field("sent"), field("errors")) else {
        return Err(format!("the F1 publisher said {report:?}"));
    };
    let (sent, errors) = (sent as u64, errors as u64);
    let (h, received) = {
        let mut g = hist.lock().unwrap_or_else(|p| p.into_inner());
        (std::mem::replace(&mut g.0, Hist::new()), g.1)
    };
    let share = |a: Option<Duration>, b: Option<Duration>| match (a, b) {
        (Some(a), Some(b)) => Some(100.0 * (b.saturating_sub(a)).as_secs_f64() / secs),
        _ => None,
    };
    let (topside_cpu, publisher_cpu) = (share(cpu0, cpu1), share(child0, child1));
    let pct = |c: Option<f64>| c.map_or("CPU unknown".into(), |c| format!("{c:.1} % of one core"));
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
            "{n} platforms × 10 Hz for {secs:.1} s: sent {sent}, put errors {errors}, taken in {received}; topside {}, {rss}; the publishers (a child process) {}; before the window, every vehicle heard and its key declared within {:.2} s",
            pct(topside_cpu),
            pct(publisher_cpu),
            appeared.as_secs_f64(),
        ),
        sent as usize,
        sent.saturating_sub(received) as usize,
    );
    if let serde_json::Value::Object(m) = &mut row.extra {
        m.insert("vehicles".into(), json!(n));
        m.insert("topside_cpu_percent".into(), json!(topside_cpu));
        m.insert("publishers_cpu_percent".into(), json!(publisher_cpu));
        m.insert("topside_rss_kib".into(), json!(rss1));
        m.insert("appeared_s".into(), json!(appeared.as_secs_f64()));
    }
    Ok(row)
}

async fn f2(vehicles: usize, window: Duration) -> Row {
    let r = frontseat_sim::capacity_bench(vehicles, 10.0, 1.0, window).await;
    let what = format!("{F2} ({vehicles} vehicles)");
    if r.running == 0 || r.window.is_zero() {
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
            "ticks due in the window {}: integrated {}, reported {} (skipped as stale {}); NAV received {:.2} % of {} /s; worst tick lateness {:.1} ms, late (> 2 ms) {}; vehicles running {} of {}; {cpu}",
            r.ticks_due,
            r.kept(),
            frontseat_sim::bench::share(r.ticks_reported, r.ticks_due),
            r.skipped_ticks,
            pct(r.received_nav_per_s),
            r.expected_nav_per_s,
            r.worst_lateness.as_secs_f64() * 1e3,
            r.late_ticks,
            r.running,
            r.vehicles,
        )),
        detail: format!(
            "frontseat_sim::capacity_bench over {:.1} s from once every vehicle runs, ticks counted by deadline (integrated up to 0.5 s after the window), clients in the same process over loopback (CPU counts both)",
            r.window.as_secs_f64()
        ),
        extra: json!({
            "vehicles": r.vehicles,
            "running": r.running,
            "ticks_due": r.ticks_due,
            "ticks_integrated": r.ticks_integrated,
            "ticks_reported": r.ticks_reported,
            "ticks_per_s": r.ticks_per_s,
            "nav_sent_per_s": r.sent_nav_per_s,
            "nav_received_per_s": r.received_nav_per_s,
            "worst_lateness_us": r.worst_lateness.as_secs_f64() * 1e6,
            "late_ticks": r.late_ticks,
            "skipped_ticks": r.skipped_ticks,
            "cpu_percent": r.cpu_percent,
        }),
    }
}
