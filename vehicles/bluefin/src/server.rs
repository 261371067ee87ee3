//! The Huxley payload port: a TCP server where each connection is one emulated Bluefin vehicle
//! ([`crate::emulator::Huxley`]). A connection task reads bounded CRLF lines, feeds them to the
//! emulator, and ticks it at its navigation rate in (warped) simulated time; everything a
//! wake-up produces is written in one `write_all`.

use std::net::SocketAddr;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::watch;
use tokio::task::JoinSet;
use tokio::time::Instant;

use crate::codec::seconds_of_day;
use crate::emulator::{Huxley, HuxleyOptions, LineKind};
use frontseat_sim::SimError;

/// Problems logged at warn level per connection before the rest go to debug.
const LOUD_PROBLEMS: u64 = 20;

#[derive(Debug, Clone, PartialEq)]
pub struct HuxleyServerOptions {
    pub huxley: HuxleyOptions,
    /// Simulated seconds per wall second.
    pub warp: f64,
    /// Longest accepted payload line (bytes, terminator excluded); a longer one is counted and
    /// discarded up to its end.
    pub max_line_bytes: usize,
    /// Most connections at once; more are closed at once.
    pub max_vehicles: usize,
}

impl Default for HuxleyServerOptions {
    fn default() -> Self {
        Self {
            huxley: HuxleyOptions::default(),
            warp: 1.0,
            max_line_bytes: 1024,
            max_vehicles: 64,
        }
    }
}

/// Counters since the server started.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct HuxleyStats {
    pub connections: u64,
    pub refused: u64,
    pub lines_in: u64,
    pub lines_out: u64,
    /// Not a sentence, bad checksum, malformed fields, or not UTF-8.
    pub bad_lines: u64,
    /// Well-formed sentences of an id the emulator does not know.
    pub unknown_lines: u64,
    pub oversized: u64,
}

#[derive(Default)]
struct Counters {
    connections: AtomicU64,
    refused: AtomicU64,
    lines_in: AtomicU64,
    lines_out: AtomicU64,
    bad_lines: AtomicU64,
    unknown_lines: AtomicU64,
    oversized: AtomicU64,
    active: AtomicU64,
}

fn add(c: &AtomicU64, n: u64) {
    c.fetch_add(n, Ordering::Relaxed);
}

struct Shared {
    opts: HuxleyServerOptions,
    counters: Counters,
}

/// The emulator server; [`HuxleyServer::bind`] starts it.
pub struct HuxleyServer;

impl HuxleyServer {
    pub async fn bind(
        addr: SocketAddr,
        opts: HuxleyServerOptions,
    ) -> Result<HuxleyHandle, SimError> {
        let listener = TcpListener::bind(addr)
            .await
            .map_err(|source| SimError::Bind { addr, source })?;
        let local = listener.local_addr()?;
        let shared = Arc::new(Shared {
            opts,
            counters: Counters::default(),
        });
        let (stop_tx, stop_rx) = watch::channel(false);
        let task = tokio::spawn(accept_loop(listener, shared.clone(), stop_rx));
        tracing::info!(addr = %local, "Bluefin Huxley emulator listening");
        Ok(HuxleyHandle {
            local,
            shared,
            stop: Arc::new(stop_tx),
            task: Arc::new(tokio::sync::Mutex::new(Some(task))),
        })
    }
}

/// The embedding handle; cheap to clone.
#[derive(Clone)]
pub struct HuxleyHandle {
    local: SocketAddr,
    shared: Arc<Shared>,
    stop: Arc<watch::Sender<bool>>,
    task: Arc<tokio::sync::Mutex<Option<tokio::task::JoinHandle<()>>>>,
}

impl HuxleyHandle {
    pub fn local_addr(&self) -> SocketAddr {
        self.local
    }

    pub fn stats(&self) -> HuxleyStats {
        let c = &self.shared.counters;
        let g = |a: &AtomicU64| a.load(Ordering::Relaxed);
        HuxleyStats {
            connections: g(&c.connections),
            refused: g(&c.refused),
            lines_in: g(&c.lines_in),
            lines_out: g(&c.lines_out),
            bad_lines: g(&c.bad_lines),
            unknown_lines: g(&c.unknown_lines),
            oversized: g(&c.oversized),
        }
    }

    /// Closes every connection and the listener, and waits for them.
    pub async fn shutdown(&self) {
        let _ = self.stop.send(true);
        if let Some(t) = self.task.lock().await.take() {
            let _ = t.await;
        }
    }
}

async fn accept_loop(listener: TcpListener, shared: Arc<Shared>, mut stop: watch::Receiver<bool>) {
    let mut tasks = JoinSet::new();
    loop {
        tokio::select! {
            () = async { let _ = stop.wait_for(|s| *s).await; } => break,
            Some(done) = tasks.join_next(), if !tasks.is_empty() => {
                // Each session is isolated: a panic closes only its connection.
                if let Err(e) = done {
                    tracing::error!(error = %e, "Huxley connection task failed: its connection is closed; the others go on");
                }
            }
            accepted = listener.accept() => match accepted {
                Ok((stream, peer)) => {
                    add(&shared.counters.connections, 1);
                    if shared.counters.active.load(Ordering::Relaxed) as usize >= shared.opts.max_vehicles {
                        add(&shared.counters.refused, 1);
                        tracing::warn!(%peer, "refusing payload connection: too many vehicles");
                        drop(stream);
                        continue;
                    }
                    let shared2 = shared.clone();
                    let mut stop2 = stop.clone();
                    tasks.spawn(async move {
                        add(&shared2.counters.active, 1);
                        // Counted down however the task ends, a panic included: a crashed
                        // session must not hold a vehicle slot for ever.
                        let _active = Active(&shared2.counters.active);
                        tokio::select! {
                            () = connection(stream, peer, &shared2) => {}
                            () = async { let _ = stop2.wait_for(|s| *s).await; } => {}
                        }
                    });
                }
                Err(e) => {
                    tracing::warn!(error = %e, "accept failed");
                    tokio::time::sleep(Duration::from_millis(50)).await;
                }
            }
        }
    }
    tasks.shutdown().await;
}

struct Active<'a>(&'a std::sync::atomic::AtomicU64);

impl Drop for Active<'_> {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::Relaxed);
    }
}

fn now_tod() -> f64 {
    let unix = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs_f64())
        .unwrap_or(0.0);
    seconds_of_day(unix)
}

async fn connection(mut stream: TcpStream, peer: SocketAddr, shared: &Shared) {
    let _ = stream.set_nodelay(true);
    let opts = &shared.opts;
    let c = &shared.counters;
    let warp = if opts.warp.is_finite() && opts.warp > 0.0 {
        opts.warp
    } else {
        1.0
    };
    let mut huxley = Huxley::new(opts.huxley.clone());
    // Tick at the navigation rate (at least 10 Hz of simulated time so mission events are
    // prompt), in wall time divided by the warp.
    let hz = opts.huxley.nav_hz.max(10.0);
    let period = Duration::from_secs_f64((1.0 / hz / warp).max(0.001));
    let mut ticker = tokio::time::interval(period);
    ticker.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut last = Instant::now();
    let mut buf: Vec<u8> = Vec::with_capacity(256);
    let mut discarding = false;
    let mut chunk = [0u8; 4096];
    let mut out: Vec<String> = Vec::new();
    let mut problems = 0u64;
    tracing::info!(%peer, "payload connected to the Huxley emulator");
    loop {
        out.clear();
        tokio::select! {
            _ = ticker.tick() => {
                let now = Instant::now();
                let dt = now.duration_since(last).as_secs_f64() * warp;
                last = now;
                huxley.advance(dt, now_tod(), &mut out);
            }
            read = stream.read(&mut chunk) => {
                let n = match read {
                    Ok(0) => break,
                    Ok(n) => n,
                    Err(e) => {
                        tracing::debug!(%peer, error = %e, "payload read failed");
                        break;
                    }
                };
                for &b in &chunk[..n] {
                    if b == b'\n' {
                        if discarding {
                            discarding = false;
                        } else {
                            handle(&mut huxley, &buf, c, &mut problems, peer, &mut out);
                        }
                        buf.clear();
                    } else if !discarding {
                        buf.push(b);
                        if buf.len() > opts.max_line_bytes {
                            add(&c.oversized, 1);
                            problems += 1;
                            if problems <= LOUD_PROBLEMS {
                                tracing::warn!(%peer, max = opts.max_line_bytes, "oversized payload line discarded");
                            }
                            buf.clear();
                            discarding = true;
                        }
                    }
                }
            }
        }
        if !out.is_empty() {
            let mut bytes = Vec::with_capacity(out.iter().map(|l| l.len() + 2).sum());
            for l in &out {
                bytes.extend_from_slice(l.as_bytes());
                bytes.extend_from_slice(b"\r\n");
            }
            add(&c.lines_out, out.len() as u64);
            if let Err(e) = stream.write_all(&bytes).await {
                tracing::debug!(%peer, error = %e, "payload write failed");
                break;
            }
        }
    }
    tracing::info!(%peer, "payload disconnected from the Huxley emulator");
}

fn handle(
    huxley: &mut Huxley,
    raw: &[u8],
    c: &Counters,
    problems: &mut u64,
    peer: SocketAddr,
    out: &mut Vec<String>,
) {
    let raw = raw.strip_suffix(b"\r").unwrap_or(raw);
    if raw.iter().all(u8::is_ascii_whitespace) {
        return;
    }
    add(&c.lines_in, 1);
    let kind = match std::str::from_utf8(raw) {
        Ok(line) => huxley.on_line(line, now_tod(), out),
        Err(_) => LineKind::Bad,
    };
    let counter = match kind {
        LineKind::Known => return,
        LineKind::Unknown => &c.unknown_lines,
        LineKind::Bad => &c.bad_lines,
    };
    add(counter, 1);
    *problems += 1;
    if *problems <= LOUD_PROBLEMS {
        tracing::warn!(%peer, line = %String::from_utf8_lossy(&raw[..raw.len().min(80)]), ?kind, "payload line not understood");
    } else {
        tracing::debug!(%peer, ?kind, "payload line not understood");
    }
}
