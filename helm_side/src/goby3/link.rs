//! The connection to gobyd, in one background task: join (REQ handshake, SUB and PUB connected
//! to the endpoints gobyd hands out, hold released, a settle delay for the slow joiner), serve
//! (frames both ways) until either socket loses gobyd, then join again with capped backoff.
//! Joining afresh after every loss also follows a TCP gobyd whose publish/subscribe ports
//! changed on restart. While not joined, local publications are drained and counted, never
//! queued without bound.

use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::Duration;

use frontseat_actors::bus::{Bus, GOBY3_LINK};
use frontseat_actors::generated::EncodedEnvelope;
use futures::StreamExt;
use futures::channel::mpsc as fmpsc;
use tokio::sync::{mpsc, watch};
use zeromq::{
    PubSocket, ReqSocket, Socket, SocketEvent, SocketOptions, SocketRecv, SocketSend, SubSocket,
    ZmqMessage,
};

use super::guard::{self, Guard};
use super::manager::{self, PubSub};
use super::settings::Goby3Settings;
use super::traffic::{Counters, Exporter, Importer, Origin3, bump};
use crate::wire;

/// Goby3 polls the hold state every 100 ms.
const HOLD_POLL: Duration = Duration::from_millis(100);
/// How long a link told to stop keeps its sockets after publishing: zeromq's PUB hands a message
/// to background queues and has neither flush nor linger, so dropping it at once loses the last
/// messages (a replay's end; the interface's last status at shutdown). libzmq lingers too.
const LINGER: Duration = Duration::from_millis(250);

pub(crate) struct Link {
    pub settings: Goby3Settings,
    pub me: Origin3,
    pub counters: Arc<Counters>,
    pub bus: Bus,
}

type Outbound = mpsc::UnboundedReceiver<(usize, EncodedEnvelope)>;

/// Why a join attempt or a session ended.
#[derive(Debug, thiserror::Error)]
enum LinkError {
    #[error("no answer from gobyd's manager at {endpoint} within {timeout:?}")]
    Timeout { endpoint: String, timeout: Duration },
    #[error("ZeroMQ on {endpoint}: {error}")]
    Zmq { endpoint: String, error: String },
    #[error("manager answer: {0}")]
    Manager(#[from] manager::ManagerError),
    #[error("manager answer has {0} parts, not one")]
    Parts(usize),
    #[error("{0} socket lost gobyd")]
    Lost(&'static str),
    #[error("stopping")]
    Stopped,
}

struct Session {
    req: ReqSocket,
    sub: SubSocket,
    publ: PubSocket,
    sub_events: fmpsc::Receiver<SocketEvent>,
    pub_events: fmpsc::Receiver<SocketEvent>,
    /// The length guards the three sockets reach gobyd through; they close with the session.
    _guards: [Guard; 3],
}

fn options(s: &Goby3Settings) -> SocketOptions {
    let mut o = SocketOptions::default();
    o.connect_timeout(s.manager_timeout);
    o
}

fn zmq_err(endpoint: &str) -> impl Fn(zeromq::ZmqError) -> LinkError + '_ {
    move |e| LinkError::Zmq {
        endpoint: endpoint.to_string(),
        error: e.to_string(),
    }
}

impl Link {
    fn set_up(&self, up: bool) {
        self.counters.link_up.store(up, Ordering::Relaxed);
        self.bus.set_link_up(GOBY3_LINK, up);
    }

    async fn within<T>(
        &self,
        endpoint: &str,
        fut: impl std::future::Future<Output = Result<T, LinkError>>,
    ) -> Result<T, LinkError> {
        let timeout = self.settings.manager_timeout;
        tokio::time::timeout(timeout, fut)
            .await
            .unwrap_or_else(|_| {
                Err(LinkError::Timeout {
                    endpoint: endpoint.to_string(),
                    timeout,
                })
            })
    }

    /// One request/response on the manager socket.
    async fn ask(
        &self,
        req: &mut ReqSocket,
        endpoint: &str,
        body: Vec<u8>,
    ) -> Result<Vec<u8>, LinkError> {
        self.within(endpoint, async {
            req.send(ZmqMessage::from(body))
                .await
                .map_err(zmq_err(endpoint))?;
            let m = req.recv().await.map_err(zmq_err(endpoint))?;
            match m.len() {
                1 => Ok(m.get(0).map(|b| b.to_vec()).unwrap_or_default()),
                n => Err(LinkError::Parts(n)),
            }
        })
        .await
    }

    /// A length guard in front of gobyd's `endpoint` (see [`guard`]).
    async fn guard(&self, endpoint: &str) -> Result<Guard, LinkError> {
        let limit = self.settings.max_message_bytes;
        self.within(endpoint, async {
            guard::front(endpoint, limit, self.counters.clone())
                .await
                .map_err(|e| LinkError::Zmq {
                    endpoint: endpoint.to_string(),
                    error: e.to_string(),
                })
        })
        .await
    }

    /// Handshake and connect; the hold is handled by the caller.
    async fn join(&self, prefixes: &[String]) -> Result<Session, LinkError> {
        let s = &self.settings;
        let name = s.client_name.as_str();
        let pid = self.me.pid;
        let manager_ep = s.transport.manager_endpoint();
        let manager_guard = self.guard(&manager_ep).await?;
        let mut req = ReqSocket::with_options(options(s));
        self.within(&manager_ep, async {
            req.connect(&manager_guard.endpoint)
                .await
                .map_err(zmq_err(&manager_ep))
        })
        .await?;
        let answer = self
            .ask(&mut req, &manager_ep, manager::sockets_request(name, pid))
            .await?;
        let (PubSub { publish, subscribe }, _hold) =
            manager::parse_sockets_response(&answer, name, pid, &s.transport)?;

        let sub_guard = self.guard(&subscribe).await?;
        let mut sub = SubSocket::with_options(options(s));
        let sub_events = sub.monitor();
        for p in prefixes {
            sub.subscribe(p).await.map_err(zmq_err(&subscribe))?;
        }
        self.within(&subscribe, async {
            sub.connect(&sub_guard.endpoint)
                .await
                .map_err(zmq_err(&subscribe))
        })
        .await?;
        let pub_guard = self.guard(&publish).await?;
        let mut publ = PubSocket::with_options(options(s));
        let pub_events = publ.monitor();
        self.within(&publish, async {
            publ.connect(&pub_guard.endpoint)
                .await
                .map_err(zmq_err(&publish))
        })
        .await?;
        tracing::debug!(%publish, %subscribe, "Goby3 sockets connected");
        Ok(Session {
            req,
            sub,
            publ,
            sub_events,
            pub_events,
            _guards: [manager_guard, sub_guard, pub_guard],
        })
    }

    /// Reports ready (our subscriptions are in place) until gobyd lifts its hold. Goby3 apps do
    /// this over pub/sub; the manager answers the same request on REQ/REP, which is simpler.
    async fn wait_hold(&self, session: &mut Session) -> Result<(), LinkError> {
        let s = &self.settings;
        let endpoint = s.transport.manager_endpoint();
        let mut logged = false;
        loop {
            let body = manager::hold_request(&s.client_name, self.me.pid, true);
            let answer = self.ask(&mut session.req, &endpoint, body).await?;
            if !manager::parse_hold_response(&answer, &s.client_name, self.me.pid)? {
                return Ok(());
            }
            if !logged {
                tracing::info!("gobyd holds publications until its required clients are ready");
                logged = true;
            }
            tokio::time::sleep(HOLD_POLL).await;
        }
    }

    /// Frames both ways until a socket loses gobyd, or we are told to stop.
    async fn serve(
        &self,
        session: &mut Session,
        out: &mut Outbound,
        exporter: &Exporter,
        importer: &Importer,
        stop: &mut watch::Receiver<bool>,
    ) -> LinkError {
        let c = &self.counters;
        loop {
            tokio::select! {
                biased;
                _ = stop.changed() => return LinkError::Stopped,
                ev = session.sub_events.next() => {
                    if matches!(ev, None | Some(SocketEvent::Disconnected(_))) {
                        return LinkError::Lost("subscribe");
                    }
                }
                ev = session.pub_events.next() => {
                    if matches!(ev, None | Some(SocketEvent::Disconnected(_))) {
                        return LinkError::Lost("publish");
                    }
                }
                m = session.sub.recv() => match m {
                    Ok(m) => {
                        crate::hops::hop("goby3.recv", "");
                        let parts: Vec<&[u8]> = m.iter().map(|b| b.as_ref()).collect();
                        importer.handle_parts(&parts);
                    }
                    Err(_) => return LinkError::Lost("subscribe"),
                },
                o = out.recv() => {
                    let Some((i, env)) = o else { return LinkError::Stopped };
                    crate::hops::hop("goby3.send", env.group);
                    let Some(bytes) = exporter.encode(i, &env) else { continue };
                    match session.publ.send(ZmqMessage::from(bytes)).await {
                        Ok(()) => { c.exported.fetch_add(1, Ordering::Relaxed); }
                        Err(e) => {
                            let n = bump(&c.export_errors);
                            if wire::worth_logging(n) {
                                tracing::warn!(error = %e, count = n, "publishing to gobyd failed");
                            }
                        }
                    }
                    // The bus's in-flight slot for this envelope is released only now.
                    drop(env);
                }
            }
        }
    }
}

/// Runs `fut` while dropping (and counting) whatever local publications arrive meanwhile.
async fn draining<T>(
    out: &mut Outbound,
    c: &Counters,
    fut: impl std::future::Future<Output = T>,
) -> T {
    tokio::pin!(fut);
    loop {
        tokio::select! {
            biased;
            r = &mut fut => return r,
            Some(_) = out.recv() => {
                c.dropped_link_down.fetch_add(1, Ordering::Relaxed);
            }
        }
    }
}

pub(crate) async fn run(
    link: Link,
    exporter: Exporter,
    importer: Importer,
    mut out: Outbound,
    mut stop: watch::Receiver<bool>,
) {
    let s = link.settings.clone();
    let c = link.counters.clone();
    let prefixes = importer.prefixes();
    let manager_ep = s.transport.manager_endpoint();
    let mut delay = s.reconnect_initial;
    let mut failures: u64 = 0;
    loop {
        if *stop.borrow() {
            return;
        }
        let attempt = async {
            let mut session = link.join(&prefixes).await?;
            link.wait_hold(&mut session).await?;
            Ok::<_, LinkError>(session)
        };
        let joined = tokio::select! {
            r = draining(&mut out, &c, attempt) => r,
            _ = stop.changed() => return,
        };
        match joined {
            Ok(mut session) => {
                // Slow joiner: our PUB learns our peers' subscriptions from gobyd only now.
                // Local publications wait in the (bounded) queue meanwhile, as Goby3 buffers them.
                tokio::select! {
                    _ = tokio::time::sleep(s.settle) => {}
                    _ = stop.changed() => return,
                }
                failures = 0;
                delay = s.reconnect_initial;
                c.connects.fetch_add(1, Ordering::Relaxed);
                link.set_up(true);
                tracing::info!(manager = %manager_ep, platform = %s.platform, "joined gobyd: Goby3 link up");
                let exported_before = c.exported.load(Ordering::Relaxed);
                let why = link
                    .serve(&mut session, &mut out, &exporter, &importer, &mut stop)
                    .await;
                let stopped = matches!(why, LinkError::Stopped);
                if stopped && c.exported.load(Ordering::Relaxed) > exported_before {
                    tokio::time::sleep(LINGER).await;
                }
                if !stopped {
                    // Logged and counted before the flag drops, so whoever sees it down finds why.
                    c.link_losses.fetch_add(1, Ordering::Relaxed);
                    tracing::warn!(reason = %why, "Goby3 link down; joining gobyd again");
                }
                link.set_up(false);
                drop(session);
                if stopped {
                    return;
                }
            }
            Err(e) => {
                failures += 1;
                c.connect_failures.fetch_add(1, Ordering::Relaxed);
                if wire::worth_logging(failures) {
                    tracing::warn!(error = %e, attempt = failures, retry_in = ?delay, "cannot join gobyd (is it running?)");
                }
            }
        }
        let wait = tokio::time::sleep(delay);
        tokio::select! {
            _ = draining(&mut out, &c, wait) => {}
            _ = stop.changed() => return,
        }
        delay = (delay * 2).min(s.reconnect_max);
    }
}
