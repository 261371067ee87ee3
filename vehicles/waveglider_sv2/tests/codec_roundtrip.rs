//! Property tests: every message type encodes and decodes back to itself, and the decoder finds
//! every frame of a stream whatever noise sits between them and however the stream is chunked.

use frontseat_waveglider_sv2::codec::{
    DeviceInfo, FrameDecoder, HeadingCommand, Message, Packet, PayloadStatus, START,
};
use proptest::prelude::*;

fn sv2_message() -> impl Strategy<Value = Message> {
    let bytes = |n| proptest::collection::vec(any::<u8>(), 0..n);
    prop_oneof![
        (any::<u16>(), any::<u16>()).prop_map(|(p, c)| Message::RequestEnumerate {
            protocols_supported: p,
            commands_supported: c
        }),
        (any::<[u8; 6]>(), any::<u32>(), any::<u32>(), any::<u8>()).prop_map(
            |(time, latitude, longitude, fix_valid)| Message::RequestStatus {
                time,
                latitude,
                longitude,
                fix_valid
            }
        ),
        Just(Message::RequestQueuedMessage),
        (any::<u16>(), any::<u8>(), bytes(100)).prop_map(|(f, r, m)| {
            Message::QueuedMessageAckNak {
                command_format: f,
                response_code: r,
                message: m,
            }
        }),
        (any::<u16>(), any::<u8>(), bytes(100)).prop_map(|(o, r, d)| Message::Nak {
            original_msg_type: o,
            response_code: r,
            details: d
        }),
        // Generic ACKs of types that are not one of the three typed replies.
        (any::<u16>(), bytes(100))
            .prop_filter("typed replies", |(o, _)| !matches!(
                o & 0x7FFF,
                0x0010 | 0x0022 | 0x0040
            ))
            .prop_map(|(o, d)| Message::Ack {
                original_msg_type: o,
                details: d
            }),
        (any::<bool>(), any::<u16>(), any::<u32>(), any::<u8>()).prop_map(|(w, addr, poll, x)| {
            let mut device = DeviceInfo::goby(addr);
            device.polling_frequency = poll;
            device.extra_info = x;
            Message::EnumerateReply {
                original_msg_type: 0x0010 | if w { 0x8000 } else { 0 },
                device,
            }
        }),
        (any::<u16>(), any::<u16>(), any::<[u8; 6]>()).prop_map(|(version, alarms, s)| {
            Message::StatusReply {
                original_msg_type: 0x0022,
                status: PayloadStatus {
                    devices_responding: 1,
                    devices_in_message: 1,
                    version,
                    board_address: 0x0301,
                    alarms,
                    leak1: s[0],
                    leak2: s[1],
                    humidity_temp: s[2],
                    humidity: s[3],
                    pressure_temp: s[4],
                    pressure: s[5],
                },
            }
        }),
        (any::<u16>(), any::<u32>(), any::<u32>()).prop_map(|(h, la, lo)| {
            let mut command = HeadingCommand::follow_heading(h);
            command.latitude = la;
            command.longitude = lo;
            Message::QueuedCommandReply {
                original_msg_type: 0x0040,
                command,
            }
        }),
        (
            any::<u16>().prop_filter("known types", |t| !matches!(
                t & 0x7FFF,
                0x0000 | 0x0001 | 0x0010 | 0x0022 | 0x0040 | 0x0041
            )),
            bytes(200)
        )
            .prop_map(|(t, p)| Message::Other {
                message_type: t,
                payload: p
            }),
    ]
}

fn packet() -> impl Strategy<Value = Packet> {
    (any::<u16>(), any::<u16>(), any::<u16>(), sv2_message()).prop_map(|(d, s, t, m)| Packet {
        dest: d,
        src: s,
        transaction_id: t,
        message: m,
    })
}

proptest! {
    #[test]
    fn every_sv2_message_round_trips(p in packet()) {
        let wire = p.encode().unwrap();
        let mut got = Vec::new();
        FrameDecoder::new().feed(&wire, &mut |r| got.push(r));
        prop_assert_eq!(got.len(), 1);
        let f = got.remove(0).unwrap();
        prop_assert_eq!(Packet::from_frame(&f).unwrap(), p);
    }

    #[test]
    fn frames_are_found_through_noise_and_any_chunking(
        packets in proptest::collection::vec(packet(), 1..6),
        noise in proptest::collection::vec(
            proptest::collection::vec(any::<u8>().prop_filter("no start byte", |b| *b != START), 0..20),
            6,
        ),
        chunk in 1usize..64,
    ) {
        let mut stream = Vec::new();
        for (p, n) in packets.iter().zip(&noise) {
            stream.extend_from_slice(n);
            stream.extend_from_slice(&p.encode().unwrap());
        }
        let mut d = FrameDecoder::new();
        let mut found = Vec::new();
        for c in stream.chunks(chunk) {
            d.feed(c, &mut |r| if let Ok(f) = r {
                found.push(Packet::from_frame(&f).unwrap());
            });
        }
        prop_assert_eq!(found, packets);
    }
}
