//! The connections of an HTTP server (the vehicle's page, the topside's page, the Foxglove
//! WebSocket servers): how many at once, which one gives way when a new client comes, and how
//! long each may take. Owns the accept loop and each connection's task; the routes are the
//! caller's `Router`.
//!
//! A connection is *unfinished* while no request of it is being answered and it was not
//! upgraded: a socket that sent nothing, a head still arriving (one byte, or a byte a second),
//! a body still arriving (until its handler answers), or a keep-alive connection between
//! requests. A request without a body is being answered from its complete head on. When every slot is held
//! and a new connection comes, the oldest unfinished one is closed (counted, logged
//! rate-limited) and the new one takes its slot, as the simulator does with connections that
//! sent no START (`sim/src/server.rs`). A connection being answered (an event stream, a page
//! being sent) or upgraded (a WebSocket client) is never evicted; only when every slot is such
//! a connection is a new one closed at accept. On top of that, hyper's own header-read timeout
//! bounds the time to a complete request head (from the connection's start, or the end of its
//! previous answer), and the stream's own timers bound silence both ways and the time from a
//! request's first byte to the first byte of its answer (a trickled body).

use std::collections::VecDeque;
use std::convert::Infallible;
use std::future::Future;
use std::pin::Pin;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::task::{Context, Poll};
use std::time::Duration;

use axum::Router;
use axum::http::{Request, Response, StatusCode};
use http_body::Body as _;
use hyper::body::Incoming;
use hyper_util::rt::{TokioIo, TokioTimer};
use hyper_util::service::TowerToHyperService;
use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::Notify;
use tokio::task::JoinSet;

use crate::server::ServerCounters;

/// Default of [`ConnLimits::header_timeout`] (`header_timeout_s` in the configs).
pub const HEADER_TIMEOUT: Duration = Duration::from_secs(5);

/// The bounds of one server's connections.
#[derive(Clone, Copy, Debug)]
pub struct ConnLimits {
    /// Connections held at once (answered, upgraded or unfinished).
    pub max_connections: usize,
    /// A connection silent both ways this long is closed; a request not answered within this
    /// long of its first byte (a trickled body) too.
    pub idle: Duration,
    /// Longest from a connection's start (or the end of its previous answer) to a complete
    /// request head (hyper's `header_read_timeout`).
    pub header_timeout: Duration,
}

/// One connection as the slot table sees it.
struct Conn {
    id: u64,
    /// Answers being sent now (a response body not yet finished or dropped).
    answering: AtomicUsize,
    /// Switched protocols (a WebSocket): never unfinished again.
    upgraded: AtomicBool,
    /// Fired when a new connection takes this one's slot.
    evict: Notify,
}

impl Conn {
    fn unfinished(&self) -> bool {
        self.answering.load(Ordering::Acquire) == 0 && !self.upgraded.load(Ordering::Acquire)
    }
}

/// The connections holding a slot, oldest first. `connections_open` is kept equal to their
/// number (an evicted connection's socket may outlive its slot by the moment its task takes
/// to see the eviction).
struct Slots {
    max: usize,
    held: Mutex<VecDeque<Arc<Conn>>>,
    counters: Arc<ServerCounters>,
}

enum Admission {
    Free,
    Evicted(Arc<Conn>),
    Full,
}

impl Slots {
    fn admit(&self, conn: &Arc<Conn>) -> Admission {
        let mut held = self.held.lock().unwrap_or_else(|p| p.into_inner());
        if held.len() < self.max {
            held.push_back(conn.clone());
            self.counters
                .connections_open
                .store(held.len() as u64, Ordering::Relaxed);
            return Admission::Free;
        }
        let Some(i) = held.iter().position(|c| c.unfinished()) else {
            return Admission::Full;
        };
        let old = held.remove(i);
        held.push_back(conn.clone());
        match old {
            Some(old) => Admission::Evicted(old),
            None => Admission::Free,
        }
    }

    fn release(&self, conn: &Arc<Conn>) {
        let mut held = self.held.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(i) = held.iter().position(|c| Arc::ptr_eq(c, conn)) {
            held.remove(i);
            self.counters
                .connections_open
                .store(held.len() as u64, Ordering::Relaxed);
        }
    }
}

/// Holds a connection's slot until its socket is gone (after an upgrade, that is when the
/// WebSocket ends, not when the HTTP exchange does).
struct SlotGuard {
    slots: Arc<Slots>,
    conn: Arc<Conn>,
}

impl Drop for SlotGuard {
    fn drop(&mut self) {
        self.slots.release(&self.conn);
    }
}

/// A listener and the bounds of its connections; [`serve`](Self::serve) runs it.
pub struct BoundedListener {
    inner: TcpListener,
    limits: ConnLimits,
    counters: Arc<ServerCounters>,
    /// Which server, in log lines.
    what: &'static str,
}

/// Rate-limited: the 1st, 2nd, 4th, 8th … occurrence (`n` counts from 1) is logged, so a flood
/// cannot fill the log.
fn loud(n: u64) -> bool {
    n.is_power_of_two()
}

impl BoundedListener {
    pub fn new(
        inner: TcpListener,
        limits: ConnLimits,
        counters: Arc<ServerCounters>,
        what: &'static str,
    ) -> Self {
        Self {
            inner,
            limits,
            counters,
            what,
        }
    }

    pub fn local_addr(&self) -> std::io::Result<std::net::SocketAddr> {
        self.inner.local_addr()
    }

    /// Serves `app` on every connection admitted. Runs until dropped (aborting its task closes
    /// every connection not upgraded; upgraded ones end with their own task).
    pub async fn serve(self, app: Router) {
        let Self {
            inner,
            limits,
            counters,
            what,
        } = self;
        let slots = Arc::new(Slots {
            max: limits.max_connections.max(1),
            held: Mutex::new(VecDeque::new()),
            counters: counters.clone(),
        });
        let idle = limits.idle.max(Duration::from_millis(10));
        let header_timeout = limits.header_timeout.max(Duration::from_millis(10));
        let service = TowerToHyperService::new(app);
        let mut tasks = JoinSet::new();
        let mut next_id = 0u64;
        loop {
            let accepted = tokio::select! {
                a = inner.accept() => a,
                Some(_) = tasks.join_next(), if !tasks.is_empty() => continue,
            };
            let (stream, peer) = match accepted {
                Ok(s) => s,
                Err(e) => {
                    // Out of descriptors and the like: wait instead of spinning.
                    tracing::warn!(error = %e, server = what, "accept failed");
                    tokio::time::sleep(Duration::from_millis(100)).await;
                    continue;
                }
            };
            counters
                .connections_accepted
                .fetch_add(1, Ordering::Relaxed);
            next_id += 1;
            let conn = Arc::new(Conn {
                id: next_id,
                answering: AtomicUsize::new(0),
                upgraded: AtomicBool::new(false),
                evict: Notify::new(),
            });
            match slots.admit(&conn) {
                Admission::Free => {}
                Admission::Evicted(old) => {
                    // `notify_one` keeps the wake-up if the task is not waiting yet.
                    old.evict.notify_one();
                    let n = counters.evicted.fetch_add(1, Ordering::Relaxed) + 1;
                    if loud(n) {
                        tracing::warn!(
                            server = what,
                            connection = old.id,
                            evicted = n,
                            max = slots.max,
                            "closing the oldest unfinished connection: a new client needs its slot"
                        );
                    }
                }
                Admission::Full => {
                    let n = counters.connections_refused.fetch_add(1, Ordering::Relaxed) + 1;
                    if loud(n) {
                        tracing::warn!(server = what, %peer, refused = n,
                            "every connection slot is being answered; closing the new connection");
                    }
                    drop(stream);
                    continue;
                }
            }
            let _ = stream.set_nodelay(true);
            let now = tokio::time::Instant::now();
            let io = BoundedStream {
                stream,
                _slot: SlotGuard {
                    slots: slots.clone(),
                    conn: conn.clone(),
                },
                counters: counters.clone(),
                idle,
                last: now,
                unanswered_since: None,
                timer: Box::pin(tokio::time::sleep_until(now + idle)),
            };
            let svc = Tracked {
                inner: service.clone(),
                conn: conn.clone(),
            };
            let counters = counters.clone();
            tasks.spawn(async move {
                let mut http = hyper::server::conn::http1::Builder::new();
                http.timer(TokioTimer::new())
                    .header_read_timeout(header_timeout);
                let served = http.serve_connection(TokioIo::new(io), svc).with_upgrades();
                tokio::select! {
                    r = served => {
                        if let Err(e) = r
                            && e.is_timeout()
                        {
                            let n = counters.header_timeouts.fetch_add(1, Ordering::Relaxed) + 1;
                            if loud(n) {
                                tracing::warn!(server = what, %peer, header_timeouts = n, timeout = ?header_timeout,
                                    "request head not complete in time; connection closed");
                            }
                        }
                    }
                    // Dropping the connection closes its socket and frees its slot.
                    () = conn.evict.notified() => {}
                }
            });
        }
    }
}

/// The router, with the connection told when an answer starts and ends.
#[derive(Clone)]
struct Tracked {
    inner: TowerToHyperService<Router>,
    conn: Arc<Conn>,
}

impl hyper::service::Service<Request<Incoming>> for Tracked {
    type Response = Response<TrackedBody>;
    type Error = Infallible;
    type Future = Pin<Box<dyn Future<Output = Result<Self::Response, Infallible>> + Send>>;

    fn call(&self, req: Request<Incoming>) -> Self::Future {
        // A request without a body is finished with its head (a page, an event stream, an
        // upgrade): from here on it is being answered, however long its handler takes. One with
        // a body is finished when its handler answers, after reading the body: a trickled body
        // leaves the connection unfinished, hence evictable.
        let early = req
            .body()
            .is_end_stream()
            .then(|| Answering::new(self.conn.clone()));
        let fut = hyper::service::Service::call(&self.inner, req);
        let conn = self.conn.clone();
        Box::pin(async move {
            let resp = fut.await?;
            if resp.status() == StatusCode::SWITCHING_PROTOCOLS {
                conn.upgraded.store(true, Ordering::Release);
            }
            let answering = early.unwrap_or_else(|| Answering::new(conn));
            Ok(resp.map(|body| TrackedBody {
                inner: body,
                _answering: answering,
            }))
        })
    }
}

/// Marks its connection as being answered while it lives.
struct Answering(Arc<Conn>);

impl Answering {
    fn new(conn: Arc<Conn>) -> Self {
        conn.answering.fetch_add(1, Ordering::AcqRel);
        Self(conn)
    }
}

impl Drop for Answering {
    fn drop(&mut self) {
        self.0.answering.fetch_sub(1, Ordering::AcqRel);
    }
}

/// A response body that keeps its connection marked as answering until it ends.
struct TrackedBody {
    inner: axum::body::Body,
    _answering: Answering,
}

impl http_body::Body for TrackedBody {
    type Data = <axum::body::Body as http_body::Body>::Data;
    type Error = <axum::body::Body as http_body::Body>::Error;

    fn poll_frame(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
    ) -> Poll<Option<Result<http_body::Frame<Self::Data>, Self::Error>>> {
        Pin::new(&mut self.inner).poll_frame(cx)
    }
    fn is_end_stream(&self) -> bool {
        self.inner.is_end_stream()
    }
    fn size_hint(&self) -> http_body::SizeHint {
        self.inner.size_hint()
    }
}

/// One served connection: holds its slot, and ends itself after `idle` without a byte either
/// way; and after `idle` from the first byte of a request with no byte of an answer, so a
/// client trickling a body a byte at a time, which resets the idle timer with every byte, still
/// cannot hold its slot longer than that. (The head has hyper's header timeout.)
struct BoundedStream {
    stream: TcpStream,
    _slot: SlotGuard,
    counters: Arc<ServerCounters>,
    idle: Duration,
    last: tokio::time::Instant,
    /// Since when the peer has sent bytes that no byte of ours answered yet.
    unanswered_since: Option<tokio::time::Instant>,
    timer: Pin<Box<tokio::time::Sleep>>,
}

impl AsyncRead for BoundedStream {
    fn poll_read(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<std::io::Result<()>> {
        let before = buf.filled().len();
        match Pin::new(&mut self.stream).poll_read(cx, buf) {
            Poll::Ready(r) => {
                if buf.filled().len() > before {
                    self.last = tokio::time::Instant::now();
                    if self.unanswered_since.is_none() {
                        self.unanswered_since = Some(self.last);
                    }
                }
                Poll::Ready(r)
            }
            Poll::Pending => {
                // Waiting for the peer: wake up at the idle deadline, or the request's, and close
                // if it passed.
                loop {
                    let idle = self.last + self.idle;
                    let deadline = self
                        .unanswered_since
                        .map_or(idle, |t| idle.min(t + self.idle));
                    if self.timer.deadline() != deadline {
                        self.timer.as_mut().reset(deadline);
                    }
                    match self.timer.as_mut().poll(cx) {
                        Poll::Pending => return Poll::Pending,
                        Poll::Ready(()) if deadline <= tokio::time::Instant::now() => {
                            let why = if deadline < idle {
                                self.counters.slow_requests.fetch_add(1, Ordering::Relaxed);
                                "request not answered in time"
                            } else {
                                "idle connection"
                            };
                            return Poll::Ready(Err(std::io::Error::new(
                                std::io::ErrorKind::TimedOut,
                                why,
                            )));
                        }
                        Poll::Ready(()) => continue,
                    }
                }
            }
        }
    }
}

impl AsyncWrite for BoundedStream {
    fn poll_write(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &[u8],
    ) -> Poll<std::io::Result<usize>> {
        let r = Pin::new(&mut self.stream).poll_write(cx, buf);
        if matches!(r, Poll::Ready(Ok(n)) if n > 0) {
            self.last = tokio::time::Instant::now();
            self.unanswered_since = None;
        }
        r
    }
    fn poll_flush(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<std::io::Result<()>> {
        Pin::new(&mut self.stream).poll_flush(cx)
    }
    fn poll_shutdown(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<std::io::Result<()>> {
        Pin::new(&mut self.stream).poll_shutdown(cx)
    }
    fn poll_write_vectored(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        bufs: &[std::io::IoSlice<'_>],
    ) -> Poll<std::io::Result<usize>> {
        let r = Pin::new(&mut self.stream).poll_write_vectored(cx, bufs);
        if matches!(r, Poll::Ready(Ok(n)) if n > 0) {
            self.last = tokio::time::Instant::now();
            self.unanswered_since = None;
        }
        r
    }
    fn is_write_vectored(&self) -> bool {
        self.stream.is_write_vectored()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn conn(id: u64) -> Arc<Conn> {
        Arc::new(Conn {
            id,
            answering: AtomicUsize::new(0),
            upgraded: AtomicBool::new(false),
            evict: Notify::new(),
        })
    }

    #[test]
    fn the_oldest_unfinished_gives_way_and_answered_or_upgraded_ones_never_do() {
        let counters = Arc::new(ServerCounters::default());
        let slots = Slots {
            max: 3,
            held: Mutex::new(VecDeque::new()),
            counters: counters.clone(),
        };
        let (a, b, c) = (conn(1), conn(2), conn(3));
        for x in [&a, &b, &c] {
            assert!(matches!(slots.admit(x), Admission::Free));
        }
        a.answering.store(1, Ordering::Relaxed);
        let d = conn(4);
        assert!(matches!(slots.admit(&d), Admission::Evicted(o) if o.id == 2));
        c.upgraded.store(true, Ordering::Relaxed);
        let e = conn(5);
        assert!(matches!(slots.admit(&e), Admission::Evicted(o) if o.id == 4));
        e.answering.store(1, Ordering::Relaxed);
        assert!(matches!(slots.admit(&conn(6)), Admission::Full));
        assert_eq!(counters.connections_open.load(Ordering::Relaxed), 3);
        // A released slot is free again; releasing an evicted one changes nothing.
        slots.release(&b);
        assert!(matches!(slots.admit(&conn(7)), Admission::Full));
        slots.release(&a);
        assert_eq!(counters.connections_open.load(Ordering::Relaxed), 2);
        assert!(matches!(slots.admit(&conn(8)), Admission::Free));
    }
}
