//! Where AIS sentences go: UDP datagrams to a list of destinations (OpenCPN's UDP input), and a
//! TCP server that sends them to every connected client (OpenCPN's TCP client connection). Both
//! only send and never wait: a UDP send that would block is counted and dropped; a TCP client
//! whose bounded queue is full is disconnected (it reconnects, OpenCPN does by itself).

use std::net::SocketAddr;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use tokio::io::AsyncWriteExt;
use tokio::net::{TcpListener, UdpSocket};
use tokio::sync::mpsc;

/// Largest datagram written: sentences are packed up to this (OpenCPN reads 4096 at a time).
const MAX_DATAGRAM: usize = 1400;
/// Batches queued per TCP client before it counts as not keeping up.
const CLIENT_QUEUE: usize = 64;

/// What was sent and what was lost.
#[derive(Debug, Default)]
pub struct SendCounters {
    pub sentences: AtomicU64,
    pub datagrams: AtomicU64,
    pub udp_errors: AtomicU64,
    pub tcp_clients: AtomicU64,
    pub tcp_refused: AtomicU64,
    pub tcp_dropped: AtomicU64,
}

type Clients = Arc<std::sync::Mutex<Vec<mpsc::Sender<Arc<str>>>>>;

/// The open outputs.
pub struct Outputs {
    udp: Option<(UdpSocket, Vec<SocketAddr>)>,
    clients: Clients,
    tcp: Option<(SocketAddr, tokio::task::JoinHandle<()>)>,
    pub counters: Arc<SendCounters>,
}

impl Drop for Outputs {
    fn drop(&mut self) {
        if let Some((_, t)) = &self.tcp {
            t.abort();
        }
    }
}

impl Outputs {
    /// Opens the UDP socket and binds the TCP server (`tcp_listen` empty: none).
    pub async fn open(
        udp: &[String],
        tcp_listen: &str,
        max_clients: usize,
    ) -> std::io::Result<Self> {
        let bad = |a: &str| {
            std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                format!("`{a}` is not an IP address and port"),
            )
        };
        let dests = udp
            .iter()
            .map(|a| a.parse::<SocketAddr>().map_err(|_| bad(a)))
            .collect::<Result<Vec<_>, _>>()?;
        let udp = if dests.is_empty() {
            None
        } else {
            let any = if dests.iter().all(SocketAddr::is_ipv6) {
                "[::]:0"
            } else {
                "0.0.0.0:0"
            };
            let s = UdpSocket::bind(any).await?;
            if dests
                .iter()
                .any(|d| matches!(d.ip(), std::net::IpAddr::V4(v) if v.octets()[3] == 255))
            {
                s.set_broadcast(true)?;
            }
            Some((s, dests))
        };
        let counters = Arc::new(SendCounters::default());
        let clients: Clients = Arc::default();
        let tcp = if tcp_listen.is_empty() {
            None
        } else {
            let addr: SocketAddr = tcp_listen.parse().map_err(|_| bad(tcp_listen))?;
            let l = TcpListener::bind(addr).await?;
            let local = l.local_addr()?;
            let task = tokio::spawn(accept(
                l,
                clients.clone(),
                max_clients.max(1),
                counters.clone(),
            ));
            Some((local, task))
        };
        Ok(Self {
            udp,
            clients,
            tcp,
            counters,
        })
    }

    /// The TCP server's address, when there is one.
    pub fn tcp_addr(&self) -> Option<SocketAddr> {
        self.tcp.as_ref().map(|(a, _)| *a)
    }

    /// Sends `sentences` (each with its CR LF) to every output; never waits.
    pub fn send(&self, sentences: &[String]) {
        if sentences.is_empty() {
            return;
        }
        let c = &self.counters;
        c.sentences
            .fetch_add(sentences.len() as u64, Ordering::Relaxed);
        if let Some((sock, dests)) = &self.udp {
            let mut datagram = String::new();
            let flush = |d: &mut String| {
                if d.is_empty() {
                    return;
                }
                for to in dests {
                    match sock.try_send_to(d.as_bytes(), *to) {
                        Ok(_) => {
                            c.datagrams.fetch_add(1, Ordering::Relaxed);
                        }
                        Err(e) => {
                            let n = c.udp_errors.fetch_add(1, Ordering::Relaxed) + 1;
                            if n <= 10 || n.is_power_of_two() {
                                tracing::warn!(%to, error = %e, count = n, "AIS: UDP send failed");
                            }
                        }
                    }
                }
                d.clear();
            };
            for s in sentences {
                if datagram.len() + s.len() > MAX_DATAGRAM {
                    flush(&mut datagram);
                }
                datagram.push_str(s);
            }
            flush(&mut datagram);
        }
        if self.tcp.is_some() {
            let batch: Arc<str> = sentences.concat().into();
            let mut clients = self.clients.lock().unwrap_or_else(|p| p.into_inner());
            clients.retain(|tx| match tx.try_send(batch.clone()) {
                Ok(()) => true,
                Err(mpsc::error::TrySendError::Full(_)) => {
                    c.tcp_dropped.fetch_add(1, Ordering::Relaxed);
                    tracing::warn!("AIS: a TCP client did not keep up and was disconnected");
                    false
                }
                Err(mpsc::error::TrySendError::Closed(_)) => false,
            });
        }
    }
}

async fn accept(l: TcpListener, clients: Clients, max: usize, c: Arc<SendCounters>) {
    loop {
        let (mut sock, peer) = match l.accept().await {
            Ok(x) => x,
            Err(e) => {
                tracing::warn!(error = %e, "AIS: TCP accept failed");
                tokio::time::sleep(std::time::Duration::from_millis(100)).await;
                continue;
            }
        };
        let (tx, mut rx) = mpsc::channel::<Arc<str>>(CLIENT_QUEUE);
        {
            let mut cl = clients.lock().unwrap_or_else(|p| p.into_inner());
            cl.retain(|t| !t.is_closed());
            if cl.len() >= max {
                c.tcp_refused.fetch_add(1, Ordering::Relaxed);
                tracing::warn!(%peer, max, "AIS: TCP client refused: max_tcp_clients reached");
                continue;
            }
            cl.push(tx);
        }
        c.tcp_clients.fetch_add(1, Ordering::Relaxed);
        tracing::info!(%peer, "AIS: TCP client connected");
        tokio::spawn(async move {
            let _ = sock.set_nodelay(true);
            while let Some(b) = rx.recv().await {
                if sock.write_all(b.as_bytes()).await.is_err() {
                    break;
                }
            }
        });
    }
}
