//! Runs a vehicle emulator session (the vehicle's side of a serial protocol) on a
//! pseudo-terminal or a loopback TCP port: reads bytes into the session, steps its vehicle at
//! 10 Hz of simulated time, writes what it answers. The sessions themselves are pure
//! (the Iver3 and Wave Glider SV2 sessions).

use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::mpsc;

use crate::pty::PtyMaster;

/// The vehicle side of a protocol, without I/O.
pub trait Session: Send + 'static {
    /// Bytes from the backseat; replies are appended to `out`.
    fn on_bytes(&mut self, bytes: &[u8], out: &mut Vec<u8>);
    /// `dt` simulated seconds passed; anything the vehicle sends on its own goes to `out`.
    fn step(&mut self, dt: f64, out: &mut Vec<u8>);
    /// The backseat's connection is gone (TCP) — forget partial input.
    fn reset_input(&mut self) {}
}

/// Control period of the emulated vehicle, in simulated seconds.
const STEP_S: f64 = 0.1;
/// A write to a peer that does not read is abandoned after this long (wall time).
const WRITE_WITHIN: Duration = Duration::from_secs(1);

/// Where an emulator listens.
#[derive(Debug, Clone)]
pub enum Endpoint {
    /// A new pseudo-terminal; its slave path is what the driver opens.
    Pty,
    /// A loopback (or given) TCP address; one backseat at a time.
    Tcp(SocketAddr),
}

/// What the handle asks of the running emulator.
enum Ask {
    /// Bytes written to the backseat as they are.
    Bytes(Vec<u8>),
    /// Close the backseat's connection.
    HangUp,
}

/// A running emulator.
pub struct Emulator<S: Session> {
    session: Arc<Mutex<S>>,
    inject: mpsc::UnboundedSender<Ask>,
    task: tokio::task::JoinHandle<()>,
    pty_path: Option<PathBuf>,
    tcp_addr: Option<SocketAddr>,
}

impl<S: Session> Drop for Emulator<S> {
    fn drop(&mut self) {
        self.task.abort();
    }
}

impl<S: Session> Emulator<S> {
    /// Starts `session` on `endpoint`; `warp` speeds simulated time up.
    pub async fn start(session: S, endpoint: Endpoint, warp: f64) -> std::io::Result<Self> {
        let session = Arc::new(Mutex::new(session));
        let (tx, rx) = mpsc::unbounded_channel();
        let step_wall = Duration::from_secs_f64(STEP_S / warp.clamp(1e-3, 1e4));
        let s = session.clone();
        let (task, pty_path, tcp_addr) = match endpoint {
            Endpoint::Pty => {
                let master = PtyMaster::open()?;
                let path = master.slave_path().to_path_buf();
                let task = tokio::spawn(run_pty(master, s, rx, step_wall));
                (task, Some(path), None)
            }
            Endpoint::Tcp(addr) => {
                let listener = TcpListener::bind(addr).await?;
                let addr = listener.local_addr()?;
                let task = tokio::spawn(run_tcp(listener, s, rx, step_wall));
                (task, None, Some(addr))
            }
        };
        Ok(Self {
            session,
            inject: tx,
            task,
            pty_path,
            tcp_addr,
        })
    }

    pub fn pty_path(&self) -> Option<&Path> {
        self.pty_path.as_deref()
    }

    pub fn tcp_addr(&self) -> Option<SocketAddr> {
        self.tcp_addr
    }

    /// The session, for inspection and fault injection (never held across an await).
    pub fn session(&self) -> MutexGuard<'_, S> {
        self.session.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Writes raw bytes to the backseat (line noise, broken frames) as they are.
    pub fn inject_bytes(&self, bytes: Vec<u8>) {
        let _ = self.inject.send(Ask::Bytes(bytes));
    }

    /// Closes the backseat's current TCP connection as a pulled cable would (a fault hook): the
    /// emulator keeps listening and takes the next connection. A pseudo-terminal has no
    /// connection to close: there it does nothing (`stop` makes the device vanish).
    pub fn drop_connection(&self) {
        let _ = self.inject.send(Ask::HangUp);
    }

    /// Stops the emulator; on a pty the driver sees the device vanish.
    pub fn stop(self) {}
}

fn lock<S>(m: &Mutex<S>) -> MutexGuard<'_, S> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

async fn run_pty<S: Session>(
    master: PtyMaster,
    session: Arc<Mutex<S>>,
    mut inject: mpsc::UnboundedReceiver<Ask>,
    step_wall: Duration,
) {
    let mut tick = tokio::time::interval(step_wall);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut buf = vec![0u8; 4096];
    let mut out = Vec::new();
    loop {
        tokio::select! {
            _ = tick.tick() => lock(&session).step(STEP_S, &mut out),
            r = master.read(&mut buf) => match r {
                Ok(n) => lock(&session).on_bytes(&buf[..n], &mut out),
                Err(e) => {
                    tracing::warn!(error = %e, "emulator pty read failed; stopping");
                    return;
                }
            },
            Some(Ask::Bytes(b)) = inject.recv() => out.extend_from_slice(&b),
        }
        if !out.is_empty() {
            if let Err(e) = master.write_all(&out, WRITE_WITHIN).await {
                tracing::warn!(error = %e, "emulator pty write failed; stopping");
                return;
            }
            out.clear();
        }
    }
}

async fn run_tcp<S: Session>(
    listener: TcpListener,
    session: Arc<Mutex<S>>,
    mut inject: mpsc::UnboundedReceiver<Ask>,
    step_wall: Duration,
) {
    let mut tick = tokio::time::interval(step_wall);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut peer: Option<TcpStream> = None;
    let mut buf = vec![0u8; 4096];
    let mut out = Vec::new();
    loop {
        let mut lost = false;
        tokio::select! {
            _ = tick.tick() => lock(&session).step(STEP_S, &mut out),
            a = listener.accept(), if peer.is_none() => {
                if let Ok((s, _)) = a {
                    let _ = s.set_nodelay(true);
                    peer = Some(s);
                }
            }
            r = read_some(&mut peer, &mut buf), if peer.is_some() => match r {
                Ok(0) | Err(_) => lost = true,
                Ok(n) => lock(&session).on_bytes(&buf[..n], &mut out),
            },
            Some(ask) = inject.recv() => match ask {
                Ask::Bytes(b) => out.extend_from_slice(&b),
                Ask::HangUp => lost = peer.is_some(),
            },
        }
        if lost {
            peer = None;
            lock(&session).reset_input();
        }
        if let Some(p) = peer.as_mut()
            && !out.is_empty()
            && tokio::time::timeout(WRITE_WITHIN, p.write_all(&out))
                .await
                .map_or(true, |r| r.is_err())
        {
            peer = None;
            lock(&session).reset_input();
        }
        // Bytes for a backseat that is not there are lost, as on a cable.
        out.clear();
    }
}

async fn read_some(peer: &mut Option<TcpStream>, buf: &mut [u8]) -> std::io::Result<usize> {
    match peer {
        Some(p) => p.read(buf).await,
        None => std::future::pending().await,
    }
}
