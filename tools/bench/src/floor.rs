//! The bench's own floors: the least the last hop of a row can cost on this machine, measured in
//! the same run at the rate the latency rows use. L0: a line written on a loopback socket → the
//! reading tokio task wakes with it. L1: the same line → a thread blocked in `read(2)` wakes with
//! it (the scripted frontseat's reader: the end of P2, M2, G2, Z2). L2: a line written on a
//! pseudo-terminal → the tokio task reading its other side wakes with it (the serial vehicles'
//! link, Iver3 and SV2; B2's relay reads as L1 does). L3 (in `web`): an SSE event written by a
//! server task → the client parses it (W1's last hop). L4: a Zenoh put in a child process (a
//! peer listening on loopback, as the interface's gateway) → a Zenoh client session's subscriber
//! callback here (Z1's last hop, and F1's; [`l4_peer_main`] is the child). On a small VM the idle wake-up latency dominates every absolute figure
//! (an idle 2-core machine is slower than a busy one), so each latency row is also given as a
//! ratio over its own floor ([`floor_of`]): only the ratios compare between runs, and a row is
//! never compared with a cheaper wake-up than its own last hop has.

use std::io::Write as _;
use std::net::{Ipv4Addr, TcpStream};
use std::path::Path;
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use frontseat_actors::bus::BusMessage;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CartesianCoordinate, EulerAngles, NodeStatus, Speed,
};
use frontseat_actors::proto::goby::middleware::protobuf::LatLonPoint;

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
        // The last hop is a tokio task (a bus subscriber, a MOOS client, a Zenoh subscriber, the
        // ArduPilot and DUNE emulators' TCP reader) woken by data from another thread or process.
        "P1" | "M1" | "G1" | "A1" | "U1" | "D1" | "B1" | "C1" | "A2" | "U2" | "D2" => Some("L0"),
        // A Zenoh subscriber in this process woken by a put in another (`run_l4`): Z1's last
        // hop, and F1's (the topside's subscriber, before its fleet model).
        "Z1" | "F1" => Some("L4"),
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

/// The floors of every process boundary a cross-process row cannot avoid crossing, where there
/// is more than its last hop: Z1 is a loopback line into the interface child (L0) and then a
/// Zenoh put back out of it (L4); Z2 a Zenoh put into the child (L4) and then its CMD line to the
/// blocking reader (L1). [`floor_of`] keeps the last hop (so no row is ever below 1 there); this
/// sum is the least the whole path can cost, printed beside it (`over L0+L4`; JSON
/// `p50_over_path_floor`, `p99_over_path_floor`). The p99s are added too, which overstates the
/// p99 of a sum: at p99 that ratio flatters the row.
pub fn path_floor_of(id: &str) -> Option<&'static [&'static str]> {
    match id {
        "Z1" => Some(&["L0", "L4"]),
        "Z2" => Some(&["L4", "L1"]),
        _ => None,
    }
}

/// The floors [`floor_of`] names, for the row selection.
pub const FLOORS: [&str; 5] = ["L0", "L1", "L2", "L3", "L4"];

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
        if let Some(parts) = path_floor_of(r.id) {
            let found: Vec<Latency> = parts.iter().filter_map(|p| floor(p)).collect();
            if found.len() == parts.len() {
                let sum = |f: fn(&Latency) -> Duration| found.iter().map(f).sum::<Duration>();
                let (x50, x99) = (ratio(p50, sum(|l| l.p50)), ratio(p99, sum(|l| l.p99)));
                let name = parts.join("+");
                said.push(format!(
                    "×{x50:.1} / ×{x99:.1} over {name} (its whole path)"
                ));
                if let serde_json::Value::Object(m) = &mut r.extra {
                    m.insert("path_floor".into(), json!(name));
                    m.insert("p50_over_path_floor".into(), json!(x50));
                    m.insert("p99_over_path_floor".into(), json!(x99));
                }
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

pub const L4: &str = "floor: a Zenoh put in another process → this process's Zenoh subscriber callback (same rate, same modes as Z1)";

/// Set (to `<port> <count> <rate_hz>`) in the environment of L4's putting child: this very
/// executable, started by [`run_l4`].
pub const L4_PEER_ENV: &str = "FRONTSEAT_BENCH_L4_PEER";

fn encode<T: BusMessage>(m: &T) -> Vec<u8> {
    m.encode_to_vec()
}

fn decode<T: BusMessage>(bytes: &[u8]) -> Option<T> {
    T::decode(bytes).ok()
}

/// CLOCK_MONOTONIC now, in ns: the clock `Instant` reads, the same in both processes.
fn mono_ns() -> u64 {
    let t = rustix::time::clock_gettime(rustix::time::ClockId::Monotonic);
    u64::try_from(t.tv_sec)
        .unwrap_or(0)
        .saturating_mul(1_000_000_000)
        .saturating_add(u64::try_from(t.tv_nsec).unwrap_or(0))
}

/// The key L4 puts on: the shape of Z1's (`<platform>/goby/middleware/frontseat/node_status`).
fn l4_key() -> String {
    frontseat_helm_side::key_for(
        "bench-l4",
        frontseat_actors::groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS.name(),
    )
}

/// L4's payload: a node_status as Z1's carries (position, speed, pose), with the sequence number
/// in depth (0: warm-up) and the put instant (CLOCK_MONOTONIC, ns; exact in an f64) in time.
fn l4_message(seq: usize, at_ns: u64) -> NodeStatus {
    NodeStatus {
        time: at_ns as f64,
        name: Some("bench-l4".into()),
        global_fix: LatLonPoint {
            lat: 42.5,
            lon: 10.9,
            depth: Some(seq as f64),
            ..Default::default()
        },
        local_fix: Some(CartesianCoordinate {
            x: 1.0,
            y: 2.0,
            z: Some(-(seq as f64)),
        }),
        pose: EulerAngles {
            heading: Some(90.0),
            ..Default::default()
        },
        speed: Speed {
            over_ground: 1.5,
            ..Default::default()
        },
        ..Default::default()
    }
}

/// L4's putting child: opens a Zenoh session exactly as the interface's gateway does (peer,
/// listening on the loopback port), declares the publisher as the gateway declares its exports,
/// says `listening`, puts warm-up samples until `go` arrives on stdin, then `count` samples at
/// `rate_hz` from a plain thread, each stamped right before its put, and says `sent S errors E`.
pub fn l4_peer_main(spec: &str) -> ExitCode {
    let parts: Vec<f64> = spec
        .split_whitespace()
        .filter_map(|p| p.parse().ok())
        .collect();
    let [port, count, rate_hz] = parts[..] else {
        eprintln!("{L4_PEER_ENV}: expected `<port> <count> <rate_hz>`, got {spec:?}");
        return ExitCode::from(2);
    };
    super::procs::role_main("L4 peer", l4_put(port as u16, count as usize, rate_hz))
}

async fn l4_put(port: u16, count: usize, rate_hz: f64) -> Result<(), String> {
    use frontseat_helm_side::zenoh::Wait as _;
    let session = super::procs::gateway_session(port).await?;
    let publisher = super::procs::node_status_publisher(&session, l4_key()).await?;
    let go_rx = super::procs::listening();
    let putting = tokio::task::spawn_blocking(move || -> Result<(usize, usize), String> {
        // Warm up until the bench has heard one (its session must connect and subscribe first).
        let deadline = Instant::now() + Duration::from_secs(30);
        loop {
            let _ = publisher.put(encode(&l4_message(0, mono_ns()))).wait();
            match go_rx.recv_timeout(Duration::from_millis(20)) {
                Ok(()) => break,
                Err(std::sync::mpsc::RecvTimeoutError::Timeout) if Instant::now() < deadline => {}
                Err(_) => return Err("no `go` from the bench".into()),
            }
        }
        let period = Duration::from_secs_f64(1.0 / rate_hz.max(1e-3));
        let start = Instant::now();
        let (mut sent, mut errors) = (0, 0);
        for i in 0..count {
            let due = start + period.mul_f64(i as f64);
            if let Some(d) = due.checked_duration_since(Instant::now()) {
                std::thread::sleep(d);
            }
            // Encoded before the stamp, as the gateway's put takes bytes already encoded.
            let mut msg = l4_message(i + 1, 0);
            let bytes = {
                msg.time = mono_ns() as f64;
                encode(&msg)
            };
            match publisher.put(bytes).wait() {
                Ok(()) => sent += 1,
                Err(_) => errors += 1,
            }
        }
        Ok((sent, errors))
    });
    let r = putting
        .await
        .map_err(|e| format!("the putting thread: {e}"))?;
    let (sent, errors) = match r {
        Ok(v) => v,
        Err(e) => {
            let _ = session.close().await;
            return Err(e);
        }
    };
    println!("sent {sent} errors {errors}");
    let _ = std::io::stdout().flush();
    // Let the last puts leave before the session closes.
    tokio::time::sleep(Duration::from_millis(200)).await;
    let _ = session.close().await;
    Ok(())
}

/// Measures L4: `count` node_status put at `rate_hz` by a child process whose Zenoh session is
/// configured as the interface's gateway (peer, listening on loopback), taken by a Zenoh client
/// session here (as Z1's) whose subscriber callback stamps it: Z1's last hop with nothing in
/// front of it. Both stamps are CLOCK_MONOTONIC, the clock `Instant` reads.
pub async fn run_l4(bench_exe: &Path, count: usize, rate_hz: f64) -> Row {
    match l4(bench_exe, count, rate_hz).await {
        Ok(r) => r,
        Err(why) => Row::failed("L4", L4, why),
    }
}

async fn l4(bench_exe: &Path, count: usize, rate_hz: f64) -> Result<Row, String> {
    let port = super::procs::free_port()?;
    let mut peer = super::procs::RoleChild::spawn(
        bench_exe,
        L4_PEER_ENV,
        format!("{port} {count} {rate_hz}"),
        "the L4 peer",
    )?;
    let said = peer.line(Duration::from_secs(20)).await?;
    if said != "listening" {
        return Err(format!("the L4 peer said {said:?}"));
    }
    let cfg = frontseat_helm_side::client_config(&[format!("tcp/127.0.0.1:{port}")])
        .map_err(|e| format!("Zenoh client config: {e}"))?;
    let session = frontseat_helm_side::zenoh::open(cfg)
        .await
        .map_err(|e| format!("Zenoh client session: {e}"))?;
    // Latency in ns by sequence number (0: not received), and warm-up samples seen.
    let took: Arc<Vec<AtomicU64>> = Arc::new((0..count).map(|_| AtomicU64::new(0)).collect());
    let warm = Arc::new(AtomicU64::new(0));
    let (t, w) = (took.clone(), warm.clone());
    let sub = session
        .declare_subscriber(l4_key())
        .callback(move |s| {
            let now = mono_ns();
            let Some(m) = decode::<NodeStatus>(&s.payload().to_bytes()) else {
                return;
            };
            let seq = m.global_fix.depth.unwrap_or(-1.0);
            if seq == 0.0 {
                w.fetch_add(1, Ordering::Relaxed);
            } else if seq >= 1.0
                && let Some(slot) = t.get(seq as usize - 1)
            {
                slot.store(now.saturating_sub(m.time as u64).max(1), Ordering::Relaxed);
            }
        })
        .await;
    let result = async {
        let _sub = sub.map_err(|e| format!("Zenoh subscriber: {e}"))?;
        let heard = tokio::time::timeout(Duration::from_secs(20), async {
            while warm.load(Ordering::Relaxed) == 0 {
                tokio::time::sleep(Duration::from_millis(10)).await;
            }
        })
        .await;
        if heard.is_err() {
            return Err("the subscriber never heard the L4 peer".to_string());
        }
        peer.go()?;
        let period = Duration::from_secs_f64(1.0 / rate_hz.max(1e-3));
        let report = peer
            .line(period.mul_f64(count as f64) + Duration::from_secs(10))
            .await?;
        // The last puts' way here, bounded.
        let deadline = tokio::time::Instant::now() + Duration::from_secs(1);
        while took.last().is_some_and(|l| l.load(Ordering::Relaxed) == 0)
            && tokio::time::Instant::now() < deadline
        {
            tokio::time::sleep(Duration::from_millis(5)).await;
        }
        Ok(report)
    }
    .await;
    let _ = session.close().await;
    drop(peer);
    let report = result?;
    let field = |name: &str| -> Option<usize> {
        let mut it = report.split_whitespace();
        it.find(|w| *w == name)?;
        it.next()?.parse().ok()
    };
    let (Some(sent), Some(errors)) = (field("sent"), field("errors")) else {
        return Err(format!("the L4 peer said {report:?}"));
    };
    let mut h = Hist::new();
    let mut lost = 0;
    for t in took.iter() {
        match t.load(Ordering::Relaxed) {
            0 => lost += 1,
            ns => h.record(Duration::from_nanos(ns)),
        }
    }
    let detail = format!(
        "{count} node_status at {rate_hz:.0} Hz put by a child process (a Zenoh peer listening on loopback, as the interface's gateway) from a plain thread → a Zenoh client session here, stamped in its subscriber's callback (as Z1); sent {sent}, put errors {errors}, lost {lost}"
    );
    Ok(row("L4", L4, &h, count, lost, detail))
}
