//! The writer thread: takes queued items and writes them to MCAP (a channel per topic and
//! origin, each with its message type's descriptors), flushes and syncs at least every
//! `flush_s`, rotates by size and age, names and creates files without ever replacing one,
//! trims the directory to the budget and stops writing below the free-space floor. Every failure
//! is counted and logged here and never leaves the thread.

use std::borrow::Cow;
use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant, SystemTime};

use frontseat_actors::bus::Origin;

use super::options::{RecorderError, RecorderOptions, Target};
use super::queue::{Counters, Item, RecorderStats, bump, worth_logging};
use crate::time::{compact_utc, iso_utc, unix_ns};
use crate::{CHANNEL_ORIGIN, CHANNEL_PLATFORM, META_RECORDER, META_RUN, PROFILE};

/// Uncompressed bytes per chunk before it is closed regardless of `flush_s`.
const CHUNK_BYTES: u64 = 512 * 1024;
/// How often the directory is checked against the budget and the disk for free space.
const DISK_CHECK: Duration = Duration::from_secs(5);
/// Other names tried when a file's name is taken (`run.1.mcap` ... for a fixed `path`).
const MAX_ALTERNATIVES: u32 = 999;
/// After a file could not be opened or written, wait this long before trying a new one.
const RETRY_AFTER: Duration = Duration::from_secs(5);

/// The name an origin is recorded under (channel metadata `origin`): the bus's own names.
pub fn origin_name(o: Origin) -> &'static str {
    o.name()
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
pub(super) struct Sink {
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
    /// The writer's state with its first file open.
    pub(super) fn open(
        opts: &RecorderOptions,
        meta: BTreeMap<String, String>,
        pool: &'static prost_reflect::DescriptorPool,
        counters: Arc<Counters>,
        current: Arc<Mutex<Option<PathBuf>>>,
    ) -> Self {
        let mut sink = Sink {
            opts: opts.clone(),
            meta,
            pool,
            file: None,
            seq: 0,
            counters,
            current,
            last_failure: None,
            disk_ok: true,
        };
        // A disk that is full or unwritable now degrades the recorder, never the process: the
        // failure is counted and logged, and a new file is tried every RETRY_AFTER.
        if let Err(e) = sink.open_next() {
            sink.fail(&e.to_string());
        }
        sink.enforce_disk();
        sink
    }

    pub(super) fn run(mut self, rx: Receiver<Item>, stop: Arc<AtomicBool>) {
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
                target: super::LOG_TARGET,
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
                                    target: super::LOG_TARGET,
                                    kept = %p.display(),
                                    recording_to = %path.display(),
                                    "recorder: record.path exists (a previous run's recording?): kept, its messages untouched (finished in place if a crash left it without a summary); this run records to a new name"
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
        // Held while the file is written (released by the kernel when the process dies): the
        // recovery of crashed files, in this process or another, never takes a live one.
        if let Err(e) =
            rustix::fs::flock(&file, rustix::fs::FlockOperation::NonBlockingLockExclusive)
        {
            tracing::debug!(target: super::LOG_TARGET, file = %path.display(), error = %e, "recorder: no advisory lock on the file");
        }
        let compression = crate::recover::RecoverOptions::new(self.opts.compression).compression;
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
                        tracing::info!(target: super::LOG_TARGET, file = %path.display(), "recorder: removed the oldest record to stay within record.budget_mb");
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
                tracing::warn!(target: super::LOG_TARGET, dir = %dir.display(), free_mb = free >> 20, min_free_mb = self.opts.min_free_bytes >> 20, count = n, "recorder: the disk is nearly full");
            }
        }
        if was_ok && !self.disk_ok {
            tracing::error!(target: super::LOG_TARGET, dir = %dir.display(), free_mb = free >> 20, "recorder: stopped writing, the disk is below half of record.min_free_mb; messages are dropped and counted");
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

/// The files of earlier runs this recorder's options would have named, newest first: what the
/// start-up recovery looks at (each is then checked by its header, footer and lock). Listed
/// before this run creates its first file.
pub(super) fn earlier_files(opts: &RecorderOptions) -> Vec<PathBuf> {
    match &opts.target {
        // `--force`: the file is to be replaced by this run.
        Target::File(_) if opts.replace => Vec::new(),
        Target::File(p) => {
            let mut v: Vec<PathBuf> = (0..=MAX_ALTERNATIVES)
                .map(|n| if n == 0 { p.clone() } else { numbered(p, n) })
                .filter(|p| std::fs::symlink_metadata(p).is_ok_and(|m| m.file_type().is_file()))
                .collect();
            v.reverse();
            v
        }
        Target::Dir { dir, prefix } => {
            let mut v: Vec<PathBuf> = our_files(dir, prefix).into_iter().map(|(p, _)| p).collect();
            // Names sort by start time.
            v.sort_unstable_by(|a, b| b.cmp(a));
            v
        }
    }
}

/// The copies an interrupted recovery may have left in a rotated directory: `<ours>.part` and
/// `<ours>.<pid>.<n>.part` beside the recorder's own names ([`crate::output::create_temp_beside`]).
/// A fixed `path` has none swept: its `.part` is the demo's `--force` recording, kept readable.
pub(super) fn stale_copies(opts: &RecorderOptions) -> Vec<PathBuf> {
    let Target::Dir { dir, prefix } = &opts.target else {
        return Vec::new();
    };
    let Ok(rd) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    rd.filter_map(Result::ok)
        .filter(|e| {
            e.file_name()
                .to_str()
                .and_then(|n| n.strip_suffix(".part"))
                .is_some_and(|base| {
                    let numbered = base.rsplitn(3, '.').collect::<Vec<_>>();
                    let digits = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
                    is_ours(base, prefix)
                        || (numbered.len() == 3
                            && digits(numbered[0])
                            && digits(numbered[1])
                            && is_ours(numbered[2], prefix))
                })
        })
        .map(|e| e.path())
        .collect()
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
