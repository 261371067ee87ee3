//! A minimal scripted frontseat for the latency rows: a loopback TCP server speaking the basic
//! simulator protocol (sim/PROTOCOL.md) on plain OS threads, so that the instant a NAV line is
//! written and the instant a CMD line is read are stamped right at the socket call, away from
//! the tokio runtime being measured.
//!
//! Lines carry a sequence number in DEPTH (`DEPTH:<index + 1>`; `DEPTH:0` is an unmeasured
//! keep-alive) so each delivery on the bus can be matched to its write. The real simulator is
//! not used here because its NAV writes happen inside its own tasks and cannot be stamped.

use std::io::{BufRead, BufReader, Write};
use std::net::{Ipv4Addr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, mpsc};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// One instant per sequence number, stored as nanoseconds after a shared base (0 = not yet).
pub struct Stamps {
    base: Instant,
    slots: Box<[AtomicU64]>,
}

impl Stamps {
    pub fn new(base: Instant, len: usize) -> Arc<Self> {
        Arc::new(Self {
            base,
            slots: (0..len).map(|_| AtomicU64::new(0)).collect(),
        })
    }

    /// Keeps the first stamp of a slot: a duplicate delivery must not hide the first one.
    pub fn set(&self, i: usize, t: Instant) {
        if let Some(slot) = self.slots.get(i) {
            let ns = u64::try_from(t.saturating_duration_since(self.base).as_nanos())
                .unwrap_or(u64::MAX - 1)
                + 1;
            let _ = slot.compare_exchange(0, ns, Ordering::AcqRel, Ordering::Relaxed);
        }
    }

    pub fn get(&self, i: usize) -> Option<Instant> {
        let ns = self.slots.get(i)?.load(Ordering::Acquire);
        (ns != 0).then(|| self.base + Duration::from_nanos(ns - 1))
    }
}

/// The sequence index carried in a line's `DEPTH:` field (`DEPTH:0` and anything unparsable:
/// None).
pub fn seq_of(line: &[u8]) -> Option<usize> {
    let text = std::str::from_utf8(line).ok()?;
    let v = text
        .split(',')
        .find_map(|kv| kv.trim().strip_prefix("DEPTH:"))?;
    let d: f64 = v.trim().parse().ok()?;
    if d >= 1.0 && d.fract() == 0.0 && d < 1e12 {
        Some(d as usize - 1)
    } else {
        None
    }
}

pub fn nav_line(seq: Option<usize>) -> String {
    let depth = seq.map(|s| s + 1).unwrap_or(0);
    format!("NAV,LAT:42.358456,LON:-71.087589,DEPTH:{depth},HEADING:90,SPEED:1.5\r\n")
}

/// A run of measured NAV lines.
pub struct Burst {
    /// Index of the first line in the NAV stamps.
    pub first: usize,
    pub count: usize,
    pub rate_hz: f64,
    /// Write every line due at once (one write per millisecond) instead of one write per line
    /// at its own instant: how a fast frontseat's lines arrive.
    pub batched: bool,
    pub done: tokio::sync::oneshot::Sender<BurstReport>,
}

#[derive(Clone, Copy, Debug, Default)]
pub struct BurstReport {
    pub written: usize,
    pub elapsed: Duration,
}

struct Shared {
    stop: AtomicBool,
    started: AtomicBool,
    conn: Mutex<Option<TcpStream>>,
    cmds_read: AtomicU64,
}

pub struct ScriptedFrontseat {
    port: u16,
    shared: Arc<Shared>,
    ctl: Option<mpsc::Sender<Burst>>,
    threads: Vec<JoinHandle<()>>,
}

/// How often an unmeasured NAV line keeps the interface's "providing data" up between bursts.
const KEEPALIVE: Duration = Duration::from_millis(100);

impl ScriptedFrontseat {
    /// Binds 127.0.0.1 on an ephemeral port; `nav_written` gets the write instants of measured
    /// NAV lines, `cmd_read` the read instants of CMD lines (by the sequence in their DEPTH).
    pub fn start(nav_written: Arc<Stamps>, cmd_read: Arc<Stamps>) -> std::io::Result<Self> {
        let listener = TcpListener::bind((Ipv4Addr::LOCALHOST, 0))?;
        let port = listener.local_addr()?.port();
        listener.set_nonblocking(true)?;
        let shared = Arc::new(Shared {
            stop: AtomicBool::new(false),
            started: AtomicBool::new(false),
            conn: Mutex::new(None),
            cmds_read: AtomicU64::new(0),
        });
        let (tx, rx) = mpsc::channel::<Burst>();
        let s = shared.clone();
        let reader = std::thread::Builder::new()
            .name("bench-frontseat-rd".into())
            .spawn(move || accept_and_read(listener, &s, &cmd_read))?;
        let s = shared.clone();
        let writer = std::thread::Builder::new()
            .name("bench-frontseat-wr".into())
            .spawn(move || write_loop(&rx, &s, &nav_written))?;
        Ok(Self {
            port,
            shared,
            ctl: Some(tx),
            threads: vec![reader, writer],
        })
    }

    pub fn port(&self) -> u16 {
        self.port
    }

    pub fn cmds_read(&self) -> u64 {
        self.shared.cmds_read.load(Ordering::Relaxed)
    }

    /// Queues a burst; the report arrives when its last line is written.
    pub fn burst(
        &self,
        first: usize,
        count: usize,
        rate_hz: f64,
        batched: bool,
    ) -> tokio::sync::oneshot::Receiver<BurstReport> {
        let (done, rx) = tokio::sync::oneshot::channel();
        if let Some(ctl) = &self.ctl {
            let _ = ctl.send(Burst {
                first,
                count,
                rate_hz,
                batched,
                done,
            });
        }
        rx
    }

    pub fn stop(mut self) {
        self.shutdown();
    }

    fn shutdown(&mut self) {
        self.shared.stop.store(true, Ordering::Release);
        self.ctl = None;
        if let Ok(mut g) = self.shared.conn.lock()
            && let Some(c) = g.take()
        {
            let _ = c.shutdown(std::net::Shutdown::Both);
        }
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

impl Drop for ScriptedFrontseat {
    fn drop(&mut self) {
        self.shutdown();
    }
}

fn write_line(shared: &Shared, bytes: &[u8]) -> Option<Instant> {
    let mut g = shared.conn.lock().ok()?;
    let conn = g.as_mut()?;
    let t = Instant::now();
    conn.write_all(bytes).ok()?;
    Some(t)
}

fn accept_and_read(listener: TcpListener, shared: &Shared, cmd_read: &Stamps) {
    let stream = loop {
        if shared.stop.load(Ordering::Acquire) {
            return;
        }
        match listener.accept() {
            Ok((s, _)) => break s,
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                std::thread::sleep(Duration::from_millis(2));
            }
            Err(e) => {
                tracing::warn!(error = %e, "bench frontseat: accept failed");
                return;
            }
        }
    };
    let setup = stream
        .set_nonblocking(false)
        .and_then(|()| stream.set_nodelay(true))
        .and_then(|()| stream.try_clone());
    let read_half = match setup {
        Ok(r) => r,
        Err(e) => {
            tracing::warn!(error = %e, "bench frontseat: socket setup failed");
            return;
        }
    };
    if let Ok(mut g) = shared.conn.lock() {
        *g = Some(stream);
    }
    let mut rd = BufReader::new(read_half);
    let mut line = Vec::with_capacity(256);
    loop {
        line.clear();
        match rd.read_until(b'\n', &mut line) {
            Ok(0) | Err(_) => return,
            Ok(_) => {}
        }
        let now = Instant::now();
        if line.starts_with(b"CMD,") {
            shared.cmds_read.fetch_add(1, Ordering::Relaxed);
            if let Some(seq) = seq_of(line.trim_ascii_end()) {
                cmd_read.set(seq, now);
            }
            write_line(shared, b"CMD,RESULT:OK\r\n");
        } else if line.starts_with(b"START,") {
            write_line(shared, b"CTRL,STATE:PAYLOAD\r\n");
            write_line(shared, nav_line(None).as_bytes());
            shared.started.store(true, Ordering::Release);
        }
    }
}

fn write_loop(ctl: &mpsc::Receiver<Burst>, shared: &Shared, nav_written: &Stamps) {
    let keepalive = nav_line(None);
    loop {
        match ctl.recv_timeout(KEEPALIVE) {
            Ok(b) => {
                let report = if b.batched {
                    batched_burst(&b, shared, nav_written)
                } else {
                    paced_burst(&b, shared, nav_written)
                };
                let _ = b.done.send(report);
            }
            Err(mpsc::RecvTimeoutError::Timeout) => {
                if shared.started.load(Ordering::Acquire) {
                    write_line(shared, keepalive.as_bytes());
                }
            }
            Err(mpsc::RecvTimeoutError::Disconnected) => return,
        }
        if shared.stop.load(Ordering::Acquire) {
            return;
        }
    }
}

fn period(rate_hz: f64) -> Duration {
    Duration::from_secs_f64(1.0 / rate_hz.max(1e-3))
}

/// One write per line, each at its own instant start + i·period.
fn paced_burst(b: &Burst, shared: &Shared, stamps: &Stamps) -> BurstReport {
    let start = Instant::now();
    let period = period(b.rate_hz);
    let mut written = 0;
    for i in 0..b.count {
        if shared.stop.load(Ordering::Acquire) {
            break;
        }
        let due = start + period.mul_f64(i as f64);
        let now = Instant::now();
        if due > now {
            std::thread::sleep(due - now);
        }
        let seq = b.first + i;
        match write_line(shared, nav_line(Some(seq)).as_bytes()) {
            Some(t) => {
                stamps.set(seq, t);
                written += 1;
            }
            None => break,
        }
    }
    BurstReport {
        written,
        elapsed: start.elapsed(),
    }
}

/// Every line due so far in one write, about once a millisecond.
fn batched_burst(b: &Burst, shared: &Shared, stamps: &Stamps) -> BurstReport {
    let start = Instant::now();
    let secs_per_line = 1.0 / b.rate_hz.max(1e-3);
    let mut written = 0;
    let mut buf = String::with_capacity(64 * 1024);
    while written < b.count && !shared.stop.load(Ordering::Acquire) {
        let due = ((start.elapsed().as_secs_f64() / secs_per_line) as usize + 1).min(b.count);
        if due > written {
            buf.clear();
            for i in written..due {
                buf.push_str(&nav_line(Some(b.first + i)));
            }
            let Some(t) = write_line(shared, buf.as_bytes()) else {
                break;
            };
            for i in written..due {
                stamps.set(b.first + i, t);
            }
            written = due;
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    BurstReport {
        written,
        elapsed: start.elapsed(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sequence_round_trips_through_depth() {
        assert_eq!(seq_of(nav_line(Some(41)).trim_end().as_bytes()), Some(41));
        assert_eq!(seq_of(nav_line(None).as_bytes()), None);
        assert_eq!(seq_of(b"CMD,HEADING:90,SPEED:1.5,DEPTH:7"), Some(6));
        assert_eq!(seq_of(b"CMD,HEADING:90,SPEED:1.5,DEPTH:7.5"), None);
        assert_eq!(seq_of(b"CMD,HEADING:90"), None);
        assert_eq!(seq_of(&[0xff, 0xfe]), None);
    }

    #[test]
    fn stamps_keep_the_first_instant() {
        let base = Instant::now();
        let s = Stamps::new(base, 2);
        assert_eq!(s.get(0), None);
        let t = base + Duration::from_micros(5);
        s.set(0, t);
        s.set(0, t + Duration::from_secs(1));
        s.set(7, t);
        assert_eq!(s.get(0), Some(t));
        assert_eq!(s.get(7), None);
    }
}
