//! The chaos link: a loopback TCP proxy between a vehicle's emulator and its real driver, owned
//! by the harness, so the vehicle families' link faults need no hook in any emulator. The
//! driver connects here; each of its connections gets one to the emulator, and bytes are pumped
//! both ways. On command it drops the pair (both sockets closed), goes silent (the vehicle's
//! bytes are discarded), adds latency each way (a queue of timestamped chunks, so a slow link
//! delays without throttling), and writes bytes of its own into the vehicle's stream between
//! two of the vehicle's chunks — garbage and truncated frames made from the vehicle's own
//! recent frames, so they are in its protocol.

use std::collections::VecDeque;
use std::net::SocketAddr;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::{mpsc, watch};
use tokio::time::Instant;

/// Chunks queued per direction before the reader waits (backpressure, as a real link's buffer).
const QUEUE: usize = 1024;
/// Recent chunks of the vehicle kept as material for garbage and truncated frames.
const KEEP: usize = 16;
/// Largest chunk kept as material.
const KEEP_BYTES: usize = 4096;

enum Item {
    Data(Instant, Vec<u8>),
    Inject(Vec<u8>),
}

#[derive(Default)]
struct Shared {
    /// Vehicle bytes are dropped until then.
    silent_until: Mutex<Option<Instant>>,
    /// Added to each chunk's way, both directions.
    delay: Mutex<Duration>,
    /// The current pair's queue toward the driver (for injected bytes).
    downlink: Mutex<Option<mpsc::Sender<Item>>>,
    recent: Mutex<VecDeque<Vec<u8>>>,
    connections: AtomicU64,
    drops: AtomicU64,
    injected_bytes: AtomicU64,
    discarded_bytes: AtomicU64,
    /// What the driver's bytes are searched for (a command sentence's start), and how often it
    /// was found.
    marker: Option<&'static [u8]>,
    marker_count: AtomicU64,
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// What the link counted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct LinkStats {
    /// Driver connections accepted (and paired with the emulator).
    pub(crate) connections: u64,
    pub(crate) drops: u64,
    pub(crate) injected_bytes: u64,
    pub(crate) discarded_bytes: u64,
}

/// The proxy: where the driver connects, and the faults it can put on the line.
pub(crate) struct ChaosLink {
    addr: SocketAddr,
    shared: Arc<Shared>,
    /// Bumped to end the current pair.
    generation: watch::Sender<u64>,
    task: tokio::task::JoinHandle<()>,
}

impl Drop for ChaosLink {
    fn drop(&mut self) {
        self.task.abort();
    }
}

impl ChaosLink {
    /// Listens on an ephemeral loopback port; every driver connection is paired with a new
    /// connection to `upstream` (the emulator). A second driver connection ends the first pair.
    /// `marker`: counted in the driver's bytes ([`Self::marker_count`]).
    pub(crate) async fn start(
        upstream: SocketAddr,
        marker: Option<&'static [u8]>,
    ) -> std::io::Result<Self> {
        let listener = TcpListener::bind(("127.0.0.1", 0)).await?;
        let addr = listener.local_addr()?;
        let shared = Arc::new(Shared {
            marker,
            ..Default::default()
        });
        let (generation, _) = watch::channel(0u64);
        let task = tokio::spawn(accept_loop(
            listener,
            upstream,
            shared.clone(),
            generation.clone(),
        ));
        Ok(Self {
            addr,
            shared,
            generation,
            task,
        })
    }

    pub(crate) fn addr(&self) -> SocketAddr {
        self.addr
    }

    pub(crate) fn stats(&self) -> LinkStats {
        let s = &self.shared;
        LinkStats {
            connections: s.connections.load(Ordering::Relaxed),
            drops: s.drops.load(Ordering::Relaxed),
            injected_bytes: s.injected_bytes.load(Ordering::Relaxed),
            discarded_bytes: s.discarded_bytes.load(Ordering::Relaxed),
        }
    }

    /// How often the marker was in the driver's bytes so far.
    pub(crate) fn marker_count(&self) -> u64 {
        self.shared.marker_count.load(Ordering::SeqCst)
    }

    /// Ends the current pair: both sockets closed, as a cable pulled and put back.
    pub(crate) fn drop_connection(&self) {
        self.shared.drops.fetch_add(1, Ordering::Relaxed);
        self.generation.send_modify(|g| *g += 1);
    }

    /// Discards everything the vehicle sends for `d` (wall).
    pub(crate) fn silence(&self, d: Duration) {
        *lock(&self.shared.silent_until) = Some(Instant::now() + d);
    }

    /// Latency added to each chunk, each way (zero: none).
    pub(crate) fn set_delay(&self, d: Duration) {
        *lock(&self.shared.delay) = d;
    }

    /// Writes `bytes` into the vehicle's stream toward the driver, between two of its chunks;
    /// false when no pair is up.
    pub(crate) fn inject(&self, bytes: Vec<u8>) -> bool {
        let tx = lock(&self.shared.downlink).clone();
        let n = bytes.len() as u64;
        match tx {
            Some(tx) if tx.try_send(Item::Inject(bytes)).is_ok() => {
                self.shared.injected_bytes.fetch_add(n, Ordering::Relaxed);
                true
            }
            _ => false,
        }
    }

    /// The vehicle's most recent chunks (oldest first), as material for frames of its protocol.
    pub(crate) fn recent(&self) -> Vec<Vec<u8>> {
        lock(&self.shared.recent).iter().cloned().collect()
    }
}

async fn accept_loop(
    listener: TcpListener,
    upstream: SocketAddr,
    shared: Arc<Shared>,
    generation: watch::Sender<u64>,
) {
    loop {
        let Ok((driver, _)) = listener.accept().await else {
            tokio::time::sleep(Duration::from_millis(5)).await;
            continue;
        };
        // A new driver connection replaces the old pair (the emulator serves one backseat).
        generation.send_modify(|g| *g += 1);
        let vehicle = match tokio::time::timeout(
            Duration::from_secs(2),
            TcpStream::connect(upstream),
        )
        .await
        {
            Ok(Ok(v)) => v,
            // No vehicle to pair with: the driver sees its connection closed and retries.
            _ => continue,
        };
        let _ = driver.set_nodelay(true);
        let _ = vehicle.set_nodelay(true);
        shared.connections.fetch_add(1, Ordering::Relaxed);
        tokio::spawn(pair(
            driver,
            vehicle,
            shared.clone(),
            generation.subscribe(),
        ));
    }
}

/// One driver connection and its emulator connection, until either side closes or the
/// generation moves on.
async fn pair(
    driver: TcpStream,
    vehicle: TcpStream,
    shared: Arc<Shared>,
    mut generation: watch::Receiver<u64>,
) {
    generation.mark_unchanged();
    let (driver_rd, driver_wr) = driver.into_split();
    let (vehicle_rd, vehicle_wr) = vehicle.into_split();
    let (down_tx, down_rx) = mpsc::channel(QUEUE);
    let (up_tx, up_rx) = mpsc::channel(QUEUE);
    *lock(&shared.downlink) = Some(down_tx.clone());
    let mut tasks = tokio::task::JoinSet::new();
    tasks.spawn(read_side(vehicle_rd, down_tx, shared.clone(), true));
    tasks.spawn(write_side(driver_wr, down_rx, shared.clone()));
    tasks.spawn(read_side(driver_rd, up_tx, shared.clone(), false));
    tasks.spawn(write_side(vehicle_wr, up_rx, shared.clone()));
    tokio::select! {
        _ = generation.changed() => {}
        _ = tasks.join_next() => {}
    }
    // Dropping the halves closes both sockets.
    tasks.abort_all();
    while tasks.join_next().await.is_some() {}
}

async fn read_side(
    mut rd: tokio::net::tcp::OwnedReadHalf,
    tx: mpsc::Sender<Item>,
    shared: Arc<Shared>,
    from_vehicle: bool,
) {
    let mut buf = vec![0u8; 4096];
    // The end of the last chunk, so a marker split between two chunks is found.
    let mut tail: Vec<u8> = Vec::new();
    loop {
        let n = match rd.read(&mut buf).await {
            Ok(0) | Err(_) => return,
            Ok(n) => n,
        };
        let chunk = buf[..n].to_vec();
        if !from_vehicle && let Some(m) = shared.marker {
            tail.extend_from_slice(&chunk);
            let found = tail.windows(m.len()).filter(|w| *w == m).count() as u64;
            shared.marker_count.fetch_add(found, Ordering::SeqCst);
            let keep = m.len().saturating_sub(1).min(tail.len());
            tail.drain(..tail.len() - keep);
        }
        if from_vehicle {
            let silent = lock(&shared.silent_until).is_some_and(|t| Instant::now() < t);
            if silent {
                shared
                    .discarded_bytes
                    .fetch_add(n as u64, Ordering::Relaxed);
                continue;
            }
            if n <= KEEP_BYTES {
                let mut r = lock(&shared.recent);
                if r.len() >= KEEP {
                    r.pop_front();
                }
                r.push_back(chunk.clone());
            }
        }
        if tx.send(Item::Data(Instant::now(), chunk)).await.is_err() {
            return;
        }
    }
}

async fn write_side(
    mut wr: tokio::net::tcp::OwnedWriteHalf,
    mut rx: mpsc::Receiver<Item>,
    shared: Arc<Shared>,
) {
    while let Some(item) = rx.recv().await {
        let bytes = match item {
            Item::Data(at, b) => {
                let delay = *lock(&shared.delay);
                if !delay.is_zero() {
                    tokio::time::sleep_until(at + delay).await;
                }
                b
            }
            Item::Inject(b) => b,
        };
        if wr.write_all(&bytes).await.is_err() {
            return;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An echo server stands in for the emulator: bytes go through both ways, an injection
    /// lands between chunks, a drop closes the driver's side, silence discards.
    #[tokio::test]
    async fn pumps_injects_drops_and_silences() {
        let echo = TcpListener::bind(("127.0.0.1", 0)).await.unwrap();
        let upstream = echo.local_addr().unwrap();
        tokio::spawn(async move {
            loop {
                let Ok((mut s, _)) = echo.accept().await else {
                    return;
                };
                tokio::spawn(async move {
                    let mut b = [0u8; 1024];
                    while let Ok(n) = s.read(&mut b).await {
                        if n == 0 || s.write_all(&b[..n]).await.is_err() {
                            return;
                        }
                    }
                });
            }
        });
        let link = ChaosLink::start(upstream, Some(b"ll")).await.unwrap();
        let mut c = TcpStream::connect(link.addr()).await.unwrap();
        let within = Duration::from_secs(5);
        let mut b = [0u8; 64];
        c.write_all(b"hel").await.unwrap();
        let n = tokio::time::timeout(within, c.read(&mut b))
            .await
            .unwrap()
            .unwrap();
        assert_eq!(&b[..n], b"hel");
        c.write_all(b"lo").await.unwrap();
        let n = tokio::time::timeout(within, c.read(&mut b))
            .await
            .unwrap()
            .unwrap();
        assert_eq!(&b[..n], b"lo");
        assert_eq!(link.marker_count(), 1, "a marker split over two chunks");
        c.write_all(b"hello").await.unwrap();
        let n = tokio::time::timeout(within, c.read(&mut b))
            .await
            .unwrap()
            .unwrap();
        assert_eq!(&b[..n], b"hello");
        assert_eq!(link.recent().last(), Some(&b"hello".to_vec()));
        assert!(link.inject(b"XYZ".to_vec()));
        let n = tokio::time::timeout(within, c.read(&mut b))
            .await
            .unwrap()
            .unwrap();
        assert_eq!(&b[..n], b"XYZ");
        link.silence(Duration::from_secs(60));
        c.write_all(b"lost").await.unwrap();
        assert!(
            tokio::time::timeout(Duration::from_millis(200), c.read(&mut b))
                .await
                .is_err(),
            "a silent vehicle's bytes reached the driver"
        );
        link.drop_connection();
        let n = tokio::time::timeout(within, c.read(&mut b))
            .await
            .unwrap()
            .unwrap_or(0);
        assert_eq!(n, 0, "the dropped pair still carried bytes");
        let s = link.stats();
        assert_eq!((s.connections, s.drops, s.injected_bytes), (1, 1, 3));
        assert_eq!(s.discarded_bytes, 4);
    }
}
