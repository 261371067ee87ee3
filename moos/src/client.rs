//! The async MOOS client: one background task that connects, handshakes, keeps the DB's 5 s
//! silence timer fed with TIMING heartbeats, sends what the handle queued, turns incoming NOTIFYs
//! into [`MoosEvent::Mail`], and on any failure reconnects with capped exponential backoff,
//! re-registering every variable the handle registered (the bug of GobySoft/goby3#265).
//!
//! Outgoing notifications wait in one bounded queue (`queue_limit` messages) whether connected or
//! not; when it is full the *oldest* queued message is dropped and counted. Registrations are not
//! queued while disconnected: the set of registered variables is state, replayed on every connect.

use std::collections::{BTreeMap, VecDeque};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};
use std::time::Duration;

use bytes::{BufMut, Bytes, BytesMut};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;
use tokio::net::tcp::{OwnedReadHalf, OwnedWriteHalf};
use tokio::sync::{Notify, mpsc, watch};
use tokio::task::JoinHandle;
use tokio::time::{Instant, sleep, sleep_until, timeout};
use tracing::{debug, info, warn};

use crate::codec::{
    BANNER, DataType, Fields, MESSAGE_MIN_LEN, MoosMessage, MoosValue, MsgType, PACKET_HEADER_LEN,
    PacketDecoder, TIMING_KEY, Welcome, begin_packet, encode_fields, finish_packet,
    handshake_message, parse_handshake_reply, timing_message,
};
use crate::error::{MoosError, Result};
use crate::sock::write_shared;
use crate::time::moos_time;

/// Room kept in every packet for a TIMING message and a NULL held-mail poll.
const HEADROOM: usize = PACKET_HEADER_LEN + (MESSAGE_MIN_LEN + TIMING_KEY.len()) + MESSAGE_MIN_LEN;
/// Size of the chunks outgoing messages are encoded into (amortises allocations).
const ARENA_CHUNK: usize = 64 * 1024;

/// Client configuration. `MoosClientConfig::new(name)` gives the defaults below.
#[derive(Clone, Debug)]
pub struct MoosClientConfig {
    /// `host:port` of the MOOSDB (default `127.0.0.1:9000`).
    pub server: String,
    /// The unique client name sent in the handshake and in `source` of every message.
    pub name: String,
    /// MOOSTimeWarp: every time stamp is Unix time × this (default 1).
    pub time_warp: f64,
    /// Period of TIMING heartbeats (default 1 s; the DB drops a client silent for 5 s).
    pub heartbeat: Duration,
    /// Add a NULL message to heartbeat packets so that the DB releases mail it holds for us
    /// (it only does so for packets carrying more than a TIMING message). Default true.
    pub poll_held_mail: bool,
    /// First reconnect delay (default 250 ms), doubled after each failure ...
    pub reconnect_initial: Duration,
    /// ... up to this (default 5 s).
    pub reconnect_max: Duration,
    /// Time allowed for TCP connect + banner + WELCOME (default 5 s).
    pub handshake_timeout: Duration,
    /// Largest packet accepted or sent (default 1 MiB).
    pub max_packet: usize,
    /// Most notifications waiting to be sent; beyond it the oldest is dropped (default 4096).
    pub queue_limit: usize,
    /// Capacity of the event channel (default 1024). When full, reading from the DB pauses.
    pub event_capacity: usize,
    /// Report the mail of each packet as one [`MoosEvent::Packet`] instead of one
    /// [`MoosEvent::Mail`] per message, for clients that must treat the mail of one packet as one
    /// batch (Goby3 buffers a whole OnNewMail before its triggers fire). One event per packet
    /// also means one wake-up of the reader per packet. Default false.
    pub mail_by_packet: bool,
}

impl MoosClientConfig {
    /// Defaults for a client called `name`.
    pub fn new(name: impl Into<String>) -> Self {
        MoosClientConfig {
            server: "127.0.0.1:9000".to_owned(),
            name: name.into(),
            time_warp: 1.0,
            heartbeat: Duration::from_secs(1),
            poll_held_mail: true,
            reconnect_initial: Duration::from_millis(250),
            reconnect_max: Duration::from_secs(5),
            handshake_timeout: Duration::from_secs(5),
            max_packet: crate::codec::DEFAULT_MAX_PACKET,
            queue_limit: 4096,
            event_capacity: 1024,
            mail_by_packet: false,
        }
    }

    /// Check every field; the error names the bad one.
    pub fn validate(&self) -> Result<()> {
        let bad = |what: &str| Err(MoosError::InvalidArgument(what.to_owned()));
        if self.name.is_empty() {
            return bad("name must not be empty");
        }
        if self.server.is_empty() {
            return bad("server must not be empty");
        }
        if !(self.time_warp.is_finite() && self.time_warp > 0.0) {
            return bad("time_warp must be a positive number");
        }
        if self.heartbeat.is_zero() || self.heartbeat > Duration::from_secs(4) {
            return bad("heartbeat must be in (0, 4 s] (the DB drops clients silent for 5 s)");
        }
        if self.reconnect_initial.is_zero() || self.reconnect_max < self.reconnect_initial {
            return bad("reconnect_initial must be > 0 and <= reconnect_max");
        }
        if self.handshake_timeout.is_zero() {
            return bad("handshake_timeout must be > 0");
        }
        if self.max_packet < HEADROOM + MESSAGE_MIN_LEN + self.name.len()
            || self.max_packet > i32::MAX as usize
        {
            return bad("max_packet is too small for a message or larger than i32::MAX");
        }
        if self.queue_limit == 0 || self.event_capacity == 0 {
            return bad("queue_limit and event_capacity must be > 0");
        }
        Ok(())
    }
}

impl Default for MoosClientConfig {
    fn default() -> Self {
        MoosClientConfig::new("frontseat")
    }
}

/// What the client reports on its event channel.
#[derive(Clone, Debug, PartialEq)]
pub enum MoosEvent {
    /// Handshake done; registrations were (re)sent.
    Connected,
    /// The connection ended (reason text); a reconnect follows unless shutting down.
    Disconnected(String),
    /// A NOTIFY for a registered variable. `time` is the poster's MOOS time.
    Mail(MoosMessage),
    /// All the NOTIFYs of one packet from the DB, in order (only with `mail_by_packet`, and only
    /// for a packet that carried mail).
    Packet(Vec<MoosMessage>),
}

/// A snapshot of the client's counters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ClientCounters {
    /// Successful handshakes.
    pub connects: u64,
    /// Failed connection attempts (refused, timed out, poisoned).
    pub connect_failures: u64,
    /// Connections that ended.
    pub disconnects: u64,
    /// Packets written.
    pub packets_sent: u64,
    /// Messages written (TIMING and NULL included).
    pub messages_sent: u64,
    /// Packets read.
    pub packets_received: u64,
    /// NOTIFY messages delivered as mail.
    pub mail_received: u64,
    /// TIMING echoes received.
    pub timing_echoes: u64,
    /// Notifications dropped because the send queue was full (oldest first).
    pub dropped_queue_full: u64,
    /// Malformed packets from the DB (each one closes the connection).
    pub decode_errors: u64,
}

#[derive(Default)]
struct Counters {
    connects: AtomicU64,
    connect_failures: AtomicU64,
    disconnects: AtomicU64,
    packets_sent: AtomicU64,
    messages_sent: AtomicU64,
    packets_received: AtomicU64,
    mail_received: AtomicU64,
    timing_echoes: AtomicU64,
    dropped_queue_full: AtomicU64,
    decode_errors: AtomicU64,
}

fn inc(c: &AtomicU64) {
    c.fetch_add(1, Ordering::Relaxed);
}

struct State {
    /// Registered variables → interval; replayed on every connect.
    subs: BTreeMap<String, f64>,
    /// Encoded (un)registrations for the current connection.
    ctrl: VecDeque<Bytes>,
    /// Encoded notifications, bounded by `queue_limit`.
    outbox: VecDeque<Bytes>,
    arena: BytesMut,
    next_id: i32,
    connected: bool,
    closed: bool,
    welcome: Option<Welcome>,
    /// The connection's write half, for posts written straight from the posting thread.
    direct: Option<Arc<OwnedWriteHalf>>,
    /// The writer task is waiting for work (set and cleared under this lock, so a post may
    /// write directly only while the writer is not writing).
    writer_idle: bool,
    /// The rest of a packet a post began to write directly: the writer sends it before anything.
    partial: Option<Bytes>,
}

struct Shared {
    cfg: MoosClientConfig,
    state: Mutex<State>,
    wake: Notify,
    connected: AtomicBool,
    counters: Counters,
}

impl Shared {
    fn lock(&self) -> MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(PoisonError::into_inner)
    }

    fn now(&self) -> f64 {
        moos_time(self.cfg.time_warp)
    }

    /// After a post was queued: while the writer task waits for work and the connection takes
    /// the packet now, writes what is queued as one packet from the posting thread (a
    /// non-blocking write under the state lock), which spares the post a wake-up of the writer
    /// (issue 49); anything else — disconnected, registrations waiting, the writer busy, a
    /// socket that takes only part — is left to the writer, woken, which sends the rest first.
    fn send_queued(&self, mut st: MutexGuard<'_, State>) {
        if !st.connected || st.outbox.is_empty() {
            return;
        }
        let wr = match &st.direct {
            Some(wr) if st.writer_idle && st.ctrl.is_empty() && st.partial.is_none() => wr.clone(),
            _ => {
                drop(st);
                self.wake.notify_one();
                return;
            }
        };
        let mut batch = VecDeque::new();
        let mut used = 0;
        take_within(
            &mut st.outbox,
            &mut batch,
            &mut used,
            self.cfg.max_packet - HEADROOM,
        );
        let mut buf = BytesMut::with_capacity(used + PACKET_HEADER_LEN);
        let start = begin_packet(&mut buf);
        let n = batch.len();
        for b in batch {
            buf.put_slice(&b);
        }
        if let Err(e) = finish_packet(&mut buf, start, n) {
            warn!(error = %e, "cannot frame packet");
            return;
        }
        crate::hops::hop("moos.client.write", &self.cfg.name);
        // An error other than WouldBlock is the writer's to meet (it ends the session).
        let written = wr.try_write(&buf).unwrap_or(0);
        inc(&self.counters.packets_sent);
        self.counters
            .messages_sent
            .fetch_add(n as u64, Ordering::Relaxed);
        let more = !st.outbox.is_empty();
        if written < buf.len() {
            st.partial = Some(buf.freeze().slice(written..));
            st.writer_idle = false;
        }
        let wake = more || st.partial.is_some();
        drop(st);
        if wake {
            self.wake.notify_one();
        }
    }
}

impl State {
    /// Encode one message with the next id into the arena.
    fn encode(&mut self, mut f: Fields<'_>) -> Result<Bytes> {
        f.id = self.next_id;
        // libMOOS counts from 0 and never resets; stay non-negative (-1/-2 have meanings).
        self.next_id = self.next_id.checked_add(1).unwrap_or(0);
        let len = f.encoded_len();
        if self.arena.capacity() < len {
            self.arena.reserve(len.max(ARENA_CHUNK));
        }
        encode_fields(&mut self.arena, &f)?;
        Ok(self.arena.split().freeze())
    }
}

struct Inner {
    shared: Arc<Shared>,
    stop: watch::Sender<bool>,
    task: Mutex<Option<JoinHandle<()>>>,
}

impl Drop for Inner {
    fn drop(&mut self) {
        // The last handle gone: let the background task finish.
        let _ = self.stop.send(true);
    }
}

/// Handle to a running MOOS client. Cheap to clone; the task stops on `shutdown()` or when the
/// last clone is dropped.
#[derive(Clone)]
pub struct MoosClient {
    inner: Arc<Inner>,
}

impl MoosClient {
    /// Validate `cfg`, spawn the client task on the current tokio runtime and return the handle
    /// and the event receiver. The first connection attempt starts at once; registrations and
    /// notifications may be made before it succeeds.
    pub fn start(cfg: MoosClientConfig) -> Result<(MoosClient, mpsc::Receiver<MoosEvent>)> {
        cfg.validate()?;
        let runtime = tokio::runtime::Handle::try_current().map_err(|_| {
            MoosError::InvalidArgument("MoosClient::start needs a tokio runtime".into())
        })?;
        let (tx, rx) = mpsc::channel(cfg.event_capacity);
        let (stop_tx, stop_rx) = watch::channel(false);
        let shared = Arc::new(Shared {
            state: Mutex::new(State {
                subs: BTreeMap::new(),
                ctrl: VecDeque::new(),
                outbox: VecDeque::new(),
                arena: BytesMut::with_capacity(ARENA_CHUNK),
                next_id: 0,
                connected: false,
                closed: false,
                welcome: None,
                direct: None,
                writer_idle: false,
                partial: None,
            }),
            cfg,
            wake: Notify::new(),
            connected: AtomicBool::new(false),
            counters: Counters::default(),
        });
        let task = runtime.spawn(run(shared.clone(), tx, stop_rx));
        let inner = Arc::new(Inner {
            shared,
            stop: stop_tx,
            task: Mutex::new(Some(task)),
        });
        Ok((MoosClient { inner }, rx))
    }

    fn shared(&self) -> &Shared {
        &self.inner.shared
    }

    /// The client's name (the `source` of everything it sends).
    pub fn name(&self) -> &str {
        &self.shared().cfg.name
    }

    /// Current MOOS time (Unix time × time warp).
    pub fn moos_time(&self) -> f64 {
        self.shared().now()
    }

    /// Whether a handshake succeeded and the connection is still up.
    pub fn is_connected(&self) -> bool {
        self.shared().connected.load(Ordering::Acquire)
    }

    /// What the DB said in its last WELCOME (community, host, skew), if ever connected.
    pub fn welcome(&self) -> Option<Welcome> {
        self.shared().lock().welcome.clone()
    }

    /// A snapshot of the counters.
    pub fn counters(&self) -> ClientCounters {
        let c = &self.shared().counters;
        let g = |a: &AtomicU64| a.load(Ordering::Relaxed);
        ClientCounters {
            connects: g(&c.connects),
            connect_failures: g(&c.connect_failures),
            disconnects: g(&c.disconnects),
            packets_sent: g(&c.packets_sent),
            messages_sent: g(&c.messages_sent),
            packets_received: g(&c.packets_received),
            mail_received: g(&c.mail_received),
            timing_echoes: g(&c.timing_echoes),
            dropped_queue_full: g(&c.dropped_queue_full),
            decode_errors: g(&c.decode_errors),
        }
    }

    /// Post a double. `time` = None stamps it with the current MOOS time.
    pub fn notify_double(&self, key: &str, value: f64, time: Option<f64>) -> Result<()> {
        self.notify(key, DataType::Double, value, &[], time)
    }

    /// Post several doubles so that they leave in the same packet, as one application iteration
    /// does (pHelmIvP posts its DESIRED_* of one iteration together): queued under one lock, so
    /// the writer takes them together. Stamped with one MOOS time (`None` = now).
    pub fn notify_doubles(&self, values: &[(&str, f64)], time: Option<f64>) -> Result<()> {
        let values: Vec<(&str, MoosValue<'_>)> = values
            .iter()
            .map(|&(key, v)| (key, MoosValue::Double(v)))
            .collect();
        self.notify_values(&values, time)
    }

    /// Post values of any type so that they leave in the same packet, as one application
    /// iteration does (libMOOS's writer thread sends whatever is queued when it wakes): encoded
    /// and queued under one lock, with one wake of the writer, where one notify each would wake
    /// it (and often send a packet) per value. Stamped with one MOOS time (`None` = now). A bad
    /// key or a value too large for a packet refuses the whole batch before any of it is queued.
    pub fn notify_values(&self, values: &[(&str, MoosValue<'_>)], time: Option<f64>) -> Result<()> {
        let sh = self.shared();
        let name = sh.cfg.name.as_str();
        let time = time.unwrap_or_else(|| sh.now());
        let mut fields = Vec::with_capacity(values.len());
        for (key, v) in values {
            check_key(key)?;
            let f = match *v {
                MoosValue::Double(d) => Fields::notify_double(name, key, d, time),
                MoosValue::Binary(b) => Fields::notify_binary(name, key, b, time),
                MoosValue::String(s) => Fields::notify_string(name, key, s, time),
                MoosValue::None => Fields::notify_string(name, key, &[], time),
            };
            let len = f.encoded_len();
            if len + HEADROOM > sh.cfg.max_packet {
                return Err(MoosError::MessageTooLarge {
                    len,
                    max: sh.cfg.max_packet - HEADROOM,
                });
            }
            fields.push(f);
        }
        let mut st = sh.lock();
        if st.closed {
            return Err(MoosError::Shutdown);
        }
        for f in fields {
            let b = st.encode(f)?;
            if st.outbox.len() >= sh.cfg.queue_limit {
                st.outbox.pop_front();
                inc(&sh.counters.dropped_queue_full);
                debug!("moos send queue full: dropped the oldest notification");
            }
            st.outbox.push_back(b);
        }
        sh.send_queued(st);
        Ok(())
    }

    /// Post a string.
    pub fn notify_string(&self, key: &str, value: &str, time: Option<f64>) -> Result<()> {
        self.notify(key, DataType::String, -1.0, value.as_bytes(), time)
    }

    /// Post binary data (data type `B`).
    pub fn notify_binary(&self, key: &str, value: &[u8], time: Option<f64>) -> Result<()> {
        self.notify(key, DataType::Binary, -1.0, value, time)
    }

    fn notify(
        &self,
        key: &str,
        data_type: DataType,
        double_val: f64,
        bytes: &[u8],
        time: Option<f64>,
    ) -> Result<()> {
        let value = match data_type {
            DataType::Double => MoosValue::Double(double_val),
            DataType::Binary => MoosValue::Binary(bytes),
            _ => MoosValue::String(bytes),
        };
        self.notify_values(&[(key, value)], time)
    }

    /// Subscribe to `key`, receiving at most one update per `interval` seconds (0 = every write).
    /// Remembered and re-sent on every reconnect; registering again changes the interval.
    pub fn register(&self, key: &str, interval: f64) -> Result<()> {
        check_key(key)?;
        if !(interval.is_finite() && interval >= 0.0) {
            return Err(MoosError::InvalidArgument(format!(
                "register interval {interval} must be >= 0"
            )));
        }
        self.control(key, Some(interval))
    }

    /// Stop the subscription to `key`.
    pub fn unregister(&self, key: &str) -> Result<()> {
        check_key(key)?;
        self.control(key, None)
    }

    fn control(&self, key: &str, interval: Option<f64>) -> Result<()> {
        let sh = self.shared();
        let mut st = sh.lock();
        if st.closed {
            return Err(MoosError::Shutdown);
        }
        match interval {
            Some(i) => st.subs.insert(key.to_owned(), i),
            None => st.subs.remove(key),
        };
        if st.connected {
            let b = st.encode(control_fields(&sh.cfg.name, key, interval, sh.now()))?;
            st.ctrl.push_back(b);
            drop(st);
            sh.wake.notify_one();
        }
        Ok(())
    }

    /// The variables currently registered, with their intervals.
    pub fn registrations(&self) -> Vec<(String, f64)> {
        let st = self.shared().lock();
        st.subs.iter().map(|(k, v)| (k.clone(), *v)).collect()
    }

    /// Stop: flush what is queued (if connected), close the connection, end the task.
    /// Later calls on this handle or its clones return [`MoosError::Shutdown`].
    pub async fn shutdown(&self) {
        let _ = self.inner.stop.send(true);
        let task = self
            .inner
            .task
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .take();
        if let Some(mut task) = task {
            // A DB that stopped reading could block the final flush; don't wait for ever.
            if timeout(Duration::from_secs(3), &mut task).await.is_err() {
                task.abort();
            }
        }
        self.shared().lock().closed = true;
        self.shared().connected.store(false, Ordering::Release);
    }
}

fn check_key(key: &str) -> Result<()> {
    if key.is_empty() {
        return Err(MoosError::InvalidArgument(
            "variable name must not be empty".into(),
        ));
    }
    Ok(())
}

fn control_fields<'a>(name: &'a str, key: &'a str, interval: Option<f64>, now: f64) -> Fields<'a> {
    match interval {
        Some(i) => Fields::register(name, key, i, now),
        None => Fields::unregister(name, key, now),
    }
}

/// Connection manager: connect, run a session, back off, repeat until stopped.
async fn run(
    shared: Arc<Shared>,
    events: mpsc::Sender<MoosEvent>,
    mut stop: watch::Receiver<bool>,
) {
    let cfg = &shared.cfg;
    let mut backoff = cfg.reconnect_initial;
    loop {
        if *stop.borrow() {
            break;
        }
        let attempt = tokio::select! {
            r = connect(&shared) => r,
            _ = stop.changed() => break,
        };
        match attempt {
            Ok((stream, rbuf, welcome)) => {
                backoff = cfg.reconnect_initial;
                info!(name = %cfg.name, server = %cfg.server, community = %welcome.community, "connected to MOOSDB");
                on_connected(&shared, welcome);
                let _ = events.send(MoosEvent::Connected).await;
                let reason = session(&shared, stream, rbuf, &events, &mut stop).await;
                on_disconnected(&shared);
                info!(name = %cfg.name, %reason, "disconnected from MOOSDB");
                let _ = events.send(MoosEvent::Disconnected(reason)).await;
            }
            Err(e) => {
                inc(&shared.counters.connect_failures);
                if matches!(
                    e,
                    MoosError::Io(_) | MoosError::Timeout(_) | MoosError::Closed
                ) {
                    // Expected while the DB is down: keep it quiet.
                    debug!(name = %cfg.name, server = %cfg.server, error = %e, "MOOSDB connect failed; retrying in {backoff:?}");
                } else {
                    warn!(name = %cfg.name, server = %cfg.server, error = %e, "MOOSDB handshake failed; retrying in {backoff:?}");
                }
            }
        }
        if *stop.borrow() {
            break;
        }
        tokio::select! {
            _ = sleep(backoff) => {}
            _ = stop.changed() => break,
        }
        backoff = (backoff * 2).min(cfg.reconnect_max);
    }
    shared.lock().closed = true;
}

async fn connect(shared: &Shared) -> Result<(TcpStream, BytesMut, Welcome)> {
    let cfg = &shared.cfg;
    let fut = async {
        let mut stream = TcpStream::connect(cfg.server.as_str()).await?;
        stream.set_nodelay(true)?;
        // Banner and handshake in one write: the DB reads exactly 32 bytes for the banner.
        let mut out = BytesMut::with_capacity(256);
        out.put_slice(&BANNER);
        let hs = handshake_message(&cfg.name, shared.now());
        crate::codec::encode_packet([&hs], &mut out)?;
        stream.write_all(&out).await?;
        let dec = PacketDecoder::new(cfg.max_packet);
        let mut rbuf = BytesMut::with_capacity(4096);
        loop {
            if let Some(msgs) = dec.decode(&mut rbuf)? {
                let welcome = parse_handshake_reply(&msgs)?;
                return Ok((stream, rbuf, welcome));
            }
            rbuf.reserve(dec.bytes_needed(&rbuf)?.max(512));
            if stream.read_buf(&mut rbuf).await? == 0 {
                return Err(MoosError::Closed);
            }
        }
    };
    timeout(cfg.handshake_timeout, fut)
        .await
        .map_err(|_| MoosError::Timeout("connect and handshake"))?
}

fn on_connected(shared: &Shared, welcome: Welcome) {
    let name = shared.cfg.name.as_str();
    let now = shared.now();
    let mut st = shared.lock();
    st.connected = true;
    st.welcome = Some(welcome);
    // Whatever (un)registrations were pending belonged to the old connection; the full set
    // replaces them.
    st.ctrl.clear();
    let subs: Vec<(String, f64)> = st.subs.iter().map(|(k, v)| (k.clone(), *v)).collect();
    for (key, interval) in &subs {
        match st.encode(control_fields(name, key, Some(*interval), now)) {
            Ok(b) => st.ctrl.push_back(b),
            Err(e) => warn!(key = %key, error = %e, "cannot encode REGISTER"),
        }
    }
    drop(st);
    inc(&shared.counters.connects);
    shared.connected.store(true, Ordering::Release);
}

fn on_disconnected(shared: &Shared) {
    let mut st = shared.lock();
    st.connected = false;
    st.ctrl.clear();
    // What a post began to write belonged to the lost connection.
    st.direct = None;
    st.partial = None;
    st.writer_idle = false;
    drop(st);
    shared.connected.store(false, Ordering::Release);
    inc(&shared.counters.disconnects);
}

/// One connected session; returns why it ended.
async fn session(
    shared: &Shared,
    stream: TcpStream,
    rbuf: BytesMut,
    events: &mpsc::Sender<MoosEvent>,
    stop: &mut watch::Receiver<bool>,
) -> String {
    let (rd, wr) = stream.into_split();
    let wr = Arc::new(wr);
    {
        let mut st = shared.lock();
        st.direct = Some(wr.clone());
        st.writer_idle = false;
        st.partial = None;
    }
    tokio::select! {
        r = read_loop(shared, rd, rbuf, events) => r,
        w = write_loop(shared, &wr, stop) => w,
    }
}

async fn read_loop(
    shared: &Shared,
    mut rd: OwnedReadHalf,
    mut buf: BytesMut,
    events: &mpsc::Sender<MoosEvent>,
) -> String {
    let dec = PacketDecoder::new(shared.cfg.max_packet);
    let c = &shared.counters;
    loop {
        loop {
            let msgs = match dec.decode(&mut buf) {
                Ok(Some(m)) => m,
                Ok(None) => break,
                Err(e) => {
                    inc(&c.decode_errors);
                    warn!(name = %shared.cfg.name, error = %e, "malformed packet from MOOSDB; closing");
                    return format!("malformed packet from DB: {e}");
                }
            };
            inc(&c.packets_received);
            let mut mail = Vec::new();
            for m in msgs {
                match m.msg_type {
                    MsgType::Notify => {
                        inc(&c.mail_received);
                        if shared.cfg.mail_by_packet {
                            mail.push(m);
                        } else {
                            // Backpressure: a full event channel pauses reading from the DB.
                            let _ = events.send(MoosEvent::Mail(m)).await;
                        }
                    }
                    MsgType::Timing => inc(&c.timing_echoes),
                    MsgType::Poison => {
                        return format!(
                            "poisoned by DB: {}",
                            String::from_utf8_lossy(&m.string_val)
                        );
                    }
                    other => debug!(?other, "ignoring message from MOOSDB"),
                }
            }
            if !mail.is_empty() {
                let _ = events.send(MoosEvent::Packet(mail)).await;
            }
        }
        let need = match dec.bytes_needed(&buf) {
            Ok(n) => n,
            Err(e) => {
                inc(&c.decode_errors);
                return format!("malformed packet from DB: {e}");
            }
        };
        buf.reserve(need.max(8192));
        match rd.read_buf(&mut buf).await {
            Ok(0) => return "connection closed by DB".to_owned(),
            Ok(_) => crate::hops::hop("moos.client.read", &shared.cfg.name),
            Err(e) => return format!("read failed: {e}"),
        }
    }
}

/// Move encoded messages from `from` to `to` while they fit in `budget` bytes.
fn take_within(
    from: &mut VecDeque<Bytes>,
    to: &mut VecDeque<Bytes>,
    used: &mut usize,
    budget: usize,
) {
    while let Some(b) = from.front() {
        if *used + b.len() > budget && !to.is_empty() {
            break;
        }
        *used += b.len();
        if let Some(b) = from.pop_front() {
            to.push_back(b);
        }
    }
}

async fn write_loop(
    shared: &Shared,
    wr: &OwnedWriteHalf,
    stop: &mut watch::Receiver<bool>,
) -> String {
    let cfg = &shared.cfg;
    let c = &shared.counters;
    let budget = cfg.max_packet - HEADROOM;
    let mut last_timing: Option<Instant> = None;
    let mut buf = BytesMut::with_capacity(ARENA_CHUNK);
    let mut batch: VecDeque<Bytes> = VecDeque::new();
    loop {
        let stopping = *stop.borrow();
        let (more_waiting, partial) = {
            let mut st = shared.lock();
            st.writer_idle = false;
            let partial = st.partial.take();
            let mut used = 0;
            take_within(&mut st.ctrl, &mut batch, &mut used, budget);
            take_within(&mut st.outbox, &mut batch, &mut used, budget);
            (!st.ctrl.is_empty() || !st.outbox.is_empty(), partial)
        };
        // The rest of a packet a post began: before anything else, or the stream breaks.
        if let Some(p) = partial
            && let Err(e) = write_shared(wr, &p).await
        {
            return format!("write failed: {e}");
        }
        let timing_due = last_timing.is_none_or(|t| t.elapsed() >= cfg.heartbeat);
        if batch.is_empty() && !timing_due {
            if stopping {
                return "shut down".to_owned();
            }
            let next = last_timing.map_or_else(Instant::now, |t| t + cfg.heartbeat);
            {
                // Waiting from here: a post may now write directly (see `send_queued`).
                let mut st = shared.lock();
                if !(st.outbox.is_empty() && st.ctrl.is_empty() && st.partial.is_none()) {
                    continue;
                }
                st.writer_idle = true;
            }
            tokio::select! {
                _ = shared.wake.notified() => {}
                _ = sleep_until(next) => {}
                _ = stop.changed() => {}
            }
            continue;
        }
        buf.clear();
        let start = begin_packet(&mut buf);
        let mut n = 0;
        if timing_due {
            // Encoding a TIMING into a buffer we own cannot fail.
            if timing_message(shared.now()).encode(&mut buf).is_ok() {
                n += 1;
            }
            last_timing = Some(Instant::now());
            if batch.is_empty() && cfg.poll_held_mail {
                let null = Fields {
                    msg_type: MsgType::Null,
                    key: &[],
                    ..Fields::notify_double(&cfg.name, "", -1.0, shared.now())
                };
                if encode_fields(&mut buf, &null).is_ok() {
                    n += 1;
                }
            }
        }
        for b in batch.drain(..) {
            buf.put_slice(&b);
            n += 1;
        }
        if let Err(e) = finish_packet(&mut buf, start, n) {
            warn!(error = %e, "cannot frame packet");
            continue;
        }
        crate::hops::hop("moos.client.write", &cfg.name);
        if let Err(e) = write_shared(wr, &buf).await {
            return format!("write failed: {e}");
        }
        inc(&c.packets_sent);
        c.messages_sent.fetch_add(n as u64, Ordering::Relaxed);
        if stopping && !more_waiting {
            return "shut down".to_owned();
        }
    }
}
