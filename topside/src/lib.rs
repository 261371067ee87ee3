//! `frontseat topside -c FILE`: every vehicle of a fleet on one page. A Zenoh subscriber of what
//! the vehicles' interfaces publish (`*/goby/middleware/frontseat/node_status`, `status`) and of
//! what their helms command (`desired_course`), with the platform taken from the key expression;
//! a [`fleet`] model (bounded, stale-not-removed); each vehicle's [`scope`] (every interprocess
//! group heard under its platform, newest message decoded on request); and an HTTP page served
//! with the web crate's access rules (loopback by default, Host check, optional token) and
//! bounded listener.
//!
//! The topside publishes nothing itself: a command for a vehicle is relayed ([`relay`]) to that
//! vehicle's own page, which checks that vehicle's token, so its interface's gates decide. The
//! page's commander form is the vehicle page's own (`form.js`, the same schema).
//!
//! `[record]` writes every sample the fleet model took in (decoded, of a platform it tracks) to
//! MCAP, channel `<platform>/<group>`, stamped with its receive time, through the recorder's
//! bounded queue: the Zenoh callback never waits for the disk.
#![forbid(unsafe_code)]

pub mod ais;
pub mod chart;
pub mod config;
pub mod fleet;
pub mod live;
pub mod relay;
pub mod scope;

use std::collections::BTreeMap;
use std::net::SocketAddr;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use axum::Router;
use axum::extract::{Query, State};
use axum::http::header::{CACHE_CONTROL, CONTENT_TYPE};
use axum::http::{HeaderMap, HeaderValue};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use frontseat_actors::bus::Layer;
use frontseat_actors::groups::{self, GroupInfo};
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    DesiredCourse, InterfaceStatus, NodeStatus,
};
use frontseat_actors::service_child::{BoxFuture, Service};
use frontseat_actors::supervisor::ChildFailure;
use frontseat_config::{InterprocessConfig, InterprocessMode};
use frontseat_record::recorder::{RecordMeta, RecorderOptions};
use frontseat_record::{RecordInput, Recorder};
use frontseat_web::auth::Access;
use prost::Message;
use serde::Deserialize;
use serde_json::json;

pub use config::TopsideConfig;
use fleet::{Fleet, Refused};
use scope::Scope;

const INDEX_HTML: &str = include_str!("../assets/topside.html");

#[derive(Debug, thiserror::Error)]
pub enum TopsideError {
    #[error("web.listen `{0}` is not an address and port")]
    BadListen(String),
    #[error("cannot listen on {addr}: {source}")]
    Bind {
        addr: SocketAddr,
        source: std::io::Error,
    },
    #[error(
        "{} is set but shorter than {} characters",
        config::TOKEN_ENV,
        frontseat_config::MIN_TOKEN_CHARS
    )]
    ShortEnvToken,
    #[error("Zenoh: {0}")]
    Zenoh(String),
    #[error("record: {0}")]
    Record(#[from] frontseat_record::RecorderError),
    #[error("foxglove: {0}")]
    Foxglove(#[from] frontseat_record::foxglove::FoxgloveError),
    #[error("{0}")]
    Chart(#[from] chart::ChartError),
}

/// What came in over Zenoh and what was refused; on the page and in the logs.
#[derive(Debug, Default)]
pub struct Counters {
    pub accepted: AtomicU64,
    pub oversized: AtomicU64,
    pub undecodable: AtomicU64,
    pub bad_key: AtomicU64,
    pub implausible: AtomicU64,
    pub too_many_vehicles: AtomicU64,
}

impl Counters {
    fn json(&self) -> serde_json::Value {
        let g = |c: &AtomicU64| c.load(Ordering::Relaxed);
        json!({
            "accepted": g(&self.accepted),
            "oversized": g(&self.oversized),
            "undecodable": g(&self.undecodable),
            "bad_key": g(&self.bad_key),
            "implausible": g(&self.implausible),
            "too_many_vehicles": g(&self.too_many_vehicles),
        })
    }
}

/// The token in force: the environment's when set, else the config's.
pub fn effective_token(cfg: &TopsideConfig) -> Result<Option<String>, TopsideError> {
    match std::env::var(config::TOKEN_ENV) {
        Ok(t) if t.chars().count() < frontseat_config::MIN_TOKEN_CHARS => {
            Err(TopsideError::ShortEnvToken)
        }
        Ok(t) => Ok(Some(t)),
        Err(_) => Ok(cfg.web.token.clone()),
    }
}

#[derive(Clone)]
struct AppState {
    fleet: Arc<Mutex<Fleet>>,
    scope: Arc<Mutex<Scope>>,
    access: Access,
    counters: Arc<Counters>,
    links: Arc<BTreeMap<String, String>>,
}

/// Which of the groups the fleet model shows a sample is (the map and table).
#[derive(Clone, Copy)]
enum Kind {
    NodeStatus,
    Status,
    Course,
}

/// Where a sample the model took in is recorded: its group and protobuf type.
#[derive(Clone)]
struct RecordTo {
    input: RecordInput,
    group: &'static str,
    type_name: &'static str,
}

impl RecordTo {
    fn new(input: &RecordInput, group: &'static str) -> Option<Self> {
        let type_name = groups::ALL.iter().find(|g| g.name == group)?.type_name;
        Some(Self {
            input: input.clone(),
            group,
            type_name,
        })
    }

    fn record(&self, platform: &str, payload: &[u8]) {
        // The queue is bounded and try_send: a full queue drops (counted by the recorder).
        self.input.record_encoded(
            format!("{platform}/{}", self.group),
            self.type_name,
            Some(platform),
            payload.to_vec(),
            std::time::SystemTime::now(),
        );
    }
}

/// Starts the recorder of `[record]` when enabled: files named `topside_<UTC>_<seq>.mcap`.
pub fn start_recorder(
    cfg: &TopsideConfig,
) -> Result<Option<(Recorder, RecordInput)>, TopsideError> {
    if !cfg.record.enabled {
        return Ok(None);
    }
    let opts = RecorderOptions::from_config(&cfg.record, "topside")?;
    let mut extra = BTreeMap::new();
    extra.insert("process".to_string(), "topside".to_string());
    let meta = RecordMeta {
        vehicle: "topside".into(),
        version: env!("CARGO_PKG_VERSION").into(),
        config_digest: frontseat_record::recorder::config_digest(
            &serde_json::to_string(cfg).unwrap_or_default(),
        ),
        extra,
        ..Default::default()
    };
    let (rec, input) = Recorder::start_detached(opts, meta)?;
    // Ends by itself once the recorder stops.
    drop(rec.spawn_drop_watch(Duration::from_secs(10)));
    Ok(Some((rec, input)))
}

fn bump(c: &AtomicU64, what: &str, key: &str) {
    let n = c.fetch_add(1, Ordering::Relaxed) + 1;
    if frontseat_helm_side::wire::worth_logging(n) {
        tracing::warn!(key = %key.chars().take(120).collect::<String>(), count = n, "topside: {what}");
    }
}

/// Called with each node_status the fleet model took in (benchmarks measure arrival with it).
pub type Observer = Arc<dyn Fn(&str, &NodeStatus) + Send + Sync>;

/// Where the samples of one subscription go: the fleet model (for the three groups it shows),
/// the scope (every group), the counters, the observer and the recorder.
#[derive(Clone)]
struct Sink {
    fleet: Arc<Mutex<Fleet>>,
    scope: Arc<Mutex<Scope>>,
    counters: Arc<Counters>,
    observer: Option<Observer>,
    record: Option<RecordTo>,
    /// The live Foxglove server's channel for this group (`[foxglove]`).
    live: Option<live::LiveTo>,
    /// Keys heard for the first time, for the topside to declare (see [`declare_heard_keys`]).
    declare: tokio::sync::mpsc::Sender<String>,
}

impl Sink {
    /// Takes one sample of `info`'s group: the platform from the key, the payload bounded, kept
    /// for the scope, and decoded into the fleet when it is one of the groups the map shows.
    fn take(&self, info: &'static GroupInfo, kind: Option<Kind>, key: &str, payload: &[u8]) {
        let counters = &self.counters;
        let Some(platform) = key
            .split('/')
            .next()
            .filter(|p| frontseat_helm_side::plan::check_platform(p).is_ok())
        else {
            return bump(&counters.bad_key, "bad platform in key expression", key);
        };
        if payload.len() > frontseat_helm_side::DEFAULT_MAX_PAYLOAD {
            return bump(&counters.oversized, "oversized payload refused", key);
        }
        let now = tokio::time::Instant::now();
        let scoped = self
            .scope
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .on_sample(platform, info, payload, now);
        if let Ok(true) = scoped {
            // Full: the key stays undeclared, which costs time per sample, never a sample.
            let _ = self.declare.try_send(key.to_string());
        }
        let Some(kind) = kind else {
            // The fleet's own groups count their refusals below; the others here.
            if scoped.is_err() {
                bump(
                    &counters.too_many_vehicles,
                    "max_vehicles reached; platform refused",
                    key,
                );
            }
            return;
        };
        let mut f = self.fleet.lock().unwrap_or_else(|p| p.into_inner());
        let r = match kind {
            Kind::NodeStatus => match NodeStatus::decode(payload) {
                Ok(m) => {
                    let r = f.on_node_status(platform, &m, now);
                    if let (Ok(()), Some(o)) = (&r, &self.observer) {
                        o(platform, &m);
                    }
                    r
                }
                Err(_) => return bump(&counters.undecodable, "undecodable node_status", key),
            },
            Kind::Status => match InterfaceStatus::decode(payload) {
                Ok(m) => f.on_status(platform, &m, now),
                Err(_) => return bump(&counters.undecodable, "undecodable status", key),
            },
            Kind::Course => match DesiredCourse::decode(payload) {
                Ok(m) => f.on_course(platform, &m),
                Err(_) => return bump(&counters.undecodable, "undecodable desired_course", key),
            },
        };
        drop(f);
        // Recorded as heard, implausible values too (the record is of what came in); a platform
        // the model refused is not, so the file's channels are bounded by max_vehicles.
        if let Ok(()) | Err(Refused::Implausible) = &r {
            if let Some(rec) = &self.record {
                rec.record(platform, payload);
            }
            // Served live by the same rule as recorded.
            if let Some(l) = &self.live {
                l.publish(platform, payload);
            }
        }
        match r {
            Ok(()) => {
                counters.accepted.fetch_add(1, Ordering::Relaxed);
            }
            Err(Refused::Implausible) => {
                bump(&counters.implausible, "implausible value refused", key)
            }
            Err(Refused::TooManyVehicles) => bump(
                &counters.too_many_vehicles,
                "max_vehicles reached; platform refused",
                key,
            ),
        }
    }
}

/// Keys waiting to be declared; more are not declared (each platform's groups, once).
const DECLARE_QUEUE: usize = 4096;

/// Declares each key the topside hears for the first time (`<platform>/<group>`) on its own
/// session. A put whose key no one declared is routed from scratch: Zenoh matches its key
/// against every subscription, in the router and again in the session, for every sample (with
/// 1 000 vehicles at 10 Hz, the larger part of the topside's CPU). A key declared here gets a
/// resource of its own, whose route is computed once and kept until the subscriptions change.
/// Bounded: a key is sent here only once per platform and group the scope took in, and the
/// scope is bounded by `max_vehicles`.
async fn declare_heard_keys(
    session: frontseat_helm_side::zenoh::Session,
    mut keys: tokio::sync::mpsc::Receiver<String>,
    count: Arc<AtomicU64>,
) {
    let mut declared = Vec::new();
    while let Some(key) = keys.recv().await {
        match session.declare_keyexpr(key).await {
            Ok(k) => {
                declared.push(k);
                count.fetch_add(1, Ordering::Relaxed);
            }
            // Only slower, never wrong: the samples of this key go on being taken in.
            Err(e) => tracing::debug!(error = %e, "topside: cannot declare a heard key"),
        }
    }
}

/// The running topside.
pub struct Topside {
    addr: SocketAddr,
    session: frontseat_helm_side::zenoh::Session,
    _subs: Vec<frontseat_helm_side::zenoh::pubsub::Subscriber<()>>,
    server: tokio::task::JoinHandle<()>,
    declarer: tokio::task::JoinHandle<()>,
    /// Keys [`declare_heard_keys`] declared.
    declared: Arc<AtomicU64>,
    pub counters: Arc<Counters>,
    /// The recorder this topside started itself (not one handed in by [`run`]).
    recorder: Option<Recorder>,
    /// `[foxglove]`'s live server.
    live: Option<live::Live>,
}

impl Topside {
    /// Starts the topside, and its recorder when `[record]` is enabled.
    pub async fn start(cfg: &TopsideConfig) -> Result<Self, TopsideError> {
        Self::start_observed(cfg, None).await
    }

    /// [`Topside::start`], calling `observer` with every node_status taken into the model.
    pub async fn start_observed(
        cfg: &TopsideConfig,
        observer: Option<Observer>,
    ) -> Result<Self, TopsideError> {
        let own = start_recorder(cfg)?;
        let input = own.as_ref().map(|(_, i)| i.clone());
        let mut t = Self::start_with(cfg, observer, input).await?;
        t.recorder = own.map(|(r, _)| r);
        Ok(t)
    }

    /// The topside recording into `record` (a recorder that outlives restarts), if given.
    pub async fn start_with(
        cfg: &TopsideConfig,
        observer: Option<Observer>,
        record: Option<RecordInput>,
    ) -> Result<Self, TopsideError> {
        let token = effective_token(cfg)?;
        // Once at start, before anything is served: a few small reads.
        let chart = chart::Chart::open(&cfg.chart)?;
        let listen: SocketAddr = cfg
            .web
            .listen
            .parse()
            .map_err(|_| TopsideError::BadListen(cfg.web.listen.clone()))?;
        let ip = InterprocessConfig {
            enabled: true,
            mode: InterprocessMode::Peer,
            listen: cfg.zenoh.listen.clone(),
            connect: cfg.zenoh.connect.clone(),
            platform: String::new(),
            tls: cfg.zenoh.tls.clone(),
            access: cfg.zenoh.access.clone(),
        };
        let zcfg = frontseat_helm_side::zenoh_config(&ip, frontseat_helm_side::DEFAULT_MAX_PAYLOAD)
            .map_err(|e| TopsideError::Zenoh(e.to_string()))?;
        let session = frontseat_helm_side::zenoh::open(zcfg)
            .await
            .map_err(|e| TopsideError::Zenoh(e.to_string()))?;
        let fleet = Arc::new(Mutex::new(Fleet::new(
            cfg.max_vehicles,
            cfg.track_points,
            Duration::from_secs_f64(cfg.stale_after_s.clamp(0.001, 3600.0)),
        )));
        let scope = Arc::new(Mutex::new(Scope::new(cfg.max_vehicles)));
        let counters = Arc::new(Counters::default());
        let live = live::start(cfg)?;
        let (declare, heard_keys) = tokio::sync::mpsc::channel(DECLARE_QUEUE);
        let declared = Arc::new(AtomicU64::new(0));
        let declarer = tokio::spawn(declare_heard_keys(
            session.clone(),
            heard_keys,
            declared.clone(),
        ));
        let mut subs = Vec::new();
        // One subscription per interprocess group (the scope shows them all), so the group is
        // known from the subscription and only the platform is read from the key.
        for info in groups::ALL
            .iter()
            .filter(|g| g.layer == Layer::Interprocess)
        {
            let kind = match info.name {
                n if n == groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS.name() => {
                    Some(Kind::NodeStatus)
                }
                n if n == groups::GOBY_MIDDLEWARE_FRONTSEAT_STATUS.name() => Some(Kind::Status),
                n if n == groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE.name() => {
                    Some(Kind::Course)
                }
                _ => None,
            };
            let key = frontseat_helm_side::key_for("*", info.name);
            let sink = Sink {
                fleet: fleet.clone(),
                scope: scope.clone(),
                counters: counters.clone(),
                observer: observer.clone(),
                record: kind
                    .and(record.as_ref())
                    .and_then(|i| RecordTo::new(i, info.name)),
                live: kind.and(live.as_ref()).and_then(|l| l.to(info.name)),
                declare: declare.clone(),
            };
            let sub = session
                .declare_subscriber(key.clone())
                .callback(move |s| {
                    let payload = s.payload().to_bytes();
                    sink.take(info, kind, s.key_expr().as_str(), &payload);
                })
                .await
                .map_err(|e| TopsideError::Zenoh(format!("subscribe {key}: {e}")))?;
            subs.push(sub);
        }
        let listener = tokio::net::TcpListener::bind(listen)
            .await
            .map_err(|source| TopsideError::Bind {
                addr: listen,
                source,
            })?;
        let addr = listener.local_addr().map_err(|source| TopsideError::Bind {
            addr: listen,
            source,
        })?;
        let state = AppState {
            fleet,
            scope,
            access: Access::new(addr, token),
            counters: counters.clone(),
            links: Arc::new(
                cfg.vehicle
                    .iter()
                    .map(|v| (v.name.clone(), v.page.clone()))
                    .collect(),
            ),
        };
        let chart_state = chart::ChartState {
            chart: Arc::new(chart),
            access: state.access.clone(),
        };
        let app = router(state).merge(chart::router(chart_state));
        let bounded = frontseat_web::conn::BoundedListener::new(
            listener,
            frontseat_web::conn::ConnLimits {
                max_connections: cfg.web.max_connections,
                idle: Duration::from_secs(cfg.web.idle_timeout_s.max(1)),
                header_timeout: Duration::from_secs(cfg.web.header_timeout_s.max(1)),
            },
            Arc::new(frontseat_web::ServerCounters::default()),
            "topside",
        );
        let server = tokio::spawn(bounded.serve(app));
        tracing::info!(url = %format!("http://{addr}/"), connect = ?cfg.zenoh.connect, "topside serving");
        Ok(Self {
            addr,
            session,
            _subs: subs,
            server,
            declarer,
            declared,
            counters,
            recorder: None,
            live,
        })
    }

    /// How many of the keys heard so far the topside has declared (one per platform and group).
    pub fn declared_keys(&self) -> u64 {
        self.declared.load(Ordering::Relaxed)
    }

    /// The address `[foxglove]`'s live server is bound to, when enabled.
    pub fn foxglove_addr(&self) -> Option<SocketAddr> {
        self.live.as_ref().map(live::Live::local_addr)
    }

    /// The file the topside's own recorder writes now.
    pub fn record_file(&self) -> Option<std::path::PathBuf> {
        self.recorder.as_ref().and_then(Recorder::current_file)
    }

    pub fn local_addr(&self) -> SocketAddr {
        self.addr
    }

    /// Stops serving and closes the Zenoh session.
    pub async fn shutdown(self) {
        Service::stop(Box::new(self), Duration::from_secs(3)).await;
    }
}

impl Service for Topside {
    fn ended(&mut self) -> BoxFuture<'_, Result<(), ChildFailure>> {
        Box::pin(async move {
            let r = (&mut self.server).await;
            self.server = tokio::spawn(async {});
            Err(ChildFailure::new(match r {
                Ok(()) => "the topside web server ended".to_string(),
                Err(e) => format!("the topside web server failed: {e}"),
            }))
        })
    }
    fn stop(self: Box<Self>, within: Duration) -> BoxFuture<'static, ()> {
        Box::pin(async move {
            self.server.abort();
            self.declarer.abort();
            let _ = tokio::time::timeout(within, self.session.close()).await;
            // After the session: no callback feeds the recorder any more; closing the file
            // (its summary) blocks, so off the async threads.
            if let Some(r) = self.recorder {
                stop_recorder(r).await;
            }
        })
    }
}

fn router(st: AppState) -> Router {
    Router::new()
        .route("/", get(index))
        .route("/api/fleet", get(fleet_json))
        .route(
            "/form.js",
            get(|| async {
                frontseat_web::server::asset("text/javascript", frontseat_web::server::FORM_JS)
            }),
        )
        .route(
            "/plots.js",
            get(|| async {
                frontseat_web::server::asset("text/javascript", frontseat_web::server::PLOTS_JS)
            }),
        )
        .route("/api/info", get(info))
        .route("/api/commander", get(commander))
        .route("/api/vehicle/{name}/scope", get(vehicle_scope))
        .route("/api/vehicle/{name}/send", axum::routing::post(send))
        .layer(axum::extract::DefaultBodyLimit::max(relay::MAX_BODY))
        .with_state(st)
}

fn refused(status: axum::http::StatusCode, text: impl Into<String>) -> Response {
    (
        status,
        axum::Json(json!({"ok": false, "error": text.into()})),
    )
        .into_response()
}

/// A command for one vehicle: the topside's own write rules (Host, Origin, its token), then
/// relayed to that vehicle's page with the vehicle's token from `X-Vehicle-Token`.
async fn send(
    State(st): State<AppState>,
    axum::extract::Path(name): axum::extract::Path<String>,
    headers: HeaderMap,
    body: axum::body::Bytes,
) -> Response {
    use axum::http::StatusCode;
    if let Err(r) = st.access.check_write(&headers) {
        return refused(r.status(), r.text());
    }
    let json_ct = headers
        .get(CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .is_some_and(|v| v.starts_with("application/json"));
    if !json_ct {
        return refused(
            StatusCode::UNSUPPORTED_MEDIA_TYPE,
            "Content-Type must be application/json",
        );
    }
    let Some(target) = st.links.get(&name).and_then(|p| relay::parse_page(p)) else {
        return refused(
            StatusCode::NOT_FOUND,
            format!(
                "no http:// page configured for vehicle `{}`",
                name.chars().take(64).collect::<String>()
            ),
        );
    };
    let Some(token) = headers
        .get("x-vehicle-token")
        .and_then(|v| v.to_str().ok())
        .filter(|t| !t.is_empty() && t.chars().all(|c| c.is_ascii_graphic()))
    else {
        return refused(
            StatusCode::UNAUTHORIZED,
            "the vehicle's token is needed (X-Vehicle-Token)",
        );
    };
    match relay::relay(&target, token, &body).await {
        Ok((code, answer)) => {
            tracing::info!(vehicle = %name, status = code, "topside relayed a command");
            let status = StatusCode::from_u16(code).unwrap_or(StatusCode::BAD_GATEWAY);
            (
                status,
                [(CONTENT_TYPE, HeaderValue::from_static("application/json"))],
                answer,
            )
                .into_response()
        }
        Err(e @ relay::RelayError::NoVehicleToken) => refused(StatusCode::FORBIDDEN, e.to_string()),
        Err(e) => refused(StatusCode::BAD_GATEWAY, e.to_string()),
    }
}

async fn index() -> Response {
    (
        [
            (
                CONTENT_TYPE,
                HeaderValue::from_static("text/html; charset=utf-8"),
            ),
            (CACHE_CONTROL, HeaderValue::from_static("no-cache")),
        ],
        INDEX_HTML,
    )
        .into_response()
}

async fn info(State(st): State<AppState>) -> Response {
    axum::Json(json!({ "token_required": st.access.token_required() })).into_response()
}

#[derive(Deserialize)]
struct TokenQuery {
    token: Option<String>,
}

/// `/api/fleet`'s query: the token, and the newest track point the page already has.
#[derive(Deserialize)]
struct FleetQuery {
    token: Option<String>,
    tracks_after: Option<u64>,
}

async fn fleet_json(
    State(st): State<AppState>,
    headers: HeaderMap,
    Query(q): Query<FleetQuery>,
) -> Response {
    if let Err(r) = st.access.check_read(&headers, q.token.as_deref()) {
        return (
            r.status(),
            axum::Json(json!({"ok": false, "error": r.text()})),
        )
            .into_response();
    }
    let now = tokio::time::Instant::now();
    // Copied under the lock, rendered outside it: with 1 000 vehicles the JSON takes long
    // enough that the Zenoh callbacks waiting on the lock would show it in their latency.
    let view = st
        .fleet
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .view(now, q.tracks_after);
    let mut snap = view.json(&st.links);
    snap["counters"] = st.counters.json();
    let mut r = axum::Json(snap).into_response();
    r.headers_mut()
        .insert(CACHE_CONTROL, HeaderValue::from_static("no-store"));
    r
}

/// One vehicle's scope: every group heard under its platform, the newest message decoded.
async fn vehicle_scope(
    State(st): State<AppState>,
    axum::extract::Path(name): axum::extract::Path<String>,
    headers: HeaderMap,
    Query(q): Query<TokenQuery>,
) -> Response {
    if let Err(r) = st.access.check_read(&headers, q.token.as_deref()) {
        return refused(r.status(), r.text());
    }
    let now = tokio::time::Instant::now();
    // Copied under the lock, decoded outside it: the Zenoh callbacks never wait for a decode.
    let rows = st
        .scope
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .rows(&name, now);
    let Some(rows) = rows else {
        return refused(
            axum::http::StatusCode::NOT_FOUND,
            format!(
                "no vehicle `{}` heard",
                name.chars().take(64).collect::<String>()
            ),
        );
    };
    let mut r = axum::Json(scope::render(&name, rows)).into_response();
    r.headers_mut()
        .insert(CACHE_CONTROL, HeaderValue::from_static("no-store"));
    r
}

/// The commander's groups and form schemas, the same as every vehicle's page serves. The
/// envelope (`limits`) is each vehicle's own and its gate applies it, so none is given here.
async fn commander(
    State(st): State<AppState>,
    headers: HeaderMap,
    Query(q): Query<TokenQuery>,
) -> Response {
    if let Err(r) = st.access.check_read(&headers, q.token.as_deref()) {
        return refused(r.status(), r.text());
    }
    axum::Json(json!({
        "groups": frontseat_web::server::commander_groups(),
        "limits": {},
        "vehicles": st.links.keys().collect::<Vec<_>>(),
    }))
    .into_response()
}

/// Stops a recorder off the async threads and logs what it counted.
async fn stop_recorder(r: Recorder) {
    match tokio::task::spawn_blocking(move || r.stop()).await {
        Ok(s) => tracing::info!(
            written = s.written,
            dropped = s.dropped(),
            files = s.files_opened,
            write_errors = s.write_errors,
            "topside recorder stopped"
        ),
        Err(e) => tracing::error!(error = %e, "the topside recorder did not stop cleanly"),
    }
}

/// The topside's root supervisor's children: one, the page server with its Zenoh session,
/// restarted with backoff and never ending the process (it steers nothing by itself). Also what
/// `frontseat interfaces` prints for `frontseat topside`.
pub fn children(
    cfg: TopsideConfig,
    input: Option<RecordInput>,
) -> Vec<frontseat_actors::supervisor::ChildSpec> {
    use frontseat_actors::service_child::service_child_with;
    use frontseat_actors::supervisor::Policy;
    let policy = Policy::from(&frontseat_config::RestartConfig::default()).helm_side();
    // `[ais]`: the node_status the fleet model takes in also feeds the AIS targets.
    let fleet = cfg.ais.enabled.then(|| ais::fleet(&cfg.ais));
    let observer = fleet.as_ref().map(ais::observer);
    let ais_child = fleet.map(|f| ais::child(cfg.ais.clone(), f, policy.clone()));
    let ctx = (Arc::new(cfg), input, observer);
    let mut children = vec![
        service_child_with(
            "Topside",
            policy,
            ctx,
            |(cfg, input, observer)| async move {
                Topside::start_with(&cfg, observer, input)
                    .await
                    .map(|t| Box::new(t) as Box<dyn Service>)
                    .map_err(|e| e.to_string())
            },
        )
        .noted("the page server and its Zenoh session; restarted without end, jittered"),
    ];
    children.extend(ais_child);
    children
}

/// The topside under a supervisor until `stop`: restarted (with backoff) if its server fails.
/// The recorder is started once, outside the restarts, so a restart continues its file.
pub async fn run(cfg: TopsideConfig, stop: impl std::future::Future<Output = ()>) -> u8 {
    use frontseat_actors::supervisor::SupervisorHandle;
    // Fail fast on what a restart cannot fix.
    if let Err(e) = effective_token(&cfg) {
        tracing::error!("{e}");
        return 2;
    }
    // A chart that cannot be opened is the operator's file to fix, not a restart's.
    if let Err(e) = chart::Chart::open(&cfg.chart) {
        tracing::error!("{e}");
        return 2;
    }
    let (recorder, input) = match start_recorder(&cfg) {
        Ok(Some((r, i))) => (Some(r), Some(i)),
        Ok(None) => (None, None),
        Err(e) => {
            tracing::error!("{e}");
            return 2;
        }
    };
    let mut root = match SupervisorHandle::start("topside", children(cfg, input), None).await {
        Ok(r) => r,
        Err(e) => {
            tracing::error!(error = %e, "cannot start the topside");
            if let Some(r) = recorder {
                stop_recorder(r).await;
            }
            return 1;
        }
    };
    let code = tokio::select! {
        e = root.wait() => e.code().clamp(1, 255) as u8,
        _ = stop => 0,
    };
    root.shutdown(Duration::from_secs(3)).await;
    if let Some(r) = recorder {
        stop_recorder(r).await;
    }
    code
}
