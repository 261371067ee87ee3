//! Rows Z1, Z2, Z3 and T1: the real `frontseat interface` as a child process with its Zenoh
//! gateway listening on a free loopback port, while this process plays both the scripted
//! frontseat and a helm in another process (a Zenoh client, as examples/rust/zenoh_bench.rs
//! does). T1 runs the same paths on a second child with OpenTelemetry export on, to an OTLP/HTTP
//! sink served here, and reads each child's CPU at 10 Hz NAV (the frontseat's keep-alive rate).
//!
//! Telemetry runs in a child because the bench process already has its global tracing
//! subscriber; a child also measures the exporter exactly as deployed.

use std::net::Ipv4Addr;
use std::path::Path;
use std::sync::Arc;
use std::time::{Duration, Instant};

use frontseat_actors::bus::BusMessage;
use frontseat_actors::groups;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    DesiredCourse, HelmState, HelmStateReport, InterfaceState, InterfaceStatus, NodeStatus, Raw,
};
use frontseat_helm_side::{client_config, key_for, put_message, zenoh};
use serde_json::json;

use super::frontseat::{ScriptedFrontseat, Stamps, seq_of};
use super::inproc::{GRACE, latency_row, match_up};
use super::procs::{cpu_percent, free_port, interface_child};
use super::report::{Figures, Latency, Row, fmt_count, fmt_duration};
use super::sink::{Sink, SinkStats};

/// How much each row measures.
#[derive(Clone, Copy, Debug)]
pub struct Plan {
    pub z1_count: usize,
    pub z1_rate_hz: f64,
    pub z2_count: usize,
    pub z2_rate_hz: f64,
    pub z3_rate_hz: f64,
    pub z3_duration: Duration,
    /// After running:command, before the CPU window: start-up work must not count.
    pub settle: Duration,
    pub cpu_window: Duration,
}

const PLATFORM: &str = "bench-auv";
const Z1: &str =
    "NAV line written by the frontseat → node_status at a Zenoh subscriber in another process";
const Z2: &str =
    "desired_course put over Zenoh by another process → CMD line read at the frontseat";
const Z3: &str = "raw_in across processes over Zenoh at 10 000 NAV lines/s";
const T1: &str =
    "Z1 / Z2 with telemetry (OpenTelemetry export) on vs off; interface CPU at 10 Hz NAV";

/// Time for the child to start, open its gateway and reach running:command.
const STARTUP_BOUND: Duration = Duration::from_secs(20);
/// Across processes the tail of a 10 000 lines/s burst takes longer to drain than in-process.
const RAW_GRACE: Duration = Duration::from_secs(1);

fn decode<T: BusMessage>(bytes: &[u8]) -> Option<T> {
    T::decode(bytes).ok()
}

/// The instants of one child run, by sequence number.
struct Stamped {
    nav_written: Arc<Stamps>,
    node_status_at: Arc<Stamps>,
    raw_in_at: Arc<Stamps>,
    cmd_sent: Arc<Stamps>,
    cmd_read: Arc<Stamps>,
}

/// What one child run measured.
struct Measured {
    z1: Row,
    z2: Row,
    z3: Option<Row>,
    cpu_percent: f64,
    cpu_window: Duration,
}

impl Plan {
    fn z3_count(&self) -> usize {
        (self.z3_rate_hz * self.z3_duration.as_secs_f64()).round() as usize
    }
}

/// Runs one child with export off (Z1, Z2, Z3, CPU) then one with export on (Z1, Z2, CPU);
/// returns the rows Z1, Z2, Z3, T1.
pub async fn run(exe: &Path, plan: Plan) -> Vec<Row> {
    let off = measure(exe, &plan, None).await;
    let sink = Sink::start().await;
    let on = match &sink {
        Ok(s) => measure(exe, &plan, Some(s)).await,
        Err(e) => Err(format!("OTLP sink: {e}")),
    };
    let sink_stats = sink.as_ref().map(Sink::stats).unwrap_or_default();
    drop(sink);
    let t1 = t1(&off, &on, sink_stats);
    let mut rows = match off {
        Ok(m) => vec![
            m.z1,
            m.z2,
            m.z3.unwrap_or_else(|| Row::failed("Z3", Z3, "not run")),
        ],
        Err(why) => vec![
            Row::failed("Z1", Z1, why.clone()),
            Row::failed("Z2", Z2, why.clone()),
            Row::failed("Z3", Z3, why),
        ],
    };
    rows.push(t1);
    rows
}

/// One `frontseat interface` child against a fresh scripted frontseat; export to `sink` if
/// given (and then no Z3: the raw_in flood is not what T1 compares).
async fn measure(exe: &Path, plan: &Plan, sink: Option<&Sink>) -> Result<Measured, String> {
    let base = Instant::now();
    let z3_count = if sink.is_none() { plan.z3_count() } else { 0 };
    let navs = plan.z1_count + z3_count;
    let st = Stamped {
        nav_written: Stamps::new(base, navs),
        node_status_at: Stamps::new(base, navs),
        raw_in_at: Stamps::new(base, navs),
        cmd_sent: Stamps::new(base, plan.z2_count),
        cmd_read: Stamps::new(base, plan.z2_count),
    };
    let fs = ScriptedFrontseat::start(st.nav_written.clone(), st.cmd_read.clone())
        .map_err(|e| format!("scripted frontseat: {e}"))?;
    let zport = free_port()?;
    let tag = if sink.is_some() { "otel" } else { "zenoh" };
    let telemetry = sink
        .map(|s| {
            format!(
                "\n[telemetry]\nenabled = true\nendpoint = \"{}\"\nservice_name = \"frontseat-bench\"\n",
                s.url()
            )
        })
        .unwrap_or_default();
    let cfg = format!(
        "# written by `frontseat bench` (rows Z1–Z3, T1); removed when it ends\n\
         name = \"{PLATFORM}\"\n\
         status_period = 0.5\n\n\
         [driver.basic_simulator]\n\
         tcp_port = {}\n\n\
         [interprocess]\n\
         enabled = true\n\
         listen = [\"tcp/127.0.0.1:{zport}\"]\n\n\
         # Z2 carries its sequence number in DEPTH (up to z2_count): the default 300 m limit\n\
         # would refuse the rest. 12000 is the most a config file may say.\n\
         [limits]\n\
         max_depth = 12000.0\n\n\
         # Z1's NAV lines step their DEPTH 1 m a line at 500 Hz: past the navigation gate's\n\
         # depth-rate bound, which would refuse four lines in five. Z3's carry sequence numbers\n\
         # up to z1 + z3 (55 000): past the gate's depth bound (11 000 m), which refused all\n\
         # but the first 6 000 node_status; 1e5 is the most validation accepts.\n\
         [limits.navigation]\n\
         max_depth = 100000.0\n\
         max_abs_depth_rate = 1e9\n{telemetry}",
        fs.port()
    );
    let (_cfg, mut child) = interface_child(exe, tag, &cfg)?;
    let r = connect_and_measure(plan, &fs, child.pid(), zport, &st, z3_count)
        .await
        .map_err(|e| format!("{e}; the interface logged: {}", child.tail(4)));
    drop(child);
    fs.stop();
    r
}

async fn connect_and_measure(
    plan: &Plan,
    fs: &ScriptedFrontseat,
    pid: u32,
    zport: u16,
    st: &Stamped,
    z3_count: usize,
) -> Result<Measured, String> {
    let deadline = tokio::time::Instant::now() + STARTUP_BOUND;
    while tokio::net::TcpStream::connect((Ipv4Addr::LOCALHOST, zport))
        .await
        .is_err()
    {
        if tokio::time::Instant::now() > deadline {
            return Err(format!(
                "the interface's Zenoh gateway did not listen on {zport} within {STARTUP_BOUND:?}"
            ));
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    let cfg = client_config(&[format!("tcp/127.0.0.1:{zport}")])
        .map_err(|e| format!("Zenoh client config: {e}"))?;
    let session = zenoh::open(cfg)
        .await
        .map_err(|e| format!("Zenoh client session: {e}"))?;
    let r = on_session(plan, fs, pid, &session, st, z3_count).await;
    let _ = session.close().await;
    r
}

/// Aborts a task when dropped, whichever way the measurement ends.
struct AbortOnDrop(tokio::task::JoinHandle<()>);

impl Drop for AbortOnDrop {
    fn drop(&mut self) {
        self.0.abort();
    }
}

async fn on_session(
    plan: &Plan,
    fs: &ScriptedFrontseat,
    pid: u32,
    session: &zenoh::Session,
    st: &Stamped,
    z3_count: usize,
) -> Result<Measured, String> {
    let key = |g: &str| key_for(PLATFORM, g);
    let zerr = |what: &str, e: zenoh::Error| format!("Zenoh {what}: {e}");

    let at = st.node_status_at.clone();
    let _ns = session
        .declare_subscriber(key(groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS.name()))
        .callback(move |s| {
            let now = Instant::now();
            if let Some(m) = decode::<NodeStatus>(&s.payload().to_bytes()) {
                let d = m.global_fix.depth();
                if d >= 1.0 && d.fract() == 0.0 {
                    at.set(d as usize - 1, now);
                }
            }
        })
        .await
        .map_err(|e| zerr("subscriber", e))?;
    let at = st.raw_in_at.clone();
    let _raw = session
        .declare_subscriber(key(groups::GOBY_MIDDLEWARE_FRONTSEAT_RAW_IN.name()))
        .callback(move |s| {
            let now = Instant::now();
            if let Some(seq) = decode::<Raw>(&s.payload().to_bytes())
                .and_then(|r| r.raw.as_deref().and_then(seq_of))
            {
                at.set(seq, now);
            }
        })
        .await
        .map_err(|e| zerr("subscriber", e))?;
    let (cmd_tx, mut in_command) = tokio::sync::watch::channel(false);
    let _status = session
        .declare_subscriber(key(groups::GOBY_MIDDLEWARE_FRONTSEAT_STATUS.name()))
        .callback(move |s| {
            if let Some(m) = decode::<InterfaceStatus>(&s.payload().to_bytes()) {
                let _ = cmd_tx.send(m.state() == InterfaceState::InterfaceCommand);
            }
        })
        .await
        .map_err(|e| zerr("subscriber", e))?;

    // The helm, in this process: DRIVE at 10 Hz, as a real helm's heartbeat.
    let hb = session.clone();
    let helm_key = key(groups::GOBY_MIDDLEWARE_FRONTSEAT_HELM_STATE.name());
    let _helm = AbortOnDrop(tokio::spawn(async move {
        loop {
            let drive = HelmStateReport {
                state: HelmState::HelmDrive as i32,
            };
            let _ = put_message(
                &hb,
                &helm_key,
                groups::GOBY_MIDDLEWARE_FRONTSEAT_HELM_STATE.type_name(),
                &drive,
                None,
            );
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
    }));
    match tokio::time::timeout(STARTUP_BOUND, in_command.wait_for(|c| *c)).await {
        Ok(Ok(_)) => {}
        _ => {
            return Err(format!(
                "no running:command status over Zenoh within {STARTUP_BOUND:?}"
            ));
        }
    }

    // CPU at steady state: only the keep-alive NAV (10 Hz) and the helm heartbeat (10 Hz) flow.
    tokio::time::sleep(plan.settle).await;
    let (cpu_percent, cpu_window) = cpu_percent(pid, plan.cpu_window).await?;

    let z1 = z1(plan, fs, st).await;
    let z2 = z2(plan, fs, session, st).await;
    let z3 = if z3_count > 0 {
        Some(z3(plan, fs, st, z3_count).await)
    } else {
        None
    };
    Ok(Measured {
        z1,
        z2,
        z3,
        cpu_percent,
        cpu_window,
    })
}

async fn z1(plan: &Plan, fs: &ScriptedFrontseat, st: &Stamped) -> Row {
    let report = match fs.burst(0, plan.z1_count, plan.z1_rate_hz, false).await {
        Ok(r) => r,
        Err(_) => return Row::failed("Z1", Z1, "the scripted frontseat stopped"),
    };
    tokio::time::sleep(GRACE).await;
    let (h, n, lost) = match_up(&st.nav_written, &st.node_status_at, 0..plan.z1_count);
    let detail = format!(
        "{} NAV lines at {} Hz, one write each; `frontseat interface` child (Zenoh gateway listening on loopback) → Zenoh client session in the bench process; lost {lost}",
        fmt_count(n as f64),
        plan.z1_rate_hz
    );
    latency_row("Z1", Z1, &h, detail, report.written, lost)
}

async fn z2(plan: &Plan, fs: &ScriptedFrontseat, session: &zenoh::Session, st: &Stamped) -> Row {
    let course_key = key_for(
        PLATFORM,
        groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE.name(),
    );
    let before = fs.cmds_read();
    let start = tokio::time::Instant::now();
    let period = Duration::from_secs_f64(1.0 / plan.z2_rate_hz.max(1e-3));
    let mut put_errors = 0usize;
    for i in 0..plan.z2_count {
        tokio::time::sleep_until(start + period.mul_f64(i as f64)).await;
        let course = DesiredCourse {
            time: 0.0,
            heading: Some(90.0),
            speed: Some(1.5),
            depth: Some((i + 1) as f64),
            ..Default::default()
        };
        st.cmd_sent.set(i, Instant::now());
        if put_message(
            session,
            &course_key,
            groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE.type_name(),
            &course,
            None,
        )
        .is_err()
        {
            put_errors += 1;
        }
    }
    let deadline = tokio::time::Instant::now() + GRACE;
    while fs.cmds_read() < before + plan.z2_count as u64 && tokio::time::Instant::now() < deadline {
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    let (h, n, lost) = match_up(&st.cmd_sent, &st.cmd_read, 0..plan.z2_count);
    let detail = format!(
        "{} desired_course at {} Hz (sequence in DEPTH), stamped before the Zenoh put; lost {lost}{}",
        fmt_count(n as f64),
        plan.z2_rate_hz,
        if put_errors > 0 {
            format!(" ({put_errors} puts refused)")
        } else {
            String::new()
        }
    );
    latency_row("Z2", Z2, &h, detail, n, lost)
}

async fn z3(plan: &Plan, fs: &ScriptedFrontseat, st: &Stamped, count: usize) -> Row {
    let first = plan.z1_count;
    let report = match fs.burst(first, count, plan.z3_rate_hz, true).await {
        Ok(r) => r,
        Err(_) => return Row::failed("Z3", Z3, "the scripted frontseat stopped"),
    };
    tokio::time::sleep(RAW_GRACE).await;
    let range = first..first + count;
    let (h_raw, n, raw_lost) = match_up(&st.nav_written, &st.raw_in_at, range.clone());
    let (_, _, ns_lost) = match_up(&st.nav_written, &st.node_status_at, range);
    let secs = report.elapsed.as_secs_f64().max(1e-9);
    let rate = n as f64 / secs;
    let delivered = n - raw_lost;
    let mut result = format!(
        "{} lines/s written for {:.1} s: raw_in delivered over Zenoh {} ({:.2} %), lost {raw_lost}; node_status lost {ns_lost}",
        fmt_count(rate),
        secs,
        fmt_count(delivered as f64),
        100.0 * delivered as f64 / n.max(1) as f64,
    );
    if let Some(l) = h_raw.latency() {
        result.push_str(&format!(
            "; write → raw_in at the Zenoh subscriber p50 {} p99 {} max {}",
            fmt_duration(l.p50),
            fmt_duration(l.p99),
            fmt_duration(l.max)
        ));
    }
    Row {
        id: "Z3",
        what: Z3.into(),
        figures: if n == 0 {
            Figures::Failed("no line written".into())
        } else {
            Figures::Result(result)
        },
        detail: "lines written in batches every 1 ms; default queue capacities (bus 1024, gateway export 4096)".into(),
        extra: json!({
            "written": n,
            "rate_per_s": rate,
            "raw_in_delivered": delivered,
            "raw_in_lost": raw_lost,
            "node_status_lost": ns_lost,
        }),
    }
}

fn latency_of(r: &Row) -> Option<Latency> {
    match r.figures {
        Figures::Latency(l) => Some(l),
        _ => None,
    }
}

fn p50_p99(l: Option<Latency>) -> String {
    l.map(|l| format!("{} / {}", fmt_duration(l.p50), fmt_duration(l.p99)))
        .unwrap_or_else(|| "–".into())
}

fn lost_of(r: &Row) -> u64 {
    r.extra["lost"].as_u64().unwrap_or(0)
}

fn t1(off: &Result<Measured, String>, on: &Result<Measured, String>, sink: SinkStats) -> Row {
    let on = match on {
        Ok(m) => m,
        Err(why) => return Row::failed("T1", T1, format!("export on: {why}")),
    };
    for r in [&on.z1, &on.z2] {
        if let Figures::Failed(why) = &r.figures {
            return Row::failed("T1", T1, format!("export on, {}: {why}", r.id));
        }
    }
    let off = off.as_ref().ok();
    let us = |l: Option<Latency>| {
        l.map(|l| json!({ "p50_us": l.p50.as_secs_f64() * 1e6, "p99_us": l.p99.as_secs_f64() * 1e6, "max_us": l.max.as_secs_f64() * 1e6 }))
    };
    let (on_z1, on_z2) = (latency_of(&on.z1), latency_of(&on.z2));
    let (off_z1, off_z2) = (
        off.and_then(|m| latency_of(&m.z1)),
        off.and_then(|m| latency_of(&m.z2)),
    );
    let off_cpu = off
        .map(|m| format!("{:.1} %", m.cpu_percent))
        .unwrap_or_else(|| "–".into());
    let result = format!(
        "p50 / p99 export on vs off: Z1 {} vs {}, Z2 {} vs {} (lost with export on: {} / {}); interface CPU at 10 Hz NAV: on {:.1} % vs off {off_cpu} of one core (target < 2 %); the sink got {} export requests, {:.1} KiB",
        p50_p99(on_z1),
        p50_p99(off_z1),
        p50_p99(on_z2),
        p50_p99(off_z2),
        lost_of(&on.z1),
        lost_of(&on.z2),
        on.cpu_percent,
        sink.exports,
        sink.bytes as f64 / 1024.0,
    );
    Row {
        id: "T1",
        what: T1.into(),
        figures: Figures::Result(result),
        detail: format!(
            "a second `frontseat interface` child with [telemetry] enabled, exporting OTLP/HTTP to a sink the bench serves on loopback (200 to every POST /v1/traces), same Z1/Z2 bursts; CPU from /proc/<pid>/stat over {} while only the 10 Hz keep-alive NAV and the 10 Hz helm heartbeat flow",
            fmt_duration(on.cpu_window)
        ),
        extra: json!({
            "on": { "z1": us(on_z1), "z2": us(on_z2), "z1_lost": lost_of(&on.z1), "z2_lost": lost_of(&on.z2), "cpu_percent": on.cpu_percent },
            "off": { "z1": us(off_z1), "z2": us(off_z2), "cpu_percent": off.map(|m| m.cpu_percent) },
            "sink": { "exports": sink.exports, "bytes": sink.bytes, "refused": sink.refused },
        }),
    }
}
