//! The TCP server: accepts connections, gives each its own vehicle task, and offers the embedding
//! handle (truth stream, fault injection, vehicle list, counters, shutdown).
//!
//! Each connection is an actor in the plain sense: one tokio task owns the socket and the vehicle
//! and is reached only through its bounded fault mailbox. Plain tasks rather than ractor actors
//! because a vehicle's tick must be a deadline timer in the same select loop as its socket
//! reads; as a ractor actor every tick would be a mailbox message from a timer task
//! (100 000 a second at the capacity target) and the socket would still need a reader task.

use std::collections::VecDeque;
use std::net::SocketAddr;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use tokio::net::TcpListener;
use tokio::sync::{broadcast, mpsc, oneshot, watch};
use tokio::task::JoinSet;

use crate::connection::{Connection, StartMark};
use crate::shared::{Counters, Shared, TickWindow};
use crate::{Fault, SimError, SimOptions, SimStats, Truth};

/// Truth messages buffered for slow subscribers before they see `Lagged`.
const TRUTH_CAPACITY: usize = 8192;
/// Faults queued per vehicle before more are refused (and logged).
const FAULT_MAILBOX: usize = 64;

/// The simulator server; [`SimServer::bind`] starts it.
pub struct SimServer;

impl SimServer {
    /// Bind `addr` and start accepting vehicles. Runs until [`SimHandle::shutdown`].
    pub async fn bind(addr: SocketAddr, opts: SimOptions) -> Result<SimHandle, SimError> {
        let listener = TcpListener::bind(addr)
            .await
            .map_err(|source| SimError::Bind { addr, source })?;
        let local = listener.local_addr()?;
        let (truth, _) = broadcast::channel(TRUTH_CAPACITY);
        let shared = Arc::new(Shared {
            opts,
            counters: Counters::default(),
            truth,
            vehicles: Default::default(),
            detached: Default::default(),
            running: Arc::default(),
            window: TickWindow::new(tokio::time::Instant::now()),
        });
        let (stop_tx, stop_rx) = watch::channel(false);
        let (done_tx, done_rx) = watch::channel(None);
        let accept = tokio::spawn(accept_loop(listener, shared.clone(), stop_rx));
        // Says how the accept task ended, so that a supervisor sees a failure of the server.
        let task = tokio::spawn(async move {
            let why = match accept.await {
                Ok(()) => Ending::Stopped,
                Err(e) => Ending::Failed(e.to_string()),
            };
            done_tx.send_replace(Some(why.clone()));
            if let Ending::Failed(e) = why {
                tracing::error!(error = %e, "simulator accept task failed");
            }
        });
        tracing::info!(addr = %local, "basic frontseat simulator listening");
        Ok(SimHandle {
            local,
            shared,
            stop: Arc::new(stop_tx),
            task: Arc::new(tokio::sync::Mutex::new(Some(task))),
            done: done_rx,
        })
    }
}

/// The embedding handle; cheap to clone.
#[derive(Clone)]
pub struct SimHandle {
    local: SocketAddr,
    shared: Arc<Shared>,
    stop: Arc<watch::Sender<bool>>,
    task: Arc<tokio::sync::Mutex<Option<tokio::task::JoinHandle<()>>>>,
    done: watch::Receiver<Option<Ending>>,
}

#[derive(Clone, Debug)]
enum Ending {
    Stopped,
    Failed(String),
}

impl SimHandle {
    pub fn local_addr(&self) -> SocketAddr {
        self.local
    }

    /// One [`Truth`] per reported vehicle tick, for every vehicle.
    pub fn subscribe_truth(&self) -> broadcast::Receiver<Truth> {
        self.shared.truth.subscribe()
    }

    /// Make one vehicle (or, with `None`, every vehicle) show `fault` now.
    pub fn inject(&self, vehicle: Option<u64>, fault: Fault) {
        let targets: Vec<(u64, mpsc::Sender<Fault>)> = {
            let map = self.shared.vehicles();
            match vehicle {
                Some(id) => map
                    .get(&id)
                    .map(|tx| (id, tx.clone()))
                    .into_iter()
                    .collect(),
                None => map.iter().map(|(id, tx)| (*id, tx.clone())).collect(),
            }
        };
        if targets.is_empty() {
            tracing::warn!(?vehicle, ?fault, "fault injection: no such vehicle");
        }
        for (id, tx) in targets {
            if tx.try_send(fault.clone()).is_err() {
                tracing::warn!(
                    vehicle = id,
                    ?fault,
                    "fault injection: mailbox full or vehicle gone"
                );
            }
        }
    }

    /// Ids of the connected vehicles, ascending.
    pub fn vehicles(&self) -> Vec<u64> {
        let mut v: Vec<u64> = self.shared.vehicles().keys().copied().collect();
        v.sort_unstable();
        v
    }

    pub fn stats(&self) -> SimStats {
        let c = &self.shared.counters;
        let g = |a: &AtomicU64| a.load(Ordering::Relaxed);
        SimStats {
            connections: g(&c.connections),
            refused: g(&c.refused),
            nav_lines: g(&c.nav_lines),
            bad_lines: g(&c.bad_lines),
            oversized: g(&c.oversized),
            cmd_errors: g(&c.cmd_errors),
            start_errors: g(&c.start_errors),
            late_ticks: g(&c.late_ticks),
            integrated_ticks: g(&c.integrated_ticks),
            window_ticks: g(&c.window_ticks),
            window_navs: g(&c.window_navs),
            skipped_ticks: g(&c.skipped_ticks),
            dropped_ticks: g(&c.dropped_ticks),
            worst_lateness: Duration::from_nanos(g(&c.worst_lateness_ns)),
            faults: g(&c.faults),
            vehicle_panics: g(&c.vehicle_panics),
            start_timeouts: g(&c.start_timeouts),
            evicted: g(&c.evicted),
            running: self.shared.running.load(Ordering::Relaxed) as u64,
        }
    }

    /// Start over the worst tick lateness of [`stats`](Self::stats) (a benchmark measuring a
    /// window leaves the start-up's out).
    pub fn reset_worst_lateness(&self) {
        self.shared
            .counters
            .worst_lateness_ns
            .store(0, Ordering::Relaxed);
    }

    /// From now on count in [`SimStats::window_ticks`] every integrated tick whose deadline lies
    /// in `from..to` (replacing an earlier window; the count goes on from where it is).
    pub fn count_ticks_due_in(&self, from: tokio::time::Instant, to: tokio::time::Instant) {
        self.shared.window.set(from, to);
    }

    /// Resolves when the server has stopped: `None` after [`shutdown`](Self::shutdown), `Some`
    /// with the reason when its accept task failed by itself.
    pub async fn ended(&self) -> Option<String> {
        let mut done = self.done.clone();
        match done.wait_for(Option::is_some).await {
            Ok(e) => match e.clone() {
                Some(Ending::Failed(why)) => Some(why),
                _ => None,
            },
            Err(_) => Some("simulator server task gone".into()),
        }
    }

    /// Stop accepting, close every vehicle's connection and wait until they are gone.
    pub async fn shutdown(&self) {
        let _ = self.stop.send(true);
        let task = self.task.lock().await.take();
        if let Some(task) = task {
            let _ = task.await;
        }
    }
}

/// A connection that has not sent its first START yet, oldest first in the accept loop's queue.
struct Pending {
    id: u64,
    started: Arc<StartMark>,
    evict: oneshot::Sender<()>,
}

async fn accept_loop(listener: TcpListener, shared: Arc<Shared>, mut stop: watch::Receiver<bool>) {
    let mut tasks = JoinSet::new();
    let mut next_id: u64 = 1;
    // Why a queue and not just a timeout: a timeout frees slots only after it, and 10 000 silent
    // connections opened within it would still keep a new vehicle out (and exhaust descriptors,
    // so accept itself fails). Bounding the not-yet-started connections and closing the oldest
    // keeps the descriptors bounded and always lets the newest client in.
    let mut pending: VecDeque<Pending> = VecDeque::new();
    let max_pending = shared.opts.max_pending.max(1);
    let running = shared.running.clone();
    let stop_for_tasks = stop.clone();
    loop {
        tokio::select! {
            () = async { let _ = stop.wait_for(|s| *s).await; } => break,
            Some(done) = tasks.join_next(), if !tasks.is_empty() => {
                // The server supervises its vehicles: a panic ends one connection, never the
                // server or another vehicle.
                if let Err(e) = done {
                    if e.is_panic() {
                        Counters::add(&shared.counters.vehicle_panics, 1);
                    }
                    tracing::error!(error = %e, "vehicle task failed: its connection is closed; the other vehicles go on");
                }
            }
            accepted = listener.accept() => match accepted {
                Ok((stream, peer)) => {
                    Counters::add(&shared.counters.connections, 1);
                    let id = next_id;
                    next_id += 1;
                    pending.retain(|p| !p.started.is_started() && !p.evict.is_closed());
                    // Only vehicles that started count against max_vehicles: the waiting ones
                    // are bounded by max_pending.
                    if running.load(Ordering::Relaxed) >= shared.opts.max_vehicles {
                        Counters::add(&shared.counters.refused, 1);
                        tracing::warn!(vehicle = id, %peer, max = shared.opts.max_vehicles,
                            "refusing connection: too many vehicles");
                        tasks.spawn(crate::connection::refuse(stream, shared.opts.max_vehicles));
                        continue;
                    }
                    while pending.len() >= max_pending {
                        let Some(old) = pending.pop_front() else { break };
                        if old.evict.send(()).is_ok() {
                            let n = shared.counters.evicted.fetch_add(1, Ordering::Relaxed) + 1;
                            // Rate-limited: a flood of silent connections must not flood the log.
                            if n == 1 || n.is_multiple_of(1000) {
                                tracing::warn!(vehicle = old.id, evicted = n, max_pending,
                                    "closing the oldest connection that sent no START: a new client needs the slot");
                            }
                        }
                    }
                    let (tx, rx) = mpsc::channel(FAULT_MAILBOX);
                    shared.vehicles().insert(id, tx);
                    let current_id = Arc::new(AtomicU64::new(id));
                    let started = Arc::new(StartMark::new(running.clone()));
                    let (evict_tx, evict_rx) = oneshot::channel();
                    pending.push_back(Pending { id, started: started.clone(), evict: evict_tx });
                    let conn = Connection::new(current_id.clone(), peer, stream, shared.clone(), rx)
                        .awaiting_start(started.clone(), evict_rx);
                    let shared2 = shared.clone();
                    let mut stop2 = stop_for_tasks.clone();
                    tasks.spawn(async move {
                        // Deregisters however the task ends, panic included (under the id the
                        // connection has then: a resumed vehicle takes its old id back).
                        let _registered = Registered(shared2, current_id, started);
                        tokio::select! {
                            _ = conn.run() => {}
                            () = async { let _ = stop2.wait_for(|s| *s).await; } => {}
                        }
                    });
                }
                Err(e) => {
                    // Typically out of file descriptors: back off instead of spinning.
                    tracing::warn!(error = %e, "accept failed");
                    tokio::time::sleep(Duration::from_millis(50)).await;
                }
            }
        }
    }
    while let Some(done) = tasks.join_next().await {
        if let Err(e) = done {
            tracing::error!(error = %e, "vehicle task failed");
        }
    }
    shared.vehicles().clear();
}

struct Registered(Arc<Shared>, Arc<AtomicU64>, Arc<StartMark>);

impl Drop for Registered {
    fn drop(&mut self) {
        self.2.release();
        self.0.vehicles().remove(&self.1.load(Ordering::Relaxed));
    }
}
