//! The vehicle drivers' link: a serial port, a TCP connection (serial-over-IP adapters) or a
//! UDP socket (MAVLink routers), cut into lines, SV2 frames or MAVLink frames by [`Framing`]. Opens without blocking the driver,
//! reopens with capped exponential backoff when the device or connection goes away (USB
//! adapters vanish and come back), bounds what it buffers both ways, counts what it did, and
//! hands every event to the driver actor the moment it happens.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use tokio::io::{AsyncRead, AsyncReadExt, AsyncWrite, AsyncWriteExt};
use tokio::net::TcpStream;
use tokio::sync::mpsc;

use super::framing::{Deframer, Framing};
use super::serial::SerialSettings;
use super::{DriverIoEvent, IoSender};
use super::{LineWriter, WRITE_QUEUE};
use crate::ratelog::{LogDecision, RateLimitedLog};

#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Transport {
    Serial(SerialSettings),
    Tcp {
        host: String,
        port: u16,
    },
    /// Bound here; every datagram goes to whoever sent the last one (MAVLink `udpin`).
    UdpIn {
        host: String,
        port: u16,
    },
    /// From an ephemeral port to this address (MAVLink `udpout`).
    UdpOut {
        host: String,
        port: u16,
    },
}

impl Transport {
    /// For logs: the device path or host:port.
    pub fn describe(&self) -> String {
        match self {
            Transport::Serial(s) => format!("{} at {} baud", s.path, s.baud),
            Transport::Tcp { host, port } => format!("tcp {host}:{port}"),
            Transport::UdpIn { host, port } => format!("udp in {host}:{port}"),
            Transport::UdpOut { host, port } => format!("udp out {host}:{port}"),
        }
    }
}

#[derive(Debug, Clone)]
pub struct ByteLinkConfig {
    pub transport: Transport,
    pub framing: Framing,
    pub backoff_initial: Duration,
    pub backoff_max: Duration,
}

/// What a link did since it started (shared with its driver, read by tests and logs).
#[derive(Debug, Default)]
pub struct LinkStats {
    pub opens: AtomicU64,
    pub open_failures: AtomicU64,
    pub disconnects: AtomicU64,
    pub bytes_in: AtomicU64,
    pub bytes_out: AtomicU64,
    pub messages: AtomicU64,
    pub bad_input: AtomicU64,
}

impl LinkStats {
    pub fn get(c: &AtomicU64) -> u64 {
        c.load(Ordering::Relaxed)
    }
}

fn add(c: &AtomicU64, n: u64) {
    c.fetch_add(n, Ordering::Relaxed);
}

/// Runs until the driver actor is gone (or the task is aborted by the driver's drop).
pub fn spawn(
    cfg: ByteLinkConfig,
    io: IoSender,
    stats: Arc<LinkStats>,
) -> tokio::task::JoinHandle<()> {
    spawn_with(cfg, io, stats, false)
}

/// As [`spawn`], but a serial or TCP connection's writer writes at once from the caller's thread
/// when nothing is queued (`LineWriter::writes_at_once`), as the TCP line link does: the way a
/// driver with a setpoint lane (`crate::setpoint_lane`) writes a course from the publisher's
/// thread. Only the drivers that take the lane use it (Iver3, DUNE): with it, ArduPilot's chaos
/// run at seed 103 let target frames reach the vehicle out of COMMAND, which it does not with the
/// queued writer — a cause not yet found, so the others keep the queued writer.
pub fn spawn_direct(
    cfg: ByteLinkConfig,
    io: IoSender,
    stats: Arc<LinkStats>,
) -> tokio::task::JoinHandle<()> {
    spawn_with(cfg, io, stats, true)
}

fn spawn_with(
    cfg: ByteLinkConfig,
    io: IoSender,
    stats: Arc<LinkStats>,
    direct: bool,
) -> tokio::task::JoinHandle<()> {
    tokio::spawn(async move {
        let mut delay = cfg.backoff_initial;
        let what = cfg.transport.describe();
        let mut failures = OpenFailures::new();
        loop {
            let reason = match &cfg.transport {
                Transport::Serial(s) => match s.open() {
                    Ok(port) => {
                        delay = cfg.backoff_initial;
                        if let Some((n, away)) = failures.opened(tokio::time::Instant::now()) {
                            tracing::info!(
                                "serial port {} open again after {n} failed opens in {away:.1?}",
                                s.path
                            );
                        }
                        add(&stats.opens, 1);
                        Some(run(port, &cfg, &io, &stats, direct).await)
                    }
                    Err(e) => {
                        add(&stats.open_failures, 1);
                        let report = failures.failed(e.kind(), tokio::time::Instant::now());
                        log_open_failure(s, &e, report, cfg.backoff_max, delay);
                        None
                    }
                },
                Transport::UdpIn { .. } | Transport::UdpOut { .. } => {
                    match udp_open(&cfg.transport).await {
                        Ok((sock, peer)) => {
                            delay = cfg.backoff_initial;
                            add(&stats.opens, 1);
                            Some(run_udp(sock, peer, &cfg, &io, &stats).await)
                        }
                        Err(e) => {
                            add(&stats.open_failures, 1);
                            tracing::debug!(%what, error = %e, "cannot open the UDP socket; retrying in {:?}", delay);
                            None
                        }
                    }
                }
                Transport::Tcp { host, port } => {
                    match TcpStream::connect((host.as_str(), *port)).await {
                        Ok(stream) => {
                            delay = cfg.backoff_initial;
                            add(&stats.opens, 1);
                            let _ = stream.set_nodelay(true);
                            Some(run(stream, &cfg, &io, &stats, direct).await)
                        }
                        Err(e) => {
                            add(&stats.open_failures, 1);
                            tracing::debug!(%what, error = %e, "frontseat connect failed; retrying in {:?}", delay);
                            None
                        }
                    }
                }
            };
            if let Some(reason) = reason {
                add(&stats.disconnects, 1);
                if !io.send(DriverIoEvent::Disconnected(reason)) {
                    return;
                }
            }
            // Backoff is wall time: a warped simulation does not reopen faster.
            tokio::time::sleep(delay).await;
            delay = (delay * 2).min(cfg.backoff_max);
        }
    })
}

/// Open failures of one serial port since it was last open, and what of them to log. A USB
/// adapter that is unplugged fails to open for as long as it is out (every backoff step, for
/// hours): the first failure of an outage is logged at WARN with the configured path and the
/// error (for a permission error, what to do about it), so is the first of each other kind (the
/// device back, but not yet ours: missing → permission denied), and further ones at most once a
/// minute with how many failed so far (the counter is [`LinkStats::open_failures`]); the reopen
/// says how many failed and for how long.
struct OpenFailures {
    limiter: RateLimitedLog,
    /// Failed opens since the port was last open (or since the link started).
    count: u64,
    since: Option<tokio::time::Instant>,
    /// The kinds of error this outage has said at once (few: the kinds are a small enum).
    kinds: Vec<std::io::ErrorKind>,
}

/// At most one line per this long while a port stays unopenable.
const OPEN_FAILURE_LOG_EVERY: Duration = Duration::from_secs(60);

/// What to log about one failed open.
#[derive(Debug, PartialEq, Eq)]
enum OpenReport {
    /// The first of its kind in this outage: say what and why, and how it is retried.
    First,
    /// The once-a-minute reminder: `count` failed opens over `away`.
    Still { count: u64, away: Duration },
    /// Counted only.
    Quiet,
}

impl OpenFailures {
    fn new() -> Self {
        Self {
            limiter: RateLimitedLog::new(1, OPEN_FAILURE_LOG_EVERY),
            count: 0,
            since: None,
            kinds: Vec::new(),
        }
    }

    fn failed(&mut self, kind: std::io::ErrorKind, now: tokio::time::Instant) -> OpenReport {
        self.count += 1;
        let since = *self.since.get_or_insert(now);
        if !self.kinds.contains(&kind) {
            // A new outage, or a new reason: said at once, and the reminder's minute starts here.
            self.kinds.push(kind);
            self.limiter = RateLimitedLog::new(1, OPEN_FAILURE_LOG_EVERY);
            self.limiter.decide(now);
            return OpenReport::First;
        }
        match self.limiter.decide(now) {
            LogDecision::Log { .. } => OpenReport::Still {
                count: self.count,
                away: now.saturating_duration_since(since),
            },
            LogDecision::Suppress => OpenReport::Quiet,
        }
    }

    /// Open again: how many opens failed before, over how long (None when none failed).
    fn opened(&mut self, now: tokio::time::Instant) -> Option<(u64, Duration)> {
        let since = self.since.take()?;
        let count = self.count;
        *self = Self::new();
        Some((count, now.saturating_duration_since(since)))
    }
}

fn log_open_failure(
    s: &SerialSettings,
    e: &std::io::Error,
    report: OpenReport,
    backoff_max: Duration,
    retry_in: Duration,
) {
    let path = s.path.as_str();
    match report {
        OpenReport::First => {
            let what = s
                .open_hint(e)
                .unwrap_or_else(|| format!("cannot open serial port {path}: {e}"));
            tracing::warn!(
                "{what}; retrying with backoff up to {backoff_max:?}, logged again at most once a minute"
            );
        }
        OpenReport::Still { count, away } => tracing::warn!(
            "still cannot open serial port {path}: {e}; {count} failed opens in {away:.0?}, retrying"
        ),
        OpenReport::Quiet => {
            tracing::debug!("cannot open serial port {path}: {e}; retrying in {retry_in:?}")
        }
    }
}

async fn run<S>(
    stream: S,
    cfg: &ByteLinkConfig,
    io: &IoSender,
    stats: &Arc<LinkStats>,
    direct: bool,
) -> String
where
    S: AsyncRead + AsyncWrite + Send + 'static,
{
    let (mut rd, mut wr) = tokio::io::split(stream);
    let wstats = stats.clone();
    let mut _closed_with_this = None;
    let mut writer = if direct {
        // A write goes to the device from the caller's thread when nothing is queued (the
        // setpoint lane's way to a serial vehicle), else to the writer task, in order.
        let (w, drain, guard) = super::direct_writer(wr, move |n| add(&wstats.bytes_out, n as u64));
        _closed_with_this = Some(guard);
        if !io.send(DriverIoEvent::Connected(w)) {
            return "driver gone".into();
        }
        tokio::spawn(drain)
    } else {
        let (tx, mut rx) = mpsc::channel::<Vec<u8>>(WRITE_QUEUE);
        if !io.send(DriverIoEvent::Connected(LineWriter::from_sender(tx))) {
            return "driver gone".into();
        }
        tokio::spawn(async move {
            while let Some(b) = rx.recv().await {
                if let Err(e) = wr.write_all(&b).await {
                    return format!("write failed: {e}");
                }
                add(&wstats.bytes_out, b.len() as u64);
            }
            let _ = wr.shutdown().await;
            "closed by driver".to_string()
        })
    };
    let mut deframer = Deframer::new(cfg.framing);
    let mut buf = vec![0u8; 4096];
    let reason = loop {
        // Flow control: no more reading while the driver has a backlog (see IoSender); the
        // writer still ends the loop if it fails meanwhile.
        tokio::select! {
            _ = io.ready() => {}
            w = &mut writer => break w.unwrap_or_else(|e| format!("writer ended: {e}")),
        }
        tokio::select! {
            r = rd.read(&mut buf) => match r {
                Ok(0) => break "end of stream (device or connection gone)".to_string(),
                Ok(n) => {
                    add(&stats.bytes_in, n as u64);
                    let mut alive = true;
                    deframer.feed(&buf[..n], &mut |ev| {
                        match &ev {
                            DriverIoEvent::BadInput(_) => add(&stats.bad_input, 1),
                            _ => add(&stats.messages, 1),
                        }
                        alive &= io.send(ev);
                    });
                    if !alive {
                        break "driver gone".to_string();
                    }
                }
                Err(e) => break format!("read failed: {e}"),
            },
            w = &mut writer => break w.unwrap_or_else(|e| format!("writer ended: {e}")),
        }
    };
    writer.abort();
    reason
}

/// The socket and, for `udpout`, the peer it sends to.
async fn udp_open(
    t: &Transport,
) -> std::io::Result<(tokio::net::UdpSocket, Option<std::net::SocketAddr>)> {
    use tokio::net::{UdpSocket, lookup_host};
    match t {
        Transport::UdpIn { host, port } => {
            Ok((UdpSocket::bind((host.as_str(), *port)).await?, None))
        }
        Transport::UdpOut { host, port } => {
            let peer = lookup_host((host.as_str(), *port))
                .await?
                .next()
                .ok_or_else(|| std::io::Error::other("no address"))?;
            let local: std::net::SocketAddr = if peer.is_ipv4() {
                ([0, 0, 0, 0], 0).into()
            } else {
                (std::net::Ipv6Addr::UNSPECIFIED, 0).into()
            };
            Ok((UdpSocket::bind(local).await?, Some(peer)))
        }
        _ => Err(std::io::Error::other("not a UDP transport")),
    }
}

/// One UDP "connection": lasts until the socket fails or the driver goes. A datagram to send
/// before any peer is known (udpin, nobody heard yet) is dropped and counted.
async fn run_udp(
    sock: tokio::net::UdpSocket,
    mut peer: Option<std::net::SocketAddr>,
    cfg: &ByteLinkConfig,
    io: &IoSender,
    stats: &Arc<LinkStats>,
) -> String {
    let (tx, mut rx) = mpsc::channel::<Vec<u8>>(WRITE_QUEUE);
    if !io.send(DriverIoEvent::Connected(LineWriter::from_sender(tx))) {
        return "driver gone".into();
    }
    let mut deframer = Deframer::new(cfg.framing);
    let mut buf = vec![0u8; 65_536];
    loop {
        tokio::select! {
            r = sock.recv_from(&mut buf) => match r {
                Ok((n, from)) => {
                    peer = Some(from);
                    add(&stats.bytes_in, n as u64);
                    let mut alive = true;
                    deframer.feed(&buf[..n], &mut |ev| {
                        match &ev {
                            DriverIoEvent::BadInput(_) => add(&stats.bad_input, 1),
                            _ => add(&stats.messages, 1),
                        }
                        alive &= io.send(ev);
                    });
                    if !alive {
                        return "driver gone".to_string();
                    }
                }
                Err(e) => return format!("UDP receive failed: {e}"),
            },
            b = rx.recv() => match b {
                Some(b) => match peer {
                    Some(p) => match sock.send_to(&b, p).await {
                        Ok(n) => add(&stats.bytes_out, n as u64),
                        Err(e) => tracing::debug!(error = %e, "UDP send failed"),
                    },
                    None => tracing::trace!("no UDP peer heard yet; datagram dropped"),
                },
                None => return "closed by driver".to_string(),
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::ErrorKind::{NotFound, PermissionDenied};

    /// An adapter out for ten minutes, retried every 5 s: one line at once, then one a minute;
    /// the device back but root's: one more at once; the reopen counts them all.
    #[tokio::test(start_paused = true)]
    async fn an_unopenable_port_is_said_once_then_once_a_minute() {
        let mut f = OpenFailures::new();
        let t0 = tokio::time::Instant::now();
        let mut reports = Vec::new();
        for i in 0..120u64 {
            reports.push(f.failed(NotFound, t0 + Duration::from_secs(5 * i)));
        }
        assert_eq!(reports[0], OpenReport::First);
        let still: Vec<_> = reports
            .iter()
            .filter_map(|r| match r {
                OpenReport::Still { count, away } => Some((*count, away.as_secs())),
                _ => None,
            })
            .collect();
        assert_eq!(
            still,
            (1..10).map(|m| (12 * m + 1, 60 * m)).collect::<Vec<_>>(),
            "once a minute, with the count so far"
        );
        let quiet = reports.iter().filter(|r| **r == OpenReport::Quiet).count();
        assert_eq!(quiet, 120 - 1 - 9);

        let t1 = t0 + Duration::from_secs(600);
        assert_eq!(f.failed(PermissionDenied, t1), OpenReport::First);
        assert_eq!(
            f.failed(PermissionDenied, t1 + Duration::from_secs(5)),
            OpenReport::Quiet
        );
        assert_eq!(
            f.failed(NotFound, t1 + Duration::from_secs(10)),
            OpenReport::Quiet,
            "a kind already said in this outage is not said again at once"
        );
        assert_eq!(
            f.opened(t1 + Duration::from_secs(12)),
            Some((123, Duration::from_secs(612)))
        );
        // The next outage starts afresh.
        assert_eq!(f.opened(t1 + Duration::from_secs(20)), None);
        assert_eq!(
            f.failed(NotFound, t1 + Duration::from_secs(30)),
            OpenReport::First
        );
    }
}
