//! The live view: the groups the recorder would record, served over the Foxglove WebSocket
//! protocol (`foxglove.websocket.v1`) so Foxglove or Lichtblick shows the vehicle as it runs.
//! One channel per group (topic = the Goby3 group, protobuf with the same self-contained
//! FileDescriptorSet the MCAP files carry). [`FoxgloveServer::start`] serves a bus's groups;
//! [`FoxgloveServer::serve`] hands back a [`LiveFeed`] instead, for a process whose channels
//! appear as it runs (the topside: `<platform>/<group>`), each advertised to every client when
//! added. Read-only: the server advertises no client
//! capability and answers anything but subscribe/unsubscribe with an error status; nothing a
//! client sends reaches the bus.
//!
//! Bounds: clients at once, subscriptions per client, inbound frame size; each client has its own
//! bounded queue and a slow one misses messages (counted), never slowing a publisher. Before the
//! upgrade, connections go through the web crate's connection bounds (`frontseat_web::conn`,
//! shared with the web scope and the topside's page): a limited number at once, the oldest
//! unfinished one (no upgrade yet) closed when a new one needs its slot, an upgrade request not
//! complete within `header_timeout` closed, a silent socket closed after `request_timeout` (all
//! counted). After it, the server pings every third of `request_timeout`, which keeps a quiet
//! but live client open, and a send that cannot complete within it (a client that stopped
//! reading) ends the client; an upgraded client is never closed to make room.
//!
//! Access: the upgrade passes the web pages' own check (`frontseat_web::auth::Access::
//! check_upgrade`): on loopback a foreign `Host` (DNS rebinding) is refused, a foreign `Origin`
//! (another site's page in the operator's browser) is refused unless listed in
//! `allowed_origins`, both with 403; the token as before (`?token=` or a Bearer header).

use std::collections::HashMap;
use std::net::SocketAddr;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant, SystemTime};

use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::extract::{Query, State};
use axum::http::{HeaderMap, StatusCode, header};
use axum::response::{IntoResponse, Response};
use base64::Engine as _;
use frontseat_actors::bus::{Bus, Subscription, Undeliverable};
use frontseat_actors::groups::GroupInfo;
use serde::Deserialize;
use tokio::sync::{Semaphore, broadcast};

use crate::time::unix_ns;

/// The one subprotocol spoken.
pub const SUBPROTOCOL: &str = "foxglove.websocket.v1";
/// Largest frame a client may send (subscribe lists are small).
const MAX_INBOUND: usize = 64 * 1024;
const MAX_SUBSCRIPTIONS: usize = 1024;
/// Most channels one server advertises (a topside: vehicles × groups).
pub const MAX_CHANNELS: usize = 4096;
const BUS_IN_FLIGHT: usize = 1024;
/// Connections beyond `max_clients` let in to be answered 503 (rather than reset) when full.
const HANDSHAKE_HEADROOM: usize = 8;

#[derive(Debug, thiserror::Error)]
pub enum FoxgloveError {
    #[error("record.foxglove.bind {0:?}: not an address and port like \"127.0.0.1:8765\"")]
    Bind(String),
    #[error(
        "record.foxglove.bind {0}: not a loopback address and no token: set record.foxglove.token"
    )]
    NeedsToken(SocketAddr),
    #[error("cannot listen on {addr}: {source}")]
    Listen {
        addr: SocketAddr,
        source: std::io::Error,
    },
    #[error("the compiled protobuf descriptors do not decode (a build defect)")]
    NoDescriptors,
}

/// Settings of the live server.
#[derive(Clone, Debug)]
pub struct FoxgloveOptions {
    pub bind: String,
    pub token: Option<String>,
    pub max_clients: usize,
    /// Messages queued per client. Unit: messages.
    pub client_queue: usize,
    /// Longest a connection may stay silent, or take from its request's first byte to an
    /// answer; also the ping period × 3 and the longest a send may block after the upgrade.
    pub request_timeout: Duration,
    /// Longest from a connection's start to a complete upgrade request head.
    pub header_timeout: Duration,
    /// Origins besides the server's own whose pages may connect (e.g.
    /// `https://app.foxglove.dev`).
    pub allowed_origins: Vec<String>,
}

impl FoxgloveOptions {
    /// The options of a `[record.foxglove]` (or the topside's `[foxglove]`) section, the token
    /// from the environment when set there.
    pub fn from_config(c: &frontseat_config::FoxgloveConfig) -> Self {
        Self {
            bind: c.bind.clone(),
            token: c.effective_token(),
            max_clients: c.max_clients,
            client_queue: c.client_queue,
            header_timeout: Duration::from_secs(c.header_timeout_s.max(1)),
            allowed_origins: c.allowed_origins.clone(),
            ..Default::default()
        }
    }
}

/// Default of [`FoxgloveOptions::request_timeout`].
pub const REQUEST_TIMEOUT: Duration = Duration::from_secs(10);

impl Default for FoxgloveOptions {
    fn default() -> Self {
        Self {
            bind: "127.0.0.1:8765".into(),
            token: None,
            max_clients: 8,
            client_queue: 1024,
            request_timeout: REQUEST_TIMEOUT,
            header_timeout: frontseat_web::conn::HEADER_TIMEOUT,
            allowed_origins: Vec::new(),
        }
    }
}

/// What the server counted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FoxgloveStats {
    pub clients: u64,
    pub refused: u64,
    /// Message-data frames handed to a client's socket.
    pub sent: u64,
    /// Messages a client's queue had no room for.
    pub lagged: u64,
    /// Client frames that were not a subscribe/unsubscribe the server understood.
    pub bad_requests: u64,
    /// Connections closed before their upgrade request was answered in time (slowloris).
    pub slow_requests: u64,
    /// Connections closed because their request head was not complete within the header
    /// timeout.
    pub header_timeouts: u64,
    /// Connections with no upgrade yet closed because a new connection needed their slot.
    pub evicted: u64,
    /// Connections closed at accept: every slot was held by an upgraded client or one being
    /// answered.
    pub connections_refused: u64,
    /// Upgrades refused for their Origin or Host (another site's page).
    pub foreign_site: u64,
}

#[derive(Default)]
struct Counters {
    clients: AtomicU64,
    refused: AtomicU64,
    sent: AtomicU64,
    lagged: AtomicU64,
    bad_requests: AtomicU64,
    foreign_site: AtomicU64,
}

struct Frame {
    channel: u32,
    time_ns: u64,
    bytes: Vec<u8>,
}

/// What every client hears: a message, or that channels were added (read from the registry).
enum Event {
    Frame(Frame),
    Advertised,
}

/// The channels advertised so far (channel id = index + 1), and the schemas already built.
#[derive(Default)]
struct Registry {
    channels: Vec<serde_json::Value>,
    schemas: HashMap<String, Option<String>>,
}

struct Shared {
    server_info: String,
    registry: std::sync::Mutex<Registry>,
    access: frontseat_web::auth::Access,
    tx: broadcast::Sender<Arc<Event>>,
    slots: Arc<Semaphore>,
    counters: Arc<Counters>,
    /// Ping period; a send blocked for three of them ends the client.
    ping: Duration,
}

/// The running server; dropping it (or [`FoxgloveServer::stop`]) closes it.
pub struct FoxgloveServer {
    addr: SocketAddr,
    subs: Vec<Subscription>,
    task: tokio::task::JoinHandle<()>,
    counters: Arc<Counters>,
    conns: Arc<frontseat_web::ServerCounters>,
}

impl std::fmt::Debug for FoxgloveServer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FoxgloveServer")
            .field("addr", &self.addr)
            .finish()
    }
}

impl FoxgloveServer {
    /// Binds and serves `groups` (those `wants` lets through). Must be called inside a tokio
    /// runtime. `name` is the server name clients show (the vehicle).
    pub fn start(
        bus: &Bus,
        groups: &[GroupInfo],
        wants: impl Fn(&str) -> bool,
        opts: &FoxgloveOptions,
        name: &str,
    ) -> Result<Self, FoxgloveError> {
        let (mut server, feed) = Self::serve(opts, name)?;
        let (t0, wall0) = (Instant::now(), unix_ns(SystemTime::now()));
        for g in groups.iter().filter(|g| wants(g.name)) {
            let Some(id) = feed.add_channel(g.name, g.type_name) else {
                continue;
            };
            let feed = feed.clone();
            let sub = frontseat_actors::generated::subscribe_encoded(
                bus,
                g.name,
                "foxglove",
                BUS_IN_FLIGHT,
                move |env| {
                    let since = env
                        .published_at
                        .checked_duration_since(t0)
                        .unwrap_or_default();
                    let time_ns =
                        wall0.saturating_add(u64::try_from(since.as_nanos()).unwrap_or(0));
                    feed.publish(id, time_ns, env.bytes);
                    Ok::<(), Undeliverable>(())
                },
            );
            if let Some(s) = sub {
                server.subs.push(s);
            }
        }
        tracing::info!(addr = %server.addr, channels = server.subs.len(), "foxglove live server (read-only) listening");
        Ok(server)
    }

    /// Binds and serves no channel yet: the [`LiveFeed`] adds channels and publishes on them.
    /// Must be called inside a tokio runtime. `name` is the server name clients show.
    pub fn serve(opts: &FoxgloveOptions, name: &str) -> Result<(Self, LiveFeed), FoxgloveError> {
        let addr: SocketAddr = opts
            .bind
            .parse()
            .map_err(|_| FoxgloveError::Bind(opts.bind.clone()))?;
        let token = opts.token.clone().filter(|t| !t.is_empty());
        if !addr.ip().is_loopback() && token.is_none() {
            return Err(FoxgloveError::NeedsToken(addr));
        }
        crate::schema::compiled_pool().ok_or(FoxgloveError::NoDescriptors)?;
        let std_listener = std::net::TcpListener::bind(addr)
            .and_then(|l| l.set_nonblocking(true).map(|()| l))
            .map_err(|source| FoxgloveError::Listen { addr, source })?;
        let listener = tokio::net::TcpListener::from_std(std_listener)
            .map_err(|source| FoxgloveError::Listen { addr, source })?;
        let local = listener
            .local_addr()
            .map_err(|source| FoxgloveError::Listen { addr, source })?;

        let (tx, _) = broadcast::channel::<Arc<Event>>(opts.client_queue.clamp(16, 1 << 16));
        let counters = Arc::new(Counters::default());
        let wall0 = unix_ns(SystemTime::now());
        let shared = Arc::new(Shared {
            server_info: serde_json::json!({
                "op": "serverInfo",
                "name": format!("frontseat {name}"),
                "capabilities": [],
                "supportedEncodings": [],
                "metadata": {"vehicle": name, "read_only": "true"},
                "sessionId": format!("{wall0}"),
            })
            .to_string(),
            registry: std::sync::Mutex::new(Registry::default()),
            access: frontseat_web::auth::Access::new(local, token)
                .with_allowed_origins(&opts.allowed_origins),
            tx,
            slots: Arc::new(Semaphore::new(opts.max_clients.max(1))),
            counters: counters.clone(),
            ping: (opts.request_timeout / 3).max(Duration::from_millis(10)),
        });
        let feed = LiveFeed {
            shared: shared.clone(),
        };
        let app = axum::Router::new()
            .route("/", axum::routing::get(upgrade))
            .with_state(shared);
        let conns = Arc::new(frontseat_web::ServerCounters::default());
        let bounded = frontseat_web::conn::BoundedListener::new(
            listener,
            frontseat_web::conn::ConnLimits {
                max_connections: opts.max_clients.max(1).saturating_add(HANDSHAKE_HEADROOM),
                idle: opts.request_timeout.max(Duration::from_millis(10)),
                header_timeout: opts.header_timeout.max(Duration::from_millis(10)),
            },
            conns.clone(),
            "foxglove",
        );
        let task = tokio::spawn(bounded.serve(app));
        Ok((
            Self {
                addr: local,
                subs: Vec::new(),
                task,
                counters,
                conns,
            },
            feed,
        ))
    }

    /// The address bound (the port when 0 was asked).
    pub fn local_addr(&self) -> SocketAddr {
        self.addr
    }

    pub fn stats(&self) -> FoxgloveStats {
        let g = |c: &AtomicU64| c.load(Ordering::Relaxed);
        let c = &self.counters;
        FoxgloveStats {
            clients: g(&c.clients),
            refused: g(&c.refused),
            sent: g(&c.sent),
            lagged: g(&c.lagged),
            bad_requests: g(&c.bad_requests),
            slow_requests: g(&self.conns.slow_requests),
            header_timeouts: g(&self.conns.header_timeouts),
            evicted: g(&self.conns.evicted),
            connections_refused: g(&self.conns.connections_refused),
            foreign_site: g(&c.foreign_site),
        }
    }

    pub fn stop(mut self) -> FoxgloveStats {
        self.close();
        self.stats()
    }

    fn close(&mut self) {
        for s in self.subs.drain(..) {
            s.cancel();
        }
        self.task.abort();
    }
}

impl Drop for FoxgloveServer {
    fn drop(&mut self) {
        self.close();
    }
}

/// Adds channels to a running server and publishes on them; cheap to clone. Never waits: a
/// message nobody watches is dropped at once, and a slow client misses messages (counted).
#[derive(Clone)]
pub struct LiveFeed {
    shared: Arc<Shared>,
}

impl std::fmt::Debug for LiveFeed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("LiveFeed")
    }
}

impl LiveFeed {
    /// Advertises a channel `topic` of protobuf type `type_name` (its schema from the compiled
    /// descriptors) to every client, now and later; its id, or `None` when the type is unknown
    /// or [`MAX_CHANNELS`] are advertised already.
    pub fn add_channel(&self, topic: &str, type_name: &str) -> Option<u32> {
        let mut r = self
            .shared
            .registry
            .lock()
            .unwrap_or_else(|p| p.into_inner());
        if r.channels.len() >= MAX_CHANNELS {
            return None;
        }
        let schema = match r.schemas.get(type_name) {
            Some(s) => s.clone(),
            None => {
                let s = crate::schema::compiled_pool()
                    .and_then(|pool| crate::schema::descriptor_set(pool, type_name))
                    .map(|d| base64::engine::general_purpose::STANDARD.encode(d));
                r.schemas.insert(type_name.to_string(), s.clone());
                s
            }
        }?;
        let id = u32::try_from(r.channels.len() + 1).ok()?;
        r.channels.push(serde_json::json!({
            "id": id,
            "topic": topic,
            "encoding": "protobuf",
            "schemaName": type_name,
            "schema": schema,
            "schemaEncoding": "protobuf",
        }));
        drop(r);
        // No client yet: the next one reads the registry when it connects.
        let _ = self.shared.tx.send(Arc::new(Event::Advertised));
        Some(id)
    }

    /// True while a client is connected (so a caller may skip building a message).
    pub fn watched(&self) -> bool {
        self.shared.tx.receiver_count() > 0
    }

    /// Sends `bytes` (the encoded message) on `channel`, stamped `time_ns` (ns since the Unix
    /// epoch), to the clients subscribed to it.
    pub fn publish(&self, channel: u32, time_ns: u64, bytes: Vec<u8>) {
        // Nobody watching: nothing to do.
        if !self.watched() {
            return;
        }
        // A send fails only when every client left since the check: fine.
        let _ = self.shared.tx.send(Arc::new(Event::Frame(Frame {
            channel,
            time_ns,
            bytes,
        })));
    }
}

#[derive(Deserialize)]
struct TokenQuery {
    token: Option<String>,
}

async fn upgrade(
    State(s): State<Arc<Shared>>,
    Query(q): Query<TokenQuery>,
    headers: HeaderMap,
    ws: WebSocketUpgrade,
) -> Response {
    use frontseat_web::auth::Refusal;
    match s.access.check_upgrade(&headers, q.token.as_deref()) {
        Ok(()) => {}
        Err(Refusal::ForeignSite) => {
            s.counters.refused.fetch_add(1, Ordering::Relaxed);
            let n = s.counters.foreign_site.fetch_add(1, Ordering::Relaxed) + 1;
            // Rate-limited: the 1st, 2nd, 4th … refusal is logged.
            if n.is_power_of_two() {
                let origin = headers.get(header::ORIGIN).and_then(|v| v.to_str().ok());
                tracing::warn!(
                    ?origin,
                    refused = n,
                    "foxglove: upgrade from another site refused (Origin or Host; see allowed_origins)"
                );
            }
            return (StatusCode::FORBIDDEN, Refusal::ForeignSite.text()).into_response();
        }
        Err(_) => {
            s.counters.refused.fetch_add(1, Ordering::Relaxed);
            return (StatusCode::UNAUTHORIZED, "a token is required (?token=)").into_response();
        }
    }
    let offered = headers
        .get_all(header::SEC_WEBSOCKET_PROTOCOL)
        .iter()
        .filter_map(|v| v.to_str().ok())
        .flat_map(|v| v.split(','))
        .any(|p| p.trim() == SUBPROTOCOL);
    if !offered {
        s.counters.refused.fetch_add(1, Ordering::Relaxed);
        return (
            StatusCode::BAD_REQUEST,
            "this server speaks the foxglove.websocket.v1 subprotocol only",
        )
            .into_response();
    }
    let Ok(permit) = s.slots.clone().try_acquire_owned() else {
        s.counters.refused.fetch_add(1, Ordering::Relaxed);
        return (StatusCode::SERVICE_UNAVAILABLE, "too many clients").into_response();
    };
    ws.protocols([SUBPROTOCOL])
        .max_message_size(MAX_INBOUND)
        .max_frame_size(MAX_INBOUND)
        .on_upgrade(move |socket| async move {
            s.counters.clients.fetch_add(1, Ordering::Relaxed);
            client(socket, &s).await;
            drop(permit);
        })
}

#[derive(Deserialize)]
#[serde(tag = "op", rename_all = "camelCase")]
enum ClientOp {
    Subscribe {
        subscriptions: Vec<SubscribeItem>,
    },
    Unsubscribe {
        #[serde(rename = "subscriptionIds")]
        subscription_ids: Vec<u32>,
    },
}

#[derive(Deserialize)]
struct SubscribeItem {
    id: u32,
    #[serde(rename = "channelId")]
    channel_id: u32,
}

fn status(level: u8, message: &str) -> Message {
    Message::Text(
        serde_json::json!({"op": "status", "level": level, "message": message})
            .to_string()
            .into(),
    )
}

/// Sends `m`, false when the client is gone or did not take it within three ping periods.
async fn send(socket: &mut WebSocket, m: Message, s: &Shared) -> bool {
    matches!(
        tokio::time::timeout(s.ping * 3, socket.send(m)).await,
        Ok(Ok(()))
    )
}

/// The `advertise` op for the channels past the first `known`, and how many are known after it;
/// `None` when there is nothing new.
fn advertise_new(s: &Shared, known: usize) -> Option<(Message, usize)> {
    let r = s.registry.lock().unwrap_or_else(|p| p.into_inner());
    let new = r.channels.get(known..).filter(|n| !n.is_empty())?;
    let text = serde_json::json!({"op": "advertise", "channels": new}).to_string();
    Some((Message::Text(text.into()), r.channels.len()))
}

async fn client(mut socket: WebSocket, s: &Shared) {
    // Subscribed before the registry is read: a channel added in between is in the snapshot
    // or announced by an event, never missed.
    let mut rx = s.tx.subscribe();
    if !send(&mut socket, Message::Text(s.server_info.clone().into()), s).await {
        return;
    }
    // Channels this client was told of (ids 1..=known); Foxglove expects an advertise op at
    // the start even when it lists none.
    let mut known = 0usize;
    let first = match advertise_new(s, 0) {
        Some((m, n)) => {
            known = n;
            m
        }
        None => Message::Text(
            serde_json::json!({"op": "advertise", "channels": []})
                .to_string()
                .into(),
        ),
    };
    if !send(&mut socket, first, s).await {
        return;
    }
    // channel id -> subscription id
    let mut subscribed: HashMap<u32, u32> = HashMap::new();
    let mut ping = tokio::time::interval(s.ping);
    ping.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    loop {
        tokio::select! {
            _ = ping.tick() => {
                if !send(&mut socket, Message::Ping(Default::default()), s).await {
                    return;
                }
            }
            inbound = socket.recv() => {
                let reply = match inbound {
                    None | Some(Err(_)) | Some(Ok(Message::Close(_))) => return,
                    Some(Ok(Message::Text(t))) => handle(&t, &mut subscribed, known, s),
                    Some(Ok(Message::Binary(_))) => {
                        s.counters.bad_requests.fetch_add(1, Ordering::Relaxed);
                        Some(status(2, "read-only server: client publishing is not offered"))
                    }
                    Some(Ok(_)) => None,
                };
                if let Some(r) = reply
                    && !send(&mut socket, r, s).await
                {
                    return;
                }
            }
            event = rx.recv() => {
                let f = match event.as_deref() {
                    Ok(Event::Frame(f)) => f,
                    // Missed events may have been advertisements: the registry has them all.
                    Ok(Event::Advertised) | Err(broadcast::error::RecvError::Lagged(_)) => {
                        if let Err(broadcast::error::RecvError::Lagged(n)) = event {
                            s.counters.lagged.fetch_add(n, Ordering::Relaxed);
                        }
                        if let Some((m, n)) = advertise_new(s, known) {
                            known = n;
                            if !send(&mut socket, m, s).await {
                                return;
                            }
                        }
                        continue;
                    }
                    Err(broadcast::error::RecvError::Closed) => return,
                };
                let Some(sub) = subscribed.get(&f.channel) else { continue };
                let mut b = Vec::with_capacity(13 + f.bytes.len());
                b.push(0x01);
                b.extend(sub.to_le_bytes());
                b.extend(f.time_ns.to_le_bytes());
                b.extend(&f.bytes);
                // Counted as handed to the socket: counted after the send, a frame could reach
                // the client before the count did (a stats read in between missed it).
                s.counters.sent.fetch_add(1, Ordering::Relaxed);
                if !send(&mut socket, Message::Binary(b.into()), s).await {
                    return;
                }
            }
        }
    }
}

fn handle(
    text: &str,
    subscribed: &mut HashMap<u32, u32>,
    known: usize,
    s: &Shared,
) -> Option<Message> {
    let op: ClientOp = match serde_json::from_str(text) {
        Ok(op) => op,
        Err(_) => {
            s.counters.bad_requests.fetch_add(1, Ordering::Relaxed);
            return Some(status(
                2,
                "unsupported request: this read-only server takes subscribe and unsubscribe only",
            ));
        }
    };
    match op {
        ClientOp::Subscribe { subscriptions } => {
            for it in subscriptions {
                let advertised = it.channel_id >= 1 && (it.channel_id as usize) <= known;
                if !advertised || subscribed.len() >= MAX_SUBSCRIPTIONS {
                    s.counters.bad_requests.fetch_add(1, Ordering::Relaxed);
                    return Some(status(
                        2,
                        &format!("cannot subscribe to channel {}", it.channel_id),
                    ));
                }
                subscribed.insert(it.channel_id, it.id);
            }
            None
        }
        ClientOp::Unsubscribe { subscription_ids } => {
            subscribed.retain(|_, sub| !subscription_ids.contains(sub));
            None
        }
    }
}
