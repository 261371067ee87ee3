//! The SV2 codec against the fact sheet: the CRC check value, golden frames both ways,
//! escaping, bad input and resynchronisation, and the position and heading units.

use super::*;

fn hex(s: &str) -> Vec<u8> {
    s.split_whitespace()
        .map(|h| u8::from_str_radix(h, 16).unwrap())
        .collect()
}

fn decode_all(bytes: &[u8]) -> Vec<Result<Frame, FrameError>> {
    let mut d = FrameDecoder::new();
    let mut v = Vec::new();
    d.feed(bytes, &mut |r| v.push(r));
    v
}

#[test]
fn crc_check_value() {
    assert_eq!(crc16(b"123456789"), 0xBB3D);
}

/// The constructed frames of the fact sheet (waveglider_sv2.md §2.2, §7).
#[test]
fn golden_frames_encode_and_decode() {
    let addr = 0x0301;
    let cases: Vec<(&str, Packet)> = vec![
        (
            "7E 10 00 FF FF 00 00 01 00 10 00 01 00 01 00 B6 E2",
            Packet {
                dest: 0xFFFF,
                src: 0,
                transaction_id: 1,
                message: Message::RequestEnumerate {
                    protocols_supported: 1,
                    commands_supported: 1,
                },
            },
        ),
        (
            "7E 3C 00 00 00 01 03 01 00 01 00 10 00 01 00 01 00 01 00 01 10 01 03 30 30 30 30 30 31 00 01 00 00 00 \
             08 00 00 01 00 69 46 72 6F 6E 74 53 65 61 74 20 44 72 69 76 65 72 00 00 00 40 30",
            Packet {
                dest: 0,
                src: addr,
                transaction_id: 1,
                message: Message::EnumerateReply {
                    original_msg_type: 0x0010,
                    device: DeviceInfo::goby(addr),
                },
            },
        ),
        (
            "7E 1B 00 01 03 00 00 02 00 22 00 00 00 0C 0A 0A 18 00 00 00 00 00 00 00 00 59 16 46",
            Packet {
                dest: addr,
                src: 0,
                transaction_id: 2,
                message: Message::RequestStatus {
                    time: [0, 0, 12, 10, 10, 24],
                    latitude: 0,
                    longitude: 0,
                    fix_valid: b'Y',
                },
            },
        ),
        (
            "7E 1E 00 00 00 01 03 03 00 01 00 22 00 01 00 01 00 01 80 01 03 00 00 00 00 00 00 00 00 0B A3",
            Packet {
                dest: 0,
                src: addr,
                transaction_id: 3,
                message: Message::StatusReply {
                    original_msg_type: 0x0022,
                    status: PayloadStatus {
                        devices_responding: 1,
                        devices_in_message: 1,
                        version: 0x8001,
                        board_address: addr,
                        ..Default::default()
                    },
                },
            },
        ),
        (
            "7E 0C 00 01 03 00 00 04 00 40 00 02 03",
            Packet {
                dest: addr,
                src: 0,
                transaction_id: 4,
                message: Message::RequestQueuedMessage,
            },
        ),
        (
            "7E 29 00 01 00 01 03 04 00 01 00 40 00 01 00 0A FF FF FF FF 12 00 10 08 00 00 00 00 5A 00 \
             00 00 00 00 00 00 00 00 02 19 99 D9",
            Packet {
                dest: 1,
                src: addr,
                transaction_id: 4,
                message: Message::QueuedCommandReply {
                    original_msg_type: 0x0040,
                    command: HeadingCommand::follow_heading(90),
                },
            },
        ),
        (
            "7E 11 00 01 03 01 00 04 00 41 00 01 00 00 00 00 8D 71",
            Packet {
                dest: addr,
                src: 1,
                transaction_id: 4,
                message: Message::QueuedMessageAckNak {
                    command_format: 1,
                    response_code: 0,
                    message: vec![],
                },
            },
        ),
    ];
    for (wire, pkt) in cases {
        let wire = hex(wire);
        assert_eq!(pkt.to_frame().unescaped().unwrap(), wire, "{pkt:?}");
        let frames = decode_all(&wire);
        assert_eq!(frames.len(), 1);
        let f = frames[0].clone().unwrap();
        assert_eq!(Packet::from_frame(&f).unwrap(), pkt);
        assert_eq!(Frame::from_unescaped(&wire), Ok(f));
    }
}

#[test]
fn escaping_example_from_the_fact_sheet() {
    let pkt = Packet {
        dest: 1,
        src: 0x0301,
        transaction_id: 0x007D,
        message: Message::QueuedCommandReply {
            original_msg_type: 0x0040,
            command: HeadingCommand::follow_heading(126),
        },
    };
    let wire = hex(
        "7E 29 00 01 00 01 03 7D 5D 00 01 00 40 00 01 00 0A FF FF FF FF 12 00 10 08 00 00 00 00 7D 5E \
         00 00 00 00 00 00 00 00 00 42 A6 D4 0A",
    );
    assert_eq!(pkt.encode().unwrap(), wire);
    let f = decode_all(&wire).remove(0).unwrap();
    assert_eq!(Packet::from_frame(&f).unwrap(), pkt);
}

#[test]
fn bad_input_is_reported_and_the_decoder_resynchronises() {
    let good = Packet {
        dest: 0x0301,
        src: 0,
        transaction_id: 9,
        message: Message::RequestQueuedMessage,
    }
    .encode()
    .unwrap();
    let mut bad_crc = good.clone();
    let n = bad_crc.len();
    bad_crc[n - 1] ^= 0xFF;
    let mut bytes = b"noise".to_vec();
    bytes.extend_from_slice(&good[..6]); // truncated by the next start byte
    bytes.extend_from_slice(&bad_crc);
    bytes.extend_from_slice(&[START, 0x05, ESC, 0x33]); // bad escape
    bytes.extend_from_slice(&[START, 0xFF, 0xFF]); // size beyond the protocol
    bytes.extend_from_slice(&[START, 0x02, 0x00]); // size below the header
    bytes.extend_from_slice(&good);
    let r = decode_all(&bytes);
    assert_eq!(
        r.iter()
            .map(|x| x.as_ref().err().cloned())
            .collect::<Vec<_>>(),
        vec![
            Some(FrameError::Noise(5)),
            Some(FrameError::Truncated(6)),
            Some(FrameError::BadCrc {
                got: u16::from_le_bytes([bad_crc[n - 2], bad_crc[n - 1]]),
                computed: crc16(&good[1..n - 2]),
            }),
            Some(FrameError::BadEscape(0x33)),
            Some(FrameError::BadSize(0xFFFF)),
            Some(FrameError::BadSize(2)),
            None,
        ]
    );
}

#[test]
fn position_unit_round_trips() {
    for d in [0.0, 42.3584, -71.0876, 179.999, -89.5] {
        assert!((wire_to_degrees(degrees_to_wire(d)) - d).abs() < 1e-6);
    }
}

#[test]
fn headings_wrap_and_round() {
    for (h, want) in [
        (90.0, Some(90)),
        (90.4, Some(90)),
        (90.6, Some(91)),
        (359.7, Some(0)),
        (-10.0, Some(350)),
        (720.0 + 45.0, Some(45)),
        (f64::NAN, None),
        (f64::INFINITY, None),
    ] {
        assert_eq!(heading_to_wire(h), want, "{h}");
    }
}
