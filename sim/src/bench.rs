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
    /// Ticks processed (reported + skipped) per second; equal to expected means no drift.
    pub ticks_per_s: f64,
    pub late_ticks: u64,
    pub skipped_ticks: u64,
    /// Worst lateness of a reported tick since the server started.
    pub worst_lateness: Duration,
    /// Process CPU over the window, 100 = one core (server and clients together), when
    /// /proc/self/stat is readable.
    pub cpu_percent: Option<f64>,
    /// Vehicles that failed to connect or start.
    pub failed_vehicles: usize,
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
            "  ticks/s          {:>12.0}  ({:.2} % of expected)",
            self.ticks_per_s,
            pct(self.ticks_per_s)
        )?;
        writeln!(
            f,
            "  NAV sent/s       {:>12.0}  ({:.2} %)",
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
            writeln!(f, "  {} vehicles failed to start", self.failed_vehicles)?;
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
        late_ticks: 0,
        skipped_ticks: 0,
        worst_lateness: Duration::ZERO,
        cpu_percent: None,
        failed_vehicles: vehicles,
    };
    let server = match SimServer::bind(SocketAddr::from((Ipv4Addr::LOCALHOST, 0)), opts).await {
        Ok(s) => s,
        Err(e) => {
            tracing::error!(error = %e, "capacity bench: cannot start the simulator");
            return report;
        }
    };
    let addr = server.local_addr();
    let lines = Arc::new(AtomicU64::new(0));
    let mut clients = tokio::task::JoinSet::new();
    for i in 0..vehicles {
        let mut p = StartParams::new(42.0 + i as f64 * 0.01, -71.0);
        p.freq = freq;
        p.warp = warp;
        clients.spawn(client(addr, format_start(&p), lines.clone()));
    }
    // Started = every client got its CTRL line and tick 0.
    let ready = tokio::time::timeout(Duration::from_secs(10), async {
        while lines.load(Ordering::Relaxed) < 2 * vehicles as u64 {
            tokio::time::sleep(Duration::from_millis(5)).await;
        }
    })
    .await;
    if ready.is_err() {
        tracing::warn!("capacity bench: not every vehicle started within 10 s");
    }
    let settle = Duration::from_millis(200);
    tokio::time::sleep(settle).await;

    let snap = |s: &SimStats| (s.nav_lines, s.skipped_ticks, s.late_ticks);
    let t0 = Instant::now();
    let cpu0 = process_cpu();
    let (nav0, skip0, late0) = snap(&server.stats());
    let recv0 = lines.load(Ordering::Relaxed);
    tokio::time::sleep(duration).await;
    let t1 = Instant::now();
    let cpu1 = process_cpu();
    let stats = server.stats();
    let (nav1, skip1, late1) = snap(&stats);
    let recv1 = lines.load(Ordering::Relaxed);
    let window = t1 - t0;
    let secs = window.as_secs_f64();

    report.failed_vehicles = vehicles.saturating_sub(server.vehicles().len());
    server.shutdown().await;
    clients.abort_all();
    while clients.join_next().await.is_some() {}

    report.window = window;
    report.sent_nav_per_s = (nav1 - nav0) as f64 / secs;
    report.received_nav_per_s = recv1.saturating_sub(recv0) as f64 / secs;
    report.ticks_per_s = ((nav1 - nav0) + (skip1 - skip0)) as f64 / secs;
    report.late_ticks = late1 - late0;
    report.skipped_ticks = skip1 - skip0;
    report.worst_lateness = stats.worst_lateness;
    report.cpu_percent = match (cpu0, cpu1) {
        (Some(a), Some(b)) => Some(100.0 * (b.saturating_sub(a)).as_secs_f64() / secs),
        _ => None,
    };
    report
}
