//! The IMC wire against its facts: the CRC check value, imcpy's golden packets, both byte
//! orders with typed errors, the nesting and list bounds, and the deframer at every split.

use super::*;

fn hex(s: &str) -> Vec<u8> {
    (0..s.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&s[i..i + 2], 16).unwrap())
        .collect()
}

#[test]
fn crc16_arc_check_value() {
    assert_eq!(crc16(b"123456789"), 0xBB3D);
}

/// The facts file's golden packets (imcpy, src 0x4F0A, dst 0x00D1/0xFF, src_ent 0,
/// timestamp 1700000000.0).
#[test]
fn facts_golden_packets() {
    let h = Header {
        src_ent: 0,
        ..Header::new(0x4F0A, 0x00D1, 1_700_000_000.0)
    };
    let rows: [(Message, &str); 3] = [
        (
            Abort {}.into(),
            "54fe2602000000000040fc54d9410a4f00d100ffe9d6",
        ),
        (
            DesiredHeading {
                value: std::f64::consts::FRAC_PI_2,
            }
            .into(),
            "54fe9001080000000040fc54d9410a4f00d100ff182d4454fb21f93fc2bc",
        ),
        (
            ControlLoops {
                enable: 1,
                mask: 0xC8,
                scope_ref: 0,
            }
            .into(),
            "54fefb01090000000040fc54d9410a4f00d100ff01c800000000000000d8c6",
        ),
    ];
    for (msg, want) in rows {
        let bytes = encode(&h, &msg, ByteOrder::Little).unwrap();
        assert_eq!(bytes, hex(want), "{}", msg.name());
        let (dh, dm) = decode(&bytes).unwrap();
        assert_eq!(dm, msg);
        assert_eq!(dh.src, 0x4F0A);
        assert_eq!(dh.dst, 0x00D1);
    }
}

#[test]
fn big_endian_round_trip_and_typed_errors() {
    let msg: Message = Reference {
        flags: 0x27,
        speed: Some(Box::new(
            DesiredSpeed {
                value: 1.5,
                speed_units: 0,
            }
            .into(),
        )),
        z: Some(Box::new(
            DesiredZ {
                value: 2.0,
                z_units: 1,
            }
            .into(),
        )),
        lat: 0.7,
        lon: -0.15,
        radius: 0.0,
    }
    .into();
    let h = Header::new(0x4F0A, 0xD1, 1.0);
    let be = encode(&h, &msg, ByteOrder::Big).unwrap();
    assert_eq!(&be[..2], &[0xFE, 0x54]);
    assert_eq!(decode(&be).unwrap().1, msg);
    let mut bad = be.clone();
    let n = bad.len();
    bad[n - 1] ^= 1;
    assert_eq!(decode(&bad), Err(ImcError::BadCrc { mgid: 479 }));
    assert_eq!(decode(&be[..10]), Err(ImcError::Truncated(10)));
    assert_eq!(decode(&[0u8; 24]), Err(ImcError::BadSync));
}

#[test]
fn nesting_and_lists_are_bounded() {
    // PlanManeuver inside PlanManeuver … deeper than MAX_DEPTH.
    let mut m: Message = Abort {}.into();
    for _ in 0..MAX_DEPTH + 1 {
        m = PlanManeuver {
            data: Some(Box::new(m)),
            ..Default::default()
        }
        .into();
    }
    let b = encode(&Header::new(1, 2, 0.0), &m, ByteOrder::Little).unwrap();
    assert_eq!(decode(&b), Err(ImcError::TooDeep));
    let long = PlanSpecification {
        maneuvers: List(vec![Abort {}.into(); MAX_LIST + 1]),
        ..Default::default()
    };
    let b = encode(&Header::new(1, 2, 0.0), &long.into(), ByteOrder::Little).unwrap();
    assert_eq!(decode(&b), Err(ImcError::ListTooLong(MAX_LIST + 1)));
}

#[test]
fn deframer_resyncs_skips_oversized_and_cuts_the_same_at_any_split() {
    let good = encode(
        &Header::new(1, 2, 0.0),
        &Heartbeat {}.into(),
        ByteOrder::Little,
    )
    .unwrap();
    let mut bad_crc = good.clone();
    *bad_crc.last_mut().unwrap() ^= 0xFF;
    let mut huge = vec![0x54, 0xFE, 0x01, 0x00];
    huge.extend_from_slice(&60_000u16.to_le_bytes());
    huge.extend(std::iter::repeat_n(0u8, 60_000 + 16));
    let mut stream = b"noise".to_vec();
    stream.extend(&bad_crc);
    stream.extend(&huge);
    stream.extend(&good);
    let run = |chunk: usize| {
        let mut d = Deframer::new();
        let mut v = Vec::new();
        for c in stream.chunks(chunk) {
            d.feed(c, &mut |r| v.push(r));
            assert!(d.buffered() <= MAX_FRAME);
        }
        v
    };
    let whole = run(stream.len());
    let frames: Vec<_> = whole.iter().filter_map(|r| r.clone().ok()).collect();
    assert_eq!(frames, vec![good.clone()]);
    assert!(whole.contains(&Err(ImcError::Oversized(60_022))));
    assert!(
        whole
            .iter()
            .any(|r| matches!(r, Err(ImcError::BadCrc { .. })))
    );
    for chunk in [1, 7, 4096] {
        let v = run(chunk);
        let f: Vec<_> = v.iter().filter_map(|r| r.clone().ok()).collect();
        assert_eq!(f, frames, "chunk {chunk}");
    }
}
