//! What the server and every connection share: options, counters, the truth stream, the fault
//! mailboxes of the connected vehicles, and the vehicles whose connection dropped recently
//! (kept for `resume_grace` so a reconnecting client gets the same vehicle back).

use std::collections::HashMap;
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};

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

/// What every connection task shares with the server.
pub(crate) struct Shared {
    pub opts: SimOptions,
    pub counters: Counters,
    pub truth: broadcast::Sender<Truth>,
    pub vehicles: Mutex<HashMap<u64, mpsc::Sender<Fault>>>,
    /// Runs whose connection dropped, newest last; see [`Shared::take_detached`].
    pub detached: Mutex<Vec<Detached>>,
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
