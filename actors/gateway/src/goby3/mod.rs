//! The Goby3 transport of the gateway: makes this process a client of an existing Goby3 system's
//! gobyd, like any Goby3 application. The groups come from the same [`crate::plan`] as Zenoh's
//! (every interprocess group a hosted actor publishes goes out, every one it subscribes comes
//! in), framed as Goby3 does (`/group/PROTOBUF/type/pid/thread/` NUL payload, see [`frame`]);
//! what was imported is never exported again. The connection lives in a background task
//! ([`link`]) that never blocks the bus: gobyd absent, restarted or gone is logged, counted,
//! retried with capped backoff, and reported as the bus link [`GOBY3_LINK`].

pub mod frame;
mod link;
pub mod manager;
pub mod standin;

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Duration;

use frontseat_actors::bus::{Bus, GOBY3_LINK, Origin, PublishMeta, Subscription, Undeliverable};
use frontseat_actors::generated::{
    EncodedEnvelope, EncodedError, groups, interprocess_publish_encoded,
    interprocess_subscribe_encoded,
};
use frontseat_config::{Goby3Config, Goby3Transport};
use tokio::sync::{mpsc, watch};

use crate::{DEFAULT_PLATFORM, GatewayError, GatewayOptions, Plan, plan, wire};
pub use manager::Transport;

/// Everything the link needs, resolved from `[goby3]` and the vehicle name.
#[derive(Clone, Debug, PartialEq)]
pub struct Goby3Settings {
    pub platform: String,
    pub transport: Transport,
    pub client_name: String,
    pub manager_timeout: Duration,
    pub settle: Duration,
    pub reconnect_initial: Duration,
    pub reconnect_max: Duration,
}

impl Goby3Settings {
    /// The platform is `[goby3] platform`, else the vehicle `name`, else Goby3's default.
    pub fn from_config(cfg: &Goby3Config, name: &str) -> Result<Self, GatewayError> {
        let platform = match (cfg.platform.as_str(), name) {
            ("", "") => DEFAULT_PLATFORM,
            ("", n) => n,
            (p, _) => p,
        };
        if platform.contains(['/', '\0']) {
            return Err(GatewayError::BadPlatform(platform.to_string()));
        }
        let transport = match cfg.transport {
            Goby3Transport::Ipc => Transport::ipc_for_platform(platform, &cfg.socket_name),
            Goby3Transport::Tcp => Transport::Tcp {
                address: cfg.ip_address.clone(),
                port: cfg.tcp_port,
            },
        };
        let secs = |s: f64| Duration::try_from_secs_f64(s).unwrap_or(Duration::from_secs(5));
        Ok(Self {
            platform: platform.to_string(),
            transport,
            client_name: cfg.client_name.clone(),
            manager_timeout: secs(cfg.manager_timeout_seconds),
            settle: Duration::from_millis(cfg.settle_ms),
            reconnect_initial: Duration::from_millis(cfg.reconnect_initial_ms.max(1)),
            reconnect_max: Duration::from_millis(cfg.reconnect_max_ms.max(1)),
        })
    }
}

/// Counters and the link flag, for status, metrics and tests.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Goby3Stats {
    /// Whether the handshake is done, the hold released and the sockets connected.
    pub link_up: bool,
    /// Completed joins (handshake + hold + settle), the first one included.
    pub connects: u64,
    /// Times an up link went down (gobyd stopped or restarted).
    pub link_losses: u64,
    /// Join attempts that failed (gobyd absent, no answer, a bad answer).
    pub connect_failures: u64,
    /// Frames published to gobyd.
    pub exported: u64,
    /// Local deliveries not exported because they had been imported (no echo).
    pub not_echoed: u64,
    /// Local publications dropped because gobyd was not reachable (Goby3 loses these too).
    pub dropped_link_down: u64,
    /// Publications the PUB socket refused.
    pub export_errors: u64,
    /// Frames decoded and published on the bus.
    pub imported: u64,
    /// Our own frames coming back through gobyd, dropped.
    pub own_echo: u64,
    /// Received messages that are not a frame (see [`frame::FrameError`]) or have several parts.
    pub malformed: u64,
    /// Frames whose payload does not decode as the group's type.
    pub undecodable: u64,
    /// Well-formed frames of a group, type or scheme we do not import.
    pub unexpected: u64,
}

impl Goby3Stats {
    /// Every refused inbound message.
    pub fn rejected(&self) -> u64 {
        self.malformed + self.undecodable + self.unexpected
    }
}

#[derive(Default)]
pub(crate) struct Counters {
    link_up: AtomicBool,
    connects: AtomicU64,
    link_losses: AtomicU64,
    connect_failures: AtomicU64,
    exported: AtomicU64,
    not_echoed: AtomicU64,
    dropped_link_down: AtomicU64,
    export_errors: AtomicU64,
    imported: AtomicU64,
    own_echo: AtomicU64,
    malformed: AtomicU64,
    undecodable: AtomicU64,
    unexpected: AtomicU64,
}

pub(crate) fn bump(c: &AtomicU64) -> u64 {
    c.fetch_add(1, Ordering::Relaxed) + 1
}

impl Counters {
    fn snapshot(&self) -> Goby3Stats {
        let g = |c: &AtomicU64| c.load(Ordering::Relaxed);
        Goby3Stats {
            link_up: self.link_up.load(Ordering::Relaxed),
            connects: g(&self.connects),
            link_losses: g(&self.link_losses),
            connect_failures: g(&self.connect_failures),
            exported: g(&self.exported),
            not_echoed: g(&self.not_echoed),
            dropped_link_down: g(&self.dropped_link_down),
            export_errors: g(&self.export_errors),
            imported: g(&self.imported),
            own_echo: g(&self.own_echo),
            malformed: g(&self.malformed),
            undecodable: g(&self.undecodable),
            unexpected: g(&self.unexpected),
        }
    }
}

/// Who we are on the wire: the pid and "thread" every frame of ours carries.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Origin3 {
    pub pid: i32,
    pub thread: u64,
}

impl Origin3 {
    /// This process. The thread id only has to be hex, stable for the process and unlikely to
    /// collide with another client's (Goby3 hashes its main thread's id), so a hash of the pid
    /// and the start time will do.
    pub fn this_process() -> Self {
        use std::hash::{BuildHasher, Hash, Hasher};
        let pid = i32::try_from(std::process::id()).unwrap_or(i32::MAX);
        let mut h = std::collections::hash_map::RandomState::new().build_hasher();
        pid.hash(&mut h);
        std::time::SystemTime::now().hash(&mut h);
        Self {
            pid,
            thread: h.finish().max(1),
        }
    }
}

/// Turns outgoing envelopes into frames.
pub(crate) struct Exporter {
    routes: Vec<(String, &'static str)>,
    me: Origin3,
}

impl Exporter {
    pub(crate) fn encode(&self, i: usize, env: &EncodedEnvelope) -> Option<Vec<u8>> {
        let (group, ty) = self.routes.get(i)?;
        Some(frame::encode(
            group,
            ty,
            self.me.pid,
            self.me.thread,
            &env.bytes,
        ))
    }
}

/// Turns received messages into bus publications, or counts why not.
pub(crate) struct Importer {
    bus: Bus,
    /// (wire group, type, bus group)
    routes: Vec<(String, &'static str, &'static str)>,
    me: Origin3,
    max: usize,
    counters: Arc<Counters>,
}

impl Importer {
    /// The ZeroMQ prefixes to subscribe: exactly the imported (group, type) pairs.
    pub(crate) fn prefixes(&self) -> Vec<String> {
        self.routes
            .iter()
            .map(|(g, t, _)| frame::subscription_prefix(g, t))
            .collect()
    }

    pub(crate) fn handle_parts(&self, parts: &[&[u8]]) {
        match parts {
            [one] => self.handle(one),
            _ => {
                // Goby3 would parse every part as a frame of its own (and likely abort).
                let n = bump(&self.counters.malformed);
                if wire::worth_logging(n) {
                    tracing::warn!(
                        parts = parts.len(),
                        count = n,
                        "multi-part message from gobyd refused"
                    );
                }
            }
        }
    }

    /// One frame from gobyd.
    pub fn handle(&self, bytes: &[u8]) {
        let c = &self.counters;
        let f = match frame::decode(bytes, self.max) {
            Ok(f) => f,
            Err(e) => {
                let n = bump(&c.malformed);
                if wire::worth_logging(n) {
                    let head: String = String::from_utf8_lossy(&bytes[..bytes.len().min(120)])
                        .chars()
                        .filter(|c| !c.is_control())
                        .collect();
                    tracing::warn!(error = %e, len = bytes.len(), %head, count = n, "malformed Goby3 frame refused");
                }
                return;
            }
        };
        if f.pid == self.me.pid && f.thread == self.me.thread {
            c.own_echo.fetch_add(1, Ordering::Relaxed);
            return;
        }
        let route = self
            .routes
            .iter()
            .find(|(g, t, _)| g == f.group && *t == f.type_name);
        let Some((_, ty, group)) = route.filter(|_| f.scheme == frame::SCHEME_PROTOBUF) else {
            let n = bump(&c.unexpected);
            if wire::worth_logging(n) {
                tracing::warn!(
                    group = f.group,
                    scheme = f.scheme,
                    r#type = f.type_name,
                    count = n,
                    "Goby3 frame of a group/type we do not import"
                );
            }
            return;
        };
        let meta = PublishMeta {
            trace: None,
            origin: Origin::Imported,
        };
        match interprocess_publish_encoded(&self.bus, group, f.payload, meta) {
            Ok(_) => {
                c.imported.fetch_add(1, Ordering::Relaxed);
            }
            Err(EncodedError::Decode { reason, .. }) => {
                let n = bump(&c.undecodable);
                if wire::worth_logging(n) {
                    tracing::warn!(group, r#type = *ty, pid = f.pid, len = f.payload.len(), %reason, count = n, "undecodable Goby3 payload refused");
                }
            }
            Err(EncodedError::UnknownGroup(g)) => {
                let n = bump(&c.undecodable);
                tracing::error!(group = %g, count = n, "imported group has no decoder");
            }
        }
    }
}

/// The running Goby3 transport. Dropping it stops the link task; [`Goby3Handle::close`] also
/// unsubscribes from the bus.
pub struct Goby3Handle {
    plan: Plan,
    settings: Goby3Settings,
    me: Origin3,
    counters: Arc<Counters>,
    bus_subs: Vec<Subscription>,
    stop: watch::Sender<bool>,
    task: tokio::task::JoinHandle<()>,
}

impl std::fmt::Debug for Goby3Handle {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Goby3Handle")
            .field("settings", &self.settings)
            .field("stats", &self.stats())
            .finish()
    }
}

impl Goby3Handle {
    pub fn stats(&self) -> Goby3Stats {
        self.counters.snapshot()
    }
    pub fn link_up(&self) -> bool {
        self.counters.link_up.load(Ordering::Relaxed)
    }
    pub fn plan(&self) -> &Plan {
        &self.plan
    }
    pub fn settings(&self) -> &Goby3Settings {
        &self.settings
    }
    /// The pid and thread id our frames carry.
    pub fn origin(&self) -> Origin3 {
        self.me
    }
    /// Unsubscribes from the bus and ends the link (sockets closed, nothing more sent).
    pub async fn close(mut self) {
        for s in std::mem::take(&mut self.bus_subs) {
            s.cancel();
        }
        let _ = self.stop.send(true);
        let task = std::mem::replace(&mut self.task, tokio::spawn(async {}));
        if tokio::time::timeout(Duration::from_secs(2), task)
            .await
            .is_err()
        {
            tracing::warn!("Goby3 link did not stop within 2 s");
        }
    }
}

impl Drop for Goby3Handle {
    fn drop(&mut self) {
        self.task.abort();
    }
}

/// Starts the Goby3 transport for a process hosting `hosted` actors (e.g.
/// `["FrontSeatInterface"]`). Returns at once: joining gobyd happens in the background, and
/// until it has, local publications are dropped and counted. Needs a tokio runtime.
pub fn start(
    bus: &Bus,
    settings: Goby3Settings,
    hosted: &[&str],
    opts: GatewayOptions,
) -> Result<Goby3Handle, GatewayError> {
    let plan = plan::routes(groups::ALL, hosted)?;
    let counters = Arc::new(Counters::default());
    let me = Origin3::this_process();

    let (tx, rx) = mpsc::unbounded_channel::<(usize, EncodedEnvelope)>();
    let mut bus_subs = Vec::with_capacity(plan.exports.len());
    for (i, r) in plan.exports.iter().enumerate() {
        let tx = tx.clone();
        let c = counters.clone();
        // The bus bounds what is in flight per group (export_capacity): the channel cannot grow
        // past that even while gobyd is slow.
        let sub = interprocess_subscribe_encoded(
            bus,
            r.group,
            "goby3-gateway",
            opts.export_capacity,
            move |env| {
                if env.meta.origin == Origin::Imported {
                    c.not_echoed.fetch_add(1, Ordering::Relaxed);
                    return Ok(());
                }
                tx.send((i, env)).map_err(|_| Undeliverable)
            },
        )
        .ok_or_else(|| GatewayError::NotInterprocess(r.group.to_string()))?;
        bus_subs.push(sub);
    }
    drop(tx);

    let exporter = Exporter {
        routes: plan
            .exports
            .iter()
            .map(|r| (r.group.to_string(), r.type_name))
            .collect(),
        me,
    };
    let importer = Importer {
        bus: bus.clone(),
        routes: plan
            .imports
            .iter()
            .map(|r| (r.group.to_string(), r.type_name, r.group))
            .collect(),
        me,
        max: opts.max_payload,
        counters: counters.clone(),
    };
    bus.set_link_up(GOBY3_LINK, false);
    let (stop, stop_rx) = watch::channel(false);
    let task = tokio::spawn(link::run(
        link::Link {
            settings: settings.clone(),
            me,
            counters: counters.clone(),
            bus: bus.clone(),
        },
        exporter,
        importer,
        rx,
        stop_rx,
    ));
    tracing::info!(
        platform = %settings.platform,
        manager = %settings.transport.manager_endpoint(),
        client_name = %settings.client_name,
        exports = ?plan.exports.iter().map(|r| r.group).collect::<Vec<_>>(),
        imports = ?plan.imports.iter().map(|r| r.group).collect::<Vec<_>>(),
        "Goby3 transport started; joining gobyd in the background"
    );
    Ok(Goby3Handle {
        plan,
        settings,
        me,
        counters,
        bus_subs,
        stop,
        task,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_resolve_platform_and_transport_like_goby3() {
        let mut cfg = Goby3Config::default();
        let s = Goby3Settings::from_config(&cfg, "").unwrap();
        assert_eq!(s.platform, DEFAULT_PLATFORM);
        assert_eq!(
            s.transport.manager_endpoint(),
            "ipc:///tmp/goby_default_goby_platform.manager"
        );
        let s = Goby3Settings::from_config(&cfg, "auv1").unwrap();
        assert_eq!(s.platform, "auv1");
        cfg.platform = "zp3".into();
        cfg.transport = Goby3Transport::Tcp;
        cfg.tcp_port = 11150;
        let s = Goby3Settings::from_config(&cfg, "auv1").unwrap();
        assert_eq!(s.transport.manager_endpoint(), "tcp://127.0.0.1:11150");
        cfg.platform = "a/b".into();
        assert!(Goby3Settings::from_config(&cfg, "").is_err());
    }

    #[test]
    fn our_thread_id_is_never_zero() {
        assert_ne!(Origin3::this_process().thread, 0);
    }
}
