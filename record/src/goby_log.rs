//! Reading goby_logger `.goby` files (Goby3's own log format) entry by entry, in bounded memory,
//! from an untrusted source: the framing, CRC and index entries of Goby3's
//! `src/middleware/log/log_entry.{h,cpp}`. What the entries mean (protobuf descriptors, messages)
//! is [`crate::import`]'s business.
//!
//! The format, as Goby3 writes it (`LogEntry::serialize`, `_serialize` in log_entry.cpp):
//! - a 4-byte big-endian file version (2 or 3; version 1 files start directly with an entry);
//! - entries `"GBY3" | size u32 | scheme u16 | group u16 | type u16 | [time u64 µs, v3] | data |
//!   crc32`, all big-endian, `size` counting everything after itself, the CRC-32 (boost's
//!   `crc_32_type`, the IEEE one) covering magic to the end of data;
//! - scheme 0xFFFF / 0xFFFE entries map a group / type index to its name (since v2 prefixed by
//!   the 2-byte scheme the mapping belongs to).
//!
//! Damage is handled as goby_log_tool does: a byte that is not a magic word is skipped until the
//! next `GBY3`; an entry whose CRC fails is dropped and the search for the next magic starts
//! right after its header (its size may be what was corrupted). Everything skipped is counted.

use std::collections::HashMap;
use std::io::Read;
use std::sync::Arc;

/// Largest entry accepted (size field): real entries are a message or a descriptor; anything
/// larger is corruption and is resynchronised over rather than allocated.
pub const MAX_ENTRY: u32 = 16 << 20;
const MAGIC: &[u8; 4] = b"GBY3";
const SCHEME_GROUP_INDEX: u16 = 0xFFFF;
const SCHEME_TYPE_INDEX: u16 = 0xFFFE;
/// Versions this reader knows (log_entry.h `compiled_current_version` = 3).
pub const CURRENT_VERSION: u32 = 3;
const READ_STEP: usize = 64 * 1024;
/// Longest group or type name kept from an index entry: Goby3's are tens of bytes. A longer one
/// is skipped and counted (its entries read as `_unknownN_`).
pub const MAX_NAME: usize = 1024;
/// Most bytes of distinct names kept (each name once, however many index entries repeat it):
/// past it, index entries with new names are skipped and counted.
pub const MAX_NAMES_BYTES: usize = 4 << 20;
/// Most index mappings kept (group and type indexes, per scheme).
pub const MAX_MAPPINGS: usize = 65_536;

#[derive(Debug, thiserror::Error)]
pub enum GobyLogError {
    #[error("reading: {0}")]
    Io(#[from] std::io::Error),
    #[error("not a goby_logger file: {0}")]
    NotGoby(String),
}

/// One data entry (not an index entry), names resolved.
#[derive(Clone, Debug)]
pub struct Entry {
    /// Goby3's MarshallingScheme (1 = PROTOBUF, 2 = DCCL, 0 = CSTR, ...).
    pub scheme: u16,
    /// Interned: the same name is the same allocation for the whole file, so a caller can key
    /// its per-group state by [`Arc::as_ptr`] and do no work per entry that grows with the name.
    pub group: Arc<str>,
    pub type_name: Arc<str>,
    /// Microseconds since the Unix epoch (files of version 3 and later).
    pub time_us: Option<u64>,
    pub data: Vec<u8>,
}

/// What the reader counted; damage never stops it, it is only reported.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct GobyReadStats {
    pub entries: u64,
    pub index_entries: u64,
    pub crc_errors: u64,
    /// Entries whose size field was impossible (too small, or above [`MAX_ENTRY`]).
    pub bad_sizes: u64,
    /// Bytes passed over looking for the next magic word.
    pub skipped_bytes: u64,
    /// Data entries whose group or type index had no index entry before them.
    pub unresolved: u64,
    /// The file ends inside an entry (a logger killed mid-write, or a copy in progress).
    pub torn_tail: bool,
    /// Index entries not kept: a name over [`MAX_NAME`], or past [`MAX_NAMES_BYTES`] /
    /// [`MAX_MAPPINGS`].
    pub names_skipped: u64,
}

/// A `.goby` file read from its start.
pub struct GobyReader<R: Read> {
    src: R,
    buf: Vec<u8>,
    pos: usize,
    eof: bool,
    version: Option<u32>,
    groups: HashMap<(u16, u16), Arc<str>>,
    types: HashMap<(u16, u16), Arc<str>>,
    /// Every distinct name once.
    names: std::collections::HashSet<Arc<str>>,
    names_bytes: usize,
    /// `_unknownN_` placeholders, made once per index number.
    unknown: HashMap<u16, Arc<str>>,
    stats: GobyReadStats,
}

impl<R: Read> GobyReader<R> {
    pub fn new(src: R) -> Self {
        Self {
            src,
            buf: Vec::new(),
            pos: 0,
            eof: false,
            version: None,
            groups: HashMap::new(),
            types: HashMap::new(),
            names: std::collections::HashSet::new(),
            names_bytes: 0,
            unknown: HashMap::new(),
            stats: GobyReadStats::default(),
        }
    }

    pub fn stats(&self) -> &GobyReadStats {
        &self.stats
    }

    /// The file's version, once the first entry was looked for.
    pub fn version(&self) -> Option<u32> {
        self.version
    }

    /// Makes `n` bytes available at `pos` if the source has them; false at the end.
    fn fill(&mut self, n: usize) -> Result<bool, GobyLogError> {
        while self.buf.len() - self.pos < n {
            if self.eof {
                return Ok(false);
            }
            if self.pos > 0 && self.pos >= self.buf.len() / 2 {
                self.buf.drain(..self.pos);
                self.pos = 0;
            }
            let old = self.buf.len();
            let want = (n - (old - self.pos)).max(READ_STEP);
            self.buf.resize(old + want, 0);
            let got = loop {
                match self.src.read(&mut self.buf[old..]) {
                    Ok(g) => break g,
                    Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                    Err(e) => {
                        self.buf.truncate(old);
                        return Err(e.into());
                    }
                }
            };
            self.buf.truncate(old + got);
            if got == 0 {
                self.eof = true;
            }
        }
        Ok(true)
    }

    fn be(&self, at: usize, n: usize) -> u64 {
        self.buf[self.pos + at..self.pos + at + n]
            .iter()
            .fold(0u64, |a, b| (a << 8) | u64::from(*b))
    }

    fn read_version(&mut self) -> Result<u32, GobyLogError> {
        if !self.fill(4)? {
            return Err(GobyLogError::NotGoby(
                "shorter than a version and an entry".into(),
            ));
        }
        let v = if &self.buf[self.pos..self.pos + 4] == MAGIC {
            // log_entry.cpp parse_version: a file that starts with the magic is version 1.
            1
        } else {
            let v = self.be(0, 4) as u32;
            self.pos += 4;
            if v == 0 {
                return Err(GobyLogError::NotGoby("version 0".into()));
            }
            // As Goby3 does, a newer version is read as the current one.
            v.min(CURRENT_VERSION)
        };
        // Something else altogether (an MCAP file, text) has no magic word where the first
        // entry must be: refuse rather than resynchronise through the whole file.
        if !self.fill(4)? || &self.buf[self.pos..self.pos + 4] != MAGIC {
            return Err(GobyLogError::NotGoby(
                "no GBY3 entry after the version".into(),
            ));
        }
        Ok(v)
    }

    /// The next data entry; `Ok(None)` at the end of the file.
    pub fn next_entry(&mut self) -> Result<Option<Entry>, GobyLogError> {
        let version = match self.version {
            Some(v) => v,
            None => {
                let v = self.read_version()?;
                self.version = Some(v);
                v
            }
        };
        let fixed: u32 = 2 + 2 + 2 + 4 + if version >= 3 { 8 } else { 0 };
        loop {
            // Find the magic word.
            loop {
                if !self.fill(4)? {
                    let left = (self.buf.len() - self.pos) as u64;
                    if left > 0 {
                        self.stats.skipped_bytes += left;
                        self.stats.torn_tail = true;
                        self.pos = self.buf.len();
                    }
                    return Ok(None);
                }
                if &self.buf[self.pos..self.pos + 4] == MAGIC {
                    break;
                }
                self.pos += 1;
                self.stats.skipped_bytes += 1;
            }
            if !self.fill(8)? {
                self.torn_at_end();
                return Ok(None);
            }
            let size = self.be(4, 4) as u32;
            if size < fixed || size > MAX_ENTRY {
                self.stats.bad_sizes += 1;
                self.skip_magic();
                continue;
            }
            let total = 8 + size as usize;
            if !self.fill(total)? {
                // Either a torn last entry or a corrupted size: look for a later entry.
                self.stats.torn_tail = true;
                self.skip_magic();
                continue;
            }
            let body = &self.buf[self.pos..self.pos + total];
            let computed = crc32fast::hash(&body[..total - 4]);
            let given = self.be(total - 4, 4) as u32;
            if computed != given {
                self.stats.crc_errors += 1;
                self.skip_magic();
                continue;
            }
            self.stats.torn_tail = false;
            let scheme = self.be(8, 2) as u16;
            let group_ix = self.be(10, 2) as u16;
            let type_ix = self.be(12, 2) as u16;
            let (time_us, data_at) = if version >= 3 {
                (Some(self.be(14, 8)), 22)
            } else {
                (None, 14)
            };
            let data = self.buf[self.pos + data_at..self.pos + total - 4].to_vec();
            self.pos += total;
            match scheme {
                SCHEME_GROUP_INDEX | SCHEME_TYPE_INDEX => {
                    self.stats.index_entries += 1;
                    let (owner, name) = if version >= 2 {
                        if data.len() < 2 {
                            self.stats.unresolved += 1;
                            continue;
                        }
                        (u16::from_be_bytes([data[0], data[1]]), &data[2..])
                    } else {
                        // Version 1: one mapping for every scheme.
                        (u16::MAX, &data[..])
                    };
                    let Some(name) = self.intern(name) else {
                        self.stats.names_skipped += 1;
                        continue;
                    };
                    let (map, key) = if scheme == SCHEME_GROUP_INDEX {
                        (&mut self.groups, (owner, group_ix))
                    } else {
                        (&mut self.types, (owner, type_ix))
                    };
                    if map.len() >= MAX_MAPPINGS && !map.contains_key(&key) {
                        self.stats.names_skipped += 1;
                        continue;
                    }
                    map.insert(key, name);
                }
                _ => {
                    self.stats.entries += 1;
                    let key = |ix| {
                        if version >= 2 {
                            (scheme, ix)
                        } else {
                            (u16::MAX, ix)
                        }
                    };
                    let group = self.groups.get(&key(group_ix)).cloned();
                    let type_name = self.types.get(&key(type_ix)).cloned();
                    if group.is_none() || type_name.is_none() {
                        self.stats.unresolved += 1;
                    }
                    return Ok(Some(Entry {
                        scheme,
                        // Goby3's own placeholders for a missing index entry.
                        group: group.unwrap_or_else(|| self.unknown(group_ix)),
                        type_name: type_name.unwrap_or_else(|| self.unknown(type_ix)),
                        time_us,
                        data,
                    }));
                }
            }
        }
    }

    /// The one allocation of `name` (lossy UTF-8); None when over [`MAX_NAME`] or when a new
    /// name would pass [`MAX_NAMES_BYTES`].
    fn intern(&mut self, name: &[u8]) -> Option<Arc<str>> {
        if name.len() > MAX_NAME {
            return None;
        }
        let name = String::from_utf8_lossy(name);
        if let Some(n) = self.names.get(&*name) {
            return Some(n.clone());
        }
        if self.names_bytes + name.len() > MAX_NAMES_BYTES {
            return None;
        }
        let n: Arc<str> = Arc::from(&*name);
        self.names_bytes += n.len();
        self.names.insert(n.clone());
        Some(n)
    }

    fn unknown(&mut self, ix: u16) -> Arc<str> {
        self.unknown
            .entry(ix)
            .or_insert_with(|| Arc::from(format!("_unknown{ix}_")))
            .clone()
    }

    /// Past this magic word, to look for the next one.
    fn skip_magic(&mut self) {
        self.pos += 4;
        self.stats.skipped_bytes += 4;
    }

    fn torn_at_end(&mut self) {
        let left = (self.buf.len() - self.pos) as u64;
        self.stats.skipped_bytes += left;
        self.stats.torn_tail = true;
        self.pos = self.buf.len();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn entry(version: u32, scheme: u16, g: u16, t: u16, time: u64, data: &[u8]) -> Vec<u8> {
        let mut size = 2 + 2 + 2 + data.len() as u32 + 4;
        if version >= 3 {
            size += 8;
        }
        let mut e = b"GBY3".to_vec();
        e.extend(size.to_be_bytes());
        e.extend(scheme.to_be_bytes());
        e.extend(g.to_be_bytes());
        e.extend(t.to_be_bytes());
        if version >= 3 {
            e.extend(time.to_be_bytes());
        }
        e.extend(data);
        let crc = crc32fast::hash(&e);
        e.extend(crc.to_be_bytes());
        e
    }

    fn sample() -> Vec<u8> {
        let mut f = 3u32.to_be_bytes().to_vec();
        f.extend(entry(3, 0xFFFF, 1, 0, 5, b"\x00\x01grp"));
        f.extend(entry(3, 0xFFFE, 0, 1, 5, b"\x00\x01a.B"));
        f.extend(entry(3, 1, 1, 1, 7, b"one"));
        f.extend(entry(3, 1, 1, 1, 8, b"two"));
        f
    }

    #[test]
    fn entries_resolve_their_group_and_type() {
        let f = sample();
        let mut r = GobyReader::new(&f[..]);
        let e = r.next_entry().unwrap().unwrap();
        assert_eq!((&*e.group, &*e.type_name), ("grp", "a.B"));
        assert_eq!((e.time_us, e.data.as_slice()), (Some(7), &b"one"[..]));
        assert_eq!(r.next_entry().unwrap().unwrap().data, b"two");
        assert!(r.next_entry().unwrap().is_none());
        assert_eq!(r.stats().entries, 2);
        assert_eq!(r.stats().index_entries, 2);
        assert_eq!(r.version(), Some(3));
    }

    #[test]
    fn a_flipped_byte_loses_that_entry_only_and_a_cut_is_a_torn_tail() {
        let mut f = sample();
        // Each data entry is 29 bytes (22 of header, 3 of data, 4 of CRC): inside "one".
        let third_data = f.len() - 29 - 29 + 22;
        f[third_data] ^= 0x40;
        let mut r = GobyReader::new(&f[..]);
        let e = r.next_entry().unwrap().unwrap();
        assert_eq!(e.data, b"two");
        assert_eq!(r.stats().crc_errors, 1);
        let mut cut = sample();
        cut.truncate(cut.len() - 5);
        let mut r = GobyReader::new(&cut[..]);
        assert_eq!(r.next_entry().unwrap().unwrap().data, b"one");
        assert!(r.next_entry().unwrap().is_none());
        assert!(r.stats().torn_tail);
    }

    #[test]
    fn other_files_are_refused_not_scanned() {
        assert!(
            GobyReader::new(&b"\x89MCAP0\r\n rest"[..])
                .next_entry()
                .is_err()
        );
        assert!(GobyReader::new(&b""[..]).next_entry().is_err());
    }
}
