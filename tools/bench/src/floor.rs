//! The bench's own floors: the least the last hop of a row can cost on this machine, measured in
//! the same run at the rate the latency rows use. L0: a line written on a loopback socket → the
//! reading tokio task wakes with it. L1: the same line → a thread blocked in `read(2)` wakes with
//! it (the scripted frontseat's reader: the end of P2, M2, G2, Z2). L2: a line written on a
//! pseudo-terminal → the tokio task reading its other side wakes with it (the serial vehicles'
//! link, Iver3 and SV2; B2's relay reads as L1 does). L3 (in `web`): an SSE event written by a
//! server task → the client parses it (W1's last hop). On a small VM the idle wake-up latency dominates every absolute figure
//! (an idle 2-core machine is slower than a busy one), so each latency row is also given as a
//! ratio over its own floor ([`floor_of`]): only the ratios compare between runs, and a row is
//! never compared with a cheaper wake-up than its own last hop has.

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

/// The floor a data-path latency row is compared with: the one its last hop has (None: the row
/// is not a data-path latency).
pub fn floor_of(id: &str) -> Option<&'static str> {
    match id {
        // The last hop is a tokio task (a bus subscriber, a MOOS client, a Zenoh subscriber)
        // woken by data from another thread or process.
        "P1" | "M1" | "G1" | "Z1" | "A1" | "U1" | "D1" | "B1" | "C1" => Some("L0"),
        // The web page's model reads an SSE stream (`web::run_floor`).
        "W1" => Some("L3"),
        // The scripted frontseat, and the bench's relay in front of the Huxley, read with a
        // blocking read(2) on a plain thread.
        "P2" | "M2" | "G2" | "Z2" | "B2" | "C2" => Some("L1"),
        // Over a pseudo-terminal both ways.
        "I1" | "I2" | "S1" | "S2" => Some("L2"),
        _ => None,
    }
}

/// The floors [`floor_of`] names, for the row selection.
pub const FLOORS: [&str; 4] = ["L0", "L1", "L2", "L3"];

/// Adds "p50 ×a, p99 ×b over <floor>" to every data-path latency row (and the ratios to its
/// JSON: `floor`, `p50_over_floor`, `p99_over_floor`; `p50_over_l0`, `p99_over_l0` as well,
/// which compare with tables from before there was more than one floor).
pub fn add_ratios(rows: &mut [Row]) {
    let floors: Vec<(&'static str, Latency)> = rows
        .iter()
        .filter_map(|r| match (&r.id, &r.figures) {
            (id, Figures::Latency(l)) if FLOORS.contains(id) => Some((r.id, *l)),
            _ => None,
        })
        .collect();
    let floor = |id: &str| floors.iter().find(|(f, _)| *f == id).map(|(_, l)| *l);
    let ratio = |a: Duration, b: Duration| a.as_secs_f64() / b.as_secs_f64().max(1e-9);
    for r in rows.iter_mut() {
        let Some(fid) = floor_of(r.id) else { continue };
        let Figures::Latency(Latency { p50, p99, .. }) = r.figures else {
            continue;
        };
        let mut said = Vec::new();
        if let Some(f) = floor(fid) {
            let (x50, x99) = (ratio(p50, f.p50), ratio(p99, f.p99));
            said.push(format!("×{x50:.1} / ×{x99:.1} over {fid} (p50 / p99)"));
            if let serde_json::Value::Object(m) = &mut r.extra {
                m.insert("floor".into(), json!(fid));
                m.insert("p50_over_floor".into(), json!(x50));
                m.insert("p99_over_floor".into(), json!(x99));
            }
        }
        if let Some(l0) = floor("L0") {
            let (x50, x99) = (ratio(p50, l0.p50), ratio(p99, l0.p99));
            if fid != "L0" {
                said.push(format!("×{x50:.1} / ×{x99:.1} over L0"));
            }
            if let serde_json::Value::Object(m) = &mut r.extra {
                m.insert("p50_over_l0".into(), json!(x50));
                m.insert("p99_over_l0".into(), json!(x99));
            }
        }
        if !said.is_empty() {
            r.detail = format!("{}; {}", said.join(", "), r.detail);
        }
    }
}

pub const L1: &str = "floor: a line written on a loopback socket → a thread blocked in read(2) wakes with it (same rate)";
pub const L2: &str = "floor: a line written on a pseudo-terminal → the task reading its other side wakes with it (same rate)";

/// Latency of each sequence number stamped in both, and how many were written but never read.
fn matched(count: usize, written: &Stamps, read: &Stamps) -> (Hist, usize) {
    let mut h = Hist::new();
    let mut lost = 0;
    for i in 0..count {
        match (written.get(i), read.get(i)) {
            (Some(a), Some(b)) => h.record(b.saturating_duration_since(a)),
            _ => lost += 1,
        }
    }
    (h, lost)
}

fn row(id: &'static str, what: &str, h: &Hist, count: usize, lost: usize, detail: String) -> Row {
    match h.latency() {
        Some(l) => Row {
            id,
            what: what.into(),
            figures: Figures::Latency(l),
            detail,
            extra: json!({ "written": count, "lost": lost }),
        },
        None => Row::failed(id, what, format!("nothing read; {detail}")),
    }
}

/// `count` lines `<tag>,SEQ:i` at `rate_hz` to `w` from this (plain) thread, each stamped right
/// before its write.
fn write_lines(
    mut w: impl std::io::Write,
    tag: &str,
    count: usize,
    rate_hz: f64,
    written: &Stamps,
) -> Result<(), String> {
    let period = Duration::from_secs_f64(1.0 / rate_hz.max(1e-3));
    let start = Instant::now();
    for i in 0..count {
        let due = start + period.mul_f64(i as f64);
        if let Some(d) = due.checked_duration_since(Instant::now()) {
            std::thread::sleep(d);
        }
        let line = format!("{tag},SEQ:{i}\r\n");
        written.set(i, Instant::now());
        w.write_all(line.as_bytes())
            .map_err(|e| format!("write: {e}"))?;
    }
    Ok(())
}

/// The sequence number of a `<tag>,SEQ:i` line.
fn seq(line: &str, tag: &str) -> Option<usize> {
    line.trim()
        .strip_prefix(tag)?
        .strip_prefix(",SEQ:")?
        .parse()
        .ok()
}

/// Measures L1: as L0, but the reader is a plain thread blocked in `read(2)` (the scripted
/// frontseat's way to read a CMD line).
pub async fn run_l1(count: usize, rate_hz: f64) -> Row {
    let result = tokio::task::spawn_blocking(move || -> Result<Row, String> {
        use std::io::BufRead as _;
        let listener = std::net::TcpListener::bind((Ipv4Addr::LOCALHOST, 0))
            .map_err(|e| format!("bind: {e}"))?;
        let addr = listener.local_addr().map_err(|e| format!("local address: {e}"))?;
        let base = Instant::now();
        let written = Stamps::new(base, count);
        let read = Stamps::new(base, count);
        let w = written.clone();
        let writer = std::thread::spawn(move || -> Result<(), String> {
            let s = TcpStream::connect(addr).map_err(|e| format!("connect: {e}"))?;
            let _ = s.set_nodelay(true);
            write_lines(s, "L1", count, rate_hz, &w)
        });
        let (stream, _) = listener.accept().map_err(|e| format!("accept: {e}"))?;
        let period = Duration::from_secs_f64(1.0 / rate_hz.max(1e-3));
        let _ = stream.set_read_timeout(Some(period.mul_f64(count as f64) + Duration::from_secs(5)));
        let mut lines = std::io::BufReader::new(stream);
        let mut line = String::new();
        loop {
            line.clear();
            match lines.read_line(&mut line) {
                Ok(0) | Err(_) => break,
                Ok(_) => {
                    let now = Instant::now();
                    if let Some(i) = seq(&line, "L1") {
                        read.set(i, now);
                        if i + 1 == count {
                            break;
                        }
                    }
                }
            }
        }
        let writer_result = writer
            .join()
            .unwrap_or_else(|_| Err("writer thread panicked".into()));
        let (h, lost) = matched(count, &written, &read);
        let detail = format!(
            "{count} lines at {rate_hz:.0} Hz, one write each from a thread, read by a thread blocked in read(2); lost {lost}{}",
            writer_result.err().map(|e| format!(" ({e})")).unwrap_or_default()
        );
        Ok(row("L1", L1, &h, count, lost, detail))
    })
    .await;
    match result {
        Ok(Ok(r)) => r,
        Ok(Err(e)) => Row::failed("L1", L1, e),
        Err(e) => Row::failed("L1", L1, format!("the reader panicked: {e}")),
    }
}

/// Measures L2: lines written on a pseudo-terminal's slave from a plain thread (as a serial
/// driver's link writes, and as a UVC answers) → the tokio task reading the master wakes.
pub async fn run_l2(count: usize, rate_hz: f64) -> Row {
    let master = match frontseat_sim::pty::PtyMaster::open() {
        Ok(m) => m,
        Err(e) => return Row::failed("L2", L2, format!("pseudo-terminal: {e}")),
    };
    let slave = match std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .open(master.slave_path())
    {
        Ok(f) => f,
        Err(e) => return Row::failed("L2", L2, format!("open the slave: {e}")),
    };
    let base = Instant::now();
    let written = Stamps::new(base, count);
    let read = Stamps::new(base, count);
    let w = written.clone();
    let writer = std::thread::spawn(move || write_lines(&slave, "L2", count, rate_hz, &w));
    let period = Duration::from_secs_f64(1.0 / rate_hz.max(1e-3));
    let bound = period.mul_f64(count as f64) + Duration::from_secs(5);
    let reading = async {
        let mut buf = vec![0u8; 4096];
        let mut line = Vec::new();
        loop {
            let n = match master.read(&mut buf).await {
                Ok(0) | Err(_) => return,
                Ok(n) => n,
            };
            let now = Instant::now();
            for &b in &buf[..n] {
                if b != b'\n' {
                    line.push(b);
                    continue;
                }
                let text = String::from_utf8_lossy(&line).into_owned();
                line.clear();
                if let Some(i) = seq(&text, "L2") {
                    read.set(i, now);
                    if i + 1 == count {
                        return;
                    }
                }
            }
        }
    };
    let _ = tokio::time::timeout(bound, reading).await;
    let writer_result = tokio::task::spawn_blocking(move || {
        writer
            .join()
            .unwrap_or_else(|_| Err("writer thread panicked".into()))
    })
    .await
    .unwrap_or_else(|e| Err(format!("join: {e}")));
    let (h, lost) = matched(count, &written, &read);
    let detail = format!(
        "{count} lines at {rate_hz:.0} Hz, one write(2) each on the slave from a thread, the master read by a tokio task (raw mode); lost {lost}{}",
        writer_result
            .err()
            .map(|e| format!(" ({e})"))
            .unwrap_or_default()
    );
    row("L2", L2, &h, count, lost, detail)
}
