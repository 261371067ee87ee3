//! Same-iteration headings, proven on a real pHelmIvP capture: the DB→frontseat packets of
//! `cap03b_frontseat_first10s` (moos/tests/fixtures/captures, recorded from a real MOOSDB feeding
//! pHelmIvP's DESIRED_* to a frontseat client) replayed through the translation's DesiredBuffer
//! packet by packet, exactly as the MOOS client reports them (one event per packet). Every course
//! must carry the DESIRED_HEADING of its own packet (pHelmIvP posts DEPTH, SPEED, HEADING).

use std::path::PathBuf;

use bytes::BytesMut;
use frontseat_helm_side::translation::{DesiredBuffer, DesiredVar};
use frontseat_moos::codec::{MsgType, PacketDecoder};

/// The DB→client TCP payload bytes of every stream, concatenated per stream, from a hex dump.
fn streams(name: &str) -> Vec<Vec<u8>> {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../moos/tests/fixtures/captures")
        .join(name);
    let text = std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    let mut out: Vec<(u32, Vec<u8>)> = Vec::new();
    let mut cur = None;
    for line in text.lines() {
        if line.starts_with("frame") {
            let w: Vec<&str> = line.split_whitespace().collect();
            let si = w.iter().position(|x| *x == "stream").expect("stream");
            let stream: u32 = w[si + 1].parse().expect("stream number");
            if !out.iter().any(|(s, _)| *s == stream) {
                out.push((stream, Vec::new()));
            }
            cur = out.iter().position(|(s, _)| *s == stream);
        } else if let Some(rest) = line.strip_prefix("    ") {
            let hex = &rest[10..rest.find('|').expect("ascii column")];
            let buf = &mut out[cur.expect("bytes before a frame line")].1;
            buf.extend(
                hex.split_whitespace()
                    .map(|h| u8::from_str_radix(h, 16).expect("hex")),
            );
        }
    }
    out.into_iter().map(|(_, b)| b).collect()
}

#[test]
fn every_course_carries_the_heading_of_its_own_helm_iteration() {
    let dec = PacketDecoder::default();
    let mut courses = 0;
    let mut headings_seen = std::collections::BTreeSet::new();
    for bytes in streams("cap03b_frontseat_first10s.payloads_DB2C.txt") {
        let mut buf = BytesMut::from(&bytes[..]);
        let mut first = true;
        let mut b = DesiredBuffer::default();
        while let Some(msgs) = dec.decode(&mut buf).expect("packet") {
            if first {
                first = false; // the handshake reply
                continue;
            }
            let mut packet_heading = None;
            for m in msgs.iter().filter(|m| m.msg_type == MsgType::Notify) {
                let key = m.key.to_string_lossy();
                let (Some(var), Some(v)) = (DesiredVar::from_key(&key), m.as_double()) else {
                    continue;
                };
                if var == DesiredVar::Heading {
                    packet_heading = Some(v);
                }
                b.on_value(var, v, m.time);
            }
            if let Some(course) = b.on_packet_end() {
                courses += 1;
                assert_eq!(course.heading, packet_heading, "course {courses}");
                headings_seen.insert(course.heading.map(|h| h as i64));
            }
        }
    }
    assert!(
        courses >= 20,
        "the capture holds ~40 helm iterations; saw {courses}"
    );
    assert!(
        headings_seen.len() >= 2,
        "the heading changes in the capture, so the previous-iteration bug would show: {headings_seen:?}"
    );
}
