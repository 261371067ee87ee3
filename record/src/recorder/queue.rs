//! What passes from the publishers to the writer thread: one queued [`Item`], and the
//! [`Counters`] both sides bump (read as [`RecorderStats`]) so that a drop on either side is
//! counted where status, metrics and the file's closing metadata can see it.

use std::borrow::Cow;
use std::sync::atomic::{AtomicU64, Ordering};

use frontseat_actors::bus::Origin;

/// What the recorder counted, for status, metrics and the file's closing metadata.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RecorderStats {
    /// Messages handed to the recorder by the bus.
    pub received: u64,
    /// Messages written into a file.
    pub written: u64,
    /// Dropped because the queue was full (the writer or the disk was too slow).
    pub dropped_queue: u64,
    /// Dropped because no file was writable (I/O error, disk below the floor).
    pub dropped_unwritable: u64,
    pub write_errors: u64,
    pub files_opened: u64,
    pub files_removed: u64,
    /// Times the disk had less free than `min_free_mb`.
    pub disk_low: u64,
    /// Files of earlier runs that a crash left without a summary, finished at start.
    pub files_recovered: u64,
    /// Such files that could not be finished (left as they were; logged).
    pub recover_failed: u64,
}

impl RecorderStats {
    pub fn dropped(&self) -> u64 {
        self.dropped_queue + self.dropped_unwritable
    }
}

#[derive(Default)]
pub(super) struct Counters {
    pub(super) received: AtomicU64,
    pub(super) written: AtomicU64,
    pub(super) dropped_queue: AtomicU64,
    pub(super) dropped_unwritable: AtomicU64,
    pub(super) write_errors: AtomicU64,
    pub(super) files_opened: AtomicU64,
    pub(super) files_removed: AtomicU64,
    pub(super) disk_low: AtomicU64,
    pub(super) files_recovered: AtomicU64,
    pub(super) recover_failed: AtomicU64,
}

impl Counters {
    pub(super) fn snapshot(&self) -> RecorderStats {
        let g = |c: &AtomicU64| c.load(Ordering::Relaxed);
        RecorderStats {
            received: g(&self.received),
            written: g(&self.written),
            dropped_queue: g(&self.dropped_queue),
            dropped_unwritable: g(&self.dropped_unwritable),
            write_errors: g(&self.write_errors),
            files_opened: g(&self.files_opened),
            files_removed: g(&self.files_removed),
            disk_low: g(&self.disk_low),
            files_recovered: g(&self.files_recovered),
            recover_failed: g(&self.recover_failed),
        }
    }
}

pub(super) fn bump(c: &AtomicU64) -> u64 {
    c.fetch_add(1, Ordering::Relaxed) + 1
}

/// Logs the 1st, 10th, 100th, ... occurrence: a failing disk must not flood the journal.
pub(super) fn worth_logging(n: u64) -> bool {
    n > 0 && (n == 1 || n.is_power_of_two() && n >= 8 || n.is_multiple_of(10_000))
}

/// One message on its way to the file.
pub(super) struct Item {
    /// The channel topic: the bus group, or `<platform>/<group>` from a [`RecordInput`].
    pub(super) topic: Cow<'static, str>,
    pub(super) type_name: &'static str,
    pub(super) origin: Origin,
    /// Where the message came from when the process hears several vehicles (channel metadata).
    pub(super) platform: Option<Box<str>>,
    pub(super) log_time: u64,
    pub(super) bytes: Vec<u8>,
}
