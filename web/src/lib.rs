//! The live web scope and commander of the frontseat interface, served by the interface process
//! itself (`[web] enabled = true`): one page with its assets embedded in the binary (no CDN, no
//! network), pushed to over Server-Sent Events by a hub that subscribes to every group of the
//! bus like any other subscriber (bounded, drop-and-count). The commander publishes through the
//! same groups a helm uses, so the interface's gates decide as for any helm.
//!
//! `hub` is the bus side (a ractor actor), `server` the HTTP side, `conn` its connections (shared
//! with the topside's page and the Foxglove servers), `auth` the access rules,
//! `reflect` the JSON view of any message from the compiled descriptors.
#![forbid(unsafe_code)]

pub mod auth;
pub mod conn;
pub mod hops;
pub mod hub;
pub mod reflect;
pub mod server;
pub mod supervisor;

use std::net::SocketAddr;
use std::sync::Arc;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use frontseat_actors::bus::Bus;
use frontseat_actors::ports::WebCommanderPorts;
use frontseat_actors::service_child::{BoxFuture, Service};
use frontseat_actors::supervisor::{ChildFailure, SupervisorHandle};
use frontseat_config::{InterfaceConfig, LimitsConfig, WEB_TOKEN_ENV, WebConfig};
use ractor::ActorRef;

pub use hub::HubCounters;
pub use server::ServerCounters;

use hub::HubArgs;

/// What can go wrong in the web component.
#[derive(Debug, thiserror::Error)]
pub enum WebError {
    #[error("web.listen `{0}` is not an address and port")]
    BadListen(String),
    #[error("cannot listen on {addr}: {source}")]
    Bind {
        addr: SocketAddr,
        source: std::io::Error,
    },
    #[error("{WEB_TOKEN_ENV} is set but shorter than {min} characters", min = frontseat_config::MIN_TOKEN_CHARS)]
    ShortEnvToken,
    #[error("cannot start the web hub: {0}")]
    Hub(String),
    #[error("unknown message type `{0}`")]
    UnknownType(String),
    #[error("does not decode: {0}")]
    Decode(String),
    #[error("invalid message: {0}")]
    Invalid(String),
}

pub(crate) fn now_ms() -> f64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64() * 1000.0)
}

/// The token in force: FRONTSEAT_WEB_TOKEN when set, else `web.token`.
pub fn effective_token(cfg: &WebConfig) -> Result<Option<String>, WebError> {
    match std::env::var(WEB_TOKEN_ENV) {
        Ok(t) if t.chars().count() < frontseat_config::MIN_TOKEN_CHARS => {
            Err(WebError::ShortEnvToken)
        }
        Ok(t) => Ok(Some(t)),
        Err(_) => Ok(cfg.token.clone()),
    }
}

/// A running web scope/commander.
pub struct WebService {
    addr: SocketAddr,
    supervisor: SupervisorHandle,
    hub: supervisor::HubHandle,
    server: tokio::task::JoinHandle<()>,
    pub hub_counters: Arc<HubCounters>,
    pub server_counters: Arc<ServerCounters>,
}

impl WebService {
    /// The web component of an interface: binds `[web] listen` (with the token from the config
    /// or the environment), reports `[limits]` to the commander's forms, subscribes the hub to
    /// every group and starts serving.
    pub async fn start(iface: &InterfaceConfig, bus: &Bus) -> Result<Self, WebError> {
        let token = effective_token(&iface.web)?;
        Self::start_with(&iface.web, &iface.limits, token, bus, &iface.name).await
    }

    /// As [`start`](Self::start), with every part given (tests, the bench).
    pub async fn start_with(
        cfg: &WebConfig,
        limits: &LimitsConfig,
        token: Option<String>,
        bus: &Bus,
        name: &str,
    ) -> Result<Self, WebError> {
        let listen = cfg
            .listen_addr()
            .ok_or_else(|| WebError::BadListen(cfg.listen.clone()))?;
        let listener = tokio::net::TcpListener::bind(listen)
            .await
            .map_err(|source| WebError::Bind {
                addr: listen,
                source,
            })?;
        let addr = listener.local_addr().map_err(|source| WebError::Bind {
            addr: listen,
            source,
        })?;
        let hub_counters = Arc::new(HubCounters::default());
        let server_counters = Arc::new(ServerCounters::default());
        let (supervisor, hub) = supervisor::start(HubArgs {
            bus: bus.clone(),
            queue_capacity: cfg.client_queue.max(64),
            history: cfg.history,
            max_clients: cfg.max_clients,
            client_queue: cfg.client_queue,
            counters: hub_counters.clone(),
        })
        .await
        .map_err(WebError::Hub)?;
        let access = auth::Access::new(addr, token);
        if !access.can_send() {
            tracing::warn!(%addr, "web: listening beyond loopback without a token; the commander refuses every send");
        }
        let state = server::AppState {
            hub: hub.clone(),
            access,
            ports: WebCommanderPorts::new(bus),
            name: name.to_string(),
            limits: server::limits_json(limits),
            hub_counters: hub_counters.clone(),
            counters: server_counters.clone(),
        };
        let app = server::router(state, cfg.max_body_bytes);
        let bounded = conn::BoundedListener::new(
            listener,
            conn::ConnLimits {
                max_connections: cfg.max_connections,
                idle: Duration::from_secs(cfg.idle_timeout_s.max(1)),
                header_timeout: Duration::from_secs(cfg.header_timeout_s.max(1)),
            },
            server_counters.clone(),
            "web",
        );
        let server = tokio::spawn(bounded.serve(app));
        tracing::info!(url = %format!("http://{addr}/"), "web scope and commander serving");
        Ok(Self {
            addr,
            supervisor,
            hub,
            server,
            hub_counters,
            server_counters,
        })
    }

    /// The bound address (the port, when `listen` asked for port 0).
    pub fn local_addr(&self) -> SocketAddr {
        self.addr
    }

    /// The hub now running, if any (diagnostics and tests).
    pub fn hub(&self) -> Option<ActorRef<hub::HubMsg>> {
        self.hub.get()
    }

    /// Resolves when the scope failed by itself: its server task ended, or its hub failed
    /// past the hub supervisor's limit.
    pub async fn ended(&mut self) -> String {
        tokio::select! {
            r = &mut self.server => {
                // A finished JoinHandle must not be polled again (`shutdown` only aborts it).
                self.server = tokio::spawn(async {});
                match r {
                    Ok(()) => "the web server ended".into(),
                    Err(e) => format!("the web server task failed: {e}"),
                }
            }
            e = self.supervisor.wait() => format!("the web hub gave up: {e:?}"),
        }
    }

    /// Stops serving: the hub unsubscribes and ends every event stream.
    pub async fn shutdown(self, bound: Duration) {
        self.server.abort();
        self.supervisor.shutdown(bound).await;
    }
}

/// The web scope as a child of the root supervisor (`[supervision.web]`): its failure is the
/// scope's own, never the process's exit code, so by default it is restarted and the
/// interface goes on.
impl Service for WebService {
    fn ended(&mut self) -> BoxFuture<'_, Result<(), ChildFailure>> {
        Box::pin(async move { Err(ChildFailure::new(WebService::ended(self).await)) })
    }
    fn stop(self: Box<Self>, within: Duration) -> BoxFuture<'static, ()> {
        Box::pin(async move { (*self).shutdown(within).await })
    }
}
