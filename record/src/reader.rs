//! Reading a recording back, from the start, in bounded memory: a file cut short by a crash or
//! power loss (no summary, a torn last chunk) reads up to its last whole chunk, and says so.
//! Every length in the file is checked against [`MAX_RECORD`] before anything is allocated;
//! nothing in a file can make this panic (the fuzz target `mcap_reader` drives it).

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
            .with_validate_chunk_crcs(true);
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
        }
    }

    /// The next message; `Ok(None)` at the end of what could be read. An error is returned only
    /// for a source that cannot be read or a file that is not MCAP at all; damage after the
    /// first record ends the reading and is reported by [`Recording::truncated`].
    pub fn next_message(&mut self) -> Result<Option<Message>, ReadError> {
        while !self.done {
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
                    let rec = match mcap::parse_record(opcode, data) {
                        Ok(r) => r,
                        Err(e) => {
                            self.end_early(format!("a damaged record: {e}"))?;
                            continue;
                        }
                    };
                    match rec {
                        Record::Schema { header, data } => {
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
                        Record::Message { header, data } => {
                            return Ok(Some(Message {
                                channel_id: header.channel_id,
                                sequence: header.sequence,
                                log_time: header.log_time,
                                data: data.into_owned(),
                            }));
                        }
                        Record::Metadata(m) => self.metadata.push((m.name, m.metadata)),
                        Record::Footer(_) => self.saw_footer = true,
                        _ => {}
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn garbage_is_not_mcap_and_does_not_panic() {
        let mut r = Recording::new(&b"definitely not an mcap file at all"[..]);
        assert!(matches!(r.next_message(), Err(ReadError::NotMcap(_))));
        let mut empty = Recording::new(&b""[..]);
        assert!(empty.next_message().is_err());
    }
}
