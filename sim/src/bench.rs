//! The capacity benchmark: N vehicles over loopback against an in-process server, measuring the
//! achieved NAV and tick rates, tick lateness and CPU use. A library function so that
//! `frontseat bench` and `examples/capacity.rs` share it; never a timed test.

use std::fmt;
use std::net::{Ipv4Addr, SocketAddr};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;
use tokio::time::Instant;

use crate::codec::{StartParams, format_start};
use crate::{SimOptions, SimServer, SimStats};

/// What [`capacity_bench`] measured over its measurement window (after every vehicle started).
#[derive(Debug, Clone, PartialEq)]
pub struct CapacityReport {
    pub vehicles: usize,
    pub freq: f64,
    pub warp: f64,
    /// Length of the measurement window.
    pub window: Duration,
    /// vehicles·FREQ·WARP.
    pub expected_nav_per_s: f64,
    /// NAV lines the server sent per second.
    pub sent_nav_per_s: f64,
    /// NAV lines the clients received per second.
    pub received_nav_per_s: f64,
    /// Ticks due in the window and integrated, per second of the window:
    /// `ticks_integrated / window`, equal to `expected_nav_per_s` when every vehicle ran and
    /// kept every tick.
    pub ticks_per_s: f64,
    /// Ticks whose deadline lies in the window, over the vehicles running throughout it:
    /// running·FREQ·WARP·window.
    pub ticks_due: u64,
    /// Of the ticks due in the window, those integrated (by [`CATCH_UP_GRACE`] after it):
    /// equal to `ticks_due` when the simulator kept every tick.
    pub ticks_integrated: u64,
    /// Of the ticks due in the window, those reported with a NAV line (the rest were integrated
    /// but skipped as stale; see [`crate::schedule`]).
    pub ticks_reported: u64,
    pub late_ticks: u64,
    pub skipped_ticks: u64,
    /// Worst lateness of a reported tick in the window.
    pub worst_lateness: Duration,
    /// Process CPU over the window, 100 = one core (server and clients together), when
    /// /proc/self/stat is readable.
    pub cpu_percent: Option<f64>,
    /// Vehicles not running throughout the window (failed to connect or start, or closed).
    pub failed_vehicles: usize,
    /// Vehicles running throughout the window (the fewer of its start and its end).
    pub running: usize,
}

/// How long after a window a tick due in it may still be integrated and counted. Half a second:
/// far more than any lateness seen on a loaded 2-core machine (tens of ms), so a tick missing
/// after it was not integrated at all.
pub const CATCH_UP_GRACE: Duration = Duration::from_millis(500);

/// `part` of `whole` as a percentage with two decimals, "–" for nothing due.
pub fn share(part: u64, whole: u64) -> String {
    if whole == 0 {
        "–".into()
    } else {
        format!("{:.2} %", 100.0 * part as f64 / whole as f64)
    }
}

impl CapacityReport {
    /// The share of the ticks due in the window that were integrated.
    pub fn kept(&self) -> String {
        share(self.ticks_integrated, self.ticks_due)
    }
}

impl fmt::Display for CapacityReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{} vehicles at FREQ {} WARP {} for {:.1} s",
            self.vehicles,
            self.freq,
            self.warp,
            self.window.as_secs_f64()
        )?;
        let pct = |v: f64| 100.0 * v / self.expected_nav_per_s.max(f64::MIN_POSITIVE);
        writeln!(f, "  expected NAV/s   {:>12.0}", self.expected_nav_per_s)?;
        writeln!(
            f,
            "  ticks due        {:>12}  integrated {} ({}), reported {} ({})",
            self.ticks_due,
            self.ticks_integrated,
            self.kept(),
            self.ticks_reported,
            share(self.ticks_reported, self.ticks_due),
        )?;
        writeln!(
            f,
            "  NAV sent/s       {:>12.0}  ({:.2} %, the reported ticks)",
            self.sent_nav_per_s,
            pct(self.sent_nav_per_s)
        )?;
        writeln!(
            f,
            "  NAV received/s   {:>12.0}  ({:.2} %)",
            self.received_nav_per_s,
            pct(self.received_nav_per_s)
        )?;
        writeln!(
            f,
            "  late ticks {}  skipped ticks {}  worst lateness {:.3} ms",
            self.late_ticks,
            self.skipped_ticks,
            self.worst_lateness.as_secs_f64() * 1e3
        )?;
        match self.cpu_percent {
            Some(c) => writeln!(f, "  CPU {c:.0} % of one core (server + clients)")?,
            None => writeln!(f, "  CPU unknown (/proc/self/stat unreadable)")?,
        }
        if self.failed_vehicles > 0 {
            writeln!(
                f,
                "  {} vehicles not running throughout the window",
                self.failed_vehicles
            )?;
        }
        Ok(())
    }
}

/// Process CPU time (user + system) from /proc/self/stat, assuming the usual 100 clock ticks
/// per second (no libc call without unsafe code).
fn process_cpu() -> Option<Duration> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    let after = stat.rsplit_once(')')?.1;
    let fields: Vec<&str> = after.split_whitespace().collect();
    // After the command name: state is field 3, utime 14, stime 15 (1-based in proc(5)).
    let utime: u64 = fields.get(11)?.parse().ok()?;
    let stime: u64 = fields.get(12)?.parse().ok()?;
    Some(Duration::from_millis((utime + stime) * 10))
}

async fn client(addr: SocketAddr, start: String, lines: Arc<AtomicU64>) -> std::io::Result<()> {
    let mut s = TcpStream::connect(addr).await?;
    s.set_nodelay(true)?;
    s.write_all(format!("{start}\r\n").as_bytes()).await?;
    let mut buf = vec![0u8; 64 * 1024];
    loop {
        let n = s.read(&mut buf).await?;
        if n == 0 {
            return Ok(());
        }
        let nl = buf[..n].iter().filter(|&&b| b == b'\n').count() as u64;
        lines.fetch_add(nl, Ordering::Relaxed);
    }
}

/// Run `vehicles` clients against an in-process simulator on 127.0.0.1 at `freq` and `warp`,
/// measure for `duration` after they have all started, and report.
pub async fn capacity_bench(
    vehicles: usize,
    freq: f64,
    warp: f64,
    duration: Duration,
) -> CapacityReport {
    let opts = SimOptions {
        max_vehicles: vehicles + 1,
        // Every client connects in the same instant; with the default bound the accept loop
        // outruns their START lines and closes honest clients (395 of 1000 under load).
        max_pending: vehicles + 1,
        ..SimOptions::default()
    };
    let expected = vehicles as f64 * freq * warp;
    let mut report = CapacityReport {
        vehicles,
        freq,
        warp,
        window: Duration::ZERO,
        expected_nav_per_s: expected,
        sent_nav_per_s: 0.0,
        received_nav_per_s: 0.0,
        ticks_per_s: 0.0,
        ticks_due: 0,
        ticks_integrated: 0,
        ticks_reported: 0,
        late_ticks: 0,
        skipped_ticks: 0,
        worst_lateness: Duration::ZERO,
        cpu_percent: None,
        failed_vehicles: vehicles,
        running: 0,
    };
    let server = match SimServer::bind(SocketAddr::from((Ipv4Addr::LOCALHOST, 0)), opts).await {
        Ok(s) => s,
        Err(e) => {
            tracing::error!(error = %e, "capacity bench: cannot start the simulator");
            return report;
        }
    };
    let addr = server.local_addr();
    // NAV lines the clients received (what the server's counters cannot see: the bytes arrived).
    let lines = Arc::new(AtomicU64::new(0));
    let mut clients = tokio::task::JoinSet::new();
    for i in 0..vehicles {
        let mut p = StartParams::new(42.0 + i as f64 * 0.01, -71.0);
        p.freq = freq;
        p.warp = warp;
        clients.spawn(client(addr, format_start(&p), lines.clone()));
    }
    // The window starts once every vehicle runs (the server took its START), so that
    // vehicles·FREQ·WARP is what is due in it. Counting the clients' lines instead (as before)
    // let the vehicles that started first stand in for those still queued at the accept loop,
    // and the late starters' missing ticks showed up as lost ticks (93.8 % with 1 000).
    let ready = tokio::time::timeout(Duration::from_secs(30), async {
        while (server.stats().running as usize) < vehicles {
            tokio::time::sleep(Duration::from_millis(5)).await;
        }
    })
    .await;
    if ready.is_err() {
        tracing::warn!(
            running = server.stats().running,
            vehicles,
            "capacity bench: not every vehicle started within 30 s; the window runs with fewer"
        );
    }
    // One tick period at least, so that every vehicle's ticks are spread over the period
    // before the window opens.
    let settle = Duration::from_millis(200).max(Duration::from_secs_f64(1.0 / (freq * warp)));
    tokio::time::sleep(settle).await;

    let snap = |s: &SimStats| (s.nav_lines, s.skipped_ticks, s.late_ticks);
    // Ticks are counted by their deadline, not by when they were processed: a window's edges
    // cut through the vehicles' backlog otherwise (±0.1 % at 1 000 vehicles), which reads as
    // ticks lost or gained.
    let t0 = Instant::now() + Duration::from_millis(20);
    server.count_ticks_due_in(t0, t0 + duration);
    tokio::time::sleep_until(t0).await;
    let t0 = Instant::now();
    let cpu0 = process_cpu();
    // Lateness of the window's ticks only, not of the start-up's (1 000 START lines at once).
    server.reset_worst_lateness();
    let stats0 = server.stats();
    let running0 = stats0.running;
    let (nav0, skip0, late0) = snap(&stats0);
    let recv0 = lines.load(Ordering::Relaxed);
    tokio::time::sleep(duration).await;
    let t1 = Instant::now();
    let cpu1 = process_cpu();
    let stats = server.stats();
    let (nav1, skip1, late1) = snap(&stats);
    let recv1 = lines.load(Ordering::Relaxed);
    let window = t1 - t0;
    let secs = window.as_secs_f64();
    // A tick due before the window's end may still be waiting for its vehicle's task: give the
    // backlog time to be integrated. One still missing after this is counted lost.
    tokio::time::sleep(CATCH_UP_GRACE).await;
    let after = server.stats();
    report.running = running0.min(after.running) as usize;
    report.failed_vehicles = vehicles.saturating_sub(report.running);
    report.ticks_due =
        (report.running as f64 * freq * warp * duration.as_secs_f64()).round() as u64;
    report.ticks_integrated = after.window_ticks;
    report.ticks_reported = after.window_navs;
    report.ticks_per_s = after.window_ticks as f64 / duration.as_secs_f64();

    server.shutdown().await;
    clients.abort_all();
    while clients.join_next().await.is_some() {}

    report.window = window;
    report.sent_nav_per_s = (nav1 - nav0) as f64 / secs;
    report.received_nav_per_s = recv1.saturating_sub(recv0) as f64 / secs;
    report.late_ticks = late1 - late0;
    report.skipped_ticks = skip1 - skip0;
    report.worst_lateness = stats.worst_lateness;
    report.cpu_percent = match (cpu0, cpu1) {
        (Some(a), Some(b)) => Some(100.0 * (b.saturating_sub(a)).as_secs_f64() / secs),
        _ => None,
    };
    report
}
