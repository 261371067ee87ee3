//! A stand-in for gobyd, for tests and local experiments where Goby3 is not installed: the
//! manager (REP) answering `PROVIDE_PUB_SUB_SOCKETS` and `PROVIDE_HOLD_STATE` the way gobyd
//! 3.1.5a was recorded doing (no `hold` field in the sockets answer, `hold: false` written
//! explicitly, the hold released for good once every required client said ready), and the
//! XSUB/XPUB proxy that forwards publications down and subscriptions up. Binds only what it is
//! told: IPC paths, or TCP on 127.0.0.1.

use std::collections::BTreeSet;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use prost::Message;
use zeromq::{
    Endpoint, RepSocket, Socket, SocketRecv, SocketSend, XPubSocket, XSubSocket, ZmqError,
    ZmqMessage,
};

use super::manager::pb::{ManagerRequest, ManagerResponse, Request, Socket as PbSocket, socket};

/// Where the stand-in binds.
#[derive(Clone, Debug)]
pub enum StandinTransport {
    /// `<base>.manager`, `<base>.xsub`, `<base>.xpub` (stale files are removed first, as libzmq does).
    Ipc { base: String },
    /// The manager on 127.0.0.1:`manager_port` (0 = any free port); XSUB and XPUB on ephemeral
    /// ports, new at every start like gobyd's.
    Tcp { manager_port: u16 },
}

#[derive(Default)]
struct StandinCounters {
    requests: AtomicU64,
    forwarded: AtomicU64,
    subscriptions: AtomicU64,
}

/// A running stand-in gobyd; dropping it stops it.
pub struct StandinGobyd {
    manager_endpoint: String,
    manager_port: Option<u16>,
    counters: Arc<StandinCounters>,
    tasks: Vec<tokio::task::JoinHandle<()>>,
}

impl Drop for StandinGobyd {
    fn drop(&mut self) {
        for t in &self.tasks {
            t.abort();
        }
    }
}

fn port_of(ep: &Endpoint) -> Option<u16> {
    match ep {
        Endpoint::Tcp(_, port) => Some(*port),
        _ => None,
    }
}

impl StandinGobyd {
    /// Binds the three sockets and starts answering. `hold_for` are the client names gobyd's
    /// `hold { required_client }` would list (gobyd's own name is implied and always ready).
    pub async fn start(transport: StandinTransport, hold_for: &[&str]) -> Result<Self, ZmqError> {
        let (manager_ep, xsub_ep, xpub_ep) = match &transport {
            StandinTransport::Ipc { base } => {
                for ext in ["manager", "xsub", "xpub"] {
                    let _ = std::fs::remove_file(format!("{base}.{ext}"));
                }
                (
                    format!("ipc://{base}.manager"),
                    format!("ipc://{base}.xsub"),
                    format!("ipc://{base}.xpub"),
                )
            }
            StandinTransport::Tcp { manager_port } => (
                format!("tcp://127.0.0.1:{manager_port}"),
                "tcp://127.0.0.1:0".to_string(),
                "tcp://127.0.0.1:0".to_string(),
            ),
        };
        let mut xsub = XSubSocket::new();
        let xsub_bound = xsub.bind(&xsub_ep).await?;
        let mut xpub = XPubSocket::new();
        let xpub_bound = xpub.bind(&xpub_ep).await?;
        let mut rep = RepSocket::new();
        let rep_bound = rep.bind(&manager_ep).await?;

        let (publish_socket, subscribe_socket) = match &transport {
            StandinTransport::Ipc { base } => (
                handed_out(socket::SocketType::Publish, socket::Transport::Ipc)
                    .with_name(format!("{base}.xsub")),
                handed_out(socket::SocketType::Subscribe, socket::Transport::Ipc)
                    .with_name(format!("{base}.xpub")),
            ),
            StandinTransport::Tcp { .. } => (
                handed_out(socket::SocketType::Publish, socket::Transport::Tcp)
                    .with_port(port_of(&xsub_bound)),
                handed_out(socket::SocketType::Subscribe, socket::Transport::Tcp)
                    .with_port(port_of(&xpub_bound)),
            ),
        };
        let counters = Arc::new(StandinCounters::default());
        let manager = tokio::spawn(manager_loop(
            rep,
            publish_socket,
            subscribe_socket,
            hold_for.iter().map(|s| s.to_string()).collect(),
            counters.clone(),
        ));
        let proxy = tokio::spawn(proxy_loop(xsub, xpub, counters.clone()));
        Ok(Self {
            manager_endpoint: rep_bound.to_string(),
            manager_port: port_of(&rep_bound),
            counters,
            tasks: vec![manager, proxy],
        })
    }

    pub fn manager_endpoint(&self) -> &str {
        &self.manager_endpoint
    }
    /// The manager's TCP port (TCP transport only).
    pub fn manager_port(&self) -> Option<u16> {
        self.manager_port
    }
    /// Manager requests answered.
    pub fn requests(&self) -> u64 {
        self.counters.requests.load(Ordering::Relaxed)
    }
    /// Publications forwarded from XSUB to XPUB.
    pub fn forwarded(&self) -> u64 {
        self.counters.forwarded.load(Ordering::Relaxed)
    }
    /// Subscription messages forwarded upstream.
    pub fn subscriptions(&self) -> u64 {
        self.counters.subscriptions.load(Ordering::Relaxed)
    }
    /// Stops answering and closes every socket (clients see their peer go away).
    pub async fn stop(self) {
        let tasks: Vec<_> = self.tasks.iter().map(|t| t.abort_handle()).collect();
        for t in tasks {
            t.abort();
        }
        drop(self);
        // Let the aborted tasks drop their sockets before the caller starts a new stand-in.
        tokio::task::yield_now().await;
    }
}

fn handed_out(kind: socket::SocketType, transport: socket::Transport) -> PbSocket {
    PbSocket {
        socket_type: kind as i32,
        transport: Some(transport as i32),
        connect_or_bind: Some(socket::ConnectOrBind::Connect as i32),
        send_queue_size: Some(1000),
        receive_queue_size: Some(1000),
        ..Default::default()
    }
}

trait With {
    fn with_name(self, n: String) -> Self;
    fn with_port(self, p: Option<u16>) -> Self;
}

impl With for PbSocket {
    fn with_name(mut self, n: String) -> Self {
        self.socket_name = Some(n);
        self
    }
    fn with_port(mut self, p: Option<u16>) -> Self {
        self.ethernet_port = p.map(u32::from);
        self
    }
}

async fn manager_loop(
    mut rep: RepSocket,
    publish: PbSocket,
    subscribe: PbSocket,
    required: BTreeSet<String>,
    counters: Arc<StandinCounters>,
) {
    let mut ready: BTreeSet<String> = BTreeSet::new();
    let mut released = required.is_empty();
    loop {
        let m = match rep.recv().await {
            Ok(m) => m,
            Err(_) => {
                // No peer, or one that went away: do not spin.
                tokio::time::sleep(std::time::Duration::from_millis(10)).await;
                continue;
            }
        };
        counters.requests.fetch_add(1, Ordering::Relaxed);
        let body = m.iter().last().cloned().unwrap_or_default();
        // gobyd ignores what it cannot parse; a REP must still answer to stay in step.
        let answer = match ManagerRequest::decode(body.as_ref()) {
            Ok(req) => {
                let mut r = ManagerResponse {
                    request: req.request,
                    client_name: req.client_name.clone(),
                    client_pid: req.client_pid,
                    ..Default::default()
                };
                match Request::try_from(req.request) {
                    Ok(Request::ProvidePubSubSockets) => {
                        r.publish_socket = Some(publish.clone());
                        r.subscribe_socket = Some(subscribe.clone());
                    }
                    Ok(Request::ProvideHoldState) => {
                        if req.ready() && required.contains(&req.client_name) {
                            ready.insert(req.client_name.clone());
                        }
                        released |= ready == required;
                        r.hold = Some(!released);
                    }
                    Err(_) => {}
                }
                r.encode_to_vec()
            }
            Err(_) => Vec::new(),
        };
        if rep.send(ZmqMessage::from(answer)).await.is_err() {
            continue;
        }
    }
}

async fn proxy_loop(mut xsub: XSubSocket, mut xpub: XPubSocket, counters: Arc<StandinCounters>) {
    loop {
        tokio::select! {
            m = xsub.recv() => match m {
                Ok(m) => {
                    counters.forwarded.fetch_add(1, Ordering::Relaxed);
                    crate::hops::hop("goby3.standin", "");
                    let _ = xpub.send(m).await;
                }
                Err(_) => tokio::time::sleep(std::time::Duration::from_millis(10)).await,
            },
            s = xpub.recv() => match s {
                Ok(s) => {
                    counters.subscriptions.fetch_add(1, Ordering::Relaxed);
                    let _ = xsub.send(s).await;
                }
                Err(_) => tokio::time::sleep(std::time::Duration::from_millis(10)).await,
            },
        }
    }
}
