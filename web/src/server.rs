//! The HTTP side: the embedded page and its assets, the event stream (SSE: the server pushes,
//! the page never polls), history and schema look-ups, and the commander's send. Every request
//! passes `auth`; connections, event streams and bodies are bounded.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use axum::Json as JsonBody;
use axum::Router;
use axum::extract::{DefaultBodyLimit, Query, State};
use axum::http::header::{CACHE_CONTROL, CONTENT_TYPE};
use axum::http::{HeaderMap, HeaderValue, StatusCode};
use axum::response::sse::{Event, KeepAlive, Sse};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use frontseat_actors::bus::PublishMeta;
use frontseat_actors::generated::groups;
use frontseat_actors::ports::WebCommanderPorts;
use futures_util::stream::Stream;
use serde::Deserialize;
use serde_json::{Value as Json, json};

use crate::auth::{Access, Refusal};
use crate::hub::{HubCounters, HubMsg, Joined};
use crate::reflect;
use crate::supervisor::HubHandle;

const INDEX_HTML: &str = include_str!("../assets/index.html");
const APP_JS: &str = include_str!("../assets/app.js");
const APP_CSS: &str = include_str!("../assets/app.css");
/// The commander's form (schema → inputs → checked JSON), also served by the topside's page.
pub const FORM_JS: &str = include_str!("../assets/form.js");
/// The plots of what a vehicle did against what it was asked; the topside serves it too.
pub const PLOTS_JS: &str = include_str!("../assets/plots.js");

/// How long a request waits for the hub before answering 503.
const HUB_TIMEOUT: Duration = Duration::from_secs(2);

/// Counters of the HTTP side.
#[derive(Debug, Default)]
pub struct ServerCounters {
    /// Connections holding a slot now (a gauge: up at accept, down when the connection ends).
    pub connections_open: AtomicU64,
    /// Connections accepted, in all.
    pub connections_accepted: AtomicU64,
    /// Connections closed at accept: every slot was held by a connection being answered (an
    /// event stream, a WebSocket), none unfinished to evict.
    pub connections_refused: AtomicU64,
    pub requests_refused: AtomicU64,
    pub sends: AtomicU64,
    pub sends_refused: AtomicU64,
    /// Connections closed because a request was not answered within the idle timeout of its
    /// first byte (a body trickled a byte at a time).
    pub slow_requests: AtomicU64,
    /// Connections closed because their request head was not complete within the header
    /// timeout (idle or trickling sockets; hyper's header-read timeout).
    pub header_timeouts: AtomicU64,
    /// Unfinished connections (no request being answered, not upgraded) closed because a new
    /// connection needed their slot.
    pub evicted: AtomicU64,
}

#[derive(Clone)]
pub struct AppState {
    pub hub: HubHandle,
    pub access: Access,
    pub ports: WebCommanderPorts,
    pub name: String,
    /// The command gate's envelope, per group and field path, for the forms.
    pub limits: Json,
    pub hub_counters: Arc<HubCounters>,
    pub counters: Arc<ServerCounters>,
}

fn refuse(st: &AppState, r: Refusal) -> Response {
    let n = st.counters.requests_refused.fetch_add(1, Ordering::Relaxed) + 1;
    // Rate-limited: the 1st, 2nd, 4th, 8th … refusal is logged, so a flood cannot fill the log.
    if n.is_power_of_two() {
        tracing::warn!(reason = r.text(), refused = n, "web: request refused");
    }
    (r.status(), r.text()).into_response()
}

fn error(status: StatusCode, text: impl Into<String>) -> Response {
    (status, JsonBody(json!({"ok": false, "error": text.into()}))).into_response()
}

/// A 503 for an event stream that cannot be served now. The connection is closed after the
/// answer (`Connection: close`): a refused tab left on keep-alive held one of
/// `max_connections` until the idle timeout, so refusals could fill the server.
fn busy(text: &str) -> Response {
    let mut r = error(StatusCode::SERVICE_UNAVAILABLE, text);
    let h = r.headers_mut();
    h.insert(
        axum::http::header::CONNECTION,
        axum::http::HeaderValue::from_static("close"),
    );
    h.insert(
        axum::http::header::RETRY_AFTER,
        axum::http::HeaderValue::from_static("5"),
    );
    r
}

pub fn router(st: AppState, max_body_bytes: usize) -> Router {
    Router::new()
        .route("/", get(index))
        .route(
            "/app.js",
            get(|| async { asset("text/javascript", APP_JS) }),
        )
        .route("/app.css", get(|| async { asset("text/css", APP_CSS) }))
        .route(
            "/form.js",
            get(|| async { asset("text/javascript", FORM_JS) }),
        )
        .route(
            "/plots.js",
            get(|| async { asset("text/javascript", PLOTS_JS) }),
        )
        .route("/api/info", get(info))
        .route("/api/events", get(events))
        .route("/api/history", get(history))
        .route("/api/schema", get(schema))
        .route("/api/commander", get(commander))
        .route("/api/send", post(send))
        .layer(DefaultBodyLimit::max(max_body_bytes))
        .with_state(st)
}

/// An embedded asset, revalidated on every load.
pub fn asset(content_type: &'static str, body: &'static str) -> Response {
    (
        [
            (CONTENT_TYPE, HeaderValue::from_static(content_type)),
            (CACHE_CONTROL, HeaderValue::from_static("no-cache")),
        ],
        body,
    )
        .into_response()
}

async fn index() -> Response {
    asset("text/html; charset=utf-8", INDEX_HTML)
}

#[derive(Deserialize)]
struct TokenQuery {
    token: Option<String>,
}

async fn info(State(st): State<AppState>) -> Response {
    JsonBody(json!({
        "name": st.name,
        "token_required": st.access.token_required(),
        "can_send": st.access.can_send(),
    }))
    .into_response()
}

async fn events(
    State(st): State<AppState>,
    headers: HeaderMap,
    Query(q): Query<TokenQuery>,
) -> Response {
    if let Err(r) = st.access.check_read(&headers, q.token.as_deref()) {
        return refuse(&st, r);
    }
    let Some(hub) = st.hub.get() else {
        return busy("the web hub is not running");
    };
    let joined = match ractor::call_t!(hub, HubMsg::Join, HUB_TIMEOUT.as_millis() as u64) {
        Ok(Some(j)) => j,
        Ok(None) => return busy("too many open scope tabs (web.max_clients)"),
        Err(_) => return busy("the web hub is not running"),
    };
    Sse::new(event_stream(joined, st.hub_counters.clone()))
        .keep_alive(KeepAlive::new().interval(Duration::from_secs(5)))
        .into_response()
}

struct StreamState {
    snapshot: Option<Arc<str>>,
    events: tokio::sync::mpsc::Receiver<Arc<str>>,
    dropped: Arc<AtomicU64>,
    counters: Arc<HubCounters>,
    tick: tokio::time::Interval,
}

/// The snapshot first, then every event, with a statistics event each second (this tab's
/// missed events among them). Ends when the hub drops the tab's queue.
fn event_stream(
    joined: Joined,
    counters: Arc<HubCounters>,
) -> impl Stream<Item = Result<Event, std::convert::Infallible>> {
    let mut tick = tokio::time::interval(Duration::from_secs(1));
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
    let state = StreamState {
        snapshot: Some(joined.snapshot),
        events: joined.events,
        dropped: joined.dropped,
        counters,
        tick,
    };
    futures_util::stream::unfold(state, |mut s| async move {
        if let Some(snap) = s.snapshot.take() {
            return Some((Ok(Event::default().data(&*snap)), s));
        }
        tokio::select! {
            ev = s.events.recv() => {
                let ev = ev?;
                crate::hops::hop("web.sse", "");
                Some((Ok(Event::default().data(&*ev)), s))
            }
            _ = s.tick.tick() => {
                let stats = json!({
                    "kind": "stats",
                    "dropped_here": s.dropped.load(Ordering::Relaxed),
                    "messages": s.counters.messages.load(Ordering::Relaxed),
                    "decode_errors": s.counters.decode_errors.load(Ordering::Relaxed),
                    "events_dropped": s.counters.events_dropped.load(Ordering::Relaxed),
                });
                Some((Ok(Event::default().data(stats.to_string())), s))
            }
        }
    })
}

#[derive(Deserialize)]
struct GroupQuery {
    group: String,
    token: Option<String>,
}

async fn history(
    State(st): State<AppState>,
    headers: HeaderMap,
    Query(q): Query<GroupQuery>,
) -> Response {
    if let Err(r) = st.access.check_read(&headers, q.token.as_deref()) {
        return refuse(&st, r);
    }
    let group = q.group;
    let Some(hub) = st.hub.get() else {
        return error(
            StatusCode::SERVICE_UNAVAILABLE,
            "the web hub is not running",
        );
    };
    match ractor::call_t!(
        hub,
        HubMsg::History,
        HUB_TIMEOUT.as_millis() as u64,
        group.clone()
    ) {
        Ok(Some(h)) => JsonBody(h).into_response(),
        Ok(None) => error(StatusCode::NOT_FOUND, format!("no group `{group}`")),
        Err(_) => error(
            StatusCode::SERVICE_UNAVAILABLE,
            "the web hub is not running",
        ),
    }
}

#[derive(Deserialize)]
struct TypeQuery {
    r#type: String,
    token: Option<String>,
}

async fn schema(
    State(st): State<AppState>,
    headers: HeaderMap,
    Query(q): Query<TypeQuery>,
) -> Response {
    if let Err(r) = st.access.check_read(&headers, q.token.as_deref()) {
        return refuse(&st, r);
    }
    match reflect::message_schema(&q.r#type) {
        Ok(s) => JsonBody(s).into_response(),
        Err(e) => error(StatusCode::NOT_FOUND, e.to_string()),
    }
}

/// The groups the commander may send on (its declared publications, which are exactly the
/// groups FrontSeatInterface subscribes a helm's messages on) with the form schema of each.
async fn commander(
    State(st): State<AppState>,
    headers: HeaderMap,
    Query(q): Query<TokenQuery>,
) -> Response {
    if let Err(r) = st.access.check_read(&headers, q.token.as_deref()) {
        return refuse(&st, r);
    }
    JsonBody(json!({"can_send": st.access.can_send(), "groups": commander_groups(), "limits": st.limits}))
        .into_response()
}

/// The groups the commander may send on, each with its type and form schema (the vehicle's
/// page and the topside's build the same form from it).
pub fn commander_groups() -> Vec<Json> {
    WebCommanderPorts::PUBLISHES
        .iter()
        .filter_map(|name| groups::ALL.iter().find(|g| g.name == *name))
        .map(|g| {
            json!({
                "group": g.name,
                "type": g.type_name,
                "schema": reflect::message_schema(g.type_name).unwrap_or(Json::Null),
            })
        })
        .collect()
}

#[derive(Deserialize)]
struct SendBody {
    group: String,
    message: Json,
}

async fn send(State(st): State<AppState>, headers: HeaderMap, body: axum::body::Bytes) -> Response {
    if let Err(r) = st.access.check_write(&headers) {
        st.counters.sends_refused.fetch_add(1, Ordering::Relaxed);
        return refuse(&st, r);
    }
    // A JSON content type makes a cross-site form post a CORS pre-flight the server never
    // answers, on top of the Origin check.
    let json_ct = headers
        .get(CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .is_some_and(|v| v.starts_with("application/json"));
    if !json_ct {
        st.counters.sends_refused.fetch_add(1, Ordering::Relaxed);
        return error(
            StatusCode::UNSUPPORTED_MEDIA_TYPE,
            "Content-Type must be application/json",
        );
    }
    let req: SendBody = match serde_json::from_slice(&body) {
        Ok(r) => r,
        Err(e) => {
            st.counters.sends_refused.fetch_add(1, Ordering::Relaxed);
            return error(StatusCode::BAD_REQUEST, format!("bad request: {e}"));
        }
    };
    let Some(info) = WebCommanderPorts::PUBLISHES
        .iter()
        .find(|g| **g == req.group)
        .and_then(|name| groups::ALL.iter().find(|g| g.name == *name))
    else {
        st.counters.sends_refused.fetch_add(1, Ordering::Relaxed);
        return error(
            StatusCode::BAD_REQUEST,
            format!("the commander cannot send on `{}`", req.group),
        );
    };
    let bytes = match reflect::from_json(info.type_name, &req.message) {
        Ok(b) => b,
        Err(e) => {
            st.counters.sends_refused.fetch_add(1, Ordering::Relaxed);
            return error(StatusCode::UNPROCESSABLE_ENTITY, e.to_string());
        }
    };
    // Exactly the path of any other helm: a publication on the group the interface
    // subscribes; the interface's gates decide, and answer on command_response. Marked as the
    // web's, so that `[raw_send] sources` can tell a browser from in-process code.
    let meta = PublishMeta {
        origin: frontseat_actors::bus::Origin::Web,
        ..PublishMeta::default()
    };
    match st.ports.publish_encoded(info.name, &bytes, meta) {
        Ok(report) => {
            st.counters.sends.fetch_add(1, Ordering::Relaxed);
            tracing::info!(
                group = info.name,
                delivered = report.delivered,
                "web commander sent"
            );
            let entry = json!({
                "time": crate::now_ms(),
                "group": info.name,
                "type": info.type_name,
                "message": req.message,
                "delivered": report.delivered,
                "dropped": report.dropped,
            });
            if let Some(hub) = st.hub.get() {
                let _ = hub.cast(HubMsg::Sent(entry.clone()));
            }
            JsonBody(json!({"ok": true, "sent": entry})).into_response()
        }
        Err(e) => {
            st.counters.sends_refused.fetch_add(1, Ordering::Relaxed);
            error(StatusCode::UNPROCESSABLE_ENTITY, e.to_string())
        }
    }
}

/// The envelope of the interface's command gate (`[limits]`) as the forms use it: per group, per
/// field path, `{min, max}`. The form flags a value outside; the gate is what refuses.
pub fn limits_json(l: &frontseat_config::LimitsConfig) -> Json {
    let course = |prefix: &str| {
        let f = |name: &str| format!("{prefix}{name}");
        json!({
            f("speed"): {"min": 0.0, "max": l.max_speed},
            f("depth"): {"min": 0.0, "max": l.max_depth},
            f("altitude"): {"min": l.min_altitude, "max": l.max_altitude},
            f("pitch"): {"min": -l.max_abs_pitch, "max": l.max_abs_pitch},
            f("roll"): {"min": -l.max_abs_roll, "max": l.max_abs_roll},
            f("z_rate"): {"min": -l.max_abs_z_rate, "max": l.max_abs_z_rate},
        })
    };
    json!({
        groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE.name(): course(""),
        groups::GOBY_MIDDLEWARE_FRONTSEAT_COMMAND_REQUEST.name(): course("desired_course."),
    })
}
