//! The recorder: subscribes every group of the generated interface that the include/exclude
//! regexes let through (both layers, the same generic way the gateway subscribes its exports),
//! and writes each message on a dedicated thread to MCAP. A process without a bus (the topside)
//! feeds the same writer through a [`RecordInput`] ([`Recorder::start_detached`]).
//!
//! What it guarantees, and how:
//! - A publisher never waits: the bus hands the encoded message to a bounded queue with
//!   `try_send`; a full queue drops the message and counts it (stats and the file's metadata).
//! - Crash safety: chunks are buffered whole and written, then flushed and `sync_data`ed, at
//!   least every `flush_s`; a killed process leaves a file readable up to its last chunk.
//! - Disk: files rotate by size and age, the oldest of ours in the directory are removed past the
//!   budget, and below the free-space floor the recorder stops writing (counted, logged) rather
//!   than fill the disk under the vehicle.
//! - A crash's file is finished at the next start: the files this recorder would have named
//!   that have no summary (and are not locked by a live recorder) get their summary, indexes and
//!   footer on a thread of their own ([`crate::recover`]), so every MCAP reader opens them.
//! - Failures stay here: an I/O error closes the file, counts, logs (rate-limited) and retries a
//!   new file later; the thread never takes the process with it.

/// Log lines keep the target this module had as one file, whatever part now writes them:
/// operators filter and grep on it.
const LOG_TARGET: &str = "frontseat_record::recorder";

mod options;
mod queue;
mod sink;

use std::borrow::Cow;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{SyncSender, TrySendError, sync_channel};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant, SystemTime};

use frontseat_actors::bus::{Bus, Origin, Subscription, Undeliverable};
use frontseat_actors::groups::{ALL, GroupInfo};

pub use options::{RecordMeta, RecorderError, RecorderOptions, Target, config_digest};
pub use queue::RecorderStats;
pub use sink::{is_ours, origin_name};

use crate::time::unix_ns;
use queue::{Counters, Item};
use sink::Sink;

/// Envelopes of one group the bus may have inside the recorder's delivery at once (one per
/// thread publishing that group concurrently).
const BUS_IN_FLIGHT: usize = 1024;

/// A way in for messages that do not come from a bus (the topside's Zenoh samples): the same
/// bounded queue as the bus path, so the caller never waits; a full queue drops and counts.
#[derive(Clone)]
pub struct RecordInput {
    tx: SyncSender<Item>,
    counters: Arc<Counters>,
}

impl std::fmt::Debug for RecordInput {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RecordInput").finish_non_exhaustive()
    }
}

impl RecordInput {
    /// Queues one encoded message of `type_name` (a message type of the compiled protobufs: its
    /// FileDescriptorSet becomes the channel's schema) on channel `topic`, stamped `time` (its
    /// receive time). `platform`, when given, is written in the channel's metadata. Never blocks:
    /// returns false when the message was dropped (queue full: counted; recorder stopped).
    /// The caller bounds the number of distinct topics (each is a channel of the file).
    pub fn record_encoded(
        &self,
        topic: impl Into<Cow<'static, str>>,
        type_name: &'static str,
        platform: Option<&str>,
        bytes: Vec<u8>,
        time: SystemTime,
    ) -> bool {
        self.counters.received.fetch_add(1, Ordering::Relaxed);
        let item = Item {
            topic: topic.into(),
            type_name,
            origin: Origin::Imported,
            platform: platform.map(Into::into),
            log_time: unix_ns(time),
            bytes,
        };
        match self.tx.try_send(item) {
            Ok(()) => true,
            Err(TrySendError::Full(_)) => {
                self.counters.dropped_queue.fetch_add(1, Ordering::Relaxed);
                frontseat_telemetry::metrics::recorder_dropped(1);
                false
            }
            Err(TrySendError::Disconnected(_)) => false,
        }
    }
}

/// The running recorder. Dropping it stops it (and waits for the file to be closed).
pub struct Recorder {
    subs: Vec<Subscription>,
    stop: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
    counters: Arc<Counters>,
    groups: Vec<&'static str>,
    current: Arc<Mutex<Option<PathBuf>>>,
    /// Finishing the files a crash left (at start); joined at stop.
    recovery: Option<std::thread::JoinHandle<()>>,
}

impl std::fmt::Debug for Recorder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Recorder")
            .field("groups", &self.groups.len())
            .field("stats", &self.stats())
            .finish()
    }
}

impl Recorder {
    /// Opens the first file and subscribes every group the options let through. A file that
    /// cannot be opened or written (full disk, read-only card) does not fail the start: messages
    /// are dropped and counted until a new file works.
    pub fn start(
        bus: &Bus,
        opts: RecorderOptions,
        meta: RecordMeta,
    ) -> Result<Self, RecorderError> {
        Self::start_with(bus, ALL, opts, meta)
    }

    /// [`Recorder::start`] over another group table (tests).
    pub fn start_with(
        bus: &Bus,
        groups: &[GroupInfo],
        opts: RecorderOptions,
        meta: RecordMeta,
    ) -> Result<Self, RecorderError> {
        let (mut rec, tx) = Self::spawn_writer(&opts, meta)?;
        // The bus gives Instants; the file wants wall time. One pairing at start keeps every
        // message's time monotonic with the bus even if the wall clock is stepped later.
        let (t0, wall0) = (Instant::now(), unix_ns(SystemTime::now()));
        let counters = rec.counters.clone();
        for g in groups.iter().filter(|g| opts.wants(g.name)) {
            let (tx, c): (SyncSender<Item>, _) = (tx.clone(), counters.clone());
            let type_name = g.type_name;
            // The envelope is released as soon as its bytes are queued here, so it is in flight
            // on the bus only during this call: the bus bound only has to cover publishers on
            // several threads at once; the bound that matters is this recorder's own queue.
            let sub = frontseat_actors::generated::subscribe_encoded(
                bus,
                g.name,
                "recorder",
                BUS_IN_FLIGHT,
                move |env| {
                    c.received.fetch_add(1, Ordering::Relaxed);
                    let since = env
                        .published_at
                        .checked_duration_since(t0)
                        .unwrap_or_default();
                    let item = Item {
                        topic: Cow::Borrowed(env.group),
                        type_name,
                        origin: env.meta.origin,
                        platform: None,
                        log_time: wall0
                            .saturating_add(u64::try_from(since.as_nanos()).unwrap_or(0)),
                        bytes: env.bytes,
                    };
                    match tx.try_send(item) {
                        Ok(()) => Ok(()),
                        Err(TrySendError::Full(_)) => {
                            c.dropped_queue.fetch_add(1, Ordering::Relaxed);
                            frontseat_telemetry::metrics::recorder_dropped(1);
                            Ok(())
                        }
                        // The writer thread is gone (stopped, or it failed): stop delivering.
                        Err(TrySendError::Disconnected(_)) => Err(Undeliverable),
                    }
                },
            );
            if let Some(s) = sub {
                rec.subs.push(s);
                rec.groups.push(g.name);
            }
        }
        drop(tx);
        rec.log_started();
        Ok(rec)
    }

    /// A recorder fed by the caller instead of a bus (the topside records what it hears over
    /// Zenoh): the same files, queue, drop counts and stop as [`Recorder::start`].
    pub fn start_detached(
        opts: RecorderOptions,
        meta: RecordMeta,
    ) -> Result<(Self, RecordInput), RecorderError> {
        let (rec, tx) = Self::spawn_writer(&opts, meta)?;
        rec.log_started();
        let input = RecordInput {
            tx,
            counters: rec.counters.clone(),
        };
        Ok((rec, input))
    }

    /// Opens the first file and starts the writer thread; messages go in through the sender.
    fn spawn_writer(
        opts: &RecorderOptions,
        meta: RecordMeta,
    ) -> Result<(Self, SyncSender<Item>), RecorderError> {
        let pool = crate::schema::compiled_pool().ok_or(RecorderError::NoDescriptors)?;
        let counters = Arc::new(Counters::default());
        let current = Arc::new(Mutex::new(None));
        // Listed before this run's first file exists.
        let earlier = sink::earlier_files(opts);
        let stale = sink::stale_copies(opts);
        let sink = Sink::open(opts, meta.to_map(), pool, counters.clone(), current.clone());

        let (tx, rx) = sync_channel::<Item>(opts.queue);
        let stop = Arc::new(AtomicBool::new(false));
        let recovery = if earlier.is_empty() && stale.is_empty() {
            None
        } else {
            let ropts = crate::recover::RecoverOptions {
                min_free_bytes: opts.min_free_bytes,
                ..crate::recover::RecoverOptions::new(opts.compression)
            };
            let (stop, counters) = (stop.clone(), counters.clone());
            // Its own thread: the recording starts at once, however long the copy takes.
            match std::thread::Builder::new()
                .name("recorder-recover".into())
                .spawn(move || {
                    remove_stale(&stale);
                    finish_earlier(earlier, &ropts, &stop, &counters);
                }) {
                Ok(t) => Some(t),
                Err(e) => {
                    tracing::warn!(target: LOG_TARGET, error = %e, "recorder: cannot start the recovery of earlier files; `frontseat log recover FILE` does it by hand");
                    None
                }
            }
        };
        let thread_stop = stop.clone();
        let thread = std::thread::Builder::new()
            .name("recorder".into())
            .spawn(move || sink.run(rx, thread_stop))
            .map_err(RecorderError::Thread)?;
        frontseat_telemetry::metrics::recorder_running(true);
        Ok((
            Self {
                subs: Vec::new(),
                stop,
                thread: Some(thread),
                counters,
                groups: Vec::new(),
                current,
                recovery,
            },
            tx,
        ))
    }

    fn log_started(&self) {
        tracing::info!(
            target: LOG_TARGET,
            groups = self.groups.len(),
            file = %self.current_file().map(|p| p.display().to_string()).unwrap_or_default(),
            "recording"
        );
    }

    pub fn stats(&self) -> RecorderStats {
        self.counters.snapshot()
    }

    /// Logs a warning each `period` in which messages were dropped (the queue was full or no
    /// file was writable), so a recorder falling behind is seen while it happens, not only in
    /// the file's closing metadata. Runs until the recorder stops (or the task is aborted).
    pub fn spawn_drop_watch(&self, period: Duration) -> tokio::task::JoinHandle<()> {
        let counters = self.counters.clone();
        let stop = self.stop.clone();
        tokio::spawn(async move {
            let mut last = counters.snapshot();
            let mut iv = tokio::time::interval(period);
            iv.tick().await;
            while !stop.load(Ordering::Acquire) {
                iv.tick().await;
                let now = counters.snapshot();
                let new = now.dropped().saturating_sub(last.dropped());
                if new > 0 {
                    tracing::warn!(
                        target: LOG_TARGET,
                        dropped = new,
                        total = now.dropped(),
                        queue_full = now.dropped_queue,
                        unwritable = now.dropped_unwritable,
                        write_errors = now.write_errors,
                        "recorder: messages dropped (never slowing a publisher)"
                    );
                }
                last = now;
            }
        })
    }

    /// Waits until the files of earlier runs are finished (or found complete, or left as they
    /// were); `false` if `timeout` passed first. The recording does not wait for this.
    pub fn wait_recovery(&self, timeout: Duration) -> bool {
        let until = Instant::now() + timeout;
        loop {
            match &self.recovery {
                Some(t) if !t.is_finished() => {}
                _ => return true,
            }
            if Instant::now() >= until {
                return false;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
    }

    /// The groups subscribed.
    pub fn groups(&self) -> &[&'static str] {
        &self.groups
    }

    /// The file being written now.
    pub fn current_file(&self) -> Option<PathBuf> {
        self.current.lock().ok().and_then(|c| c.clone())
    }

    /// Unsubscribes, writes what is queued, closes the file with its summary; returns the
    /// counts. Blocks for the final write: call from a blocking context or accept a short stall.
    pub fn stop(mut self) -> RecorderStats {
        self.shutdown();
        self.stats()
    }

    fn shutdown(&mut self) {
        for s in self.subs.drain(..) {
            s.cancel();
        }
        self.stop.store(true, Ordering::Release);
        if let Some(t) = self.recovery.take()
            && t.join().is_err()
        {
            tracing::error!(target: LOG_TARGET, "the recorder's recovery thread panicked");
        }
        if let Some(t) = self.thread.take() {
            frontseat_telemetry::metrics::recorder_running(false);
            if t.join().is_err() {
                tracing::error!(target: LOG_TARGET, "the recorder thread panicked; the last file may lack its summary");
            }
        }
    }
}

impl Drop for Recorder {
    fn drop(&mut self) {
        self.shutdown();
    }
}

/// Removes the copies an interrupted recovery left (a crash loop must not fill the disk with
/// them); anything else with such a name is left as it is.
fn remove_stale(paths: &[PathBuf]) {
    for p in paths {
        match crate::recover::remove_stale_copy(p) {
            Ok(true) => {
                tracing::info!(target: LOG_TARGET, file = %p.display(), "recorder: removed the unfinished copy an interrupted recovery left");
            }
            Ok(false) => {}
            Err(e) => {
                tracing::debug!(target: LOG_TARGET, file = %p.display(), error = %e, "recorder: a .part file left as it is");
            }
        }
    }
}

/// The start-up recovery: each earlier file that is ours, unfinished and not being written gets
/// its summary; the rest are left as they are. Every outcome is logged and counted.
fn finish_earlier(
    files: Vec<PathBuf>,
    opts: &crate::recover::RecoverOptions,
    stop: &AtomicBool,
    counters: &Counters,
) {
    use crate::recover::{Outcome, RecoverError, recover};
    for path in files {
        if stop.load(Ordering::Acquire) {
            break;
        }
        match recover(&path, opts, stop) {
            Ok(Outcome::AlreadyComplete) => {}
            Ok(Outcome::Recovered(r)) => {
                queue::bump(&counters.files_recovered);
                tracing::info!(
                    target: LOG_TARGET,
                    file = %path.display(),
                    messages = r.messages,
                    bytes_before = r.bytes_before,
                    bytes_after = r.bytes_after,
                    cut = %r.cut,
                    "recorder: finished a crash's recording (summary, indexes, footer): every MCAP reader opens it now"
                );
            }
            Err(RecoverError::Stopped) => {
                tracing::info!(target: LOG_TARGET, file = %path.display(), "recorder: stopped while finishing a crash's recording; left as it was (`frontseat log recover FILE` finishes it)");
                break;
            }
            // Our name but not our file, or a live recorder's: never touched.
            Err(
                e @ (RecoverError::InUse(_)
                | RecoverError::NotOurs { .. }
                | RecoverError::NotMcap { .. }
                | RecoverError::Symlink(_)
                | RecoverError::NotFile(_)),
            ) => {
                tracing::debug!(target: LOG_TARGET, error = %e, "recorder: an earlier file left as it is");
            }
            Err(e) => {
                queue::bump(&counters.recover_failed);
                tracing::warn!(target: LOG_TARGET, error = %e, "recorder: cannot finish a crash's recording; it still reads up to its last whole chunk (`frontseat log info`), and `frontseat log recover FILE` tries again");
            }
        }
    }
}
