//! Byte links for drivers. This file: the reconnecting TCP line link of the basic simulator
//! driver (connects without blocking the driver, retries with capped exponential backoff, reads
//! `\r\n` (or `\n`) terminated lines with a size bound, and hands every event to the driver
//! actor the moment it happens) and the writer every link hands out. [`byte`] generalises it to
//! serial ports ([`serial`]) and binary frames ([`framing`]) for the vehicle drivers.

pub mod byte;
pub mod framing;
pub mod serial;

use std::time::Duration;

use tokio::io::{AsyncBufReadExt, AsyncReadExt, BufReader};
use tokio::net::TcpStream;
use tokio::net::tcp::OwnedWriteHalf;
use tokio::sync::mpsc;

/// Something the driver's own I/O tasks observed.
#[derive(Debug)]
pub enum DriverIoEvent {
    Connected(LineWriter),
    Line(String),
    /// A CRC-checked binary frame, unescaped, start byte included (framed links only).
    Frame(Vec<u8>),
    /// Bytes that could not be a line (invalid UTF-8, oversized); the link goes on or closes.
    BadInput(String),
    Disconnected(String),
}

/// Where a driver's I/O tasks send what they observe (the driver actor's mailbox).
///
/// The actor's mailbox is unbounded, and a reader task reads as fast as the peer writes: a
/// vehicle flooding its link (issue 31: 120 000 hostile lines grew the interface by 40 MiB
/// each time) would queue all of it. A bounded sender counts the events not yet handled; the
/// links wait in [`IoSender::ready`] before reading more once `max_in_flight` are queued, so
/// the flood waits in the kernel's socket buffer and the vehicle's TCP window, not in our heap.
#[derive(Clone)]
pub struct IoSender {
    send: std::sync::Arc<dyn Fn(DriverIoEvent) -> bool + Send + Sync>,
    in_flight: Option<std::sync::Arc<InFlight>>,
}

struct InFlight {
    max: usize,
    queued: std::sync::atomic::AtomicUsize,
    freed: tokio::sync::Notify,
}

/// Events a driver actor may have queued from its links before they stop reading.
pub const MAX_IO_IN_FLIGHT: usize = 256;

impl IoSender {
    /// Without flow control: for tests and hosts that drain their channel themselves.
    pub fn new(send: impl Fn(DriverIoEvent) -> bool + Send + Sync + 'static) -> Self {
        Self {
            send: std::sync::Arc::new(send),
            in_flight: None,
        }
    }
    /// With flow control: the receiver calls [`IoSender::handled`] once per event it took.
    pub fn bounded(
        max_in_flight: usize,
        send: impl Fn(DriverIoEvent) -> bool + Send + Sync + 'static,
    ) -> Self {
        Self {
            send: std::sync::Arc::new(send),
            in_flight: Some(std::sync::Arc::new(InFlight {
                max: max_in_flight.max(1),
                queued: std::sync::atomic::AtomicUsize::new(0),
                freed: tokio::sync::Notify::new(),
            })),
        }
    }
    /// False once the driver actor is gone: the I/O task should end.
    pub fn send(&self, ev: DriverIoEvent) -> bool {
        use std::sync::atomic::Ordering;
        if let Some(f) = &self.in_flight {
            f.queued.fetch_add(1, Ordering::AcqRel);
        }
        let sent = (self.send)(ev);
        if !sent && let Some(f) = &self.in_flight {
            f.queued.fetch_sub(1, Ordering::AcqRel);
        }
        sent
    }
    /// The receiver took one event off its queue.
    pub fn handled(&self) {
        use std::sync::atomic::Ordering;
        if let Some(f) = &self.in_flight {
            let before = f
                .queued
                .fetch_update(Ordering::AcqRel, Ordering::Acquire, |n| {
                    Some(n.saturating_sub(1))
                })
                .unwrap_or(0);
            if before >= f.max {
                f.freed.notify_waiters();
            }
        }
    }
    /// Waits until fewer than the bound are queued (at once without flow control). A link calls
    /// it before each read.
    pub async fn ready(&self) {
        use std::sync::atomic::Ordering;
        let Some(f) = &self.in_flight else {
            return;
        };
        loop {
            // Created before the check, so a `handled` between the two still wakes it.
            let freed = f.freed.notified();
            if f.queued.load(Ordering::Acquire) < f.max {
                return;
            }
            freed.await;
        }
    }
    /// Events sent and not yet handled (0 without flow control).
    pub fn queued(&self) -> usize {
        self.in_flight
            .as_ref()
            .map_or(0, |f| f.queued.load(std::sync::atomic::Ordering::Acquire))
    }
}

/// Lines waiting to be written before further writes are refused (a stalled frontseat must
/// not grow our memory).
pub(crate) const WRITE_QUEUE: usize = 1024;

#[derive(Clone, Debug)]
pub struct LinkConfig {
    pub host: String,
    pub port: u16,
    pub backoff_initial: Duration,
    pub backoff_max: Duration,
    pub max_line_bytes: usize,
}

/// Writes whole lines to the current connection. Dropped lines (queue full, connection gone)
/// are reported, not silently lost.
///
/// On a TCP line link a write goes to the socket at once, from the caller's thread, when nothing
/// is queued before it (one non-blocking `write(2)` under a short lock); what the socket does not
/// take at once is queued for the connection's writer task, and every later write queues behind
/// it, so bytes leave in the order they were handed over. A byte link started with
/// `byte::spawn_direct` (the drivers that take the setpoint lane) writes the same way
/// ([`direct_writer`]); the others (and UDP, and tests) queue every write.
#[derive(Clone, Debug)]
pub struct LineWriter {
    tx: mpsc::Sender<Vec<u8>>,
    direct: Option<std::sync::Arc<DirectSocket>>,
}

/// The connection's write half, shared by the writer task and the callers that write at once.
#[derive(Debug)]
struct DirectSocket {
    state: std::sync::Mutex<DirectState>,
    half: Half,
    /// Bytes written, for the byte links' counters.
    written: Option<Written>,
}

/// Counts the bytes a connection wrote (a byte link's `LinkStats::bytes_out`).
struct Written(Box<dyn Fn(usize) + Send + Sync>);

impl std::fmt::Debug for Written {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Written")
    }
}

/// A write half any thread can try at once: a TCP socket's own, or any other `AsyncWrite` (a
/// serial port, a pseudo-terminal, a byte link's TCP stream) behind a lock held only for one
/// poll.
enum Half {
    Tcp(OwnedWriteHalf),
    Any(std::sync::Mutex<std::pin::Pin<Box<dyn tokio::io::AsyncWrite + Send>>>),
}

impl std::fmt::Debug for Half {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Half::Tcp(_) => "Half::Tcp",
            Half::Any(_) => "Half::Any",
        })
    }
}

impl Half {
    /// One attempt that never waits (WouldBlock: the device takes nothing now). Only called
    /// with nothing queued, so the writer task is not waiting on this half: the no-op waker an
    /// `Any` half may leave registered is replaced by the writer task's at its next poll.
    fn try_write(&self, b: &[u8]) -> std::io::Result<usize> {
        match self {
            Half::Tcp(h) => h.try_write(b),
            Half::Any(m) => {
                let mut w = m.lock().unwrap_or_else(|p| p.into_inner());
                let mut cx = std::task::Context::from_waker(std::task::Waker::noop());
                match w.as_mut().poll_write(&mut cx, b) {
                    std::task::Poll::Ready(r) => r,
                    std::task::Poll::Pending => Err(std::io::ErrorKind::WouldBlock.into()),
                }
            }
        }
    }

    /// Writes some of `b`, waiting until the device takes any.
    async fn write_some(&self, b: &[u8]) -> std::io::Result<usize> {
        match self {
            Half::Tcp(h) => loop {
                h.writable().await?;
                match h.try_write(b) {
                    Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {}
                    r => return r,
                }
            },
            Half::Any(m) => {
                std::future::poll_fn(|cx| {
                    let mut w = m.lock().unwrap_or_else(|p| p.into_inner());
                    w.as_mut().poll_write(cx, b)
                })
                .await
            }
        }
    }

    async fn shutdown(&self) {
        match self {
            Half::Tcp(h) => {
                let _ = socket2::SockRef::from(h.as_ref()).shutdown(std::net::Shutdown::Write);
            }
            Half::Any(m) => {
                let _ = std::future::poll_fn(|cx| {
                    let mut w = m.lock().unwrap_or_else(|p| p.into_inner());
                    w.as_mut().poll_shutdown(cx)
                })
                .await;
            }
        }
    }
}

#[derive(Debug, Default)]
struct DirectState {
    /// Chunks handed to the writer task and not yet wholly written: while any is, a caller
    /// queues behind it instead of writing.
    backlog: usize,
    /// The connection ended (read side closed or failed, a write failed, the link task gone).
    closed: bool,
}

impl DirectSocket {
    fn lock(&self) -> std::sync::MutexGuard<'_, DirectState> {
        self.state.lock().unwrap_or_else(|p| p.into_inner())
    }
    fn close(&self) {
        self.lock().closed = true;
    }
    fn wrote(&self, n: usize) {
        if let Some(w) = &self.written {
            (w.0)(n);
        }
    }
}

/// Marks the connection's write side closed when the connection's task ends, however it ends
/// (its read side closed, or the link task aborted with its driver): a writer a driver kept
/// then refuses instead of writing to a connection nobody reads.
pub(crate) struct CloseOnDrop(std::sync::Arc<DirectSocket>);

impl Drop for CloseOnDrop {
    fn drop(&mut self) {
        self.0.close();
    }
}

#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum WriteError {
    #[error("write queue full ({WRITE_QUEUE} lines)")]
    Full,
    #[error("connection closed")]
    Closed,
}

fn queue_error<T>(e: mpsc::error::TrySendError<T>) -> WriteError {
    match e {
        mpsc::error::TrySendError::Full(_) => WriteError::Full,
        mpsc::error::TrySendError::Closed(_) => WriteError::Closed,
    }
}

impl LineWriter {
    /// Writes (or queues) `line` plus `\r\n`.
    pub fn write_line(&self, line: &str) -> Result<(), WriteError> {
        let mut b = Vec::with_capacity(line.len() + 2);
        b.extend_from_slice(line.as_bytes());
        b.extend_from_slice(b"\r\n");
        self.write_bytes(b)
    }
    /// Writes (or queues) bytes as they are (binary frames).
    pub fn write_bytes(&self, bytes: Vec<u8>) -> Result<(), WriteError> {
        let Some(d) = &self.direct else {
            return self.tx.try_send(bytes).map_err(queue_error);
        };
        let mut st = d.lock();
        if st.closed {
            return Err(WriteError::Closed);
        }
        let rest = if st.backlog == 0 {
            match d.half.try_write(&bytes) {
                Ok(n) if n >= bytes.len() => {
                    d.wrote(n);
                    return Ok(());
                }
                Ok(n) => {
                    d.wrote(n);
                    bytes[n..].to_vec()
                }
                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => bytes,
                Err(e) => {
                    // The writer task would have ended the connection with this error; the
                    // reader sees the same end and reports it.
                    tracing::debug!(error = %e, "write to the frontseat failed");
                    st.closed = true;
                    return Err(WriteError::Closed);
                }
            }
        } else {
            bytes
        };
        // With nothing queued before it, a partly written chunk's rest always fits the queue: a
        // line is never cut short.
        self.tx.try_send(rest).map_err(queue_error)?;
        st.backlog += 1;
        Ok(())
    }
    /// Whether a write now would go to the socket from the caller's thread: a socket link
    /// whose connection is open with nothing queued.
    pub fn writes_at_once(&self) -> bool {
        self.direct.as_ref().is_some_and(|d| {
            let st = d.lock();
            !st.closed && st.backlog == 0
        })
    }
    /// A writer around a channel (the byte links, and tests of drivers without a socket).
    pub(crate) fn from_sender(tx: mpsc::Sender<Vec<u8>>) -> Self {
        Self { tx, direct: None }
    }
    /// A writer whose lines go to a channel; for tests of drivers without a socket.
    pub fn for_test() -> (Self, mpsc::Receiver<Vec<u8>>) {
        let (tx, rx) = mpsc::channel(WRITE_QUEUE);
        (Self { tx, direct: None }, rx)
    }
}

/// Writes every queued chunk wholly, in order; each one written frees the way for callers to
/// write at once again.
async fn drain_queue(d: &DirectSocket, rx: &mut mpsc::Receiver<Vec<u8>>) -> String {
    while let Some(b) = rx.recv().await {
        let mut off = 0;
        while off < b.len() {
            match d.half.write_some(&b[off..]).await {
                Ok(0) => {
                    d.close();
                    return "write failed: the device took no bytes".to_string();
                }
                Ok(n) => {
                    d.wrote(n);
                    off += n;
                }
                Err(e) => {
                    d.close();
                    return format!("write failed: {e}");
                }
            }
        }
        let mut st = d.lock();
        st.backlog = st.backlog.saturating_sub(1);
    }
    // Every writer is gone (the driver closed the link): end the connection cleanly, as the
    // driver's stop expects; the read side ends with the frontseat's answer to it.
    d.half.shutdown().await;
    "closed by driver".to_string()
}

/// The write side of a byte link's connection (`byte`): a writer for the driver that writes at
/// once from its caller's thread when nothing is queued, the task that writes what is queued
/// (its result: why the connection's writing ended), and the guard that marks the writer
/// closed when the connection ends. `written` counts the bytes written.
pub(crate) fn direct_writer(
    half: impl tokio::io::AsyncWrite + Send + 'static,
    written: impl Fn(usize) + Send + Sync + 'static,
) -> (
    LineWriter,
    impl std::future::Future<Output = String> + Send + 'static,
    CloseOnDrop,
) {
    let (tx, mut rx) = mpsc::channel::<Vec<u8>>(WRITE_QUEUE);
    let direct = std::sync::Arc::new(DirectSocket {
        state: std::sync::Mutex::new(DirectState::default()),
        half: Half::Any(std::sync::Mutex::new(Box::pin(half))),
        written: Some(Written(Box::new(written))),
    });
    let guard = CloseOnDrop(direct.clone());
    let writer = LineWriter {
        tx,
        direct: Some(direct.clone()),
    };
    let drain = async move { drain_queue(&direct, &mut rx).await };
    (writer, drain, guard)
}

/// Runs until the driver actor is gone (or the task is aborted by the driver's drop).
pub fn spawn(cfg: LinkConfig, io: IoSender) -> tokio::task::JoinHandle<()> {
    tokio::spawn(async move {
        let mut delay = cfg.backoff_initial;
        let addr = format!("{}:{}", cfg.host, cfg.port);
        loop {
            match TcpStream::connect(&addr).await {
                Ok(stream) => {
                    delay = cfg.backoff_initial;
                    let _ = stream.set_nodelay(true);
                    let reason = run_connection(stream, &cfg, &io).await;
                    if !io.send(DriverIoEvent::Disconnected(reason)) {
                        return;
                    }
                }
                Err(e) => {
                    tracing::debug!(%addr, error = %e, "frontseat connect failed; retrying in {:?}", delay);
                }
            }
            // Backoff is wall time: a warped simulation does not reconnect faster.
            tokio::time::sleep(delay).await;
            delay = (delay * 2).min(cfg.backoff_max);
        }
    })
}

async fn run_connection(stream: TcpStream, cfg: &LinkConfig, io: &IoSender) -> String {
    let (rd, wr) = stream.into_split();
    let (tx, mut rx) = mpsc::channel::<Vec<u8>>(WRITE_QUEUE);
    let direct = std::sync::Arc::new(DirectSocket {
        state: std::sync::Mutex::new(DirectState::default()),
        half: Half::Tcp(wr),
        written: None,
    });
    let _closed_with_this = CloseOnDrop(direct.clone());
    let writer = LineWriter {
        tx,
        direct: Some(direct.clone()),
    };
    if !io.send(DriverIoEvent::Connected(writer)) {
        return "driver gone".into();
    }
    // Dropping the last handle on the write half (the task's and every writer's) shuts the
    // connection's write side down.
    let writer = tokio::spawn(async move { drain_queue(&direct, &mut rx).await });
    let mut reader = BufReader::new(rd);
    let mut buf = Vec::with_capacity(256);
    let reason = loop {
        buf.clear();
        // Flow control: no more reading while the driver has a backlog (see IoSender).
        io.ready().await;
        // Bound the line: read at most max_line_bytes + 1 before deciding it is oversized.
        let limit = (cfg.max_line_bytes + 1) as u64;
        let mut limited = (&mut reader).take(limit);
        match limited.read_until(b'\n', &mut buf).await {
            Ok(0) => break "connection closed by frontseat".to_string(),
            Ok(_) => {
                // Without a newline: either oversized (close) or EOF mid-line (deliver it).
                if buf.last() != Some(&b'\n') && buf.len() as u64 >= limit {
                    let msg = format!("line over {} bytes", cfg.max_line_bytes);
                    io.send(DriverIoEvent::BadInput(msg.clone()));
                    break msg;
                }
                while matches!(buf.last(), Some(b'\n' | b'\r')) {
                    buf.pop();
                }
                match std::str::from_utf8(&buf) {
                    Ok(line) => {
                        // The root of a NAV line's trace: the actor handling this event continues
                        // in this span (ractor carries the sender's span with the message).
                        let span = tracing::trace_span!(
                            target: "frontseat_actors",
                            "frontseat.socket_read",
                            bytes = buf.len(),
                            line = frontseat_telemetry::truncate(line),
                            peer = %cfg.host,
                        );
                        let sent = span.in_scope(|| io.send(DriverIoEvent::Line(line.to_string())));
                        if !sent {
                            break "driver gone".to_string();
                        }
                    }
                    Err(_) => {
                        io.send(DriverIoEvent::BadInput(format!(
                            "invalid UTF-8 in a {}-byte line",
                            buf.len()
                        )));
                    }
                }
            }
            Err(e) => break format!("read failed: {e}"),
        }
    };
    writer.abort();
    reason
}
