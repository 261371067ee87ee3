//! Rows P1, P2 and P6: the real interface (basic simulator driver, bus, state machine) in this
//! process, connected over loopback TCP to the scripted frontseat, with a helm heartbeat so the
//! interface reaches COMMAND and passes desired courses on.

use std::sync::Arc;
use std::time::{Duration, Instant};

use frontseat_actors::bus::{Bus, Envelope, Subscription, Undeliverable};
use frontseat_actors::interface::InterfaceService;
use frontseat_actors::ports::{
    BenchHelmPorts, BenchNavWatchInbox, BenchRawWatchInbox, BenchStatusWatchInbox,
};
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    DesiredCourse, HelmState, HelmStateReport, InterfaceState, InterfaceStatus, NodeStatus, Raw,
};
use frontseat_config::{InterfaceConfig, MoosConfig};
use frontseat_helm_side::translation;
use frontseat_moos::{Broker, MoosClient, MoosClientConfig, MoosEvent};
use serde_json::json;
use tokio::sync::mpsc::UnboundedReceiver;

use super::frontseat::{ScriptedFrontseat, Stamps, seq_of};
use super::hops::{self, Hop, hop};
use super::report::{Figures, Hist, Row, fmt_count};

/// How much each row measures.
#[derive(Clone, Copy, Debug)]
pub struct Plan {
    pub p1_count: usize,
    pub p1_rate_hz: f64,
    pub p2_count: usize,
    pub p2_rate_hz: f64,
    pub p6_rate_hz: f64,
    pub p6_duration: Duration,
    pub m1_count: usize,
    pub m1_rate_hz: f64,
    pub m2_count: usize,
    pub m2_rate_hz: f64,
}

impl Plan {
    fn p6_count(&self) -> usize {
        (self.p6_rate_hz * self.p6_duration.as_secs_f64()).round() as usize
    }
}

const P1: &str = "NAV line written by the frontseat → node_status delivered to a bus subscriber";
const P2: &str = "desired_course published → CMD line read at the frontseat";
const P6: &str = "raw_in throughput at 10 000 NAV lines/s";
const M1: &str =
    "NAV line written → NAV_DEPTH mail at a MOOS client (FrontSeatTranslation, MOOSDB)";
const M2: &str =
    "DESIRED_* posted by a MOOS client → CMD line read at the frontseat (through MOOSDB)";

/// M1's hops: the interface publishes node_status (its bus delivers to the translation on the
/// publisher's thread), the translation's task posts NAV_* through its MOOS client's writer
/// task, the MOOSDB's reader and the helm's connection writer, the helm's client's reader.
const M1_HOPS: [Hop; 6] = [
    hop(
        "node_status delivered to the translation",
        "translation.delivered",
        None,
    ),
    hop("the translation's task", "translation.nav_woke", None),
    hop(
        "its MOOS client writes",
        "moos.client.write",
        Some("iFrontSeat"),
    ),
    hop("the MOOSDB reads", "moos.broker.read", Some("iFrontSeat")),
    hop(
        "the MOOSDB writes to the helm",
        "moos.broker.write",
        Some("bench-helm"),
    ),
    hop(
        "the helm's client reads",
        "moos.client.read",
        Some("bench-helm"),
    ),
];
/// M2's hops, the other way; the course is published when DESIRED_SPEED (the third post) is
/// in, so a triple split over packets puts the wait for the rest in the last MOOS segments.
const M2_HOPS: [Hop; 6] = [
    hop(
        "the helm's client writes",
        "moos.client.write",
        Some("bench-helm"),
    ),
    hop("the MOOSDB reads", "moos.broker.read", Some("bench-helm")),
    hop(
        "the MOOSDB writes to the translation",
        "moos.broker.write",
        Some("iFrontSeat"),
    ),
    hop(
        "the translation's client reads",
        "moos.client.read",
        Some("iFrontSeat"),
    ),
    hop("the translation's task", "translation.mail_woke", None),
    hop("desired_course published", "translation.course", None),
];

/// Time for the last deliveries of a burst to arrive before counting them lost.
pub(super) const GRACE: Duration = Duration::from_millis(300);

/// The depth limit of the bench's interfaces: above any sequence number a row writes in DEPTH.
const SEQUENCE_DEPTH_LIMIT: f64 = 1e9;
/// The navigation gate's depth bound for the bench: above any sequence number a NAV line carries
/// (and the largest `[limits.navigation] max_depth` validation accepts).
const NAV_SEQUENCE_DEPTH_LIMIT: f64 = 1e5;
/// The navigation gate's depth-rate bound for the bench: above 1 m a line at any rate a row writes.
const NAV_SEQUENCE_DEPTH_RATE: f64 = 1e9;

/// Runs P1, P2, P6, then M1 and M2 on one interface (those of them `sel` wants; M1 and M2
/// together); returns their rows in that order.
pub async fn run(plan: Plan, sel: &super::Selection) -> Vec<Row> {
    match run_inner(plan, sel).await {
        Ok(rows) => rows,
        Err(why) => vec![
            Row::failed("P1", P1, why.clone()),
            Row::failed("P2", P2, why.clone()),
            Row::failed("P6", P6, why.clone()),
            Row::failed("M1", M1, why.clone()),
            Row::failed("M2", M2, why),
        ],
    }
}

async fn run_inner(plan: Plan, sel: &super::Selection) -> Result<Vec<Row>, String> {
    let base = Instant::now();
    let navs = plan.p1_count + plan.p6_count() + plan.m1_count;
    let nav_written = Stamps::new(base, navs);
    let node_status_at = Stamps::new(base, navs);
    let raw_in_at = Stamps::new(base, navs);
    let cmds = plan.p2_count + plan.m2_count;
    let cmd_sent = Stamps::new(base, cmds);
    let cmd_read = Stamps::new(base, cmds);

    let fs = ScriptedFrontseat::start(nav_written.clone(), cmd_read.clone())
        .map_err(|e| format!("scripted frontseat: {e}"))?;

    let mut cfg = InterfaceConfig {
        name: "bench-auv".into(),
        ..InterfaceConfig::default()
    };
    cfg.driver.basic_simulator.tcp_port = fs.port();
    // P2 and M2 carry their sequence number in DEPTH (1 ..= p2_count + m2_count, 15 000 in a full
    // run): the safety envelope's depth limit (300 m by default) would refuse all but the first
    // 300 and the row would measure nothing. Every other limit stays at its default.
    cfg.limits.max_depth = SEQUENCE_DEPTH_LIMIT;
    // P1, P6 and M1 carry theirs in the NAV line's DEPTH (up to p1 + p6 + m1 = 65 000 in a full
    // run): the navigation gate drops a depth past 11 000 m (the deepest ocean), so M1, which
    // comes after P1's 10 000 lines, lost every sample in a full run. The gate's own bound is
    // raised as far as validation allows; every other navigation bound stays at its default.
    cfg.limits.navigation.max_depth = NAV_SEQUENCE_DEPTH_LIMIT;
    // And that sequence steps 1 m a line at 500 Hz: 500 m/s, past the gate's depth-rate bound
    // (20 m/s), which refused four lines in five (P1 "lost 8000" since that bound came in) and
    // left the row measuring a biased fifth.
    cfg.limits.navigation.max_abs_depth_rate = NAV_SEQUENCE_DEPTH_RATE;
    let capacity = cfg.bus.queue_capacity;

    let bus = Bus::new();
    let mut tasks = Vec::new();
    let (_ns_sub, ns_task) = stamp_node_status(&bus, &node_status_at, capacity);
    tasks.push(ns_task);
    let (_raw_sub, mut raw_rx) = raw_in_channel(&bus, capacity);
    let at = raw_in_at.clone();
    tasks.push(tokio::spawn(async move {
        while let Some(env) = raw_rx.recv().await {
            let now = Instant::now();
            if let Some(seq) = env.msg.raw.as_deref().and_then(seq_of) {
                at.set(seq, now);
            }
        }
    }));
    let (_st_sub, mut st_rx) = status_channel(&bus, capacity);
    tasks.push(helm_drive(&bus));

    let service = InterfaceService::start(&cfg, &bus, frontseat_drivers::BUILT_IN)
        .await
        .map_err(|e| format!("interface: {e}"))?;
    let rows = if reached_command(&mut st_rx).await {
        // Each row has its own range of sequence numbers, so leaving one out moves no other.
        let mut rows = Vec::new();
        if sel.wants("P1") {
            rows.push(p1(&plan, &fs, &nav_written, &node_status_at).await);
        }
        if sel.wants("P2") {
            let lane0 = lane_sent(&service).await;
            let mut row = p2(&plan, &bus, &fs, &cmd_sent, &cmd_read).await;
            note_lane(&mut row, &service, lane0).await;
            rows.push(row);
        }
        if sel.wants("P6") {
            rows.push(p6(&plan, &bus, &fs, &nav_written, &node_status_at, &raw_in_at).await);
        }
        if sel.wants("M1") || sel.wants("M2") {
            let lane0 = lane_sent(&service).await;
            let mut moos =
                moos_rows(&plan, &bus, &fs, &nav_written, &cmd_sent, &cmd_read, base).await;
            if let Some(m2) = moos.iter_mut().find(|r| r.id == "M2") {
                note_lane(m2, &service, lane0).await;
            }
            rows.extend(moos);
        }
        Ok(rows)
    } else {
        Err("the interface did not reach running:command within 10 s".to_string())
    };
    let _ = service.shutdown(Duration::from_secs(2)).await;
    for t in tasks {
        t.abort();
    }
    fs.stop();
    rows
}

/// Courses the interface's setpoint lane has written so far (0 when it does not answer).
async fn lane_sent(service: &InterfaceService) -> u64 {
    service
        .snapshot(Duration::from_secs(2))
        .await
        .map_or(0, |s| s.setpoints_direct)
}

/// Says in `row` how many of its courses took the setpoint lane (the rest went through both
/// actors): a row whose courses stopped taking it measures another path.
async fn note_lane(row: &mut Row, service: &InterfaceService, before: u64) {
    let n = lane_sent(service).await.saturating_sub(before);
    row.detail.push_str(&format!(
        "; {} through the setpoint lane",
        fmt_count(n as f64)
    ));
    if let serde_json::Value::Object(m) = &mut row.extra {
        m.insert("setpoint_lane".into(), json!(n));
    }
}

/// Stamps every node_status on `bus` whose DEPTH carries a sequence number (`DEPTH:n + 1`) with
/// the instant a bus subscriber woke with it.
pub(super) fn stamp_node_status(
    bus: &Bus,
    at: &Arc<Stamps>,
    capacity: usize,
) -> (Vec<Subscription>, tokio::task::JoinHandle<()>) {
    let (sub, mut rx) = node_status_channel(bus, "bench", capacity);
    let at = at.clone();
    let task = tokio::spawn(async move {
        while let Some(env) = rx.recv().await {
            let now = Instant::now();
            let depth = env.msg.global_fix.depth();
            if depth >= 1.0 && depth.fract() == 0.0 {
                at.set(depth as usize - 1, now);
            }
        }
    });
    (sub, task)
}

/// Every node_status on `bus`, as the bench's watcher (`BenchNavWatch` in
/// `interface_yaml/bench.yaml`) gets it, unread ones bounded by `capacity`.
pub(super) fn node_status_channel(
    bus: &Bus,
    name: &str,
    capacity: usize,
) -> (Vec<Subscription>, UnboundedReceiver<Envelope<NodeStatus>>) {
    let (tx, rx) = tokio::sync::mpsc::unbounded_channel();
    let subs = BenchNavWatchInbox::subscribe_all(bus, name, capacity, move |m| {
        let BenchNavWatchInbox::NodeStatus(env) = m;
        tx.send(env).map_err(|_| Undeliverable)
    });
    (subs, rx)
}

/// Every interface status on `bus` (`BenchStatusWatch`).
pub(super) fn status_channel(
    bus: &Bus,
    capacity: usize,
) -> (
    Vec<Subscription>,
    UnboundedReceiver<Envelope<InterfaceStatus>>,
) {
    let (tx, rx) = tokio::sync::mpsc::unbounded_channel();
    let subs = BenchStatusWatchInbox::subscribe_all(bus, "bench", capacity, move |m| {
        let BenchStatusWatchInbox::Status(env) = m;
        tx.send(env).map_err(|_| Undeliverable)
    });
    (subs, rx)
}

/// Every raw_in on `bus` (`BenchRawWatch`).
fn raw_in_channel(
    bus: &Bus,
    capacity: usize,
) -> (Vec<Subscription>, UnboundedReceiver<Envelope<Raw>>) {
    let (tx, rx) = tokio::sync::mpsc::unbounded_channel();
    let subs = BenchRawWatchInbox::subscribe_all(bus, "bench", capacity, move |m| {
        let BenchRawWatchInbox::RawIn(env) = m;
        tx.send(env).map_err(|_| Undeliverable)
    });
    (subs, rx)
}

/// A helm heartbeat on `bus`: HelmStateReport DRIVE every 100 ms.
pub(super) fn helm_drive(bus: &Bus) -> tokio::task::JoinHandle<()> {
    let ports = BenchHelmPorts::new(bus);
    tokio::spawn(async move {
        loop {
            ports.publish_helm_state(HelmStateReport {
                state: HelmState::HelmDrive as i32,
            });
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
    })
}

/// True once the interface's status says running:command, within 10 s.
pub(super) async fn reached_command(
    status: &mut UnboundedReceiver<Envelope<InterfaceStatus>>,
) -> bool {
    let reached = tokio::time::timeout(Duration::from_secs(10), async {
        while let Some(env) = status.recv().await {
            if env.msg.state() == InterfaceState::InterfaceCommand {
                return true;
            }
        }
        false
    })
    .await;
    matches!(reached, Ok(true))
}

/// `count` desired_course at `rate_hz` on `bus`, sequence `off + i + 1` in DEPTH, each stamped
/// in `sent` right before its publish; then up to [`GRACE`] for the frontseat to read them all.
pub(super) async fn publish_courses(
    bus: &Bus,
    fs: &ScriptedFrontseat,
    sent: &Stamps,
    off: usize,
    count: usize,
    rate_hz: f64,
) {
    let helm = BenchHelmPorts::new(bus);
    let before = fs.cmds_read();
    let start = tokio::time::Instant::now();
    let period = Duration::from_secs_f64(1.0 / rate_hz.max(1e-3));
    for i in 0..count {
        tokio::time::sleep_until(start + period.mul_f64(i as f64)).await;
        let course = DesiredCourse {
            time: 0.0,
            heading: Some(90.0),
            speed: Some(1.5),
            depth: Some((off + i + 1) as f64),
            ..Default::default()
        };
        sent.set(off + i, Instant::now());
        helm.publish_desired_course(course);
    }
    let deadline = tokio::time::Instant::now() + GRACE;
    while fs.cmds_read() < before + count as u64 && tokio::time::Instant::now() < deadline {
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
}

/// Latency of every index in `range` stamped in both; and how many were written but never
/// delivered.
pub(super) fn match_up(
    sent: &Stamps,
    got: &Stamps,
    range: std::ops::Range<usize>,
) -> (Hist, usize, usize) {
    let mut h = Hist::new();
    let (mut written, mut lost) = (0, 0);
    for i in range {
        let Some(s) = sent.get(i) else { continue };
        written += 1;
        match got.get(i) {
            Some(g) => h.record(g.saturating_duration_since(s)),
            None => lost += 1,
        }
    }
    (h, written, lost)
}

/// A latency row over a burst of `count` NAV lines from sequence 0 at `rate_hz`, each matched
/// to its delivery in `got`; `how` says what the path was.
#[allow(clippy::too_many_arguments)]
pub(super) async fn nav_burst_row(
    id: &'static str,
    what: &str,
    fs: &ScriptedFrontseat,
    written: &Stamps,
    got: &Stamps,
    count: usize,
    rate_hz: f64,
    how: &str,
) -> Row {
    let report = match fs.burst(0, count, rate_hz, false).await {
        Ok(r) => r,
        Err(_) => return Row::failed(id, what, "the scripted frontseat stopped"),
    };
    tokio::time::sleep(GRACE).await;
    let (h, n, lost) = match_up(written, got, 0..count);
    let detail = format!(
        "{} NAV lines at {rate_hz} Hz{how}; lost {lost}",
        fmt_count(n as f64)
    );
    latency_row(id, what, &h, detail, report.written, lost)
}

/// A latency row over `count` desired_course at `rate_hz` (sequence 0.., in DEPTH) published on
/// `bus`, each matched to the CMD line the frontseat read; `how` says what the path was.
#[allow(clippy::too_many_arguments)]
pub(super) async fn course_row(
    id: &'static str,
    what: &str,
    bus: &Bus,
    fs: &ScriptedFrontseat,
    sent: &Stamps,
    read: &Stamps,
    count: usize,
    rate_hz: f64,
    how: &str,
) -> Row {
    publish_courses(bus, fs, sent, 0, count, rate_hz).await;
    let (h, n, lost) = match_up(sent, read, 0..count);
    let detail = format!(
        "{} desired_course at {rate_hz} Hz (sequence in DEPTH){how}; lost {lost}",
        fmt_count(n as f64)
    );
    latency_row(id, what, &h, detail, n, lost)
}

async fn p1(plan: &Plan, fs: &ScriptedFrontseat, written: &Stamps, got: &Stamps) -> Row {
    let how = ", one write each (scripted loopback frontseat, stamp before write(2))";
    nav_burst_row(
        "P1",
        P1,
        fs,
        written,
        got,
        plan.p1_count,
        plan.p1_rate_hz,
        how,
    )
    .await
}

async fn p2(plan: &Plan, bus: &Bus, fs: &ScriptedFrontseat, sent: &Stamps, read: &Stamps) -> Row {
    course_row(
        "P2",
        P2,
        bus,
        fs,
        sent,
        read,
        plan.p2_count,
        plan.p2_rate_hz,
        "",
    )
    .await
}

pub(super) fn latency_row(
    id: &'static str,
    what: &str,
    h: &Hist,
    detail: String,
    written: usize,
    lost: usize,
) -> Row {
    let extra = json!({ "written": written, "lost": lost });
    match h.latency() {
        Some(l) => Row {
            id,
            what: what.into(),
            figures: Figures::Latency(l),
            detail,
            extra,
        },
        None => Row {
            extra,
            ..Row::failed(id, what, format!("nothing delivered; {detail}"))
        },
    }
}

async fn p6(
    plan: &Plan,
    bus: &Bus,
    fs: &ScriptedFrontseat,
    written: &Stamps,
    node_status: &Stamps,
    raw_in: &Stamps,
) -> Row {
    let first = plan.p1_count;
    let count = plan.p6_count();
    let dropped0 = bus.total_dropped();
    let report = match fs.burst(first, count, plan.p6_rate_hz, true).await {
        Ok(r) => r,
        Err(_) => return Row::failed("P6", P6, "the scripted frontseat stopped"),
    };
    tokio::time::sleep(GRACE).await;
    let range = first..first + count;
    let (h_raw, n, raw_lost) = match_up(written, raw_in, range.clone());
    let (_, _, ns_lost) = match_up(written, node_status, range);
    let bus_dropped = bus.total_dropped().saturating_sub(dropped0);
    let secs = report.elapsed.as_secs_f64().max(1e-9);
    let rate = n as f64 / secs;
    let delivered = n - raw_lost;
    let mut result = format!(
        "{} lines/s written for {:.1} s: raw_in delivered {} ({:.2} %), lost {raw_lost}; node_status lost {ns_lost}; bus drops {bus_dropped}",
        fmt_count(rate),
        secs,
        fmt_count(delivered as f64),
        100.0 * delivered as f64 / (n.max(1)) as f64,
    );
    if let Some(l) = h_raw.latency() {
        result.push_str(&format!(
            "; write → raw_in p50 {} p99 {} max {}",
            super::report::fmt_duration(l.p50),
            super::report::fmt_duration(l.p99),
            super::report::fmt_duration(l.max)
        ));
    }
    Row {
        id: "P6",
        what: P6.into(),
        figures: if n == 0 {
            Figures::Failed("no line written".into())
        } else {
            Figures::Result(result)
        },
        detail: "lines written in batches every 1 ms, as a fast frontseat's lines arrive".into(),
        extra: json!({
            "written": n,
            "rate_per_s": rate,
            "raw_in_delivered": delivered,
            "raw_in_lost": raw_lost,
            "node_status_lost": ns_lost,
            "bus_dropped": bus_dropped,
        }),
    }
}

/// M1 and M2: a MOOSDB (the in-crate broker) on loopback, the FrontSeatTranslation between it and
/// the bus, and one MOOS client playing pHelmIvP (registers NAV_DEPTH, posts DESIRED_*).
async fn moos_rows(
    plan: &Plan,
    bus: &Bus,
    fs: &ScriptedFrontseat,
    nav_written: &Stamps,
    cmd_sent: &Stamps,
    cmd_read: &Stamps,
    base: Instant,
) -> Vec<Row> {
    let fail = |why: String| {
        vec![
            Row::failed("M1", M1, why.clone()),
            Row::failed("M2", M2, why),
        ]
    };
    let broker = match Broker::bind("127.0.0.1:0").await {
        Ok(b) => b,
        Err(e) => return fail(format!("MOOSDB: {e}")),
    };
    let moos_cfg = MoosConfig {
        port: broker.local_addr().port(),
        ..MoosConfig::default()
    };
    let translation = match translation::spawn(&moos_cfg, "bench-auv", bus).await {
        Ok(t) => t,
        Err(e) => {
            broker.shutdown().await;
            return fail(format!("FrontSeatTranslation: {e}"));
        }
    };
    let helm_cfg = MoosClientConfig {
        server: broker.local_addr().to_string(),
        ..MoosClientConfig::new("bench-helm")
    };
    let rows = match MoosClient::start(helm_cfg) {
        Ok((helm, events)) => {
            let rows = moos_measure(
                plan,
                fs,
                nav_written,
                cmd_sent,
                cmd_read,
                base,
                &helm,
                events,
            )
            .await
            .unwrap_or_else(fail);
            helm.shutdown().await;
            rows
        }
        Err(e) => fail(format!("MOOS client: {e}")),
    };
    translation.shutdown().await;
    broker.shutdown().await;
    rows
}

#[allow(clippy::too_many_arguments)]
async fn moos_measure(
    plan: &Plan,
    fs: &ScriptedFrontseat,
    nav_written: &Stamps,
    cmd_sent: &Stamps,
    cmd_read: &Stamps,
    base: Instant,
    helm: &MoosClient,
    mut events: tokio::sync::mpsc::Receiver<MoosEvent>,
) -> Result<Vec<Row>, String> {
    helm.register("NAV_DEPTH", 0.0)
        .map_err(|e| format!("MOOS register: {e}"))?;
    let first = plan.p1_count + plan.p6_count();
    let mail_at = Stamps::new(base, first + plan.m1_count);
    let (up_tx, up_rx) = tokio::sync::oneshot::channel::<()>();
    let at = mail_at.clone();
    let collector = tokio::spawn(async move {
        let mut up = Some(up_tx);
        while let Some(ev) = events.recv().await {
            let now = Instant::now();
            if let MoosEvent::Mail(m) = ev
                && let Some(d) = m.as_double()
            {
                // The first NAV_DEPTH (a keep-alive, DEPTH 0) proves the whole chain is up.
                if let Some(tx) = up.take() {
                    let _ = tx.send(());
                }
                if d >= 1.0 && d.fract() == 0.0 {
                    at.set(d as usize - 1, now);
                }
            }
        }
    });
    let result = async {
        tokio::time::timeout(Duration::from_secs(10), up_rx)
            .await
            .map_err(|_| "no NAV_DEPTH reached the MOOS client within 10 s".to_string())?
            .map_err(|_| "MOOS client events ended".to_string())?;

        // M1: the same NAV stream as P1, now also translated to NAV_* and posted to the DB.
        hops::clear();
        let report = fs
            .burst(first, plan.m1_count, plan.m1_rate_hz, false)
            .await
            .map_err(|_| "the scripted frontseat stopped".to_string())?;
        tokio::time::sleep(GRACE).await;
        let (h, n, lost) = match_up(nav_written, &mail_at, first..first + plan.m1_count);
        let detail = format!(
            "{} NAV lines at {} Hz; NAV_DEPTH carries the sequence; MOOSDB = frontseat-moos broker on loopback; lost {lost}",
            fmt_count(n as f64),
            plan.m1_rate_hz
        );
        let mut m1 = latency_row("M1", M1, &h, detail, report.written, lost);
        hops::add_to(
            &mut m1,
            hops::breakdown(
                plan.m1_count,
                |i| nav_written.get(first + i),
                |i| mail_at.get(first + i),
                &M1_HOPS,
                "the helm's client's event (end)",
            ),
        );

        // M2: DESIRED_HEADING, DESIRED_DEPTH (the sequence), then DESIRED_SPEED, which makes the
        // translation publish the desired_course.
        let off = plan.p2_count;
        let start = tokio::time::Instant::now();
        let period = Duration::from_secs_f64(1.0 / plan.m2_rate_hz);
        let before = fs.cmds_read();
        hops::clear();
        for i in 0..plan.m2_count {
            tokio::time::sleep_until(start + period.mul_f64(i as f64)).await;
            cmd_sent.set(off + i, Instant::now());
            // One helm iteration's posts together, as pHelmIvP's (libMOOS sends what its
            // Iterate posted in one packet); one post each would be three packets now that
            // our client writes a post from the posting thread when its writer is idle.
            let posted = helm.notify_doubles(
                &[
                    ("DESIRED_HEADING", 90.0),
                    ("DESIRED_DEPTH", (off + i + 1) as f64),
                    ("DESIRED_SPEED", 1.5),
                ],
                None,
            );
            if let Err(e) = posted {
                return Err(format!("MOOS notify: {e}"));
            }
        }
        let deadline = tokio::time::Instant::now() + GRACE;
        while fs.cmds_read() < before + plan.m2_count as u64
            && tokio::time::Instant::now() < deadline
        {
            tokio::time::sleep(Duration::from_millis(5)).await;
        }
        let (h, n, lost) = match_up(cmd_sent, cmd_read, off..off + plan.m2_count);
        let detail = format!(
            "{} DESIRED_* triples at {} Hz (sequence in DESIRED_DEPTH), stamped before the first post; lost {lost}",
            fmt_count(n as f64),
            plan.m2_rate_hz
        );
        let mut m2 = latency_row("M2", M2, &h, detail, n, lost);
        hops::add_to(
            &mut m2,
            hops::breakdown(
                plan.m2_count,
                |i| cmd_sent.get(off + i),
                |i| cmd_read.get(off + i),
                &M2_HOPS,
                "CMD read at the frontseat (end)",
            ),
        );
        Ok(vec![m1, m2])
    }
    .await;
    collector.abort();
    result
}
