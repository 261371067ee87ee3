//! Hostile files built on purpose (issue 37's review): the shapes that once made a small file
//! take the machine — definitions with huge names repeated across chunks, a message type that
//! contains itself, one huge topic read per message, a goby_logger group name of megabytes.
//! Used by the tests (`tests/hostile_recordings.rs`, `record/tests/record_limits.rs`) and to
//! write the fuzz seeds (`cargo run -p frontseat-record --example crafted_seeds`).
//!
//! The compressed chunks are written by hand as zstd frames of raw and RLE blocks (RFC 8878
//! §3.1.1.2): megabytes of one repeated byte cost four bytes per 128 KiB, and building them
//! costs no compression time.

use prost::Message as _;
use prost_reflect::prost_types::{
    DescriptorProto, FieldDescriptorProto, FileDescriptorProto, FileDescriptorSet,
    field_descriptor_proto::{Label, Type},
};

/// A piece of a chunk's records: bytes as they are, or one byte repeated.
enum Seg {
    Raw(Vec<u8>),
    Run(u8, usize),
}

impl Seg {
    fn len(&self) -> usize {
        match self {
            Seg::Raw(b) => b.len(),
            Seg::Run(_, n) => *n,
        }
    }
}

const ZSTD_BLOCK: usize = 128 * 1024;

/// The segments as one zstd frame (single segment, content size given, no checksum).
fn zstd_frame(segs: &[Seg]) -> Vec<u8> {
    let total: usize = segs.iter().map(Seg::len).sum();
    let mut out = vec![0x28, 0xB5, 0x2F, 0xFD, 0xE0];
    out.extend((total as u64).to_le_bytes());
    let mut blocks: Vec<(u32, Vec<u8>)> = Vec::new();
    for s in segs {
        match s {
            Seg::Raw(b) => {
                for c in b.chunks(ZSTD_BLOCK) {
                    blocks.push(((c.len() as u32) << 3, c.to_vec()));
                }
            }
            Seg::Run(byte, n) => {
                let mut left = *n;
                while left > 0 {
                    let k = left.min(ZSTD_BLOCK);
                    blocks.push((((k as u32) << 3) | 0b010, vec![*byte]));
                    left -= k;
                }
            }
        }
    }
    let last = blocks.len().saturating_sub(1);
    for (i, (mut header, body)) in blocks.into_iter().enumerate() {
        if i == last {
            header |= 1;
        }
        out.extend(&header.to_le_bytes()[..3]);
        out.extend(body);
    }
    if total == 0 {
        // One empty last raw block.
        out.extend([1, 0, 0]);
    }
    out
}

fn record(op: u8, body: &[u8]) -> Vec<u8> {
    let mut r = vec![op];
    r.extend((body.len() as u64).to_le_bytes());
    r.extend(body);
    r
}

fn string(s: &[u8]) -> Vec<u8> {
    let mut v = (s.len() as u32).to_le_bytes().to_vec();
    v.extend(s);
    v
}

const MAGIC: &[u8] = b"\x89MCAP0\r\n";

fn header() -> Vec<u8> {
    let mut body = string(b"frontseat");
    body.extend(string(b"crafted"));
    record(0x01, &body)
}

fn footer() -> Vec<u8> {
    let mut v = record(0x02, &[0u8; 20]);
    v.extend(MAGIC);
    v
}

/// A Chunk record holding `segs` compressed with zstd (CRC 0: not checked).
fn chunk(segs: &[Seg]) -> Vec<u8> {
    let size: usize = segs.iter().map(Seg::len).sum();
    let data = zstd_frame(segs);
    let mut body = Vec::new();
    body.extend(0u64.to_le_bytes());
    body.extend(u64::MAX.to_le_bytes());
    body.extend((size as u64).to_le_bytes());
    body.extend(0u32.to_le_bytes());
    body.extend(string(b"zstd"));
    body.extend((data.len() as u64).to_le_bytes());
    body.extend(data);
    record(0x06, &body)
}

/// The segments of a record whose body is `parts` (raw bytes and runs).
fn record_segs(op: u8, parts: Vec<Seg>) -> Vec<Seg> {
    let len: usize = parts.iter().map(Seg::len).sum();
    let mut v = vec![op];
    v.extend((len as u64).to_le_bytes());
    let mut out = vec![Seg::Raw(v)];
    out.extend(parts);
    out
}

fn message(channel: u16, seq: u32, t: u64, data: &[u8]) -> Vec<u8> {
    let mut b = channel.to_le_bytes().to_vec();
    b.extend(seq.to_le_bytes());
    b.extend(t.to_le_bytes());
    b.extend(t.to_le_bytes());
    b.extend(data);
    record(0x05, &b)
}

/// `chunks` chunks, each defining `per_chunk` new schemas and channels (new ids every chunk)
/// whose schema name and topic are `name` bytes and schema data `data` bytes, and one message
/// per channel. With 30 × 3 × 6 MiB this is about 57 KB on disk and 1.6 GiB of definitions.
pub fn huge_definitions(chunks: usize, per_chunk: usize, name: usize, data: usize) -> Vec<u8> {
    let mut f = MAGIC.to_vec();
    f.extend(header());
    let mut id: u16 = 1;
    let mut seq = 0u32;
    for _ in 0..chunks {
        let mut segs = Vec::new();
        let mut msgs = Vec::new();
        for _ in 0..per_chunk {
            // Schema: id, name (run of 'S'), encoding, data (run of 0).
            let mut a = id.to_le_bytes().to_vec();
            a.extend((name as u32).to_le_bytes());
            let mut b = string(b"protobuf");
            b.extend((data as u32).to_le_bytes());
            segs.extend(record_segs(
                0x03,
                vec![
                    Seg::Raw(a),
                    Seg::Run(b'S', name),
                    Seg::Raw(b),
                    Seg::Run(0, data),
                ],
            ));
            // Channel: id, schema id, topic (run of 'T'), encoding, empty metadata.
            let mut a = id.to_le_bytes().to_vec();
            a.extend(id.to_le_bytes());
            a.extend((name as u32).to_le_bytes());
            let mut b = string(b"protobuf");
            b.extend(0u32.to_le_bytes());
            segs.extend(record_segs(
                0x04,
                vec![Seg::Raw(a), Seg::Run(b'T', name), Seg::Raw(b)],
            ));
            seq += 1;
            msgs.extend(message(id, seq, u64::from(seq) * 1_000_000, b"x"));
            id = id.wrapping_add(1).max(1);
        }
        segs.push(Seg::Raw(msgs));
        f.extend(chunk(&segs));
    }
    f.extend(footer());
    f
}

/// A file whose one message type `T` has `fields` fields of type `T` (a type containing
/// itself): flattened to depth 8 that is `fields`⁸ CSV columns. Topic `t`, one empty message.
pub fn self_referencing_type(fields: usize) -> Vec<u8> {
    let field = |i: usize| FieldDescriptorProto {
        name: Some(format!("f{i}")),
        number: Some(i as i32 + 1),
        label: Some(Label::Optional as i32),
        r#type: Some(Type::Message as i32),
        type_name: Some(".T".into()),
        ..Default::default()
    };
    let set = FileDescriptorSet {
        file: vec![FileDescriptorProto {
            name: Some("t.proto".into()),
            syntax: Some("proto2".into()),
            message_type: vec![DescriptorProto {
                name: Some("T".into()),
                field: (0..fields).map(field).collect(),
                ..Default::default()
            }],
            ..Default::default()
        }],
    };
    let mut f = MAGIC.to_vec();
    f.extend(header());
    let mut b = 1u16.to_le_bytes().to_vec();
    b.extend(string(b"T"));
    b.extend(string(b"protobuf"));
    b.extend(string(&set.encode_to_vec()));
    f.extend(record(0x03, &b));
    let mut b = 1u16.to_le_bytes().to_vec();
    b.extend(1u16.to_le_bytes());
    b.extend(string(b"t"));
    b.extend(string(b"protobuf"));
    b.extend(0u32.to_le_bytes());
    f.extend(record(0x04, &b));
    f.extend(message(1, 1, 1_000_000_000, b""));
    f.extend(footer());
    f
}

/// One chunk: a channel whose topic is `topic_len` bytes, then `messages` messages on it.
pub fn huge_topic(topic_len: usize, messages: u32) -> Vec<u8> {
    let mut f = MAGIC.to_vec();
    f.extend(header());
    let mut a = 1u16.to_le_bytes().to_vec();
    a.extend(0u16.to_le_bytes());
    a.extend((topic_len as u32).to_le_bytes());
    let mut b = string(b"protobuf");
    b.extend(0u32.to_le_bytes());
    let mut segs = record_segs(
        0x04,
        vec![Seg::Raw(a), Seg::Run(b'T', topic_len), Seg::Raw(b)],
    );
    let mut msgs = Vec::new();
    for i in 0..messages {
        msgs.extend(message(1, i, u64::from(i) * 1_000_000, b""));
    }
    segs.push(Seg::Raw(msgs));
    f.extend(chunk(&segs));
    f.extend(footer());
    f
}

fn goby_entry(scheme: u16, group: u16, ty: u16, time: u64, data: &[u8]) -> Vec<u8> {
    let size = (2 + 2 + 2 + 8 + data.len() + 4) as u32;
    let mut e = b"GBY3".to_vec();
    e.extend(size.to_be_bytes());
    e.extend(scheme.to_be_bytes());
    e.extend(group.to_be_bytes());
    e.extend(ty.to_be_bytes());
    e.extend(time.to_be_bytes());
    e.extend(data);
    let crc = crc32fast::hash(&e);
    e.extend(crc.to_be_bytes());
    e
}

/// A goby_logger file (version 3) whose one group name is `name_len` bytes, then `entries`
/// PROTOBUF entries of that group (type `goby.middleware.frontseat.protobuf.NodeStatus`, empty).
pub fn goby_long_group(name_len: usize, entries: u32) -> Vec<u8> {
    let mut f = 3u32.to_be_bytes().to_vec();
    let mut g = 1u16.to_be_bytes().to_vec();
    g.extend(std::iter::repeat_n(b'g', name_len));
    f.extend(goby_entry(0xFFFF, 1, 0, 0, &g));
    let mut t = 1u16.to_be_bytes().to_vec();
    t.extend(b"goby.middleware.frontseat.protobuf.NodeStatus");
    f.extend(goby_entry(0xFFFE, 0, 1, 0, &t));
    for i in 0..entries {
        f.extend(goby_entry(
            1,
            1,
            1,
            1_700_000_000_000_000 + u64::from(i),
            b"",
        ));
    }
    f
}

/// The fuzz seeds: (corpus directory, file name, bytes), each under 70 000 bytes.
pub fn seeds() -> Vec<(&'static str, &'static str, Vec<u8>)> {
    vec![
        (
            "mcap_reader",
            "crafted_huge_definitions.mcap",
            huge_definitions(30, 3, 6 << 20, 6 << 20),
        ),
        (
            "mcap_reader",
            "crafted_self_referencing_type.mcap",
            self_referencing_type(8),
        ),
        (
            "mcap_reader",
            "crafted_huge_topic.mcap",
            huge_topic(48 << 20, 300),
        ),
        (
            "goby_import",
            "crafted_long_group.goby",
            goby_long_group(60_000, 300),
        ),
    ]
}

/// Messages readable in a recording and an order-free digest of them: the sum of the CRC-32 of
/// each message's `topic`, NUL, sequence (u32 LE), log time (u64 LE) and bytes. The recovery
/// tests compare it with what the Python `mcap` reader computes the same way
/// (`tests/python/make_reader_digest.py`): the same messages, whatever the chunking.
pub fn message_digest<R: std::io::Read>(
    mut rec: crate::Recording<R>,
) -> Result<(u64, u64), crate::ReadError> {
    let (mut n, mut sum) = (0u64, 0u64);
    while let Some(m) = rec.next_message_ref()? {
        let mut h = crc32fast::Hasher::new();
        h.update(m.channel.map(|c| c.topic.as_bytes()).unwrap_or_default());
        h.update(&[0]);
        h.update(&m.sequence.to_le_bytes());
        h.update(&m.log_time.to_le_bytes());
        h.update(m.data);
        sum = sum.wrapping_add(u64::from(h.finalize()));
        n += 1;
    }
    Ok((n, sum))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The hand-made zstd frames decode, with zstd's own decoder, to what they describe.
    #[test]
    fn hand_made_zstd_frames_decode() {
        let segs = [
            Seg::Raw(b"head".to_vec()),
            Seg::Run(b'A', 300_000),
            Seg::Raw(vec![7; 200_000]),
        ];
        let out = zstd::bulk::decompress(&zstd_frame(&segs), 600_000).unwrap();
        assert_eq!(out.len(), 500_004);
        assert_eq!(&out[..4], b"head");
        assert!(out[4..300_004].iter().all(|b| *b == b'A'));
        assert!(out[300_004..].iter().all(|b| *b == 7));
    }
}
