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
//! - Failures stay here: an I/O error closes the file, counts, logs (rate-limited) and retries a
//!   new file later; the thread never takes the process with it.

use std::borrow::Cow;
use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError, SyncSender, TrySendError, sync_channel};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant, SystemTime};

use frontseat_actors::bus::{Bus, Origin, Subscription, Undeliverable};
use frontseat_actors::groups::{ALL, GroupInfo};
use frontseat_config::{RecordCompression, RecordConfig};
use regex::Regex;

use crate::time::{compact_utc, iso_utc, unix_ns};
use crate::{CHANNEL_ORIGIN, CHANNEL_PLATFORM, META_RECORDER, META_RUN, PROFILE};

/// Uncompressed bytes per chunk before it is closed regardless of `flush_s`.
const CHUNK_BYTES: u64 = 512 * 1024;
/// Envelopes of one group the bus may have inside the recorder's delivery at once (one per
/// thread publishing that group concurrently).
const BUS_IN_FLIGHT: usize = 1024;
/// How often the directory is checked against the budget and the disk for free space.
const DISK_CHECK: Duration = Duration::from_secs(5);
/// Other names tried when a file's name is taken (`run.1.mcap` ... for a fixed `path`).
const MAX_ALTERNATIVES: u32 = 999;
/// After a file could not be opened or written, wait this long before trying a new one.
const RETRY_AFTER: Duration = Duration::from_secs(5);

#[derive(Debug, thiserror::Error)]
pub enum RecorderError {
    #[error("record.{field}: {reason}")]
    Config { field: String, reason: String },
    #[error("cannot create {path}: {source}")]
    Create {
        path: String,
        source: std::io::Error,
    },
    #[error("cannot start the MCAP file {path}: {reason}")]
    Mcap { path: String, reason: String },
    #[error("the compiled protobuf descriptors do not decode (a build defect)")]
    NoDescriptors,
    #[error("cannot start the recorder thread: {0}")]
    Thread(std::io::Error),
}

/// Where files go. Every file is created new (`O_EXCL`, never through a symlink): the recorder
/// never truncates nor replaces a file, its own included.
#[derive(Clone, Debug)]
pub enum Target {
    /// This file: never rotated nor removed. If the name is taken (the recording of a run that
    /// crashed, restarted with the same config), that file is kept and this run records to
    /// `<stem>.1.<ext>` (then `.2`, ...), logging both names.
    File(PathBuf),
    /// `<dir>/<prefix>_<UTC>_<seq>.mcap`, rotated, trimmed to the budget.
    Dir { dir: PathBuf, prefix: String },
}

/// The recorder's settings, resolved from `[record]` (or made for `demo --record FILE`).
#[derive(Clone, Debug)]
pub struct RecorderOptions {
    pub target: Target,
    pub include: Vec<Regex>,
    pub exclude: Vec<Regex>,
    /// 0 = never by size.
    pub rotate_bytes: u64,
    pub rotate_after: Option<Duration>,
    /// 0 = no budget.
    pub budget_bytes: u64,
    pub min_free_bytes: u64,
    pub flush: Duration,
    pub compression: RecordCompression,
    pub queue: usize,
    /// [`Target::File`] only (`demo --record FILE --force`): record under a temporary name
    /// beside the file and rename it onto the file when closed, replacing what was there.
    pub replace: bool,
}

impl RecorderOptions {
    /// One file, everything recorded, the defaults of `[record]` otherwise.
    pub fn file(path: impl Into<PathBuf>) -> Self {
        let d = RecordConfig::default();
        Self {
            target: Target::File(path.into()),
            include: Vec::new(),
            exclude: Vec::new(),
            rotate_bytes: 0,
            rotate_after: None,
            budget_bytes: 0,
            min_free_bytes: d.min_free_mb << 20,
            flush: Duration::from_secs_f64(d.flush_s),
            compression: d.compression,
            queue: d.queue,
            replace: false,
        }
    }

    /// From a validated `[record]`; `vehicle` names the files (`frontseat` when empty).
    pub fn from_config(cfg: &RecordConfig, vehicle: &str) -> Result<Self, RecorderError> {
        let compile = |field: &str, list: &[String]| -> Result<Vec<Regex>, RecorderError> {
            list.iter()
                .map(|r| {
                    Regex::new(r).map_err(|e| RecorderError::Config {
                        field: field.into(),
                        reason: format!("{r:?}: {e}"),
                    })
                })
                .collect()
        };
        if !(cfg.flush_s.is_finite() && (0.05..=60.0).contains(&cfg.flush_s)) {
            return Err(RecorderError::Config {
                field: "flush_s".into(),
                reason: format!("{} outside [0.05, 60]", cfg.flush_s),
            });
        }
        let prefix: String = match vehicle {
            "" => "frontseat".into(),
            v => v
                .chars()
                .map(|c| {
                    if c.is_ascii_alphanumeric() || c == '-' {
                        c
                    } else {
                        '-'
                    }
                })
                .collect(),
        };
        let target = match &cfg.path {
            Some(p) => Target::File(PathBuf::from(p)),
            None => Target::Dir {
                dir: PathBuf::from(&cfg.dir),
                prefix,
            },
        };
        let single = matches!(target, Target::File(_));
        Ok(Self {
            target,
            include: compile("include", &cfg.include)?,
            exclude: compile("exclude", &cfg.exclude)?,
            rotate_bytes: if single { 0 } else { cfg.rotate_mb << 20 },
            rotate_after: (!single && cfg.rotate_s > 0).then(|| Duration::from_secs(cfg.rotate_s)),
            budget_bytes: if single { 0 } else { cfg.budget_mb << 20 },
            min_free_bytes: cfg.min_free_mb << 20,
            flush: Duration::from_secs_f64(cfg.flush_s),
            compression: cfg.compression,
            queue: cfg.queue.clamp(16, 1 << 20),
            replace: false,
        })
    }

    /// Whether `group` is recorded.
    pub fn wants(&self, group: &str) -> bool {
        (self.include.is_empty() || self.include.iter().any(|r| r.is_match(group)))
            && !self.exclude.iter().any(|r| r.is_match(group))
    }
}

/// What the run was, written as the `frontseat.run` metadata record of every file.
#[derive(Clone, Debug, Default)]
pub struct RecordMeta {
    pub vehicle: String,
    pub datum_lat: f64,
    pub datum_lon: f64,
    /// Hex digest of the config the process runs (see [`config_digest`]).
    pub config_digest: String,
    pub version: String,
    pub driver: String,
    /// Anything else worth keeping (the command line, the application).
    pub extra: BTreeMap<String, String>,
}

impl RecordMeta {
    fn to_map(&self) -> BTreeMap<String, String> {
        let mut m = self.extra.clone();
        m.insert("vehicle".into(), self.vehicle.clone());
        m.insert("datum_lat".into(), format!("{}", self.datum_lat));
        m.insert("datum_lon".into(), format!("{}", self.datum_lon));
        m.insert("config_digest".into(), self.config_digest.clone());
        m.insert("version".into(), self.version.clone());
        m.insert("driver".into(), self.driver.clone());
        m
    }
}

/// A stable digest of a config's text (FNV-1a, 64 bit, hex): enough to tell two runs' configs
/// apart or equal; not a security hash.
pub fn config_digest(text: &str) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in text.bytes() {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    format!("fnv1a64:{h:016x}")
}

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
}

impl RecorderStats {
    pub fn dropped(&self) -> u64 {
        self.dropped_queue + self.dropped_unwritable
    }
}

#[derive(Default)]
struct Counters {
    received: AtomicU64,
    written: AtomicU64,
    dropped_queue: AtomicU64,
    dropped_unwritable: AtomicU64,
    write_errors: AtomicU64,
    files_opened: AtomicU64,
    files_removed: AtomicU64,
    disk_low: AtomicU64,
}

impl Counters {
    fn snapshot(&self) -> RecorderStats {
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
        }
    }
}

fn bump(c: &AtomicU64) -> u64 {
    c.fetch_add(1, Ordering::Relaxed) + 1
}

/// Logs the 1st, 10th, 100th, ... occurrence: a failing disk must not flood the journal.
fn worth_logging(n: u64) -> bool {
    n > 0 && (n == 1 || n.is_power_of_two() && n >= 8 || n.is_multiple_of(10_000))
}

/// One message on its way to the file.
struct Item {
    /// The channel topic: the bus group, or `<platform>/<group>` from a [`RecordInput`].
    topic: Cow<'static, str>,
    type_name: &'static str,
    origin: Origin,
    /// Where the message came from when the process hears several vehicles (channel metadata).
    platform: Option<Box<str>>,
    log_time: u64,
    bytes: Vec<u8>,
}

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
}

impl std::fmt::Debug for Recorder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Recorder")
            .field("groups", &self.groups.len())
            .field("stats", &self.stats())
            .finish()
    }
}

/// The name an origin is recorded under (channel metadata `origin`): the bus's own names.
pub fn origin_name(o: Origin) -> &'static str {
    o.name()
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
        let mut sink = Sink {
            opts: opts.clone(),
            meta: meta.to_map(),
            pool,
            file: None,
            seq: 0,
            counters: counters.clone(),
            current: current.clone(),
            last_failure: None,
            disk_ok: true,
        };
        // A disk that is full or unwritable now degrades the recorder, never the process: the
        // failure is counted and logged, and a new file is tried every RETRY_AFTER.
        if let Err(e) = sink.open_next() {
            sink.fail(&e.to_string());
        }
        sink.enforce_disk();

        let (tx, rx) = sync_channel::<Item>(opts.queue);
        let stop = Arc::new(AtomicBool::new(false));
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
            },
            tx,
        ))
    }

    fn log_started(&self) {
        tracing::info!(
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
        if let Some(t) = self.thread.take() {
            frontseat_telemetry::metrics::recorder_running(false);
            if t.join().is_err() {
                tracing::error!("the recorder thread panicked; the last file may lack its summary");
            }
        }
    }
}

impl Drop for Recorder {
    fn drop(&mut self) {
        self.shutdown();
    }
}

/// A file that counts its length and syncs to the device on flush (the mcap writer flushes only
/// when a chunk is forced out and at the end, so this is once per `flush_s` at most).
struct SyncFile {
    file: BufWriter<File>,
    len: Arc<AtomicU64>,
}

impl Write for SyncFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.file.write(buf)?;
        self.len.fetch_add(n as u64, Ordering::Relaxed);
        Ok(n)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.file.flush()?;
        self.file.get_ref().sync_data()
    }
}

impl Seek for SyncFile {
    fn seek(&mut self, pos: SeekFrom) -> std::io::Result<u64> {
        self.file.seek(pos)
    }
}

struct OpenFile {
    writer: mcap::Writer<SyncFile>,
    path: PathBuf,
    /// Where the file is renamed when closed (`replace`): it is written under a temporary name.
    commit_to: Option<PathBuf>,
    opened: Instant,
    schemas: HashMap<&'static str, u16>,
    /// origin -> topic -> channel id (looked up without allocating).
    channels: HashMap<&'static str, HashMap<Cow<'static, str>, u16>>,
    seq: u32,
    first_counts: RecorderStats,
    len: Arc<AtomicU64>,
}

/// The writer thread's state.
struct Sink {
    opts: RecorderOptions,
    meta: BTreeMap<String, String>,
    pool: &'static prost_reflect::DescriptorPool,
    file: Option<OpenFile>,
    seq: u64,
    counters: Arc<Counters>,
    current: Arc<Mutex<Option<PathBuf>>>,
    last_failure: Option<Instant>,
    disk_ok: bool,
}

impl Sink {
    fn run(mut self, rx: Receiver<Item>, stop: Arc<AtomicBool>) {
        let mut next_flush = Instant::now() + self.opts.flush;
        let mut next_disk = Instant::now() + DISK_CHECK;
        loop {
            let wait = next_flush
                .saturating_duration_since(Instant::now())
                .min(Duration::from_millis(100));
            match rx.recv_timeout(wait) {
                Ok(item) => self.write(item),
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => break,
            }
            let now = Instant::now();
            if now >= next_flush {
                self.flush();
                next_flush = now + self.opts.flush;
            }
            if now >= next_disk {
                self.enforce_disk();
                next_disk = now + DISK_CHECK;
            }
            if stop.load(Ordering::Acquire) {
                // Write what was already queued, then close.
                while let Ok(item) = rx.try_recv() {
                    self.write(item);
                }
                break;
            }
        }
        self.close_file();
    }

    fn write(&mut self, item: Item) {
        self.rotate_if_due();
        if self.file.is_none()
            && self.disk_ok
            && self.last_failure.is_none_or(|t| t.elapsed() >= RETRY_AFTER)
            && let Err(e) = self.open_next()
        {
            self.fail(&e.to_string());
        }
        let Some(f) = self.file.as_mut() else {
            self.counters
                .dropped_unwritable
                .fetch_add(1, Ordering::Relaxed);
            frontseat_telemetry::metrics::recorder_dropped(1);
            return;
        };
        match write_item(f, self.pool, &item) {
            Ok(()) => {
                self.counters.written.fetch_add(1, Ordering::Relaxed);
            }
            Err(e) => {
                self.counters
                    .dropped_unwritable
                    .fetch_add(1, Ordering::Relaxed);
                frontseat_telemetry::metrics::recorder_dropped(1);
                let why = format!("writing {}: {e}", f.path.display());
                // The writer may be half-way through a record: this file is done.
                self.file = None;
                self.fail(&why);
            }
        }
    }

    fn fail(&mut self, why: &str) {
        self.last_failure = Some(Instant::now());
        let n = bump(&self.counters.write_errors);
        if worth_logging(n) {
            tracing::warn!(
                error = why,
                count = n,
                "recorder: cannot write; messages are dropped and counted until a new file works"
            );
        }
    }

    fn flush(&mut self) {
        if let Some(f) = self.file.as_mut()
            && let Err(e) = f.writer.flush()
        {
            let why = format!("flushing {}: {e}", f.path.display());
            self.file = None;
            self.fail(&why);
        }
    }

    fn rotate_if_due(&mut self) {
        let Some(f) = &self.file else { return };
        let by_size = self.opts.rotate_bytes > 0 && f.writer_len() >= self.opts.rotate_bytes;
        let by_age = self
            .opts
            .rotate_after
            .is_some_and(|d| f.opened.elapsed() >= d);
        if by_size || by_age {
            self.close_file();
            if let Err(e) = self.open_next() {
                self.fail(&e.to_string());
            }
            self.enforce_disk();
        }
    }

    fn next_dir_path(&mut self, dir: &Path, prefix: &str) -> PathBuf {
        self.seq += 1;
        dir.join(format!(
            "{prefix}_{}_{:04}.mcap",
            compact_utc(unix_ns(SystemTime::now())),
            self.seq
        ))
    }

    /// Creates the next file (never an existing name); its path, the file, and the name to
    /// rename it to when closed (`replace`).
    fn create_next(&mut self) -> Result<(PathBuf, File, Option<PathBuf>), RecorderError> {
        let create_err = |path: &Path| {
            let path = path.display().to_string();
            move |source| RecorderError::Create { path, source }
        };
        match self.opts.target.clone() {
            Target::File(p) if self.opts.replace => {
                let (temp, f) =
                    crate::output::create_temp_beside(&p).map_err(|e| RecorderError::Mcap {
                        path: p.display().to_string(),
                        reason: e.to_string(),
                    })?;
                Ok((temp, f, Some(p)))
            }
            Target::File(p) => {
                let mut last = None;
                for n in 0..=MAX_ALTERNATIVES {
                    let path = if n == 0 { p.clone() } else { numbered(&p, n) };
                    match crate::output::create_new(&path) {
                        Ok(f) => {
                            if n > 0 {
                                tracing::warn!(
                                    kept = %p.display(),
                                    recording_to = %path.display(),
                                    "recorder: record.path exists (a previous run's recording?): kept untouched; this run records to a new name"
                                );
                            }
                            return Ok((path, f, None));
                        }
                        Err(e) if crate::output::taken(&e) => last = Some(e),
                        Err(e) => return Err(create_err(&path)(e)),
                    }
                }
                Err(create_err(&p)(last.unwrap_or_else(|| {
                    std::io::Error::other("every alternative name is taken")
                })))
            }
            Target::Dir { dir, prefix } => {
                std::fs::create_dir_all(&dir).map_err(create_err(&dir))?;
                let mut last = None;
                for _ in 0..=MAX_ALTERNATIVES {
                    let path = self.next_dir_path(&dir, &prefix);
                    match crate::output::create_new(&path) {
                        Ok(f) => return Ok((path, f, None)),
                        Err(e) if crate::output::taken(&e) => last = Some(e),
                        Err(e) => return Err(create_err(&path)(e)),
                    }
                }
                Err(create_err(&dir)(last.unwrap_or_else(|| {
                    std::io::Error::other("every file name is taken")
                })))
            }
        }
    }

    fn open_next(&mut self) -> Result<(), RecorderError> {
        if let Target::File(p) = &self.opts.target
            && self.counters.files_opened.load(Ordering::Relaxed) > 0
        {
            // One named file: after a failure, no second file for it.
            return Err(RecorderError::Mcap {
                path: p.display().to_string(),
                reason: "the single record file failed; not starting another".into(),
            });
        }
        let (path, file, commit_to) = self.create_next()?;
        let compression = match self.opts.compression {
            RecordCompression::Zstd => Some(mcap::Compression::Zstd),
            RecordCompression::Lz4 => Some(mcap::Compression::Lz4),
            RecordCompression::None => None,
        };
        let mcap_err = |e: mcap::McapError| RecorderError::Mcap {
            path: path.display().to_string(),
            reason: e.to_string(),
        };
        let len = Arc::new(AtomicU64::new(0));
        let mut writer = mcap::WriteOptions::new()
            .profile(PROFILE)
            .library(format!("frontseat-record {}", env!("CARGO_PKG_VERSION")))
            .compression(compression)
            .chunk_size(Some(CHUNK_BYTES))
            // Chunks are built in memory and written whole: the file on disk never holds a
            // chunk header whose lengths are still to be patched, so a crash leaves only
            // complete chunks before the torn one.
            .disable_seeking(true)
            .create(SyncFile {
                file: BufWriter::with_capacity(256 * 1024, file),
                len: len.clone(),
            })
            .map_err(mcap_err)?;
        let mut meta = self.meta.clone();
        meta.insert("file_seq".into(), self.seq.to_string());
        meta.insert("started_utc".into(), iso_utc(unix_ns(SystemTime::now())));
        writer
            .write_metadata(&mcap::records::Metadata {
                name: META_RUN.into(),
                metadata: meta,
            })
            .map_err(mcap_err)?;
        // The header and run metadata reach the disk now: even a file killed in its first
        // second says what it is.
        writer.flush().map_err(mcap_err)?;
        bump(&self.counters.files_opened);
        if let Ok(mut c) = self.current.lock() {
            *c = Some(path.clone());
        }
        self.file = Some(OpenFile {
            writer,
            path,
            commit_to,
            opened: Instant::now(),
            schemas: HashMap::new(),
            channels: HashMap::new(),
            seq: 0,
            first_counts: self.counters.snapshot(),
            len,
        });
        Ok(())
    }

    fn close_file(&mut self) {
        let Some(mut f) = self.file.take() else {
            return;
        };
        let now = self.counters.snapshot();
        let mut m = BTreeMap::new();
        // Counts over this file's lifetime, and over the whole run.
        let d = |a: u64, b: u64| a.saturating_sub(b).to_string();
        m.insert("written".into(), d(now.written, f.first_counts.written));
        m.insert(
            "dropped_queue".into(),
            d(now.dropped_queue, f.first_counts.dropped_queue),
        );
        m.insert(
            "dropped_unwritable".into(),
            d(now.dropped_unwritable, f.first_counts.dropped_unwritable),
        );
        m.insert("run_dropped".into(), now.dropped().to_string());
        m.insert("run_written".into(), now.written.to_string());
        m.insert("closed_utc".into(), iso_utc(unix_ns(SystemTime::now())));
        let r = f
            .writer
            .write_metadata(&mcap::records::Metadata {
                name: META_RECORDER.into(),
                metadata: m,
            })
            .and_then(|()| f.writer.finish().map(|_| ()));
        if let Err(e) = r {
            let why = format!("closing {}: {e}", f.path.display());
            self.fail(&why);
        }
        if let Some(to) = f.commit_to.take() {
            drop(f.writer);
            if let Err(e) = std::fs::rename(&f.path, &to) {
                let why = format!("renaming {} to {}: {e}", f.path.display(), to.display());
                self.fail(&why);
            } else if let Ok(mut c) = self.current.lock() {
                *c = Some(to);
            }
        }
    }

    /// Removes our oldest files past the budget; warns, and stops writing, when the disk is low.
    fn enforce_disk(&mut self) {
        let Target::Dir { dir, prefix } = &self.opts.target else {
            self.check_free(None);
            return;
        };
        let (dir, prefix) = (dir.clone(), prefix.clone());
        if self.opts.budget_bytes > 0 {
            let current = self.file.as_ref().map(|f| f.path.clone());
            let mut files = our_files(&dir, &prefix);
            let mut total: u64 = files.iter().map(|(_, len)| len).sum();
            // Names sort by start time; the file being written is never removed.
            files.sort();
            for (path, len) in files {
                if total <= self.opts.budget_bytes {
                    break;
                }
                if Some(&path) == current.as_ref() {
                    continue;
                }
                match std::fs::remove_file(&path) {
                    Ok(()) => {
                        total = total.saturating_sub(len);
                        bump(&self.counters.files_removed);
                        tracing::info!(file = %path.display(), "recorder: removed the oldest record to stay within record.budget_mb");
                    }
                    Err(e) => self.fail(&format!("removing {}: {e}", path.display())),
                }
            }
        }
        self.check_free(Some(&dir));
    }

    fn check_free(&mut self, dir: Option<&Path>) {
        let dir = match (dir, &self.opts.target) {
            (Some(d), _) => d.to_path_buf(),
            (None, Target::File(p)) => p
                .parent()
                .filter(|p| !p.as_os_str().is_empty())
                .map(Path::to_path_buf)
                .unwrap_or_else(|| PathBuf::from(".")),
            (None, Target::Dir { dir, .. }) => dir.clone(),
        };
        let Some(free) = free_bytes(&dir) else {
            return;
        };
        let low = free < self.opts.min_free_bytes;
        let was_ok = self.disk_ok;
        self.disk_ok = free >= self.opts.min_free_bytes / 2;
        if low {
            let n = bump(&self.counters.disk_low);
            if worth_logging(n) {
                tracing::warn!(dir = %dir.display(), free_mb = free >> 20, min_free_mb = self.opts.min_free_bytes >> 20, count = n, "recorder: the disk is nearly full");
            }
        }
        if was_ok && !self.disk_ok {
            tracing::error!(dir = %dir.display(), free_mb = free >> 20, "recorder: stopped writing, the disk is below half of record.min_free_mb; messages are dropped and counted");
            self.close_file();
        }
    }
}

impl OpenFile {
    /// Bytes in the file; only whole chunks reach it, so this lags by at most one chunk.
    fn writer_len(&self) -> u64 {
        self.len.load(Ordering::Relaxed)
    }
}

fn write_item(
    f: &mut OpenFile,
    pool: &prost_reflect::DescriptorPool,
    item: &Item,
) -> Result<(), mcap::McapError> {
    let origin = origin_name(item.origin);
    let known = f
        .channels
        .get(origin)
        .and_then(|by_topic| by_topic.get(&*item.topic))
        .copied();
    let channel = match known {
        Some(c) => c,
        None => {
            let schema = match f.schemas.get(item.type_name) {
                Some(s) => *s,
                None => {
                    let data =
                        crate::schema::descriptor_set(pool, item.type_name).unwrap_or_default();
                    let s = f.writer.add_schema(item.type_name, "protobuf", &data)?;
                    f.schemas.insert(item.type_name, s);
                    s
                }
            };
            let mut meta = BTreeMap::new();
            meta.insert(CHANNEL_ORIGIN.to_string(), origin.to_string());
            if let Some(p) = &item.platform {
                meta.insert(CHANNEL_PLATFORM.to_string(), p.to_string());
            }
            let c = f
                .writer
                .add_channel(schema, &item.topic, "protobuf", &meta)?;
            f.channels
                .entry(origin)
                .or_default()
                .insert(item.topic.clone(), c);
            c
        }
    };
    f.seq = f.seq.wrapping_add(1);
    f.writer.write_to_known_channel(
        &mcap::records::MessageHeader {
            channel_id: channel,
            sequence: f.seq,
            log_time: item.log_time,
            publish_time: item.log_time,
        },
        &item.bytes,
    )
}

/// `(path, size)` of the files this recorder named in `dir`: exactly
/// `<prefix>_<YYYYMMDD>T<HHMMSS>Z_<seq>.mcap` (seq: 4 digits or more), regular files only (a
/// symlink, a directory, `auv1_survey_final.mcap` are not ours and are never removed).
fn our_files(dir: &Path, prefix: &str) -> Vec<(PathBuf, u64)> {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    rd.filter_map(Result::ok)
        .filter(|e| e.file_name().to_str().is_some_and(|n| is_ours(n, prefix)))
        // DirEntry::metadata does not follow symlinks.
        .filter_map(|e| {
            let m = e.metadata().ok()?;
            m.file_type().is_file().then(|| (e.path(), m.len()))
        })
        .collect()
}

/// Whether `name` is one the recorder generates for `prefix` (see [`our_files`]).
pub fn is_ours(name: &str, prefix: &str) -> bool {
    let digits = |s: &str, n: usize| s.len() == n && s.bytes().all(|b| b.is_ascii_digit());
    let Some(rest) = name
        .strip_prefix(prefix)
        .and_then(|r| r.strip_prefix('_'))
        .and_then(|r| r.strip_suffix(".mcap"))
    else {
        return false;
    };
    let Some((stamp, seq)) = rest.split_once('_') else {
        return false;
    };
    let Some((date, time)) = stamp.split_once('T') else {
        return false;
    };
    digits(date, 8)
        && time.strip_suffix('Z').is_some_and(|t| digits(t, 6))
        && seq.len() >= 4
        && seq.len() <= 20
        && seq.bytes().all(|b| b.is_ascii_digit())
}

/// `run.mcap` → `run.<n>.mcap` (`run` → `run.<n>`).
fn numbered(p: &Path, n: u32) -> PathBuf {
    let stem = p.file_stem().unwrap_or_default().to_string_lossy();
    let name = match p.extension() {
        Some(ext) => format!("{stem}.{n}.{}", ext.to_string_lossy()),
        None => format!("{stem}.{n}"),
    };
    p.with_file_name(name)
}

fn free_bytes(dir: &Path) -> Option<u64> {
    let s = rustix::fs::statvfs(dir).ok()?;
    Some(s.f_bavail.saturating_mul(s.f_frsize))
}
