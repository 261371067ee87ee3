//! Finishing a recording that a crash left without its summary (`frontseat log recover FILE`,
//! and the recorder at start for its own files): what `mcap recover` does, done safely. The
//! messages, schemas, channels and metadata up to the last whole chunk are read with the bounded
//! reader ([`crate::reader`]) and written again with the `mcap` crate's writer — same channel
//! and schema ids, same sequences and times, its chunk and message indexes, statistics, summary
//! and footer — into a new file beside the original, which is synced, read back, and only then
//! renamed over the original. A failure at any step leaves the original as it was.
//!
//! What is touched: only a regular file (a symlink is never opened: `O_NOFOLLOW`) whose MCAP
//! header says frontseat's recorder wrote it (profile [`crate::PROFILE`], library
//! `frontseat-record …`), that has no footer, and whose advisory lock (`flock`, held by a
//! recorder for the file it writes) can be taken: a file being recorded is never finished under
//! its recorder.

use std::borrow::Cow;
use std::collections::HashMap;
use std::fs::File;
use std::io::{BufWriter, Read, Seek, SeekFrom, Write};
use std::os::unix::fs::{MetadataExt, OpenOptionsExt};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::SystemTime;

use crate::reader::Recording;
use crate::time::{iso_utc, unix_ns};
use crate::{META_RECOVERED, PROFILE};

/// The start of the header's `library` that frontseat writes (the recorder and `log import`).
pub const LIBRARY_PREFIX: &str = "frontseat-record ";
/// Largest Header record read: ours is tens of bytes.
const MAX_HEADER: u64 = 64 * 1024;
/// Uncompressed bytes per chunk of the finished copy (the recorder's own chunk size).
const CHUNK_BYTES: u64 = 512 * 1024;
/// A Footer record and the closing magic: opcode, length 20, body, magic.
const FOOTER_AND_MAGIC: u64 = 1 + 8 + 20 + 8;
/// Messages copied between two looks at the stop flag.
const STOP_EVERY: u64 = 4096;

#[derive(Debug, thiserror::Error)]
pub enum RecoverError {
    #[error("cannot open {path}: {source}")]
    Open {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{0}: a symbolic link; give the recording itself (links are never followed)")]
    Symlink(PathBuf),
    #[error("{0}: not a regular file")]
    NotFile(PathBuf),
    #[error("{path}: not an MCAP file ({why})")]
    NotMcap { path: PathBuf, why: String },
    #[error(
        "{path}: not written by frontseat's recorder (profile {profile:?}, library {library:?}); left as it is (`mcap recover` finishes any MCAP file)"
    )]
    NotOurs {
        path: PathBuf,
        profile: String,
        library: String,
    },
    #[error(
        "{0}: a running recorder is writing it (it holds the file's lock); it gets its summary when that recorder closes it"
    )]
    InUse(PathBuf),
    #[error(
        "{path}: {free} bytes free, not enough for the finished copy ({need} bytes and the {floor} kept free); left as it is"
    )]
    NoSpace {
        path: PathBuf,
        need: u64,
        free: u64,
        floor: u64,
    },
    #[error("cannot {what} {path}: {source}")]
    Io {
        what: &'static str,
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("writing the finished copy {path}: {why}; the original is left as it was")]
    Write { path: PathBuf, why: String },
    #[error("{path}: reading it: {why}; left as it was")]
    Read { path: PathBuf, why: String },
    #[error("stopped before the end; the original is left as it was")]
    Stopped,
}

impl RecoverError {
    /// Whether the file was refused (exit 2) rather than the work failed (exit 1).
    pub fn is_usage(&self) -> bool {
        matches!(
            self,
            Self::Symlink(_) | Self::NotFile(_) | Self::NotOurs { .. } | Self::InUse(_)
        )
    }
}

/// How the finished copy is written.
#[derive(Clone, Debug)]
pub struct RecoverOptions {
    /// Chunk compression of the finished copy.
    pub compression: Option<mcap::Compression>,
    /// Free bytes to leave on the disk after the copy is written (the recorder's floor).
    pub min_free_bytes: u64,
}

impl RecoverOptions {
    /// `compression` as `[record] compression` names it; no free-space floor.
    pub fn new(compression: frontseat_config::RecordCompression) -> Self {
        use frontseat_config::RecordCompression as C;
        Self {
            compression: match compression {
                C::Zstd => Some(mcap::Compression::Zstd),
                C::Lz4 => Some(mcap::Compression::Lz4),
                C::None => None,
            },
            min_free_bytes: 0,
        }
    }
}

impl Default for RecoverOptions {
    fn default() -> Self {
        Self::new(frontseat_config::RecordCompression::Zstd)
    }
}

/// What a finished file now holds.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Recovered {
    pub path: PathBuf,
    /// Messages kept: every one up to the last whole chunk.
    pub messages: u64,
    /// Messages of a channel the file never defined (not copied: an MCAP message needs one).
    pub unknown_channel: u64,
    pub bytes_before: u64,
    pub bytes_after: u64,
    /// Where and why reading the original stopped (a torn last chunk, the end of the data).
    pub cut: String,
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// It has its footer already: nothing was written.
    AlreadyComplete,
    Recovered(Recovered),
}

/// The header fields that say who wrote a file.
struct Header {
    profile: String,
    library: String,
}

/// Whether the header says frontseat's recorder (or `log import`) wrote the file.
fn ours(h: &Header) -> bool {
    h.profile == PROFILE && h.library.starts_with(LIBRARY_PREFIX)
}

/// Finishes `path` if it is a recording of ours without its summary; see the module's text.
/// `stop` set while copying abandons the copy (the original stays as it was).
pub fn recover(
    path: &Path,
    opts: &RecoverOptions,
    stop: &AtomicBool,
) -> Result<Outcome, RecoverError> {
    let mut file = std::fs::OpenOptions::new()
        .read(true)
        .custom_flags((rustix::fs::OFlags::NOFOLLOW | rustix::fs::OFlags::CLOEXEC).bits() as i32)
        .open(path)
        .map_err(|source| {
            if source.raw_os_error() == Some(rustix::io::Errno::LOOP.raw_os_error()) {
                RecoverError::Symlink(path.to_path_buf())
            } else {
                RecoverError::Open {
                    path: path.to_path_buf(),
                    source,
                }
            }
        })?;
    let io = |what: &'static str| {
        let path = path.to_path_buf();
        move |source| RecoverError::Io { what, path, source }
    };
    let meta = file.metadata().map_err(io("stat"))?;
    if !meta.file_type().is_file() {
        return Err(RecoverError::NotFile(path.to_path_buf()));
    }
    let len = meta.len();
    let header = read_header(&mut file, len).map_err(|why| RecoverError::NotMcap {
        path: path.to_path_buf(),
        why,
    })?;
    if !ours(&header) {
        return Err(RecoverError::NotOurs {
            path: path.to_path_buf(),
            profile: header.profile,
            library: header.library,
        });
    }
    // The recorder holds this lock on the file it writes; a crash releases it with the process.
    match rustix::fs::flock(&file, rustix::fs::FlockOperation::NonBlockingLockExclusive) {
        Ok(()) => {}
        Err(rustix::io::Errno::WOULDBLOCK) => return Err(RecoverError::InUse(path.to_path_buf())),
        // A file system without flock (some network ones): nothing to learn from it.
        Err(_) => {}
    }
    if has_footer(&mut file, len).map_err(io("read"))? {
        return Ok(Outcome::AlreadyComplete);
    }
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    if let Ok(s) = rustix::fs::statvfs(&dir) {
        let free = s.f_bavail.saturating_mul(s.f_frsize);
        // The copy is about the original's size (the same chunks, compressed the same way).
        if free < len.saturating_add(opts.min_free_bytes) {
            return Err(RecoverError::NoSpace {
                path: path.to_path_buf(),
                need: len,
                free,
                floor: opts.min_free_bytes,
            });
        }
    }
    file.seek(SeekFrom::Start(0)).map_err(io("read"))?;
    if stop.load(Ordering::Acquire) {
        return Err(RecoverError::Stopped);
    }
    let (temp, out) = crate::output::create_temp_beside(path).map_err(|e| RecoverError::Write {
        path: path.to_path_buf(),
        why: e.to_string(),
    })?;
    let temp = TempFile(temp);
    // Locked while it is written: a start-up's sweep of copies an interrupted recovery left
    // ([`remove_stale_copy`]) never removes one being written.
    let _ = rustix::fs::flock(&out, rustix::fs::FlockOperation::NonBlockingLockExclusive);
    // The finished file keeps the original's mode and, where allowed (root running `log
    // recover`), its owner: the service that wrote it can still read and trim it.
    let _ = rustix::fs::fchmod(&out, rustix::fs::Mode::from_raw_mode(meta.mode() & 0o777));
    // (-1 is "no change" to the kernel and no id: never passed on.)
    if meta.uid() != u32::MAX && meta.gid() != u32::MAX {
        let _ = rustix::fs::fchown(
            &out,
            Some(rustix::fs::Uid::from_raw(meta.uid())),
            Some(rustix::fs::Gid::from_raw(meta.gid())),
        );
    }
    let copied = copy(&file, out, &header, opts, len, stop, &temp.0)?;
    // Read back what was written before anything is replaced.
    let back = count_back(&temp.0).map_err(|why| RecoverError::Write {
        path: temp.0.clone(),
        why,
    })?;
    if back != copied.messages {
        return Err(RecoverError::Write {
            path: temp.0.clone(),
            why: format!(
                "it reads back {back} messages, {} were written",
                copied.messages
            ),
        });
    }
    // The name may have been given to another file meanwhile (removed by a budget, replaced by
    // hand): then that file is not the one read, and is left alone.
    let now = std::fs::symlink_metadata(path).map_err(io("stat"))?;
    if (now.dev(), now.ino()) != (meta.dev(), meta.ino()) {
        return Err(RecoverError::Write {
            path: path.to_path_buf(),
            why: "the file was replaced or removed while it was being finished".into(),
        });
    }
    let bytes_after = std::fs::metadata(&temp.0).map(|m| m.len()).unwrap_or(0);
    std::fs::rename(&temp.0, path).map_err(io("rename the finished copy onto"))?;
    temp.keep();
    // The rename itself reaches the disk.
    if let Ok(d) = File::open(&dir) {
        let _ = d.sync_all();
    }
    Ok(Outcome::Recovered(Recovered {
        path: path.to_path_buf(),
        messages: copied.messages,
        unknown_channel: copied.unknown_channel,
        bytes_before: len,
        bytes_after,
        cut: copied.cut,
    }))
}

/// Removes `path` if it is the copy an interrupted recovery left (a process killed while it
/// finished a file): a regular file (never a symlink) whose header is ours and that nobody holds
/// locked. The caller gives only names of the copies' pattern (`<recording>.part`,
/// `<recording>.<pid>.<n>.part`). `Ok(true)` when removed.
pub fn remove_stale_copy(path: &Path) -> std::io::Result<bool> {
    let mut f = std::fs::OpenOptions::new()
        .read(true)
        .custom_flags((rustix::fs::OFlags::NOFOLLOW | rustix::fs::OFlags::CLOEXEC).bits() as i32)
        .open(path)?;
    let m = f.metadata()?;
    if !m.file_type().is_file() || !read_header(&mut f, m.len()).is_ok_and(|h| ours(&h)) {
        return Ok(false);
    }
    if rustix::fs::flock(&f, rustix::fs::FlockOperation::NonBlockingLockExclusive).is_err() {
        return Ok(false);
    }
    // The name still holds the file checked (not swapped for another since).
    let now = std::fs::symlink_metadata(path)?;
    if (now.dev(), now.ino()) != (m.dev(), m.ino()) {
        return Ok(false);
    }
    std::fs::remove_file(path)?;
    Ok(true)
}

/// The Header record after the magic (MCAP spec: opcode 0x01, u64 length, profile and library
/// as u32-length strings), its lengths checked before anything is read into memory.
fn read_header(f: &mut File, len: u64) -> Result<Header, String> {
    let mut head = [0u8; 8 + 1 + 8];
    if len < head.len() as u64 {
        return Err(format!("{len} bytes: shorter than a header"));
    }
    f.seek(SeekFrom::Start(0)).map_err(|e| e.to_string())?;
    f.read_exact(&mut head).map_err(|e| e.to_string())?;
    if &head[..8] != mcap::MAGIC {
        return Err("no MCAP magic at its start".into());
    }
    if head[8] != mcap::records::op::HEADER {
        return Err("its first record is not a header".into());
    }
    let n = u64::from_le_bytes(head[9..17].try_into().unwrap_or_default());
    if n > MAX_HEADER || n > len - head.len() as u64 {
        return Err(format!("a header of {n} bytes"));
    }
    let mut body = vec![0u8; n as usize];
    f.read_exact(&mut body).map_err(|e| e.to_string())?;
    let string = |at: usize| -> Option<(String, usize)> {
        let l = u32::from_le_bytes(body.get(at..at + 4)?.try_into().ok()?) as usize;
        let s = body.get(at + 4..(at + 4).checked_add(l)?)?;
        Some((String::from_utf8_lossy(s).into_owned(), at + 4 + l))
    };
    let (profile, next) = string(0).ok_or("a damaged header")?;
    let (library, _) = string(next).ok_or("a damaged header")?;
    Ok(Header { profile, library })
}

/// Whether the file ends with a Footer record and the closing magic.
fn has_footer(f: &mut File, len: u64) -> std::io::Result<bool> {
    if len < 8 + FOOTER_AND_MAGIC {
        return Ok(false);
    }
    let mut tail = [0u8; FOOTER_AND_MAGIC as usize];
    f.seek(SeekFrom::Start(len - FOOTER_AND_MAGIC))?;
    f.read_exact(&mut tail)?;
    Ok(tail[0] == mcap::records::op::FOOTER
        && tail[1..9] == 20u64.to_le_bytes()
        && &tail[29..] == mcap::MAGIC)
}

/// Removes the temporary copy unless it was renamed into place.
struct TempFile(PathBuf);

impl TempFile {
    fn keep(mut self) {
        self.0 = PathBuf::new();
    }
}

impl Drop for TempFile {
    fn drop(&mut self) {
        if !self.0.as_os_str().is_empty() {
            let _ = std::fs::remove_file(&self.0);
        }
    }
}

struct Copied {
    messages: u64,
    unknown_channel: u64,
    cut: String,
}

/// Reads `src` from its start and writes every message, channel, schema and metadata record it
/// yields into `out` (closed with its summary and synced).
fn copy(
    src: &File,
    out: File,
    header: &Header,
    opts: &RecoverOptions,
    len: u64,
    stop: &AtomicBool,
    temp: &Path,
) -> Result<Copied, RecoverError> {
    let werr = |e: mcap::McapError| RecoverError::Write {
        path: temp.to_path_buf(),
        why: e.to_string(),
    };
    let mut w = mcap::WriteOptions::new()
        .profile(&header.profile)
        // The same library: the finished file says who recorded it, as before.
        .library(&header.library)
        .compression(opts.compression)
        .chunk_size(Some(CHUNK_BYTES))
        .create(BufWriter::with_capacity(256 * 1024, out))
        .map_err(werr)?;
    let mut rec = Recording::new(src);
    // Channel id → (the reader's topic allocation it was built from, the writer's channel).
    let mut channels: HashMap<u16, (*const str, Arc<mcap::Channel<'static>>)> = HashMap::new();
    let mut meta_written = 0usize;
    let (mut messages, mut unknown_channel) = (0u64, 0u64);
    loop {
        let m = rec.next_message_ref().map_err(|e| RecoverError::Read {
            path: temp.to_path_buf(),
            why: e.to_string(),
        })?;
        let Some(m) = m else { break };
        let (id, seq, time) = (m.channel_id, m.sequence, m.log_time);
        let topic = m.channel.map(|c| Arc::as_ptr(&c.topic));
        let cached = channels
            .get(&id)
            .filter(|(t, _)| Some(*t) == topic)
            .map(|(_, c)| c.clone());
        let (channel, data) = match cached {
            Some(c) => (c, Cow::Borrowed(m.data)),
            None => {
                // A channel met for the first time (or redefined): the message is copied out so
                // the reader's definitions can be looked up.
                let data = m.data.to_vec();
                let Some(c) = rec.channel(id).cloned() else {
                    unknown_channel += 1;
                    continue;
                };
                let schema = rec.schema(c.schema_id).map(|s| {
                    Arc::new(mcap::Schema {
                        id: c.schema_id,
                        name: s.name.clone(),
                        encoding: s.encoding.clone(),
                        data: Cow::Owned(s.data.to_vec()),
                    })
                });
                let channel = Arc::new(mcap::Channel {
                    id,
                    topic: c.topic.to_string(),
                    schema,
                    message_encoding: c.message_encoding.clone(),
                    metadata: c.metadata.clone(),
                });
                channels.insert(id, (Arc::as_ptr(&c.topic), channel.clone()));
                (channel, Cow::Owned(data))
            }
        };
        // The recorder writes publish time = log time (the bus's publish instant).
        w.write(&mcap::Message {
            channel,
            sequence: seq,
            log_time: time,
            publish_time: time,
            data,
        })
        .map_err(werr)?;
        messages += 1;
        let meta = rec.metadata();
        for (name, m) in meta.get(meta_written..).unwrap_or_default() {
            w.write_metadata(&mcap::records::Metadata {
                name: name.clone(),
                metadata: m.clone(),
            })
            .map_err(werr)?;
        }
        meta_written = meta.len();
        if messages.is_multiple_of(STOP_EVERY) && stop.load(Ordering::Acquire) {
            return Err(RecoverError::Stopped);
        }
    }
    for (name, m) in rec.metadata().get(meta_written..).unwrap_or_default() {
        w.write_metadata(&mcap::records::Metadata {
            name: name.clone(),
            metadata: m.clone(),
        })
        .map_err(werr)?;
    }
    let cut = rec
        .truncated()
        .unwrap_or("the data ended without a summary")
        .to_string();
    let mut m = std::collections::BTreeMap::new();
    m.insert("recovered_utc".into(), iso_utc(unix_ns(SystemTime::now())));
    m.insert("messages".into(), messages.to_string());
    m.insert("original_bytes".into(), len.to_string());
    m.insert("cut".into(), cut.clone());
    m.insert(
        "by".into(),
        format!("frontseat-record {}", env!("CARGO_PKG_VERSION")),
    );
    if unknown_channel > 0 {
        m.insert("unknown_channel".into(), unknown_channel.to_string());
    }
    w.write_metadata(&mcap::records::Metadata {
        name: META_RECOVERED.into(),
        metadata: m,
    })
    .map_err(werr)?;
    w.finish().map_err(werr)?;
    let ioerr = |what: &'static str| {
        let path = temp.to_path_buf();
        move |source| RecoverError::Io { what, path, source }
    };
    let mut buf = w.into_inner();
    buf.flush().map_err(ioerr("write"))?;
    let f = buf
        .into_inner()
        .map_err(|e| ioerr("write")(e.into_error()))?;
    f.sync_all().map_err(ioerr("sync"))?;
    Ok(Copied {
        messages,
        unknown_channel,
        cut,
    })
}

/// Messages in a finished copy, which must read to its footer.
fn count_back(path: &Path) -> Result<u64, String> {
    let mut r = Recording::open(path).map_err(|e| e.to_string())?;
    let mut n = 0u64;
    while r.next_message_ref().map_err(|e| e.to_string())?.is_some() {
        n += 1;
    }
    match r.truncated() {
        Some(t) => Err(format!("it does not read to its end: {t}")),
        None => Ok(n),
    }
}
