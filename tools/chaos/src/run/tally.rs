//! What the faults measured as the run went — recoveries per kind, restarts, reconnects, stalls,
//! floods, gobyd returns, requests lost to a process restart — and every violation and note:
//! all the invariants table reads once the system is shut down.

use std::collections::{BTreeMap, HashSet};
use std::time::Duration;

use crate::plan::FaultKind;
use crate::report::KindStats;

#[derive(Default)]
pub(super) struct Tally {
    /// Driver crashes injected before the current service instance started: its restart count
    /// starts from zero.
    pub(super) crash_base: u64,
    /// Request ids a process restart may leave unanswered: in flight when the process ended,
    /// or sent while no process ran (a helm sees the same from a real restart).
    pub(super) lost_to_restart: HashSet<i32>,
    pub(super) process_restarts: Vec<Duration>,
    pub(super) web_flood_requests: u64,
    pub(super) web_floods_left_command: u32,
    pub(super) notes: Vec<String>,
    /// Helm-side faults after which the vehicle link was checked (new connections at the
    /// simulator, driver restarts).
    pub(super) vehicle_link_checked: u32,
    /// Link checks where the interface answered no snapshot (driver restarts unknown) and the
    /// simulator saw no new connection.
    pub(super) vehicle_link_unknown: u32,
    /// Per gobyd outage: the time from its return to the gateway's link up again.
    pub(super) goby_returns: Vec<Duration>,
    /// Outages during which the gateway reported its link lost.
    pub(super) goby_losses_seen: u32,
    pub(super) injected_panics: u64,
    pub(super) injected_kills: u64,
    pub(super) restart_waits: Vec<Duration>,
    pub(super) stall_deliveries: Vec<u64>,
    pub(super) stall_drops: u64,
    pub(super) moos_reconnects: Vec<Duration>,
    pub(super) translation_restarts: Vec<Duration>,
    pub(super) violations: Vec<String>,
    pub(super) by_kind: BTreeMap<FaultKind, KindStats>,
}
