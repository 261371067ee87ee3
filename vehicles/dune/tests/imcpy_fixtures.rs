//! The codec against imcpy's bytes (`fixtures/imcpy_packets.hex`, made by
//! `python/make_fixtures.py`): every packet decodes, re-encodes to the same bytes, and the values
//! imcpy was given come back; the same packets byte-swapped decode the same (IMC's sync word says
//! the sender's byte order).

use frontseat_dune::imc::{self, ByteOrder, Message, consts};

const FIXTURE: &str = include_str!("../fixtures/imcpy_packets.hex");

fn hex(s: &str) -> Vec<u8> {
    (0..s.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&s[i..i + 2], 16).unwrap())
        .collect()
}

fn fixtures() -> Vec<(&'static str, Vec<u8>)> {
    FIXTURE
        .lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .map(|l| {
            let (n, h) = l.split_once(' ').unwrap();
            (n, hex(h.trim()))
        })
        .collect()
}

fn packet(name: &str) -> (imc::Header, Message) {
    let (_, b) = fixtures().into_iter().find(|(n, _)| *n == name).unwrap();
    imc::decode(&b).unwrap()
}

#[test]
fn every_imcpy_packet_decodes_and_re_encodes_byte_for_byte() {
    let all = fixtures();
    assert!(all.len() >= 28, "{} fixtures", all.len());
    for (name, bytes) in all {
        let (h, m) = imc::decode(&bytes).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(h.mgid, m.id(), "{name}");
        let again = imc::encode(&h, &m, ByteOrder::Little).unwrap();
        assert_eq!(again, bytes, "{name} re-encodes differently");
        // The same packet from a big-endian sender.
        let be = imc::encode(&h, &m, ByteOrder::Big).unwrap();
        assert_eq!(&be[..2], &[0xFE, 0x54]);
        let (hb, mb) = imc::decode(&be).unwrap();
        assert_eq!(
            (hb.src, hb.dst, hb.src_ent, hb.dst_ent),
            (h.src, h.dst, h.src_ent, h.dst_ent)
        );
        // NaN != NaN: compare the re-encoding instead.
        assert_eq!(
            imc::encode(&hb, &mb, ByteOrder::Little).unwrap(),
            bytes,
            "{name} BE"
        );
    }
}

#[test]
fn values_imcpy_was_given_come_back() {
    let (h, Message::EstimatedState(e)) = packet("estimated_state") else {
        panic!()
    };
    assert_eq!(
        (h.src, h.dst, h.timestamp),
        (0x00D1, 0xFFFF, 1_700_000_000.0)
    );
    assert_eq!(
        (e.x, e.y, e.z, e.depth, e.alt),
        (100.0, -50.0, 2.0, 2.0, 18.5)
    );
    assert!((e.lat - 41.185f64.to_radians()).abs() < 1e-12);
    assert!((f64::from(e.psi) - 90f64.to_radians()).abs() < 1e-6);

    let (_, Message::VehicleState(v)) = packet("vs_maneuver_followref") else {
        panic!()
    };
    assert_eq!(
        (v.op_mode, v.maneuver_type, v.control_loops),
        (consts::op_mode::MANEUVER, 478, 0x4C9)
    );
    let (_, Message::VehicleState(v)) = packet("vs_error") else {
        panic!()
    };
    assert_eq!(
        (v.error_ents.as_str(), v.last_error.as_str()),
        ("GPS", "GPS: no fix")
    );

    let (h, Message::PlanControl(p)) = packet("pc_start_followref") else {
        panic!()
    };
    assert_eq!((h.src, h.dst), (0x4F0A, 0x00D1));
    assert_eq!(
        (p.kind, p.op, p.request_id, p.plan_id.as_str()),
        (0, 0, 7, "frontseat")
    );
    let Some(Message::FollowReference(f)) = p.arg.as_deref() else {
        panic!("{:?}", p.arg)
    };
    assert_eq!(
        (f.control_src, f.control_ent, f.timeout),
        (0x4F0A, 0xFF, 10.0)
    );

    let (_, Message::Reference(r)) = packet("reference_full") else {
        panic!()
    };
    assert_eq!(r.flags, 0x27);
    assert_eq!(
        r.speed.as_deref(),
        Some(&Message::DesiredSpeed(imc::DesiredSpeed {
            value: 1.5,
            speed_units: 0
        }))
    );
    assert_eq!(
        r.z.as_deref(),
        Some(&Message::DesiredZ(imc::DesiredZ {
            value: 2.0,
            z_units: 1
        }))
    );
    let (_, Message::Reference(r)) = packet("reference") else {
        panic!()
    };
    assert_eq!(
        (r.speed.is_none(), r.z.is_none()),
        (true, true),
        "65535 = absent"
    );

    let (_, Message::FollowRefState(s)) = packet("follow_ref_state_goto") else {
        panic!()
    };
    assert_eq!((s.control_src, s.state, s.proximity), (0x4F0A, 2, 1));
    assert!(matches!(
        s.reference.as_deref(),
        Some(Message::Reference(_))
    ));

    let (_, Message::PlanControl(p)) = packet("pc_start_spec") else {
        panic!()
    };
    let Some(Message::PlanSpecification(spec)) = p.arg.as_deref() else {
        panic!()
    };
    assert_eq!(spec.maneuvers.0.len(), 1);
    let Message::PlanManeuver(pm) = &spec.maneuvers.0[0] else {
        panic!()
    };
    assert!(matches!(
        pm.data.as_deref(),
        Some(Message::FollowReference(_))
    ));

    let (h, Message::Announce(a)) = packet("announce") else {
        panic!()
    };
    assert_eq!(
        (h.src, a.sys_name.as_str(), a.sys_type),
        (0x00D1, "lauv-simulator-1", 2)
    );
    let (h, Message::EntityState(es)) = packet("entity_state_normal") else {
        panic!()
    };
    assert_eq!(
        (h.src_ent, es.state, es.description.as_str()),
        (12, 1, "active")
    );
    let (_, Message::GpsFix(g)) = packet("gps_fix") else {
        panic!()
    };
    assert_eq!((g.validity & consts::GPS_VALID_POS, g.satellites), (4, 9));
}

#[test]
fn truncated_and_corrupted_imcpy_packets_are_typed_errors() {
    for (name, bytes) in fixtures() {
        for cut in [0, 1, 19, bytes.len() - 1] {
            assert!(imc::decode(&bytes[..cut]).is_err(), "{name} cut at {cut}");
        }
        let mut b = bytes.clone();
        b[HEADER_BYTE] ^= 0x40;
        assert!(imc::decode(&b).is_err(), "{name} with a flipped bit");
    }
}

/// A byte in the header's timestamp: a flip there is only seen by the CRC.
const HEADER_BYTE: usize = 9;
