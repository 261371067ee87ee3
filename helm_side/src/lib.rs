//! The helm side: every transport between the interface's bus and its helms, in one place. The
//! gateway carries the `interprocess` groups of `interface_yaml/` between this
//! process's bus and other processes or hosts. What is exported and imported follows from the
//! actors the process hosts (see [`plan`]); nothing is wired by hand. Key expression
//! `<platform>/<group with "::" → "/">`, payload the protobuf bytes, encoding
//! `application/protobuf;<message type>`, attachment the W3C traceparent of the publisher.
//! Kept out of frontseat-actors so that crate's tests do not pay Zenoh's build. The same plan
//! also drives a second transport, [`goby3`]: a client of an existing Goby3 system's gobyd. The
//! third, [`translation`], is Goby3's FrontSeatTranslation to a MOOSDB where pHelmIvP runs.
//! [`outlet`] stands in for a vehicle's interface on Zenoh or gobyd (`frontseat replay`).
//! Nothing here can end the process or touch the vehicle link: every one of them is a helm-side
//! child of the supervision tree.
#![forbid(unsafe_code)]

pub mod goby3;
pub mod hops;
pub mod outlet;
pub mod plan;
pub mod session;
pub mod translation;
pub mod wire;

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use frontseat_actors::bus::{Bus, Origin, PublishMeta, Subscription, TraceContext, Undeliverable};
use frontseat_actors::generated::{
    EncodedEnvelope, EncodedError, groups, interprocess_publish_encoded,
    interprocess_subscribe_encoded,
};
use frontseat_actors::service_child::{BoxFuture, Service};
use frontseat_actors::supervisor::ChildFailure;
use frontseat_config::InterprocessConfig;
use std::time::Duration;
use tokio::sync::mpsc;
use zenoh::Wait;
use zenoh::bytes::Encoding;
use zenoh::qos::CongestionControl;
use zenoh::sample::{Locality, Sample, SampleKind};

pub use plan::{Plan, Route, key_for, plan, routes};
pub use session::{client_config, zenoh_config};
/// The Zenoh this gateway is built with, for helms, tools and tests that talk to it directly.
pub use zenoh;

/// Largest imported payload by default. The biggest interprocess message is a Raw line (bounded
/// by the driver's line limit); anything near this is not a frontseat message.
pub const DEFAULT_MAX_PAYLOAD: usize = 64 * 1024;
/// Envelopes the exporter may hold in flight per group before the bus drops (and counts).
pub const DEFAULT_EXPORT_CAPACITY: usize = 4096;

/// One error type for the crate.
#[derive(Debug, thiserror::Error)]
pub enum GatewayError {
    #[error("the Zenoh platform name is empty")]
    EmptyPlatform,
    #[error(
        "platform {0:?} cannot be a key expression chunk: no '/', '*', '$', '?', '#' or surrounding spaces"
    )]
    BadPlatform(String),
    #[error("hosted actor {0:?} is not declared by any group in interface_yaml/")]
    UnknownActor(String),
    #[error("Zenoh config `{field}`: {reason}")]
    Config { field: String, reason: String },
    #[error("cannot open the Zenoh session: {0}")]
    Open(String),
    #[error("cannot declare the Zenoh {what} on `{key}`: {reason}")]
    Declare {
        what: &'static str,
        key: String,
        reason: String,
    },
    #[error("group `{0}` has no type-erased helper: interface_yaml/ and the gateway disagree")]
    NotInterprocess(String),
}

/// Tuning that the config file does not carry.
#[derive(Clone, Debug)]
pub struct GatewayOptions {
    /// Imported samples larger than this are refused and counted.
    pub max_payload: usize,
    /// Per exported group: envelopes waiting for Zenoh before the bus drops new ones.
    pub export_capacity: usize,
}

impl Default for GatewayOptions {
    fn default() -> Self {
        Self {
            max_payload: DEFAULT_MAX_PAYLOAD,
            export_capacity: DEFAULT_EXPORT_CAPACITY,
        }
    }
}

/// Counters, for status, metrics and tests.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GatewayStats {
    /// Messages put on Zenoh.
    pub exported: u64,
    /// Local deliveries not exported because they had been imported (no echo).
    pub not_echoed: u64,
    /// Puts that Zenoh refused.
    pub export_errors: u64,
    /// Samples decoded and published on the bus.
    pub imported: u64,
    /// Samples larger than `max_payload`.
    pub oversized: u64,
    /// Samples whose encoding names another type or format.
    pub wrong_type: u64,
    /// Samples whose bytes do not decode as the group's type.
    pub undecodable: u64,
    /// Attachments that are not a valid traceparent (the message itself is still imported).
    pub bad_traceparent: u64,
}

impl GatewayStats {
    /// Every refused sample.
    pub fn rejected(&self) -> u64 {
        self.oversized + self.wrong_type + self.undecodable
    }
}

#[derive(Default)]
struct Counters {
    exported: AtomicU64,
    not_echoed: AtomicU64,
    export_errors: AtomicU64,
    imported: AtomicU64,
    oversized: AtomicU64,
    wrong_type: AtomicU64,
    undecodable: AtomicU64,
    bad_traceparent: AtomicU64,
}

fn bump(c: &AtomicU64) -> u64 {
    c.fetch_add(1, Ordering::Relaxed) + 1
}

impl Counters {
    fn snapshot(&self) -> GatewayStats {
        let g = |c: &AtomicU64| c.load(Ordering::Relaxed);
        GatewayStats {
            exported: g(&self.exported),
            not_echoed: g(&self.not_echoed),
            export_errors: g(&self.export_errors),
            imported: g(&self.imported),
            oversized: g(&self.oversized),
            wrong_type: g(&self.wrong_type),
            undecodable: g(&self.undecodable),
            bad_traceparent: g(&self.bad_traceparent),
        }
    }
}

/// The running gateway. Dropping it stops the export task; [`GatewayHandle::close`] also
/// closes the Zenoh session in an orderly way.
pub struct GatewayHandle {
    session: zenoh::Session,
    plan: Plan,
    platform: String,
    counters: Arc<Counters>,
    bus_subs: Vec<Subscription>,
    export_task: tokio::task::JoinHandle<()>,
    _zenoh_subs: Vec<zenoh::pubsub::Subscriber<()>>,
}

impl std::fmt::Debug for GatewayHandle {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GatewayHandle")
            .field("platform", &self.platform)
            .field("plan", &self.plan)
            .field("stats", &self.stats())
            .finish()
    }
}

impl GatewayHandle {
    pub fn stats(&self) -> GatewayStats {
        self.counters.snapshot()
    }
    pub fn plan(&self) -> &Plan {
        &self.plan
    }
    pub fn platform(&self) -> &str {
        &self.platform
    }
    /// The Zenoh session, e.g. to add a liveliness token or read `info()`.
    pub fn session(&self) -> &zenoh::Session {
        &self.session
    }
    /// Resolves when the export task ended by itself (it only does when it failed): the reason.
    pub async fn ended(&mut self) -> String {
        let r = (&mut self.export_task).await;
        // A finished JoinHandle must not be polled again (`close` and drop only abort it).
        self.export_task = tokio::spawn(async {});
        match r {
            Ok(()) => "the Zenoh export task ended".into(),
            Err(e) => format!("the Zenoh export task failed: {e}"),
        }
    }

    /// Unsubscribes from the bus, stops exporting and closes the Zenoh session.
    pub async fn close(mut self) {
        for s in std::mem::take(&mut self.bus_subs) {
            s.cancel();
        }
        self.export_task.abort();
        if let Err(e) = self.session.close().await {
            tracing::warn!(error = %e, "closing the Zenoh session");
        }
    }
}

impl Drop for GatewayHandle {
    fn drop(&mut self) {
        self.export_task.abort();
    }
}

/// What a transport exports: a subscription to every group `plan` exports, delivering into one
/// channel tagged with the route's index. What was imported is never exported again: `echoed`
/// counts it instead. The bus bounds what is in flight per group (`capacity`), so the channel
/// cannot grow past that while the transport is slow.
pub(crate) type ExportFeed = (
    Vec<Subscription>,
    mpsc::UnboundedReceiver<(usize, EncodedEnvelope)>,
);

pub(crate) fn subscribe_exports(
    bus: &Bus,
    plan: &Plan,
    subscriber: &'static str,
    capacity: usize,
    echoed: impl Fn() + Clone + Send + Sync + 'static,
) -> Result<ExportFeed, GatewayError> {
    let (tx, rx) = mpsc::unbounded_channel::<(usize, EncodedEnvelope)>();
    let mut subs = Vec::with_capacity(plan.exports.len());
    for (i, r) in plan.exports.iter().enumerate() {
        let (tx, echoed) = (tx.clone(), echoed.clone());
        let sub = interprocess_subscribe_encoded(bus, r.group, subscriber, capacity, move |env| {
            if env.meta.origin.is_imported() {
                echoed();
                return Ok(());
            }
            crate::hops::hop("export.delivered", env.group);
            tx.send((i, env)).map_err(|_| Undeliverable)
        })
        .ok_or_else(|| GatewayError::NotInterprocess(r.group.to_string()))?;
        subs.push(sub);
    }
    Ok((subs, rx))
}

/// The Zenoh gateway as a child of the root supervisor.
impl Service for GatewayHandle {
    fn ended(&mut self) -> BoxFuture<'_, Result<(), ChildFailure>> {
        Box::pin(async move { Err(ChildFailure::new(GatewayHandle::ended(self).await)) })
    }
    fn stop(self: Box<Self>, within: Duration) -> BoxFuture<'static, ()> {
        Box::pin(async move {
            let stats = self.stats();
            let _ = tokio::time::timeout(within, (*self).close()).await;
            tracing::info!(?stats, "Zenoh gateway stopped");
        })
    }
}

/// Goby3's default platform name, used when neither `[interprocess] platform` nor `name` is set.
pub const DEFAULT_PLATFORM: &str = "default_goby_platform";
/// Goby3's application name of the interface, its gobyd client name by default
/// (middleware/application/detail/interprocess_common.h:35-36: client_name defaults to app.name).
pub const GOBY3_INTERFACE_APP: &str = "goby_frontseat_interface";

/// The platform name: `[interprocess] platform`, else the vehicle name, else Goby3's default.
pub fn resolve_platform(cfg: &InterprocessConfig, name: &str) -> Result<String, GatewayError> {
    let p = match (cfg.platform.as_str(), name) {
        ("", "") => DEFAULT_PLATFORM,
        ("", n) => n,
        (p, _) => p,
    };
    plan::check_platform(p)?;
    Ok(p.to_string())
}

/// Starts a gateway for a process hosting `hosted` actors (e.g. `["FrontSeatInterface"]`):
/// opens a Zenoh session from `cfg`, exports every interprocess group they publish and imports
/// every one they subscribe, on key expressions under `platform`.
pub async fn start(
    bus: &Bus,
    cfg: &InterprocessConfig,
    platform: &str,
    hosted: &[&str],
    opts: GatewayOptions,
) -> Result<GatewayHandle, GatewayError> {
    let plan = plan::plan(groups::ALL, platform, hosted)?;
    let config = zenoh_config(cfg, opts.max_payload)?;
    let session = zenoh::open(config)
        .await
        .map_err(|e| GatewayError::Open(e.to_string()))?;
    start_on(bus, session, plan, platform, opts).await
}

/// Like [`start`] on a session the caller opened (tests, embedding in a larger program).
pub async fn start_on(
    bus: &Bus,
    session: zenoh::Session,
    plan: Plan,
    platform: &str,
    opts: GatewayOptions,
) -> Result<GatewayHandle, GatewayError> {
    let counters = Arc::new(Counters::default());

    // Export: one publisher per group, one task draining every group in publish order.
    let mut publishers = Vec::with_capacity(plan.exports.len());
    for r in &plan.exports {
        let p = session
            .declare_publisher(r.key.clone())
            .encoding(Encoding::from(wire::encoding_for(r.type_name)))
            // Blocking keeps Zenoh from dropping silently; the bus bound in front of it drops
            // and counts instead, so a stalled link costs memory up to export_capacity only.
            .congestion_control(CongestionControl::Block)
            .allowed_destination(Locality::Remote)
            .await
            .map_err(|e| GatewayError::Declare {
                what: "publisher",
                key: r.key.clone(),
                reason: e.to_string(),
            })?;
        publishers.push(p);
    }
    let echoed = counters.clone();
    let (bus_subs, mut rx) = subscribe_exports(
        bus,
        &plan,
        "zenoh-gateway",
        opts.export_capacity,
        move || {
            echoed.not_echoed.fetch_add(1, Ordering::Relaxed);
        },
    )?;
    let c = counters.clone();
    let keys: Vec<String> = plan.exports.iter().map(|r| r.key.clone()).collect();
    let export_task = tokio::spawn(async move {
        while let Some((i, mut env)) = rx.recv().await {
            let bytes = std::mem::take(&mut env.bytes);
            let mut put = publishers[i].put(bytes);
            if let Some(t) = env
                .meta
                .trace
                .as_ref()
                .filter(|t| !t.traceparent.is_empty())
            {
                put = put.attachment(t.traceparent.clone());
            }
            match put.await {
                Ok(()) => {
                    c.exported.fetch_add(1, Ordering::Relaxed);
                }
                Err(e) => {
                    let n = bump(&c.export_errors);
                    if wire::worth_logging(n) {
                        tracing::warn!(key = %keys[i], error = %e, count = n, "Zenoh put failed");
                    }
                }
            }
            // `env` (and with it the bus's in-flight slot) is released only now.
            drop(env);
        }
    });

    // Import: a callback per group, decoding on Zenoh's thread straight onto the bus (the bus
    // never waits), so there is no extra hop.
    let mut zsubs = Vec::with_capacity(plan.imports.len());
    for r in &plan.imports {
        let bus = bus.clone();
        let c = counters.clone();
        let route = r.clone();
        let max = opts.max_payload;
        let sub = session
            .declare_subscriber(r.key.clone())
            .allowed_origin(Locality::Remote)
            .callback(move |sample| import_sample(&bus, &route, &c, max, sample))
            .await
            .map_err(|e| GatewayError::Declare {
                what: "subscriber",
                key: r.key.clone(),
                reason: e.to_string(),
            })?;
        zsubs.push(sub);
    }

    tracing::info!(
        platform,
        zid = %session.zid(),
        exports = ?plan.exports.iter().map(|r| r.key.as_str()).collect::<Vec<_>>(),
        imports = ?plan.imports.iter().map(|r| r.key.as_str()).collect::<Vec<_>>(),
        "Zenoh gateway running"
    );
    Ok(GatewayHandle {
        session,
        plan,
        platform: platform.to_string(),
        counters,
        bus_subs,
        export_task,
        _zenoh_subs: zsubs,
    })
}

fn import_sample(bus: &Bus, route: &Route, c: &Counters, max: usize, sample: Sample) {
    if sample.kind() == SampleKind::Delete {
        return;
    }
    let key = sample.key_expr().as_str();
    let encoding = sample.encoding().to_string();
    let len = sample.payload().len();
    match wire::check_sample(&encoding, len, max, route.type_name) {
        Ok(()) => {}
        Err(wire::Refusal::Oversized { len, max }) => {
            let n = bump(&c.oversized);
            if wire::worth_logging(n) {
                tracing::warn!(
                    key,
                    r#type = route.type_name,
                    len,
                    max,
                    count = n,
                    "oversized Zenoh payload refused"
                );
            }
            return;
        }
        Err(wire::Refusal::WrongType { encoding }) => {
            let n = bump(&c.wrong_type);
            if wire::worth_logging(n) {
                tracing::warn!(key, r#type = route.type_name, %encoding, count = n, "Zenoh payload of another type refused");
            }
            return;
        }
    }
    let trace = match sample.attachment() {
        None => None,
        Some(a) => match wire::parse_traceparent(&a.to_bytes()) {
            Some(traceparent) => Some(TraceContext { traceparent }),
            None => {
                let n = bump(&c.bad_traceparent);
                if wire::worth_logging(n) {
                    tracing::warn!(
                        key,
                        count = n,
                        "attachment is not a W3C traceparent; ignored"
                    );
                }
                None
            }
        },
    };
    let bytes = sample.payload().to_bytes();
    let meta = PublishMeta {
        trace,
        origin: Origin::Imported,
    };
    match interprocess_publish_encoded(bus, route.group, &bytes, meta) {
        Ok(_) => {
            c.imported.fetch_add(1, Ordering::Relaxed);
        }
        Err(EncodedError::Decode { reason, .. }) => {
            let n = bump(&c.undecodable);
            if wire::worth_logging(n) {
                tracing::warn!(key, r#type = route.type_name, len, %reason, count = n, "undecodable Zenoh payload refused");
            }
        }
        Err(EncodedError::UnknownGroup(g)) => {
            // The plan only holds interprocess groups, so this is a codegen/gateway mismatch.
            let n = bump(&c.undecodable);
            tracing::error!(key, group = %g, count = n, "imported group has no decoder");
        }
    }
}

/// Publishes one message on a Zenoh session the way the gateway does (encoding, attachment):
/// for helms and tools written in Rust.
pub fn put_message<M: prost::Message>(
    session: &zenoh::Session,
    key: &str,
    type_name: &str,
    msg: &M,
    traceparent: Option<&str>,
) -> zenoh::Result<()> {
    let mut put = session
        .put(key, msg.encode_to_vec())
        .encoding(Encoding::from(wire::encoding_for(type_name)));
    if let Some(tp) = traceparent {
        put = put.attachment(tp.to_string());
    }
    put.wait()
}
