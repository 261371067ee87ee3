//! A small MOOSDB: enough of `MOOSDB` (protocol.md §2, §6, §8) for tests and for users without
//! MOOS-IvP at hand. Asynchronous clients only. It keeps what the captures show MOOSDB doing:
//! banner check, WELCOME / POISON (duplicate name), TIMING echo first in the reply, held mail
//! released only by packets carrying more than a TIMING message and pushed to every client after
//! any NOTIFY, the current value sent on REGISTER (id -1), interval-limited delivery (dropped, not
//! delayed), wildcard registration, type locking, community stamping, the silent-client timeout,
//! and trusting `source` for subscriptions. Not implemented: synchronous clients, SERVER_REQUEST,
//! the DB_* status variables.

use std::collections::{HashMap, VecDeque};
use std::net::SocketAddr;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};
use std::time::Duration;

use bytes::{Bytes, BytesMut};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::tcp::OwnedWriteHalf;
use tokio::net::{TcpListener, TcpSocket, TcpStream, lookup_host};
use tokio::sync::{Notify, watch};
use tokio::task::{JoinHandle, JoinSet};
use tokio::time::timeout;
use tracing::{debug, info, warn};

use crate::codec::{
    ASYNC_KEY, BANNER_LEN, DataType, MoosMessage, MsgType, PACKET_HEADER_LEN, PacketDecoder, Text,
    banner_ok, begin_packet, finish_packet,
};
use crate::error::{MoosError, Result};
use crate::sock::write_shared;
use crate::time::moos_time;

/// Broker configuration.
#[derive(Clone, Debug)]
pub struct BrokerConfig {
    /// Community name sent in the WELCOME and stamped on NOTIFYs (default `frontseat`).
    pub community: String,
    /// Host name reported in the WELCOME (`hostname=<it>`); default: this machine's.
    pub hostname: String,
    /// A client silent for longer than this is disconnected (default 5 s, as MOOSDB).
    pub client_timeout: Duration,
    /// MOOSTimeWarp for the DB's own time stamps (default 1).
    pub time_warp: f64,
    /// Largest packet accepted or sent (default 1 MiB).
    pub max_packet: usize,
    /// Packets queued for one client's socket before further ones are dropped (default 1024).
    pub client_queue: usize,
}

impl Default for BrokerConfig {
    fn default() -> Self {
        BrokerConfig {
            community: "frontseat".to_owned(),
            hostname: local_hostname(),
            client_timeout: Duration::from_secs(5),
            time_warp: 1.0,
            max_packet: crate::codec::DEFAULT_MAX_PACKET,
            client_queue: 1024,
        }
    }
}

fn local_hostname() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .ok()
        .map(|s| s.trim().to_owned())
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| "localhost".to_owned())
}

/// A snapshot of the broker's counters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BrokerCounters {
    /// Clients that completed the handshake.
    pub clients_welcomed: u64,
    /// Connections refused: bad banner, bad hello, duplicate name.
    pub clients_refused: u64,
    /// Clients dropped for silence.
    pub clients_timed_out: u64,
    /// Packets received from clients.
    pub packets_received: u64,
    /// NOTIFYs stored.
    pub notifies: u64,
    /// NOTIFYs rejected because the variable has another type.
    pub type_rejected: u64,
    /// Malformed packets (each closes its connection).
    pub decode_errors: u64,
    /// Packets not delivered because a client's queue was full.
    pub dropped_packets: u64,
}

#[derive(Default)]
struct Counters {
    clients_welcomed: AtomicU64,
    clients_refused: AtomicU64,
    clients_timed_out: AtomicU64,
    packets_received: AtomicU64,
    notifies: AtomicU64,
    type_rejected: AtomicU64,
    decode_errors: AtomicU64,
    dropped_packets: AtomicU64,
}

fn inc(c: &AtomicU64) {
    c.fetch_add(1, Ordering::Relaxed);
}

struct Subscription {
    interval: f64,
    last_sent: f64,
}

struct Var {
    data_type: DataType,
    writes: u64,
    /// The last accepted NOTIFY (community already stamped).
    last: Option<MoosMessage>,
    subscribers: HashMap<Text, Subscription>,
}

impl Var {
    fn new(data_type: DataType) -> Self {
        Var {
            data_type,
            writes: 0,
            last: None,
            subscribers: HashMap::new(),
        }
    }
}

#[derive(Clone, PartialEq)]
struct Filter {
    app: String,
    var: String,
    interval: f64,
}

impl Filter {
    fn parse(spec: &[u8]) -> Filter {
        let spec = String::from_utf8_lossy(spec);
        let mut f = Filter {
            app: String::new(),
            var: String::new(),
            interval: 0.0,
        };
        for kv in spec.split(',') {
            let Some((k, v)) = kv.split_once('=') else {
                continue;
            };
            let v = v.trim();
            match k.trim().to_ascii_lowercase().as_str() {
                "apppattern" => f.app = v.to_owned(),
                "varpattern" => f.var = v.to_owned(),
                "interval" => f.interval = v.parse().unwrap_or(0.0),
                _ => {}
            }
        }
        f
    }

    fn matches(&self, source: &[u8], key: &[u8]) -> bool {
        glob(self.app.as_bytes(), source) && glob(self.var.as_bytes(), key)
    }
}

/// `*` = any run, `?` = any one byte.
fn glob(pat: &[u8], s: &[u8]) -> bool {
    let (mut p, mut i) = (0, 0);
    let mut star: Option<(usize, usize)> = None;
    while i < s.len() {
        if p < pat.len() && (pat[p] == b'?' || pat[p] == s[i]) {
            p += 1;
            i += 1;
        } else if p < pat.len() && pat[p] == b'*' {
            star = Some((p, i));
            p += 1;
        } else if let Some((sp, si)) = star {
            p = sp + 1;
            i = si + 1;
            star = Some((sp, si + 1));
        } else {
            return false;
        }
    }
    pat[p..].iter().all(|&c| c == b'*')
}

struct ClientSlot {
    conn: u64,
    out: Arc<Outbound>,
}

/// What goes to one client: its connection's write half, a bounded queue and its writer task's
/// state. A packet is written straight from the thread that routes it (a non-blocking write)
/// while the writer task waits for work, which spares every forwarded packet a wake-up of the
/// writer (issue 49); otherwise, or for the rest of a packet the socket took only part of, the
/// writer task sends it, in order.
struct Outbound {
    wr: OwnedWriteHalf,
    st: Mutex<OutState>,
    wake: Notify,
    limit: usize,
    /// The client's name, for the bench's hop stamps (`crate::hops`).
    name: String,
}

struct OutState {
    queue: VecDeque<Bytes>,
    /// The writer task waits for work (set and cleared under this lock, so a packet is written
    /// directly only while the writer is not writing).
    writer_idle: bool,
}

impl Outbound {
    fn lock(&self) -> MutexGuard<'_, OutState> {
        self.st.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// Sends `pkt` now or queues it; false when the queue is full and it was dropped.
    fn push(&self, pkt: Bytes) -> bool {
        let mut st = self.lock();
        if st.writer_idle && st.queue.is_empty() {
            crate::hops::hop("moos.broker.write", &self.name);
            // An error other than WouldBlock is the writer's to meet (it ends the connection).
            let n = self.wr.try_write(&pkt).unwrap_or(0);
            if n == pkt.len() {
                return true;
            }
            st.queue.push_back(pkt.slice(n..));
            st.writer_idle = false;
        } else if st.queue.len() >= self.limit {
            return false;
        } else {
            st.queue.push_back(pkt);
        }
        drop(st);
        self.wake.notify_one();
        true
    }

    /// The writer task: sends what is queued, in order, until the connection fails.
    async fn run(self: Arc<Self>) {
        loop {
            let next = {
                let mut st = self.lock();
                let next = st.queue.pop_front();
                st.writer_idle = next.is_none();
                next
            };
            match next {
                Some(pkt) => {
                    crate::hops::hop("moos.broker.write", &self.name);
                    if write_shared(&self.wr, &pkt).await.is_err() {
                        return;
                    }
                }
                None => self.wake.notified().await,
            }
        }
    }
}

#[derive(Default)]
struct Db {
    vars: HashMap<Text, Var>,
    clients: HashMap<Text, ClientSlot>,
    held: HashMap<Text, Vec<MoosMessage>>,
    filters: HashMap<Text, Vec<Filter>>,
}

struct Shared {
    cfg: BrokerConfig,
    db: Mutex<Db>,
    counters: Counters,
    community: Text,
}

impl Shared {
    fn lock(&self) -> MutexGuard<'_, Db> {
        self.db.lock().unwrap_or_else(PoisonError::into_inner)
    }
    fn now(&self) -> f64 {
        moos_time(self.cfg.time_warp)
    }

    /// Send `msgs` to `client` in as many packets as the size limit requires.
    fn send(&self, db: &Db, client: &Text, msgs: &[MoosMessage]) {
        let Some(slot) = db.clients.get(client) else {
            return;
        };
        let max = self.cfg.max_packet;
        let mut i = 0;
        while i < msgs.len() {
            let mut buf = BytesMut::new();
            let start = begin_packet(&mut buf);
            let mut n = 0;
            while i < msgs.len() {
                let len = msgs[i].encoded_len();
                if n > 0 && buf.len() + len > max {
                    break;
                }
                if msgs[i].encode(&mut buf).is_err() {
                    warn!(key = %msgs[i].key, "cannot encode message; skipped");
                } else {
                    n += 1;
                }
                i += 1;
            }
            if n == 0 || finish_packet(&mut buf, start, n).is_err() {
                continue;
            }
            if !slot.out.push(buf.freeze()) {
                inc(&self.counters.dropped_packets);
                warn!(client = %client, "client send queue full; packet dropped");
            }
        }
    }

    fn on_packet(&self, who: &Text, msgs: Vec<MoosMessage>) {
        let now = self.now();
        let mut db = self.lock();
        let mut msgs = msgs.into_iter().peekable();
        let echo = msgs
            .next_if(|m| m.msg_type == MsgType::Timing)
            .map(|mut t| {
                t.double_val = now;
                t.double_val2 = 0.0;
                t
            });
        let mut rest = false;
        let mut notified = false;
        for m in msgs {
            rest = true;
            match m.msg_type {
                MsgType::Notify => {
                    notified = true;
                    self.on_notify(&mut db, m, now);
                }
                MsgType::Register => self.on_register(&mut db, &m, now),
                MsgType::WildcardRegister => self.on_wildcard(&mut db, &m, now, true),
                MsgType::Unregister => {
                    if let Some(v) = db.vars.get_mut(&m.key) {
                        v.subscribers.remove(&m.source);
                    }
                }
                MsgType::WildcardUnregister => self.on_wildcard(&mut db, &m, now, false),
                other => debug!(?other, client = %who, "ignored"),
            }
        }
        let mut reply: Vec<MoosMessage> = echo.into_iter().collect();
        // The DB adds held mail only when the packet held more than its leading TIMING.
        if let Some(h) = db.held.get_mut(who).filter(|_| rest) {
            reply.append(h);
        }
        if !reply.is_empty() {
            self.send(&db, who, &reply);
        }
        if notified {
            let waiting: Vec<Text> = db
                .held
                .iter()
                .filter(|(n, h)| !h.is_empty() && db.clients.contains_key(*n))
                .map(|(n, _)| n.clone())
                .collect();
            for name in waiting {
                let mail = db
                    .held
                    .get_mut(&name)
                    .map(std::mem::take)
                    .unwrap_or_default();
                self.send(&db, &name, &mail);
            }
        }
    }

    fn on_notify(&self, db: &mut Db, mut m: MoosMessage, now: f64) {
        let Db {
            vars,
            held,
            filters,
            ..
        } = db;
        let var = vars
            .entry(m.key.clone())
            .or_insert_with(|| Var::new(m.data_type));
        if var.writes == 0 {
            var.data_type = m.data_type;
            for (client, fs) in filters.iter() {
                for f in fs
                    .iter()
                    .filter(|f| f.matches(m.source.as_bytes(), m.key.as_bytes()))
                {
                    var.subscribers.insert(
                        client.clone(),
                        Subscription {
                            interval: f.interval,
                            last_sent: f64::NEG_INFINITY,
                        },
                    );
                }
            }
        }
        if var.data_type != m.data_type {
            inc(&self.counters.type_rejected);
            warn!(key = %m.key, var_type = ?var.data_type, msg_type = ?m.data_type, source = %m.source,
                "attempting to update a variable with another data type; dropped");
            return;
        }
        inc(&self.counters.notifies);
        if m.community.is_empty() {
            m.community = self.community.clone();
        }
        var.writes += 1;
        for (client, sub) in var.subscribers.iter_mut() {
            if now - sub.last_sent >= sub.interval {
                sub.last_sent = now;
                held.entry(client.clone()).or_default().push(m.clone());
            }
        }
        var.last = Some(m);
    }

    fn on_register(&self, db: &mut Db, m: &MoosMessage, now: f64) {
        if m.source.is_empty() {
            warn!(key = %m.key, "failed to add subscription for a client with empty name");
            return;
        }
        let var = db
            .vars
            .entry(m.key.clone())
            .or_insert_with(|| Var::new(DataType::NotSet));
        let interval = if m.double_val.is_finite() {
            m.double_val.max(0.0)
        } else {
            0.0
        };
        let sub = var
            .subscribers
            .entry(m.source.clone())
            .or_insert(Subscription {
                interval,
                last_sent: f64::NEG_INFINITY,
            });
        sub.interval = interval;
        if let Some(last) = &var.last {
            let mut current = last.clone();
            current.id = -1;
            sub.last_sent = now;
            db.held.entry(m.source.clone()).or_default().push(current);
        }
    }

    fn on_wildcard(&self, db: &mut Db, m: &MoosMessage, now: f64, register: bool) {
        if m.source.is_empty() {
            return;
        }
        let f = Filter::parse(&m.string_val);
        let matching: Vec<Text> = db
            .vars
            .iter()
            .filter(|(k, v)| {
                let src = v.last.as_ref().map(|l| l.source.as_bytes()).unwrap_or(&[]);
                f.matches(src, k.as_bytes())
            })
            .map(|(k, _)| k.clone())
            .collect();
        if register {
            let fs = db.filters.entry(m.source.clone()).or_default();
            if !fs.contains(&f) {
                fs.push(f.clone());
            }
            for key in matching {
                let mut r = MoosMessage::new(MsgType::Register, DataType::Double, key);
                r.source = m.source.clone();
                r.double_val = f.interval;
                self.on_register(db, &r, now);
            }
        } else {
            if let Some(fs) = db.filters.get_mut(&m.source) {
                fs.retain(|g| !(g.app == f.app && g.var == f.var));
            }
            for key in matching {
                if let Some(v) = db.vars.get_mut(&key) {
                    v.subscribers.remove(&m.source);
                }
            }
        }
    }

    fn on_disconnect(&self, who: &Text, conn: u64) {
        let mut db = self.lock();
        if db.clients.get(who).is_none_or(|s| s.conn != conn) {
            return;
        }
        db.clients.remove(who);
        db.held.remove(who);
        db.filters.remove(who);
        for v in db.vars.values_mut() {
            v.subscribers.remove(who);
        }
    }
}

/// The broker. Use [`Broker::bind`] (default config) or [`Broker::bind_with`].
pub struct Broker;

impl Broker {
    /// Listen on `addr` (e.g. `127.0.0.1:9000`, or port 0 for any free port) with defaults.
    pub async fn bind(addr: impl tokio::net::ToSocketAddrs) -> Result<BrokerHandle> {
        Broker::bind_with(addr, BrokerConfig::default()).await
    }

    /// Listen on `addr` with `cfg`. The socket uses SO_REUSEADDR so that a broker can be
    /// restarted on the same port at once.
    pub async fn bind_with(
        addr: impl tokio::net::ToSocketAddrs,
        cfg: BrokerConfig,
    ) -> Result<BrokerHandle> {
        if cfg.max_packet < PACKET_HEADER_LEN + crate::codec::MESSAGE_MIN_LEN
            || cfg.client_queue == 0
            || !(cfg.time_warp.is_finite() && cfg.time_warp > 0.0)
        {
            return Err(MoosError::InvalidArgument(
                "broker max_packet, client_queue or time_warp out of range".into(),
            ));
        }
        let addr = lookup_host(addr)
            .await?
            .next()
            .ok_or_else(|| MoosError::InvalidArgument("address resolves to nothing".into()))?;
        let sock = if addr.is_ipv4() {
            TcpSocket::new_v4()?
        } else {
            TcpSocket::new_v6()?
        };
        sock.set_reuseaddr(true)?;
        sock.bind(addr)?;
        let listener = sock.listen(1024)?;
        let local_addr = listener.local_addr()?;
        let shared = Arc::new(Shared {
            community: Text::from(cfg.community.as_str()),
            cfg,
            db: Mutex::new(Db::default()),
            counters: Counters::default(),
        });
        let (stop_tx, stop_rx) = watch::channel(false);
        let task = tokio::spawn(accept_loop(listener, shared.clone(), stop_rx));
        info!(%local_addr, "MOOS broker listening");
        Ok(BrokerHandle {
            local_addr,
            shared,
            stop: stop_tx,
            task: Some(task),
        })
    }
}

/// A running broker. Dropping it stops the broker too (without waiting).
pub struct BrokerHandle {
    local_addr: SocketAddr,
    shared: Arc<Shared>,
    stop: watch::Sender<bool>,
    task: Option<JoinHandle<()>>,
}

impl BrokerHandle {
    /// The address it listens on.
    pub fn local_addr(&self) -> SocketAddr {
        self.local_addr
    }

    /// Names of the connected clients, sorted.
    pub fn client_names(&self) -> Vec<String> {
        let db = self.shared.lock();
        let mut v: Vec<String> = db.clients.keys().map(|k| k.to_string()).collect();
        v.sort();
        v
    }

    /// A snapshot of the counters.
    pub fn counters(&self) -> BrokerCounters {
        let c = &self.shared.counters;
        let g = |a: &AtomicU64| a.load(Ordering::Relaxed);
        BrokerCounters {
            clients_welcomed: g(&c.clients_welcomed),
            clients_refused: g(&c.clients_refused),
            clients_timed_out: g(&c.clients_timed_out),
            packets_received: g(&c.packets_received),
            notifies: g(&c.notifies),
            type_rejected: g(&c.type_rejected),
            decode_errors: g(&c.decode_errors),
            dropped_packets: g(&c.dropped_packets),
        }
    }

    /// Stop listening, close every client connection and wait until all of it is done; the port
    /// can be bound again afterwards.
    pub async fn shutdown(mut self) {
        let _ = self.stop.send(true);
        if let Some(task) = self.task.take() {
            let _ = task.await;
        }
    }
}

impl Drop for BrokerHandle {
    fn drop(&mut self) {
        let _ = self.stop.send(true);
    }
}

async fn accept_loop(listener: TcpListener, shared: Arc<Shared>, mut stop: watch::Receiver<bool>) {
    let mut conns = JoinSet::new();
    let mut next_conn = 0u64;
    loop {
        tokio::select! {
            r = listener.accept() => match r {
                Ok((stream, peer)) => {
                    next_conn += 1;
                    conns.spawn(serve(shared.clone(), stream, peer, next_conn, stop.clone()));
                }
                Err(e) => {
                    warn!(error = %e, "accept failed");
                    tokio::time::sleep(Duration::from_millis(50)).await;
                }
            },
            Some(_) = conns.join_next(), if !conns.is_empty() => {}
            _ = stop.changed() => break,
        }
    }
    drop(listener);
    while conns.join_next().await.is_some() {}
    let mut db = shared.lock();
    *db = Db::default();
}

async fn serve(
    shared: Arc<Shared>,
    stream: TcpStream,
    peer: SocketAddr,
    conn: u64,
    mut stop: watch::Receiver<bool>,
) {
    tokio::select! {
        r = serve_inner(&shared, stream, conn) => {
            if let Err(e) = r {
                debug!(%peer, error = %e, "client connection ended");
            }
        }
        _ = stop.changed() => {}
    }
}

/// Read one packet within the client timeout.
async fn read_packet(
    shared: &Shared,
    rd: &mut tokio::net::tcp::OwnedReadHalf,
    buf: &mut BytesMut,
    dec: &PacketDecoder,
) -> Result<Vec<MoosMessage>> {
    loop {
        match dec.decode(buf) {
            Ok(Some(m)) => return Ok(m),
            Ok(None) => {}
            Err(e) => {
                inc(&shared.counters.decode_errors);
                warn!(error = %e, "malformed packet from a client; closing its connection");
                return Err(e);
            }
        }
        buf.reserve(dec.bytes_needed(buf)?.max(8192));
        match timeout(shared.cfg.client_timeout, rd.read_buf(buf)).await {
            Err(_) => return Err(MoosError::Timeout("client silent")),
            Ok(Ok(0)) => return Err(MoosError::Closed),
            Ok(Ok(_)) => {}
            Ok(Err(e)) => return Err(e.into()),
        }
    }
}

fn poison(text: &str) -> Bytes {
    let mut m = MoosMessage::new(MsgType::Poison, DataType::String, Text::new());
    m.time = moos_time(1.0);
    m.string_val = Bytes::copy_from_slice(text.as_bytes());
    let mut buf = BytesMut::new();
    // A small message into our own buffer: encoding cannot fail.
    let _ = crate::codec::encode_packet([&m], &mut buf);
    buf.freeze()
}

async fn serve_inner(shared: &Arc<Shared>, stream: TcpStream, conn: u64) -> Result<()> {
    stream.set_nodelay(true)?;
    let (mut rd, mut wr) = stream.into_split();
    let cfg = &shared.cfg;
    let mut banner = [0u8; BANNER_LEN];
    match timeout(cfg.client_timeout, rd.read_exact(&mut banner)).await {
        Ok(Ok(_)) => {}
        Ok(Err(e)) => return Err(e.into()),
        Err(_) => return Err(MoosError::Timeout("banner")),
    }
    if !banner_ok(&banner) {
        inc(&shared.counters.clients_refused);
        let text = String::from_utf8_lossy(&banner).into_owned();
        warn!(banner = ?text, "incompatible wire protocol; closing");
        return Err(MoosError::BadBanner(text));
    }
    let dec = PacketDecoder::new(cfg.max_packet);
    let mut buf = BytesMut::with_capacity(8192);
    let hello = read_packet(shared, &mut rd, &mut buf, &dec).await?;
    let hello = match hello.as_slice() {
        [m] if m.msg_type == MsgType::Data && !m.string_val.is_empty() => m.clone(),
        _ => {
            inc(&shared.counters.clients_refused);
            wr.write_all(&poison("failed to read the client name"))
                .await?;
            return Err(MoosError::UnexpectedHandshake("no client name".into()));
        }
    };
    let name = Text::from(hello.string_val.clone());
    if hello.key != ASYNC_KEY {
        inc(&shared.counters.clients_refused);
        wr.write_all(&poison("this broker only serves asynchronous clients"))
            .await?;
        return Err(MoosError::UnexpectedHandshake("synchronous client".into()));
    }
    // Not idle until the writer task runs: what is routed here before the WELCOME waits.
    let out = Arc::new(Outbound {
        wr,
        st: Mutex::new(OutState {
            queue: VecDeque::new(),
            writer_idle: false,
        }),
        wake: Notify::new(),
        limit: cfg.client_queue,
        name: String::from_utf8_lossy(name.as_bytes()).into_owned(),
    });
    let duplicate = {
        let mut db = shared.lock();
        let duplicate = db.clients.contains_key(&name);
        if !duplicate {
            db.clients.insert(
                name.clone(),
                ClientSlot {
                    conn,
                    out: out.clone(),
                },
            );
        }
        duplicate
    };
    if duplicate {
        inc(&shared.counters.clients_refused);
        let text = format!("A client of this name (\"{name}\") already exists");
        warn!("{text}");
        write_shared(&out.wr, &poison(&text)).await?;
        return Err(MoosError::Poisoned(text));
    }
    let now = shared.now();
    let mut w = MoosMessage::new(MsgType::Welcome, DataType::Double, Text::new());
    w.source_aux = Text::from(format!("hostname={}", cfg.hostname));
    w.community = shared.community.clone();
    w.time = now;
    w.double_val = now - hello.time;
    w.string_val = Bytes::from_static(ASYNC_KEY.as_bytes());
    let mut wb = BytesMut::new();
    crate::codec::encode_packet([&w], &mut wb)?;
    if let Err(e) = write_shared(&out.wr, &wb).await {
        shared.on_disconnect(&name, conn);
        return Err(e.into());
    }
    inc(&shared.counters.clients_welcomed);
    info!(client = %name, "client connected");

    let from = out.name.clone();
    let writer = tokio::spawn(out.clone().run());
    // Abort the writer however this function ends (including being dropped on shutdown).
    let _writer_guard = AbortOnDrop(writer);
    let result = loop {
        match read_packet(shared, &mut rd, &mut buf, &dec).await {
            Ok(msgs) => {
                crate::hops::hop("moos.broker.read", &from);
                inc(&shared.counters.packets_received);
                shared.on_packet(&name, msgs);
            }
            Err(MoosError::Timeout(_)) => {
                inc(&shared.counters.clients_timed_out);
                warn!(client = %name, "disconnecting after {:?} of silence", cfg.client_timeout);
                break Err(MoosError::Timeout("client silent"));
            }
            Err(e) => break Err(e),
        }
    };
    shared.on_disconnect(&name, conn);
    info!(client = %name, "client disconnected");
    result
}

struct AbortOnDrop(JoinHandle<()>);

impl Drop for AbortOnDrop {
    fn drop(&mut self) {
        self.0.abort();
    }
}

#[cfg(test)]
mod tests {
    use super::glob;

    #[test]
    fn glob_matches_like_moos_wildcards() {
        assert!(glob(b"*", b""));
        assert!(glob(b"CAPW_*", b"CAPW_ONE"));
        assert!(!glob(b"CAPW_*", b"CAP_ONE"));
        assert!(glob(b"?AV_*", b"NAV_X"));
        assert!(glob(b"*_X", b"NAV_X"));
        assert!(!glob(b"*_X", b"NAV_Y"));
        assert!(glob(b"a*b*c", b"axxbyyc"));
    }
}
