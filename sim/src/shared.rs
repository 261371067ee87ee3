//! What the server and every connection share: options, counters, the truth stream, the fault
//! mailboxes of the connected vehicles, and the vehicles whose connection dropped recently
//! (kept for `resume_grace` so a reconnecting client gets the same vehicle back).

use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

use tokio::sync::{broadcast, mpsc};
use tokio::time::Instant;

use crate::codec::StartParams;
use crate::run::Run;
use crate::{Fault, SimOptions, Truth};

#[derive(Default)]
pub(crate) struct Counters {
    pub connections: AtomicU64,
    pub refused: AtomicU64,
    pub nav_lines: AtomicU64,
    pub bad_lines: AtomicU64,
    pub oversized: AtomicU64,
    pub cmd_errors: AtomicU64,
    pub start_errors: AtomicU64,
    pub late_ticks: AtomicU64,
    /// Every tick whose step ran (reported, skipped as stale, or with its NAV stopped).
    pub integrated_ticks: AtomicU64,
    /// Integrated ticks whose deadline lies in the counting window (see [`TickWindow`]).
    pub window_ticks: AtomicU64,
    /// Of those, the ones reported with a NAV line.
    pub window_navs: AtomicU64,
    pub skipped_ticks: AtomicU64,
    pub dropped_ticks: AtomicU64,
    pub worst_lateness_ns: AtomicU64,
    pub faults: AtomicU64,
    pub vehicle_panics: AtomicU64,
    pub start_timeouts: AtomicU64,
    pub evicted: AtomicU64,
}

impl Counters {
    pub fn add(c: &AtomicU64, n: u64) {
        if n > 0 {
            c.fetch_add(n, Ordering::Relaxed);
        }
    }
}

/// A span of wall time set by whoever measures (a benchmark): ticks whose *deadline* lies in it
/// are counted when integrated, however late, so the count over a window can be compared with
/// what was due in it without the window's edges catching some vehicles' backlog.
pub(crate) struct TickWindow {
    /// Nanoseconds after `epoch`; `from` > `to` when no window is set.
    epoch: Instant,
    from_ns: AtomicU64,
    to_ns: AtomicU64,
}

impl TickWindow {
    pub fn new(epoch: Instant) -> Self {
        Self {
            epoch,
            from_ns: AtomicU64::new(u64::MAX),
            to_ns: AtomicU64::new(0),
        }
    }

    fn ns(&self, t: Instant) -> u64 {
        u64::try_from(t.saturating_duration_since(self.epoch).as_nanos()).unwrap_or(u64::MAX)
    }

    pub fn set(&self, from: Instant, to: Instant) {
        // Closed first, so that a tick never sees the new start with the old end.
        self.from_ns.store(u64::MAX, Ordering::Relaxed);
        self.to_ns.store(self.ns(to), Ordering::Relaxed);
        self.from_ns.store(self.ns(from), Ordering::Relaxed);
    }

    /// Whether a tick due at `deadline` falls in the window: `from <= deadline < to`.
    pub fn holds(&self, deadline: Instant) -> bool {
        let from = self.from_ns.load(Ordering::Relaxed);
        if from == u64::MAX {
            return false;
        }
        let d = self.ns(deadline);
        d >= from && d < self.to_ns.load(Ordering::Relaxed)
    }
}

/// What every connection task shares with the server.
pub(crate) struct Shared {
    pub opts: SimOptions,
    pub counters: Counters,
    pub truth: broadcast::Sender<Truth>,
    pub vehicles: Mutex<HashMap<u64, mpsc::Sender<Fault>>>,
    /// Runs whose connection dropped, newest last; see [`Shared::take_detached`].
    pub detached: Mutex<Vec<Detached>>,
    /// Connections that have sent their first valid START and are still open (what
    /// `max_vehicles` limits).
    pub running: Arc<AtomicUsize>,
    pub window: TickWindow,
}

/// A vehicle whose connection dropped while it was running.
pub(crate) struct Detached {
    pub id: u64,
    pub at: Instant,
    pub run: Run,
}

impl Shared {
    pub fn vehicles(&self) -> std::sync::MutexGuard<'_, HashMap<u64, mpsc::Sender<Fault>>> {
        // A poisoned map is still a valid map: no invariant spans a panic here.
        self.vehicles.lock().unwrap_or_else(|p| p.into_inner())
    }

    fn detached(&self) -> std::sync::MutexGuard<'_, Vec<Detached>> {
        self.detached.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Keep a dropped connection's running vehicle for `resume_grace`.
    pub fn detach(&self, d: Detached) {
        if self.opts.resume_grace.is_zero() {
            return;
        }
        let mut pool = self.detached();
        Self::prune(&mut pool, d.at, self.opts.resume_grace);
        // Bounded like the connections themselves: the oldest goes first.
        if pool.len() >= self.opts.max_vehicles.max(1) {
            pool.remove(0);
        }
        pool.push(d);
    }

    /// The vehicle a reconnecting client gets back: the most recently detached one, within the
    /// grace period, whose START had exactly these parameters. A client repeats its START at
    /// full precision after a reconnect (Goby3's driver and ours do), so equal parameters name
    /// the same vehicle; a new mission (another START) gets a new vehicle.
    pub fn take_detached(&self, params: &StartParams, now: Instant) -> Option<Detached> {
        let mut pool = self.detached();
        Self::prune(&mut pool, now, self.opts.resume_grace);
        let i = pool.iter().rposition(|d| d.run.params == *params)?;
        Some(pool.remove(i))
    }

    fn prune(pool: &mut Vec<Detached>, now: Instant, grace: std::time::Duration) {
        pool.retain(|d| now.saturating_duration_since(d.at) <= grace);
    }

    /// A resumed vehicle takes its old id back: its fault mailbox moves from `from` to `to`.
    pub fn rekey(&self, from: u64, to: u64) {
        let mut map = self.vehicles();
        if let Some(tx) = map.remove(&from) {
            map.insert(to, tx);
        }
    }
}
