//! Decoder robustness: random bytes, mutated and truncated valid packets, oversized and negative
//! length fields. Never a panic, never an allocation driven by a length field, and whatever
//! decodes re-encodes to the same bytes. Plus the broker surviving garbage from a client.
//! Deterministic (fixed-seed xorshift) so that a failure reproduces.

use std::time::Duration;

use bytes::{Bytes, BytesMut};
use frontseat_moos::codec::{self, BANNER, MoosMessage, MsgType, PacketDecoder};
use frontseat_moos::{Broker, DataType, MoosError};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;
use tokio::time::timeout;

struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
    fn some_bytes(&mut self, max: usize) -> Vec<u8> {
        let n = self.below(max);
        self.bytes(n)
    }
    fn bytes(&mut self, n: usize) -> Vec<u8> {
        (0..n).map(|_| self.next() as u8).collect()
    }
}

const MAX: usize = 4096;

/// Run the stream decoder over `data` until it wants more bytes or fails; check the invariants.
fn drain(data: &[u8]) -> usize {
    let dec = PacketDecoder::new(MAX);
    let mut buf = BytesMut::from(data);
    let cap = buf.capacity();
    let mut ok = 0;
    loop {
        match dec.next_frame(&mut buf) {
            Ok(Some(frame)) => {
                assert!(frame.len() <= MAX);
                if let Ok(msgs) = codec::decode_packet(&frame) {
                    let mut out = BytesMut::new();
                    codec::encode_packet(&msgs, &mut out).unwrap();
                    // Byte 8 (compression flag) is ignored on read and written as 0.
                    assert_eq!(out[..8], frame[..8]);
                    assert_eq!(out[9..], frame[9..]);
                    ok += 1;
                }
            }
            Ok(None) => break,
            Err(_) => break,
        }
    }
    assert!(buf.capacity() <= cap, "decoder grew the buffer");
    ok
}

fn random_message(r: &mut Rng) -> MoosMessage {
    let types = [
        MsgType::Notify,
        MsgType::Register,
        MsgType::Timing,
        MsgType::Welcome,
    ];
    let dts = [DataType::Double, DataType::String, DataType::Binary];
    let mut m = MoosMessage::new(
        types[r.below(4)],
        dts[r.below(3)],
        Bytes::from(r.some_bytes(12)),
    );
    m.id = r.next() as i32;
    m.source = Bytes::from(r.some_bytes(8)).into();
    m.time = f64::from_bits(r.next());
    m.double_val = r.next() as f64;
    m.string_val = Bytes::from(r.some_bytes(40));
    m
}

fn random_packet(r: &mut Rng) -> Vec<u8> {
    let msgs: Vec<MoosMessage> = (0..1 + r.below(4)).map(|_| random_message(r)).collect();
    let mut out = BytesMut::new();
    codec::encode_packet(&msgs, &mut out).unwrap();
    let back = codec::decode_packet(&out.clone().freeze()).unwrap();
    assert_eq!(back.len(), msgs.len());
    for (a, b) in back.iter().zip(&msgs) {
        // NaN times compare unequal; compare the bits.
        assert_eq!(a.time.to_bits(), b.time.to_bits());
        assert_eq!(
            (&a.key, &a.source, &a.string_val, a.id),
            (&b.key, &b.source, &b.string_val, b.id)
        );
    }
    out.to_vec()
}

#[test]
fn random_bytes_never_panic() {
    let mut r = Rng(0x9e37_79b9_7f4a_7c15);
    for _ in 0..20_000 {
        let n = r.below(300);
        let mut data = r.bytes(n);
        // Bias towards plausible headers so that parsing gets past the length checks.
        if n >= 9 && r.below(2) == 0 {
            data[..4].copy_from_slice(&(n as i32).to_le_bytes());
            data[4..8].copy_from_slice(&(r.below(4) as i32).to_le_bytes());
        }
        drain(&data);
        let _ = codec::decode_packet(&Bytes::from(data.clone()));
        let _ = codec::decode_message(&Bytes::from(data));
    }
}

#[test]
fn mutated_valid_packets_never_panic() {
    let mut r = Rng(0x1234_5678_9abc_def1);
    let mut decoded = 0;
    for _ in 0..10_000 {
        let mut p = random_packet(&mut r);
        for _ in 0..1 + r.below(3) {
            let i = r.below(p.len());
            match r.below(3) {
                0 => p[i] ^= 1 << r.below(8),
                1 => p[i] = r.next() as u8,
                _ => {
                    // Overwrite a 4-byte window with an extreme length.
                    let v = [i32::MAX, i32::MIN, -1, 0, 53, 54, 1 << 24][r.below(7)];
                    let i = i.min(p.len().saturating_sub(4));
                    p[i..i + 4].copy_from_slice(&v.to_le_bytes());
                }
            }
        }
        decoded += drain(&p);
    }
    // Some mutations (e.g. of a double) leave the framing valid; those must have re-encoded.
    assert!(decoded > 100, "{decoded}");
}

#[test]
fn every_truncation_waits_or_fails_cleanly() {
    let mut r = Rng(42);
    for _ in 0..200 {
        let p = random_packet(&mut r);
        let dec = PacketDecoder::new(MAX);
        for cut in 0..p.len() {
            let mut buf = BytesMut::from(&p[..cut]);
            assert!(
                matches!(dec.decode(&mut buf), Ok(None)),
                "prefix {cut} of {}",
                p.len()
            );
            assert_eq!(
                dec.bytes_needed(&p[..cut]).unwrap(),
                if cut < 4 { 4 - cut } else { p.len() - cut }
            );
            assert!(codec::decode_packet(&Bytes::copy_from_slice(&p[..cut])).is_err());
        }
        let mut buf = BytesMut::from(&p[..]);
        assert!(dec.decode(&mut buf).unwrap().is_some());
    }
}

#[test]
fn length_fields_cannot_force_allocation() {
    let dec = PacketDecoder::new(1 << 20);
    for len in [i32::MAX, (1 << 20) + 1, 1 << 30] {
        let mut buf = BytesMut::from(&len.to_le_bytes()[..]);
        let cap = buf.capacity();
        match dec.decode(&mut buf) {
            Err(MoosError::PacketTooLarge { len: l, max }) => {
                assert_eq!((l, max), (len as usize, 1 << 20))
            }
            other => panic!("{other:?}"),
        }
        assert_eq!(buf.capacity(), cap);
    }
    for len in [-1, i32::MIN, 0, 8] {
        let mut buf = BytesMut::from(&len.to_le_bytes()[..]);
        assert!(matches!(
            dec.decode(&mut buf),
            Err(MoosError::BadPacketLength(_))
        ));
    }
    // A message count claiming billions of messages in a small packet is refused up front.
    let mut p = vec![];
    p.extend_from_slice(&9i32.to_le_bytes());
    p.extend_from_slice(&i32::MAX.to_le_bytes());
    p.push(0);
    assert!(matches!(
        codec::decode_packet(&Bytes::from(p)),
        Err(MoosError::BadMessageCount { .. })
    ));
    // A string length beyond its message.
    let mut m = BytesMut::new();
    codec::encode_packet(
        [&MoosMessage::new(MsgType::Notify, DataType::String, "K")],
        &mut m,
    )
    .unwrap();
    let key_len_at = 9 + 4 + 4 + 2 + 12;
    m[key_len_at..key_len_at + 4].copy_from_slice(&1_000_000i32.to_le_bytes());
    assert!(matches!(
        codec::decode_packet(&m.freeze()),
        Err(MoosError::BadFieldLength { field: "key", .. })
    ));
}

#[tokio::test]
async fn broker_survives_garbage_from_a_client() {
    let b = Broker::bind("127.0.0.1:0").await.unwrap();
    let mut r = Rng(7);
    for round in 0..5 {
        let mut s = TcpStream::connect(b.local_addr()).await.unwrap();
        let mut out = BytesMut::new();
        out.extend_from_slice(&BANNER);
        codec::encode_packet([&codec::handshake_message("garbler", 0.0)], &mut out).unwrap();
        s.write_all(&out).await.unwrap();
        let mut buf = BytesMut::new();
        while PacketDecoder::default().decode(&mut buf).unwrap().is_none() {
            assert!(s.read_buf(&mut buf).await.unwrap() > 0);
        }
        // A plausible length, then noise: the broker must close us, not crash.
        let mut junk = vec![];
        junk.extend_from_slice(&200i32.to_le_bytes());
        junk.extend_from_slice(&r.bytes(196));
        s.write_all(&junk).await.unwrap();
        let mut rest = vec![];
        let closed = timeout(Duration::from_secs(5), s.read_to_end(&mut rest)).await;
        assert!(
            closed.is_ok(),
            "round {round}: broker kept a garbling client"
        );
    }
    assert!(b.counters().decode_errors >= 4, "{:?}", b.counters());
    assert_eq!(b.counters().clients_welcomed, 5);
    b.shutdown().await;
}
