//! Row L0, the bench's own floor: a line written on a loopback socket at the rate the latency
//! rows use → the reading task wakes with it. On a small VM the idle wake-up latency dominates
//! every absolute figure (an idle 2-core machine is slower than a busy one), so each latency
//! row is also given as a ratio over L0 measured in the same run: only the ratios compare
//! between runs.

use std::io::Write as _;
use std::net::{Ipv4Addr, TcpStream};
use std::time::{Duration, Instant};

use serde_json::json;
use tokio::io::{AsyncBufReadExt, BufReader};
use tokio::net::TcpListener;

use super::frontseat::Stamps;
use super::report::{Figures, Hist, Latency, Row};

pub const L0: &str =
    "floor: a line written on a loopback socket → the reading task wakes with it (same rate)";

/// Measures L0: `count` lines at `rate_hz`, written from a plain thread (as the scripted
/// frontseat writes), read by a tokio task (as a driver's link reads).
pub async fn run(count: usize, rate_hz: f64) -> Row {
    let listener = match TcpListener::bind((Ipv4Addr::LOCALHOST, 0)).await {
        Ok(l) => l,
        Err(e) => return Row::failed("L0", L0, format!("bind: {e}")),
    };
    let addr = match listener.local_addr() {
        Ok(a) => a,
        Err(e) => return Row::failed("L0", L0, format!("local address: {e}")),
    };
    let base = Instant::now();
    let written = Stamps::new(base, count);
    let read = Stamps::new(base, count);
    let w = written.clone();
    let period = Duration::from_secs_f64(1.0 / rate_hz.max(1e-3));
    let writer = std::thread::spawn(move || -> Result<(), String> {
        let mut s = TcpStream::connect(addr).map_err(|e| format!("connect: {e}"))?;
        let _ = s.set_nodelay(true);
        let start = Instant::now();
        for i in 0..count {
            let due = start + period.mul_f64(i as f64);
            if let Some(d) = due.checked_duration_since(Instant::now()) {
                std::thread::sleep(d);
            }
            let line = format!("L0,SEQ:{i}\r\n");
            w.set(i, Instant::now());
            s.write_all(line.as_bytes())
                .map_err(|e| format!("write: {e}"))?;
        }
        Ok(())
    });
    let accepted = tokio::time::timeout(Duration::from_secs(5), listener.accept()).await;
    let stream = match accepted {
        Ok(Ok((s, _))) => s,
        _ => return Row::failed("L0", L0, "the writer never connected"),
    };
    let mut lines = BufReader::new(stream).lines();
    let bound = period.mul_f64(count as f64) + Duration::from_secs(5);
    let reading = async {
        while let Ok(Some(l)) = lines.next_line().await {
            let now = Instant::now();
            if let Some(i) = l
                .strip_prefix("L0,SEQ:")
                .and_then(|v| v.parse::<usize>().ok())
            {
                read.set(i, now);
                if i + 1 == count {
                    break;
                }
            }
        }
    };
    let _ = tokio::time::timeout(bound, reading).await;
    let writer_result = writer
        .join()
        .unwrap_or_else(|_| Err("writer thread panicked".into()));
    let mut h = Hist::new();
    let mut lost = 0;
    for i in 0..count {
        match (written.get(i), read.get(i)) {
            (Some(a), Some(b)) => h.record(b.saturating_duration_since(a)),
            _ => lost += 1,
        }
    }
    let detail = format!(
        "{count} lines at {rate_hz:.0} Hz, one write each from a thread, read by a tokio task; lost {lost}{}",
        writer_result
            .err()
            .map(|e| format!(" ({e})"))
            .unwrap_or_default()
    );
    match h.latency() {
        Some(l) => Row {
            id: "L0",
            what: L0.into(),
            figures: Figures::Latency(l),
            detail,
            extra: json!({ "written": count, "lost": lost }),
        },
        None => Row::failed("L0", L0, format!("nothing read; {detail}")),
    }
}

/// The data-path latency rows whose figures are compared as ratios over L0.
const RATIO_ROWS: [&str; 9] = ["P1", "P2", "M1", "M2", "G1", "G2", "Z1", "Z2", "W1"];

/// Adds "p50 ×a, p99 ×b over L0" to every data-path latency row (and the ratios to its JSON).
pub fn add_ratios(rows: &mut [Row]) {
    let Some(floor) = rows.iter().find_map(|r| match (&r.id, &r.figures) {
        (&"L0", Figures::Latency(l)) => Some(*l),
        _ => None,
    }) else {
        return;
    };
    let ratio = |a: Duration, b: Duration| a.as_secs_f64() / b.as_secs_f64().max(1e-9);
    for r in rows.iter_mut().filter(|r| RATIO_ROWS.contains(&r.id)) {
        if let Figures::Latency(Latency { p50, p99, .. }) = r.figures {
            let (x50, x99) = (ratio(p50, floor.p50), ratio(p99, floor.p99));
            r.detail = format!("×{x50:.1} / ×{x99:.1} over L0 (p50 / p99); {}", r.detail);
            if let serde_json::Value::Object(m) = &mut r.extra {
                m.insert("p50_over_l0".into(), json!(x50));
                m.insert("p99_over_l0".into(), json!(x99));
            }
        }
    }
}
