//! Replays what was recorded from the real gobyd 3.1.5a and goby_frontseat_interface
//! (`fixtures/goby3/`, see its README): every golden frame decodes to the recorded identifier
//! and payload, and re-encoding it — payload through our prost types, frame through our codec —
//! gives the same bytes; our manager requests equal the recorded ones and the recorded answers
//! parse to the right endpoints and hold; the deliberately malformed frames are refused.

use frontseat_actors::proto::goby::middleware::frontseat::protobuf as fs;
use frontseat_helm_side::goby3::frame::{self, FrameError};
use frontseat_helm_side::goby3::manager::{self, Transport};
use prost::Message;
use serde_json::Value;

const MAX: usize = 64 * 1024;

fn fixture(name: &str) -> Value {
    let path = format!("{}/tests/fixtures/goby3/{name}", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    serde_json::from_str(&text).unwrap()
}

fn hex(s: &str) -> Vec<u8> {
    assert!(s.len().is_multiple_of(2), "odd hex {s}");
    (0..s.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&s[i..i + 2], 16).unwrap())
        .collect()
}

fn text<'a>(v: &'a Value, k: &str) -> &'a str {
    v[k].as_str().unwrap_or_else(|| panic!("no {k} in {v}"))
}

/// A field recorded as a number or as a string, as text.
fn num(v: &Value, k: &str) -> String {
    match &v[k] {
        Value::Number(n) => n.to_string(),
        Value::String(s) => s.clone(),
        other => panic!("{k}: {other}"),
    }
}

/// Decodes with our prost type and encodes again; `None` for types outside the frontseat schema.
fn reencode(type_name: &str, payload: &[u8]) -> Option<Vec<u8>> {
    fn re<M: Message + Default>(b: &[u8]) -> Vec<u8> {
        M::decode(b).unwrap().encode_to_vec()
    }
    let t = type_name.strip_prefix("goby.middleware.frontseat.protobuf.")?;
    Some(match t {
        "InterfaceStatus" => re::<fs::InterfaceStatus>(payload),
        "InterfaceData" => re::<fs::InterfaceData>(payload),
        "NodeStatus" => re::<fs::NodeStatus>(payload),
        "Raw" => re::<fs::Raw>(payload),
        "CommandRequest" => re::<fs::CommandRequest>(payload),
        "CommandResponse" => re::<fs::CommandResponse>(payload),
        "HelmStateReport" => re::<fs::HelmStateReport>(payload),
        "DesiredCourse" => re::<fs::DesiredCourse>(payload),
        other => panic!("frontseat type {other} not covered"),
    })
}

#[test]
fn golden_frames_decode_and_encode_byte_for_byte() {
    let frames = fixture("golden_frames.json");
    let frames = frames.as_array().unwrap();
    assert_eq!(frames.len(), 20);
    let mut frontseat = 0;
    for (i, g) in frames.iter().enumerate() {
        let bytes = hex(text(g, "frame_hex"));
        let payload = hex(text(g, "payload_hex"));
        assert_eq!(
            bytes.len().to_string(),
            num(g, "frame_len"),
            "#{i} frame_len"
        );
        let f = frame::decode(&bytes, MAX).unwrap_or_else(|e| panic!("#{i}: {e}"));
        assert_eq!(f.group, text(g, "group"), "#{i}");
        assert_eq!(f.scheme, text(g, "scheme"), "#{i}");
        assert_eq!(f.type_name, text(g, "type"), "#{i}");
        assert_eq!(f.pid.to_string(), num(g, "pid"), "#{i}");
        assert_eq!(format!("{:x}", f.thread), text(g, "thread"), "#{i}");
        assert_eq!(f.payload, &payload[..], "#{i}");
        assert_eq!(
            frame::identifier(f.group, f.type_name, f.pid, f.thread),
            text(g, "identifier"),
            "#{i}"
        );
        // Our encoder, given what was recorded, writes exactly the recorded frame ...
        assert_eq!(
            frame::encode(f.group, f.type_name, f.pid, f.thread, &payload),
            bytes,
            "#{i} frame"
        );
        assert!(
            bytes.starts_with(frame::subscription_prefix(f.group, f.type_name).as_bytes()),
            "#{i}"
        );
        // ... and our messages encode Goby3's payloads identically.
        if let Some(again) = reencode(f.type_name, f.payload) {
            assert_eq!(again, payload, "#{i} payload of {}", f.type_name);
            frontseat += 1;
        }
    }
    assert_eq!(frontseat, 15, "every frontseat frame was re-encoded");
}

#[test]
fn manager_requests_equal_the_recorded_ones_and_answers_parse() {
    let m = fixture("manager_exchange.json");
    let ex = &m["req_rep_goby_frontseat_interface"]["exchange"];
    let name = "goby_frontseat_interface";
    assert_eq!(
        manager::sockets_request(name, 1390),
        hex(text(&ex[0], "body_hex"))
    );
    let ipc = Transport::ipc_for_platform("zp3", "");
    let (ps, hold) =
        manager::parse_sockets_response(&hex(text(&ex[1], "body_hex")), name, 1390, &ipc).unwrap();
    assert_eq!(ps.publish, "ipc:///tmp/goby_zp3.xsub");
    assert_eq!(ps.subscribe, "ipc:///tmp/goby_zp3.xpub");
    assert!(hold, "no hold field means held (proto2 default true)");
    // The wrong transport, or another client's answer, is refused.
    let tcp = Transport::Tcp {
        address: "127.0.0.1".into(),
        port: 11150,
    };
    assert!(
        manager::parse_sockets_response(&hex(text(&ex[1], "body_hex")), name, 1390, &tcp).is_err()
    );
    assert!(
        manager::parse_sockets_response(&hex(text(&ex[1], "body_hex")), name, 1391, &ipc).is_err()
    );

    let probe = "goby3_pubsub_probe";
    let ex = &m["req_rep_python_client"]["exchange"];
    assert_eq!(
        manager::sockets_request(probe, 1872),
        hex(text(&ex[0], "body_hex"))
    );
    assert_eq!(
        manager::hold_request(probe, 1872, true),
        hex(text(&ex[4], "body_hex"))
    );
    assert!(!manager::parse_hold_response(&hex(text(&ex[5], "body_hex")), probe, 1872).unwrap());

    let ex = &m["tcp_transport"]["exchange"];
    let (ps, _) =
        manager::parse_sockets_response(&hex(text(&ex[1], "body_hex")), probe, 7725, &tcp).unwrap();
    // The answer has ports only; the address is the manager's.
    assert_eq!(ps.publish, "tcp://127.0.0.1:43593");
    assert_eq!(ps.subscribe, "tcp://127.0.0.1:42147");

    let ex = &m["hold_true_example"]["exchange"];
    assert!(manager::parse_hold_response(&hex(text(&ex[3], "body_hex")), probe, 2727).unwrap());
}

#[test]
fn the_naive_frames_that_killed_goby3_are_refused_and_the_delivered_ones_accepted() {
    let n = fixture("naive_frame_tests.json");
    let raw = "goby.middleware.frontseat.protobuf.Raw";
    let group = "goby::middleware::frontseat::raw_send_request";
    let prefix = frame::subscription_prefix(group, raw);
    let mut seen = 0;
    for r in n["results"].as_array().unwrap() {
        let test = text(r, "test");
        let outcome = text(r, "outcome");
        let parts: Vec<Vec<u8>> = r["zmq_parts_hex"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| hex(p.as_str().unwrap()))
            .collect();
        let matches_prefix = parts[0].starts_with(prefix.as_bytes());
        let decoded = frame::decode(&parts[0], MAX);
        seen += 1;
        if parts.len() > 1 {
            // Several parts are refused before any part is parsed (Importer::handle_parts).
            assert!(outcome.starts_with("KILLED"), "{test}");
            continue;
        }
        match outcome {
            o if o.starts_with("DELIVERED") => {
                assert!(matches_prefix, "{test}");
                let f = decoded.unwrap_or_else(|e| panic!("{test}: {e}"));
                let msg = fs::Raw::decode(f.payload);
                if test == "bad_payload" {
                    // Goby3 delivered an empty Raw; we refuse it as undecodable.
                    assert!(msg.is_err(), "{test}");
                } else {
                    assert!(msg.unwrap().raw().starts_with(b"NAIVE_"), "{test}");
                }
            }
            o if o.starts_with("silently NOT") => {
                // Never reaches us either: our subscription prefix does not match it.
                assert!(!matches_prefix, "{test}");
            }
            o if o.starts_with("KILLED") => {
                let e = decoded.expect_err(test);
                let want = match test {
                    "no_pid_thread" => matches!(e, FrameError::FieldCount(3)),
                    "no_nul" => matches!(e, FrameError::NoNul),
                    "thread_not_hex" => matches!(e, FrameError::BadThread(_)),
                    "pid_not_number" => matches!(e, FrameError::BadPid(_)),
                    _ => false,
                };
                assert!(want, "{test}: {e:?}");
            }
            o => panic!("{test}: unknown outcome {o}"),
        }
    }
    assert_eq!(seen, 14);
}
