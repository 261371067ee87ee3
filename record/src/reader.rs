//! Reading a recording back, from the start, in bounded memory: a file cut short by a crash or
//! power loss (no summary, a torn last chunk) reads up to its last whole chunk, and says so.
//! Every length in the file is checked against [`MAX_RECORD`] before anything is allocated;
//! nothing in a file can make this panic (the fuzz target `mcap_reader` drives it).
//!
//! Chunks are opened here, not by the `mcap` crate's linear reader: in mcap 0.24 a chunk whose
//! header claims more uncompressed bytes than its data holds makes that reader loop for ever, and
//! a flipped compression-name length made it allocate 4 GiB (`tests/hostile_recordings.rs`). So
//! the reader hands over whole chunk records and this module checks the header's lengths against
//! the record, decompresses into at most the declared size (itself at most [`MAX_RECORD`]),
//! requires exactly that size and the declared CRC, and then walks the records inside.

use std::collections::{BTreeMap, HashMap};
use std::io::Read;
use std::path::Path;
use std::sync::Arc;

use mcap::records::Record;
use mcap::sans_io::linear_reader::{LinearReadEvent, LinearReader, LinearReaderOptions};

/// Largest record (a chunk, uncompressed or not, or one message) read: far above what the
/// recorder writes (chunks of 512 KiB), far below what would hurt a laptop.
pub const MAX_RECORD: usize = 64 << 20;
/// Most bytes asked of the source per read.
const READ_STEP: usize = 1 << 20;
/// Largest Schema, Channel or Metadata record kept (a FileDescriptorSet of a large tree of
/// .proto files is a few hundred KiB); larger ones are skipped and counted, never parsed.
pub const MAX_DEFINITION: usize = 4 << 20;
/// Longest topic, schema name or encoding kept: Goby3 groups are tens of bytes.
pub const MAX_NAME: usize = 1024;
/// Most bytes of Schema, Channel and Metadata records kept at once, however many the file
/// declares (a redefinition of an id replaces its bytes): past it, new definitions are skipped
/// and counted. What a reader keeps besides the chunk being read is bounded by this.
pub const MAX_RETAINED: usize = 16 << 20;

#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    #[error("cannot open {path}: {source}")]
    Open {
        path: String,
        source: std::io::Error,
    },
    #[error("reading: {0}")]
    Io(#[from] std::io::Error),
    #[error("not an MCAP file (or damaged before its first record): {0}")]
    NotMcap(String),
}

/// A schema of the file: for frontseat's files, a protobuf FileDescriptorSet.
#[derive(Clone, Debug)]
pub struct Schema {
    pub name: String,
    pub encoding: String,
    pub data: Arc<[u8]>,
}

/// A channel of the file: `topic` is the Goby3 group.
#[derive(Clone, Debug)]
pub struct Channel {
    pub topic: Arc<str>,
    pub schema_id: u16,
    pub message_encoding: String,
    pub metadata: BTreeMap<String, String>,
}

/// One message, owned.
#[derive(Clone, Debug)]
pub struct Message {
    pub channel_id: u16,
    pub sequence: u32,
    /// Nanoseconds since the Unix epoch.
    pub log_time: u64,
    pub data: Vec<u8>,
}

/// One message, borrowed from the reader until the next call (replay's path: no copy of the
/// bytes, and the channel already looked up).
#[derive(Clone, Copy, Debug)]
pub struct MessageRef<'a> {
    pub channel_id: u16,
    /// The channel, if the file defined it before this message.
    pub channel: Option<&'a Channel>,
    pub sequence: u32,
    /// Nanoseconds since the Unix epoch.
    pub log_time: u64,
    pub data: &'a [u8],
}

impl MessageRef<'_> {
    pub fn to_owned(&self) -> Message {
        Message {
            channel_id: self.channel_id,
            sequence: self.sequence,
            log_time: self.log_time,
            data: self.data.to_vec(),
        }
    }
}

/// Where the message [`Recording::advance`] found lies: its header and its bytes, in the open
/// chunk or (a message outside any chunk) in `Recording::loose`.
#[derive(Clone, Copy)]
struct Found {
    channel_id: u16,
    sequence: u32,
    log_time: u64,
    in_chunk: bool,
    start: usize,
    end: usize,
}

/// The fixed header of a Message record (MCAP spec: channel id u16, sequence u32, log time
/// u64, publish time u64), then the bytes from offset 22.
const MESSAGE_HEADER: usize = 22;

/// A Message record's channel id, sequence and log time; `None` if the record is shorter than
/// its fixed header.
fn message_header(body: &[u8]) -> Option<(u16, u32, u64)> {
    Some((
        u16::from_le_bytes(le::<2>(body, 0)?),
        u32::from_le_bytes(le::<4>(body, 2)?),
        u64::from_le_bytes(le::<8>(body, 6)?),
    ))
    .filter(|_| body.len() >= MESSAGE_HEADER)
}

/// A recording opened for reading from its start: call [`Recording::next_message`] until
/// `None`, then [`Recording::truncated`] says whether the file ended early.
pub struct Recording<R: Read = std::fs::File> {
    source: R,
    reader: LinearReader,
    schemas: HashMap<u16, Schema>,
    channels: HashMap<u16, Channel>,
    metadata: Vec<(String, BTreeMap<String, String>)>,
    truncated: Option<String>,
    records: u64,
    saw_footer: bool,
    done: bool,
    /// The records of the chunk being read (decompressed, checked) and how far into them.
    chunk: Option<(Vec<u8>, usize)>,
    /// The bytes of the last message found outside a chunk (reused: no allocation per message).
    loose: Vec<u8>,
    /// Bytes of the kept schema, channel and metadata records, by kind and id.
    kept: HashMap<(u8, u16), usize>,
    retained: usize,
    skipped_definitions: u64,
}

impl Recording<std::fs::File> {
    pub fn open(path: &Path) -> Result<Self, ReadError> {
        let f = std::fs::File::open(path).map_err(|source| ReadError::Open {
            path: path.display().to_string(),
            source,
        })?;
        Ok(Self::new(f))
    }
}

impl<R: Read> Recording<R> {
    pub fn new(source: R) -> Self {
        let opts = LinearReaderOptions::default()
            .with_record_length_limit(MAX_RECORD)
            // The footer and end magic are missing after a crash: not an error here, the
            // reader notes a torn end itself.
            .with_skip_end_magic(true)
            .with_emit_chunks(true);
        Self {
            source,
            reader: LinearReader::new_with_options(opts),
            schemas: HashMap::new(),
            channels: HashMap::new(),
            metadata: Vec::new(),
            truncated: None,
            records: 0,
            saw_footer: false,
            done: false,
            chunk: None,
            loose: Vec::new(),
            kept: HashMap::new(),
            retained: 0,
            skipped_definitions: 0,
        }
    }

    /// The next message; `Ok(None)` at the end of what could be read. An error is returned only
    /// for a source that cannot be read or a file that is not MCAP at all; damage after the
    /// first record ends the reading and is reported by [`Recording::truncated`].
    pub fn next_message(&mut self) -> Result<Option<Message>, ReadError> {
        Ok(self.next_message_ref()?.map(|m| m.to_owned()))
    }

    /// As [`Recording::next_message`], the message borrowed (valid until the next call) with its
    /// channel: what a reader that only passes the bytes on (replay) uses, with no copy.
    pub fn next_message_ref(&mut self) -> Result<Option<MessageRef<'_>>, ReadError> {
        let Some(f) = self.advance()? else {
            return Ok(None);
        };
        let data = if f.in_chunk {
            self.chunk.as_ref().and_then(|(d, _)| d.get(f.start..f.end))
        } else {
            self.loose.get(f.start..f.end)
        };
        // `advance` located these bytes in the buffer it left in place: always present.
        let Some(data) = data else {
            return Ok(None);
        };
        Ok(Some(MessageRef {
            channel_id: f.channel_id,
            channel: self.channels.get(&f.channel_id),
            sequence: f.sequence,
            log_time: f.log_time,
            data,
        }))
    }

    /// Reads up to the next message and says where it lies.
    fn advance(&mut self) -> Result<Option<Found>, ReadError> {
        while !self.done {
            if let Some((data, pos)) = self.chunk.take() {
                match next_in_chunk(&data, pos) {
                    Ok(None) => {}
                    Ok(Some((opcode, body, next))) => {
                        // Messages (nearly every record) are located, not parsed into an owned
                        // record: replay reads a million a second.
                        if opcode == mcap::records::op::MESSAGE {
                            let found =
                                message_header(body).map(|(channel_id, sequence, log_time)| {
                                    Found {
                                        channel_id,
                                        sequence,
                                        log_time,
                                        in_chunk: true,
                                        start: next - body.len() + MESSAGE_HEADER,
                                        end: next,
                                    }
                                });
                            self.chunk = Some((data, next));
                            match found {
                                Some(f) => return Ok(Some(f)),
                                None => self.end_early(format!(
                                    "a damaged record in a chunk: a length inside record 0x{:02x} runs past its end",
                                    mcap::records::op::MESSAGE
                                ))?,
                            }
                            continue;
                        }
                        let parsed = if admit(&self.kept, self.retained, opcode, body) {
                            parse_checked(opcode, body)
                        } else {
                            self.skipped_definitions += 1;
                            Ok(None)
                        };
                        self.chunk = Some((data, next));
                        match parsed {
                            Ok(None) => {}
                            Ok(Some(rec)) => self.take_record(rec),
                            Err(e) => {
                                self.end_early(format!("a damaged record in a chunk: {e}"))?
                            }
                        }
                    }
                    Err(why) => self.end_early(why)?,
                }
                continue;
            }
            let event = match self.reader.next_event() {
                None => {
                    self.done = true;
                    if self.records == 0 {
                        return Err(ReadError::NotMcap("the file is empty".into()));
                    }
                    if !self.saw_footer && self.truncated.is_none() {
                        self.truncated = Some(
                            "no summary: the recorder did not close this file (killed, power lost, or still recording)"
                                .into(),
                        );
                    }
                    return Ok(None);
                }
                Some(e) => e,
            };
            match event {
                Ok(LinearReadEvent::ReadRequest(n)) => {
                    let buf = self.reader.insert(n.clamp(1, READ_STEP));
                    let got = match self.source.read(buf) {
                        Ok(g) => g,
                        Err(e) if e.kind() == std::io::ErrorKind::Interrupted => 0,
                        Err(e) => {
                            self.done = true;
                            return Err(ReadError::Io(e));
                        }
                    };
                    self.reader.notify_read(got);
                }
                Ok(LinearReadEvent::Record { data, opcode }) => {
                    self.records += 1;
                    if opcode == mcap::records::op::CHUNK {
                        match open_chunk(data) {
                            Ok(records) => self.chunk = Some((records, 0)),
                            Err(why) => self.end_early(why)?,
                        }
                        continue;
                    }
                    if opcode == mcap::records::op::MESSAGE {
                        let Some((channel_id, sequence, log_time)) = message_header(data) else {
                            self.end_early(format!(
                                "a damaged record: a length inside record 0x{opcode:02x} runs past its end"
                            ))?;
                            continue;
                        };
                        self.loose.clear();
                        self.loose
                            .extend_from_slice(data.get(MESSAGE_HEADER..).unwrap_or_default());
                        return Ok(Some(Found {
                            channel_id,
                            sequence,
                            log_time,
                            in_chunk: false,
                            start: 0,
                            end: self.loose.len(),
                        }));
                    }
                    let parsed = if admit(&self.kept, self.retained, opcode, data) {
                        parse_checked(opcode, data)
                    } else {
                        self.skipped_definitions += 1;
                        Ok(None)
                    };
                    match parsed {
                        Ok(Some(r)) => self.take_record(r),
                        Ok(None) => {}
                        Err(e) => self.end_early(format!("a damaged record: {e}"))?,
                    }
                }
                Err(e) => {
                    let why = match e {
                        mcap::McapError::UnexpectedEof => {
                            "the file ends inside a record (cut short: a crash or a copy in progress)"
                                .to_string()
                        }
                        e => e.to_string(),
                    };
                    self.end_early(why)?;
                }
            }
        }
        Ok(None)
    }

    /// Keeps what a record tells (schemas, channels, metadata, the footer); messages are found
    /// by [`Recording::advance`] before they get here. Names over [`MAX_NAME`] are skipped and
    /// counted; a definition identical to the one kept for its id is not copied again.
    fn take_record(&mut self, rec: Record<'static>) {
        use mcap::records::op;
        let keep = |this: &mut Self, key: (u8, u16), cost: usize| {
            let old = this.kept.insert(key, cost).unwrap_or(0);
            this.retained = this.retained - old + cost;
        };
        match rec {
            Record::Schema { header, data } => {
                if header.name.len() > MAX_NAME || header.encoding.len() > MAX_NAME {
                    self.skipped_definitions += 1;
                    return;
                }
                if self.schemas.get(&header.id).is_some_and(|s| {
                    s.name == header.name && s.encoding == header.encoding && *s.data == *data
                }) {
                    return;
                }
                let cost = header.name.len() + header.encoding.len() + data.len();
                keep(self, (op::SCHEMA, header.id), cost);
                self.schemas.insert(
                    header.id,
                    Schema {
                        name: header.name,
                        encoding: header.encoding,
                        data: Arc::from(data.as_ref()),
                    },
                );
            }
            Record::Channel(c) => {
                if c.topic.len() > MAX_NAME || c.message_encoding.len() > MAX_NAME {
                    self.skipped_definitions += 1;
                    return;
                }
                if self.channels.get(&c.id).is_some_and(|k| {
                    *k.topic == *c.topic
                        && k.schema_id == c.schema_id
                        && k.message_encoding == c.message_encoding
                        && k.metadata == c.metadata
                }) {
                    return;
                }
                let cost = c.topic.len()
                    + c.message_encoding.len()
                    + c.metadata
                        .iter()
                        .map(|(k, v)| k.len() + v.len())
                        .sum::<usize>();
                keep(self, (op::CHANNEL, c.id), cost);
                self.channels.insert(
                    c.id,
                    Channel {
                        topic: Arc::from(c.topic.as_str()),
                        schema_id: c.schema_id,
                        message_encoding: c.message_encoding,
                        metadata: c.metadata,
                    },
                );
            }
            Record::Metadata(m) => {
                let cost = m.name.len()
                    + m.metadata
                        .iter()
                        .map(|(k, v)| k.len() + v.len())
                        .sum::<usize>();
                if self.retained + cost > MAX_RETAINED {
                    self.skipped_definitions += 1;
                    return;
                }
                self.retained += cost;
                self.metadata.push((m.name, m.metadata));
            }
            Record::Footer(_) => self.saw_footer = true,
            _ => {}
        }
    }

    /// Schema, Channel and Metadata records skipped for being over the reader's limits
    /// ([`MAX_NAME`], [`MAX_DEFINITION`], [`MAX_RETAINED`]); their channels' messages read as
    /// of an unknown channel.
    pub fn skipped_definitions(&self) -> u64 {
        self.skipped_definitions
    }

    /// Bytes of schemas, channels and metadata kept now (at most [`MAX_RETAINED`]).
    pub fn retained_bytes(&self) -> usize {
        self.retained
    }

    /// The operator's line about [`Recording::skipped_definitions`], if any were skipped.
    pub fn limits_note(&self) -> Option<String> {
        (self.skipped_definitions > 0).then(|| {
            format!(
                "{} schema/channel/metadata records skipped: over the reader's limits (a name over {MAX_NAME} bytes, a record over {} MiB, or {} MiB of definitions kept in all); their messages count as of an unknown channel",
                self.skipped_definitions,
                MAX_DEFINITION >> 20,
                MAX_RETAINED >> 20
            )
        })
    }

    fn end_early(&mut self, why: String) -> Result<(), ReadError> {
        self.done = true;
        if self.records == 0 {
            return Err(ReadError::NotMcap(why));
        }
        self.truncated = Some(why);
        Ok(())
    }

    /// Why reading stopped before a proper end, if it did.
    pub fn truncated(&self) -> Option<&str> {
        self.truncated.as_deref()
    }

    pub fn channel(&self, id: u16) -> Option<&Channel> {
        self.channels.get(&id)
    }

    pub fn schema(&self, id: u16) -> Option<&Schema> {
        self.schemas.get(&id)
    }

    /// Metadata records read so far, in file order.
    pub fn metadata(&self) -> &[(String, BTreeMap<String, String>)] {
        &self.metadata
    }
}

/// Whether a Schema, Channel or Metadata record of `body.len()` bytes may be kept under
/// [`MAX_DEFINITION`] and [`MAX_RETAINED`] (other records: always); a refused one is
/// counted by the caller and never parsed.
fn admit(kept: &HashMap<(u8, u16), usize>, retained: usize, opcode: u8, body: &[u8]) -> bool {
    use mcap::records::op;
    let key = match opcode {
        op::SCHEMA => le::<2>(body, 0).map(|b| (opcode, u16::from_le_bytes(b))),
        op::CHANNEL => le::<2>(body, 0).map(|b| (opcode, u16::from_le_bytes(b))),
        // Metadata records are kept in a list: each its own entry.
        op::METADATA => Some((opcode, u16::MAX)),
        _ => return true,
    };
    // A record too short for its id is parse_checked's to report as damage.
    let Some(key) = key else { return true };
    let old = if opcode == op::METADATA {
        0
    } else {
        kept.get(&key).copied().unwrap_or(0)
    };
    let new = body.len();
    new <= MAX_DEFINITION && retained - old + new <= MAX_RETAINED
}

/// The records this reader uses, parsed once every length prefix inside them is known to fit in
/// the record (mcap's parser allocates what a string length claims: a flipped bit in a header's
/// profile length asked for 4 GiB); `None` for the records it does not use (indexes, summary).
fn parse_checked(opcode: u8, body: &[u8]) -> Result<Option<Record<'static>>, String> {
    use mcap::records::op;
    // The fields that carry their own length: a string or bytes (u32 length) and a map (u32 byte
    // length of string pairs).
    let string = |at: usize, end: usize| -> Option<usize> {
        let n = u32::from_le_bytes(le::<4>(body, at)?) as usize;
        let next = at.checked_add(4)?.checked_add(n)?;
        (next <= end).then_some(next)
    };
    let map = |at: usize| -> Option<usize> {
        let end = string(at, body.len())?;
        let mut c = at + 4;
        while c < end {
            c = string(string(c, end)?, end)?;
        }
        Some(end)
    };
    let n = body.len();
    let fits = match opcode {
        op::HEADER => string(0, n).and_then(|c| string(c, n)).is_some(),
        op::SCHEMA => string(2, n)
            .and_then(|c| string(c, n))
            .and_then(|c| string(c, n))
            .is_some(),
        op::CHANNEL => string(4, n)
            .and_then(|c| string(c, n))
            .and_then(map)
            .is_some(),
        op::METADATA => string(0, n).and_then(map).is_some(),
        // Messages are read by `message_header` and never come here.
        op::MESSAGE => return Ok(None),
        op::FOOTER => n >= 20,
        _ => return Ok(None),
    };
    if !fits {
        return Err(format!(
            "a length inside record 0x{opcode:02x} runs past its end"
        ));
    }
    mcap::parse_record(opcode, body)
        .map(|r| Some(r.into_owned()))
        .map_err(|e| e.to_string())
}

/// Little-endian integer at `at`, if the bytes are there.
fn le<const N: usize>(b: &[u8], at: usize) -> Option<[u8; N]> {
    b.get(at..at.checked_add(N)?)?.try_into().ok()
}

/// A chunk record's body → its records, decompressed and checked (the layout is the MCAP spec's
/// Chunk: start and end time, uncompressed size and CRC, compression name, records).
fn open_chunk(body: &[u8]) -> Result<Vec<u8>, String> {
    let damaged = |what: &str| format!("a damaged chunk: {what}");
    let size = le::<8>(body, 16).map(u64::from_le_bytes);
    let crc = le::<4>(body, 24).map(u32::from_le_bytes);
    let name_len = le::<4>(body, 28).map(|b| u32::from_le_bytes(b) as usize);
    let (Some(size), Some(crc), Some(name_len)) = (size, crc, name_len) else {
        return Err(damaged("its header is cut short"));
    };
    let name = body
        .get(32..32usize.saturating_add(name_len))
        .ok_or_else(|| damaged("its compression name runs past the record"))?;
    let at = 32 + name_len;
    let records_len = le::<8>(body, at)
        .map(u64::from_le_bytes)
        .ok_or_else(|| damaged("its header is cut short"))?;
    let data = usize::try_from(records_len)
        .ok()
        .and_then(|n| body.get(at + 8..(at + 8).checked_add(n)?))
        .ok_or_else(|| damaged("its records run past the record"))?;
    let size = usize::try_from(size)
        .ok()
        .filter(|&n| n <= MAX_RECORD)
        .ok_or_else(|| {
            damaged(&format!(
                "it declares {size} bytes uncompressed, over the {} MiB limit",
                MAX_RECORD >> 20
            ))
        })?;
    let out = match name {
        b"" => data.to_vec(),
        // At most `size` bytes come out: more is an error, not an allocation.
        b"zstd" => {
            zstd::bulk::decompress(data, size).map_err(|e| damaged(&format!("zstd: {e}")))?
        }
        b"lz4" => {
            let mut out = Vec::new();
            lz4::Decoder::new(data)
                .and_then(|d| d.take(size as u64 + 1).read_to_end(&mut out))
                .map_err(|e| damaged(&format!("lz4: {e}")))?;
            out
        }
        other => {
            return Err(damaged(&format!(
                "unknown compression {:?}",
                String::from_utf8_lossy(other)
            )));
        }
    };
    if out.len() != size {
        return Err(damaged(&format!(
            "it holds {} bytes uncompressed, not the {size} it declares",
            out.len()
        )));
    }
    if crc != 0 && crc32fast::hash(&out) != crc {
        return Err(damaged("its CRC does not match"));
    }
    Ok(out)
}

/// A record inside a chunk: opcode, body, the offset of the next.
type InChunk<'a> = (u8, &'a [u8], usize);

/// The record at `pos` of a chunk's records: opcode, body, and where the next one starts;
/// `None` at the end.
fn next_in_chunk(data: &[u8], pos: usize) -> Result<Option<InChunk<'_>>, String> {
    if pos >= data.len() {
        return Ok(None);
    }
    let opcode = data[pos];
    let body = le::<8>(data, pos + 1)
        .and_then(|b| usize::try_from(u64::from_le_bytes(b)).ok())
        .and_then(|len| {
            let start = pos + 9;
            data.get(start..start.checked_add(len)?)
        })
        .ok_or_else(|| "a damaged chunk: a record inside runs past its end".to_string())?;
    Ok(Some((opcode, body, pos + 9 + body.len())))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A file written with and without chunks: the same messages, bytes and channels, borrowed
    /// (`next_message_ref`, from the chunk or from the reused buffer of a loose message) and owned.
    #[test]
    fn messages_in_and_outside_chunks_read_alike() {
        for chunked in [true, false] {
            let mut out = std::io::Cursor::new(Vec::new());
            let mut w = mcap::WriteOptions::new()
                .use_chunks(chunked)
                .create(&mut out)
                .unwrap();
            let s = w.add_schema("t.T", "protobuf", b"schema").unwrap();
            let c = w
                .add_channel(s, "g::one", "protobuf", &BTreeMap::new())
                .unwrap();
            for (i, bytes) in [&b"first"[..], &b""[..], &b"third message"[..]]
                .iter()
                .enumerate()
            {
                let header = mcap::records::MessageHeader {
                    channel_id: c,
                    sequence: i as u32,
                    log_time: 1_000 + i as u64,
                    publish_time: 1_000 + i as u64,
                };
                w.write_to_known_channel(&header, bytes).unwrap();
            }
            w.finish().unwrap();
            drop(w);
            let bytes = out.into_inner();
            let mut r = Recording::new(bytes.as_slice());
            let mut got = Vec::new();
            while let Some(m) = r.next_message_ref().unwrap() {
                assert_eq!(m.channel.map(|c| &*c.topic), Some("g::one"));
                got.push((m.sequence, m.log_time, m.data.to_vec()));
            }
            assert_eq!(r.truncated(), None, "chunked: {chunked}");
            let owned: Vec<_> = {
                let mut r = Recording::new(bytes.as_slice());
                std::iter::from_fn(|| r.next_message().unwrap())
                    .map(|m| (m.sequence, m.log_time, m.data))
                    .collect()
            };
            assert_eq!(got, owned);
            assert_eq!(
                got,
                [
                    (0, 1_000, b"first".to_vec()),
                    (1, 1_001, Vec::new()),
                    (2, 1_002, b"third message".to_vec()),
                ],
                "chunked: {chunked}"
            );
        }
    }

    #[test]
    fn garbage_is_not_mcap_and_does_not_panic() {
        let mut r = Recording::new(&b"definitely not an mcap file at all"[..]);
        assert!(matches!(r.next_message(), Err(ReadError::NotMcap(_))));
        let mut empty = Recording::new(&b""[..]);
        assert!(empty.next_message().is_err());
    }
}
