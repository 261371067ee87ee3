//! Every capture under `shared/protocol/moos/captures/` decoded packet by packet and message by
//! message, each message rendered the way the capture's `*.summary.txt` renders it and compared
//! line for line; every client→DB packet re-encoded byte for byte; our message builders checked
//! against the client bytes the captures pin down; and the facts protocol.md quotes checked.

use std::collections::BTreeMap;
use std::path::PathBuf;

use bytes::{Bytes, BytesMut};
use frontseat_moos::codec::{
    self, BANNER, BANNER_LEN, DEFAULT_MAX_PACKET, Fields, MoosMessage, MsgType, PacketDecoder,
    banner_ok, encode_fields, handshake_message, parse_handshake_reply, timing_message,
};
use frontseat_moos::{DataType, MoosError};

const CAPTURES: [&str; 6] = [
    "cap01_poke_mail",
    "cap02_rawclient",
    "cap03a_helm_startup",
    "cap03b_frontseat_first10s",
    "cap04_heldmail",
    "cap05_typelock",
];

fn capture_dir() -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/captures");
    assert!(
        dir.is_dir(),
        "MOOS capture directory {} is missing: these tests need the recorded MOOSDB captures \
         (moos/tests/fixtures/captures)",
        dir.display()
    );
    dir
}

fn read(name: &str) -> String {
    let p = capture_dir().join(name);
    std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("cannot read {}: {e}", p.display()))
}

/// (stream, client port) → concatenated payload bytes, from a `*.payloads_*.txt` file.
fn payloads(name: &str) -> BTreeMap<(u32, u32), Vec<u8>> {
    let mut out: BTreeMap<(u32, u32), Vec<u8>> = BTreeMap::new();
    let mut cur = None;
    for line in read(name).lines() {
        if line.starts_with('#') {
            continue;
        }
        if line.starts_with("frame") {
            let w: Vec<&str> = line.split_whitespace().collect();
            let si = w.iter().position(|x| *x == "stream").unwrap();
            let stream: u32 = w[si + 1].parse().unwrap();
            let port: u32 = w[si + 4].trim_end_matches(')').parse().unwrap();
            cur = Some((stream, port));
            out.entry((stream, port)).or_default();
        } else if let Some(rest) = line.strip_prefix("    ") {
            // "00000000  xx xx ... xx  xx ... xx  |ascii|"
            let hex = &rest[10..rest.find('|').unwrap()];
            let v = out.get_mut(cur.as_ref().unwrap()).unwrap();
            for h in hex.split_whitespace() {
                v.push(u8::from_str_radix(h, 16).unwrap());
            }
        }
    }
    out
}

#[derive(Default, Debug)]
struct Dir {
    banner: Option<String>,
    /// (len, n, message lines)
    packets: Vec<(usize, usize, Vec<String>)>,
}

/// (stream, client port) → (C->DB, DB->C) from a `*.summary.txt` file.
fn summary(name: &str) -> BTreeMap<(u32, u32), [Dir; 2]> {
    let mut out: BTreeMap<(u32, u32), [Dir; 2]> = BTreeMap::new();
    let mut conn = (0, 0);
    let mut dir = 0;
    for line in read(name).lines() {
        if let Some(rest) = line.strip_prefix("=== TCP connection ") {
            let w: Vec<&str> = rest.split_whitespace().collect();
            conn = (
                w[0].trim_end_matches(',').parse().unwrap(),
                w[3].parse().unwrap(),
            );
            out.entry(conn).or_default();
        } else if line == " --- C->DB ---" {
            dir = 0;
        } else if line == " --- DB->C ---" {
            dir = 1;
        } else if line.contains(" banner ") && line.trim_start().starts_with("t=") {
            out.get_mut(&conn).unwrap()[dir].banner = Some(line.to_owned());
        } else if line.contains(" pkt#") {
            let field = |k: &str| -> usize {
                let i = line.find(k).unwrap() + k.len();
                line[i..]
                    .split_whitespace()
                    .next()
                    .unwrap()
                    .parse()
                    .unwrap()
            };
            out.get_mut(&conn).unwrap()[dir]
                .packets
                .push((field(" len="), field(" n="), vec![]));
        } else if let Some(m) = line.strip_prefix("        ") {
            let d = &mut out.get_mut(&conn).unwrap()[dir];
            d.packets.last_mut().unwrap().2.push(m.to_owned());
        }
    }
    out
}

/// Python's `repr()` of a float.
fn py_float(v: f64) -> String {
    if v.is_nan() {
        return "nan".into();
    }
    if v.is_infinite() {
        return if v > 0.0 { "inf".into() } else { "-inf".into() };
    }
    let sci = format!("{:e}", v.abs());
    let (mant, exp) = sci.split_once('e').unwrap();
    let exp: i32 = exp.parse().unwrap();
    let digits: String = mant.chars().filter(|c| c.is_ascii_digit()).collect();
    let sign = if v.is_sign_negative() { "-" } else { "" };
    if !(-4..16).contains(&exp) {
        let (a, b) = digits.split_at(1);
        let frac = if b.is_empty() {
            String::new()
        } else {
            format!(".{b}")
        };
        let es = if exp < 0 { '-' } else { '+' };
        return format!("{sign}{a}{frac}e{es}{:02}", exp.abs());
    }
    if exp >= 0 {
        let int_len = exp as usize + 1;
        let mut d = digits.clone();
        while d.len() < int_len {
            d.push('0');
        }
        let (i, f) = d.split_at(int_len);
        let f = if f.is_empty() { "0" } else { f };
        format!("{sign}{i}.{f}")
    } else {
        format!("{sign}0.{}{}", "0".repeat((-exp - 1) as usize), digits)
    }
}

/// Python's `repr()` of `bytes.decode('latin1')`.
fn py_str(b: &[u8]) -> String {
    let has_sq = b.contains(&b'\'');
    let has_dq = b.contains(&b'"');
    let q = if has_sq && !has_dq { '"' } else { '\'' };
    let mut s = String::new();
    s.push(q);
    for &c in b {
        let ch = c as char;
        match c {
            b'\\' => s.push_str("\\\\"),
            b'\t' => s.push_str("\\t"),
            b'\n' => s.push_str("\\n"),
            b'\r' => s.push_str("\\r"),
            _ if ch == q => {
                s.push('\\');
                s.push(ch);
            }
            0..=0x1f | 0x7f..=0xa0 | 0xad => s.push_str(&format!("\\x{c:02x}")),
            _ => s.push(ch),
        }
    }
    s.push(q);
    s
}

fn py_time(v: f64) -> String {
    if v > 1e8 && v < 2.5e11 {
        format!("{v:.6}")
    } else {
        py_float(v)
    }
}

/// One message rendered exactly as `moos_annotate.py` renders it in the summary.
fn render(m: &MoosMessage) -> String {
    let dt = m.data_type.code() as char;
    let value = if dt == 'D' {
        String::new()
    } else {
        let s = if dt == 'B' {
            let hex: Vec<String> = m
                .string_val
                .iter()
                .take(32)
                .map(|b| format!("{b:02x}"))
                .collect();
            format!(
                "{} bytes: {}{}",
                m.string_val.len(),
                hex.join(" "),
                if m.string_val.len() > 32 { " ..." } else { "" }
            )
        } else {
            py_str(&m.string_val)
        };
        format!("s={}", s.chars().take(70).collect::<String>())
    };
    format!(
        "{}/{} key={} src={} aux={} comm={} id={} t={} d={} d2={} {}",
        m.msg_type.code() as char,
        dt,
        py_str(m.key.as_bytes()),
        py_str(m.source.as_bytes()),
        py_str(m.source_aux.as_bytes()),
        py_str(m.community.as_bytes()),
        m.id,
        py_time(m.time),
        py_float(m.double_val),
        py_float(m.double_val2),
        value
    )
}

/// A decoded direction of one connection: the packets' raw bytes and messages.
struct Decoded {
    banner: Option<Vec<u8>>,
    packets: Vec<(Bytes, Vec<MoosMessage>)>,
    trailing: usize,
}

fn decode_stream(bytes: &[u8], client_side: bool) -> Decoded {
    let mut rest = bytes;
    let mut banner = None;
    if client_side && rest.len() >= BANNER_LEN {
        banner = Some(rest[..BANNER_LEN].to_vec());
        rest = &rest[BANNER_LEN..];
    }
    let dec = PacketDecoder::new(DEFAULT_MAX_PACKET);
    let mut buf = BytesMut::new();
    let mut packets = vec![];
    // Feed in small uneven pieces: the decoder must not care how TCP cut the stream.
    for chunk in rest.chunks(97) {
        buf.extend_from_slice(chunk);
        while let Some(frame) = dec.next_frame(&mut buf).unwrap() {
            let msgs = codec::decode_packet(&frame).unwrap();
            packets.push((frame, msgs));
        }
    }
    Decoded {
        banner,
        packets,
        trailing: buf.len(),
    }
}

struct Capture {
    name: &'static str,
    conns: BTreeMap<(u32, u32), [Decoded; 2]>,
}

fn load(name: &'static str) -> Capture {
    let c2db = payloads(&format!("{name}.payloads_C2DB.txt"));
    let db2c = payloads(&format!("{name}.payloads_DB2C.txt"));
    let mut keys: Vec<(u32, u32)> = c2db.keys().chain(db2c.keys()).copied().collect();
    keys.sort();
    keys.dedup();
    let conns = keys
        .into_iter()
        .map(|k| {
            let a = decode_stream(c2db.get(&k).map(Vec::as_slice).unwrap_or(&[]), true);
            let b = decode_stream(db2c.get(&k).map(Vec::as_slice).unwrap_or(&[]), false);
            (k, [a, b])
        })
        .collect();
    Capture { name, conns }
}

#[test]
fn every_capture_decodes_to_the_annotated_values() {
    let (mut total_msgs, mut summary_msgs) = (0, 0);
    for name in CAPTURES {
        let cap = load(name);
        let summ = summary(&format!("{name}.summary.txt"));
        assert!(!summ.is_empty(), "{name}: empty summary");
        summary_msgs += summ
            .values()
            .flat_map(|d| d.iter())
            .flat_map(|d| &d.packets)
            .map(|p| p.2.len())
            .sum::<usize>();
        for (conn, dirs) in &summ {
            let decoded = cap
                .conns
                .get(conn)
                .unwrap_or_else(|| panic!("{name}: connection {conn:?} has no payloads"));
            for (d, (want, got)) in dirs.iter().zip(decoded.iter()).enumerate() {
                let ctx = format!("{name} conn {conn:?} dir {}", ["C->DB", "DB->C"][d]);
                if let Some(line) = &want.banner {
                    let b = got
                        .banner
                        .as_ref()
                        .unwrap_or_else(|| panic!("{ctx}: no banner"));
                    assert_eq!(
                        banner_ok(b),
                        line.contains("ELKS CAN'T DANCE 2/8/10"),
                        "{ctx}"
                    );
                    if banner_ok(b) {
                        assert_eq!(b.as_slice(), BANNER.as_slice(), "{ctx}: banner bytes");
                    }
                }
                assert_eq!(got.packets.len(), want.packets.len(), "{ctx}: packet count");
                // The annotator also stops at a packet cut off by the end of the capture.
                let cut = got.trailing;
                assert!(cut < DEFAULT_MAX_PACKET, "{ctx}");
                for (i, ((frame, msgs), (len, n, lines))) in
                    got.packets.iter().zip(&want.packets).enumerate()
                {
                    assert_eq!((frame.len(), msgs.len()), (*len, *n), "{ctx} pkt#{i}");
                    let rendered: Vec<String> = msgs.iter().map(render).collect();
                    assert_eq!(&rendered, lines, "{ctx} pkt#{i}");
                    total_msgs += msgs.len();
                }
            }
        }
        // No decoded connection without a summary entry.
        assert_eq!(
            cap.conns.len(),
            summ.len(),
            "{}: connection count",
            cap.name
        );
    }
    assert_eq!(total_msgs, summary_msgs);
    assert!(total_msgs > 2000, "only {total_msgs} messages checked");
}

#[test]
fn every_client_packet_re_encodes_byte_for_byte() {
    for name in CAPTURES {
        let cap = load(name);
        for (conn, [c2db, db2c]) in &cap.conns {
            for (frame, msgs) in c2db.packets.iter().chain(&db2c.packets) {
                let mut out = BytesMut::new();
                codec::encode_packet(msgs, &mut out).unwrap();
                assert_eq!(&out[..], &frame[..], "{name} {conn:?}");
            }
        }
    }
}

/// Our builders (what `MoosClient` sends) reproduce the client bytes wherever the capture fixes
/// every input: name, key, value, id and time.
#[test]
fn builders_reproduce_captured_client_messages() {
    let mut checked = [0usize; 6];
    for name in CAPTURES {
        let cap = load(name);
        for [c2db, _] in cap.conns.values() {
            for (frame, msgs) in &c2db.packets {
                // The handshake packet as a whole.
                if let [m] = msgs.as_slice()
                    && m.msg_type == MsgType::Data
                {
                    let hs = handshake_message(std::str::from_utf8(&m.string_val).unwrap(), m.time);
                    let mut out = BytesMut::new();
                    codec::encode_packet([&hs], &mut out).unwrap();
                    assert_eq!(&out[..], &frame[..], "{name} handshake");
                    checked[0] += 1;
                }
                for m in msgs {
                    let mut want = BytesMut::new();
                    m.encode(&mut want).unwrap();
                    let src = m.source.to_str().unwrap_or("");
                    let key = m.key.to_str().unwrap_or("");
                    if !m.source_aux.is_empty() || !m.community.is_empty() {
                        continue; // pHelmIvP's source_aux annotations: not something we send
                    }
                    let (slot, f) = match (m.msg_type, m.data_type) {
                        (MsgType::Timing, _) => {
                            let mut out = BytesMut::new();
                            timing_message(m.time).encode(&mut out).unwrap();
                            assert_eq!(out, want, "{name} TIMING");
                            checked[1] += 1;
                            continue;
                        }
                        (MsgType::Register, _) => {
                            (2, Fields::register(src, key, m.double_val, m.time))
                        }
                        (MsgType::Unregister, _) => (3, Fields::unregister(src, key, m.time)),
                        (MsgType::Notify, DataType::Double) => {
                            (4, Fields::notify_double(src, key, m.double_val, m.time))
                        }
                        (MsgType::Notify, DataType::String) => {
                            (5, Fields::notify_string(src, key, &m.string_val, m.time))
                        }
                        (MsgType::Notify, DataType::Binary) => {
                            (5, Fields::notify_binary(src, key, &m.string_val, m.time))
                        }
                        _ => continue,
                    };
                    let mut out = BytesMut::new();
                    encode_fields(&mut out, &f.with_id(m.id)).unwrap();
                    assert_eq!(out, want, "{name} {:?} {key}", m.msg_type);
                    checked[slot] += 1;
                }
            }
        }
    }
    // Handshakes, TIMING, REGISTER, UNREGISTER, NOTIFY double, NOTIFY string/binary all seen.
    assert!(checked.iter().all(|&c| c > 0), "{checked:?}");
}

fn find<'a>(cap: &'a Capture, client: &str) -> &'a [Decoded; 2] {
    cap.conns
        .values()
        .find(|[c2db, _]| {
            c2db.packets.first().is_some_and(|(_, m)| {
                m[0].msg_type == MsgType::Data && &m[0].string_val[..] == client.as_bytes()
            })
        })
        .unwrap_or_else(|| panic!("{}: no client {client}", cap.name))
}

fn mail(d: &Decoded) -> Vec<&MoosMessage> {
    d.packets
        .iter()
        .flat_map(|(_, m)| m)
        .filter(|m| m.msg_type == MsgType::Notify)
        .collect()
}

/// The values protocol.md quotes from the captures.
#[test]
fn facts_from_the_protocol_notes() {
    let cap01 = load("cap01_poke_mail");
    let [c, db] = find(&cap01, "capsub");
    let hs = &c.packets[0];
    assert_eq!(hs.0.len(), 81);
    assert_eq!(hs.1[0].key, "asynchronous");
    assert_eq!(format!("{:.6}", hs.1[0].time), "1795312643.188099");
    let w = parse_handshake_reply(&db.packets[0].1).unwrap();
    assert_eq!(db.packets[0].0.len(), 89);
    assert_eq!(w.community, "cap");
    assert_eq!(w.db_host.as_deref(), Some("vm"));
    assert!(w.asynchronous);
    assert!((w.skew - 0.10015).abs() < 1e-5, "{}", w.skew);
    // TIMING echo: same time, double_val = DB time, double_val2 = 0.
    let echo = &db.packets[1].1[0];
    assert_eq!(echo.msg_type, MsgType::Timing);
    assert_eq!(echo.time, c.packets[1].1[0].time);
    assert!(echo.double_val > echo.time && echo.double_val - echo.time < 0.01);
    assert_eq!(echo.double_val2, 0.0);
    assert_eq!(c.packets[1].1[0].double_val2, -1.0);
    // The two-message mail packet of 156 bytes: CAP_DBL = 3.5 (id 9) and CAP_STR = "hello".
    let (frame, two) = db
        .packets
        .iter()
        .find(|(_, m)| m.len() == 2 && m[0].key == "CAP_DBL")
        .unwrap();
    assert_eq!(frame.len(), 156);
    assert_eq!(
        (two[0].id, two[0].as_double(), two[0].source.to_str()),
        (9, Some(3.5), Some("uPokeDB"))
    );
    assert_eq!(two[0].community, "cap");
    assert_eq!((two[1].id, two[1].as_str()), (10, Some("hello")));
    // Binary mail: 16 zero bytes from capbin, data type B, 95-byte packet.
    let (frame, bin) = db
        .packets
        .iter()
        .find(|(_, m)| m[0].key == "CAP_BIN")
        .unwrap();
    assert_eq!(frame.len(), 95);
    assert_eq!(bin[0].data_type, DataType::Binary);
    assert_eq!(bin[0].as_binary(), Some(&[0u8; 16][..]));
    assert_eq!(bin[0].source, "capbin");
    // Wildcard: CAPW_ONE = 42 reached capsub.
    assert!(
        mail(db)
            .iter()
            .any(|m| m.key == "CAPW_ONE" && m.as_double() == Some(42.0))
    );

    let cap02 = load("cap02_rawclient");
    let [_, db] = find(&cap02, "rawprobe");
    let got = mail(db);
    assert!(
        got.iter()
            .any(|m| m.key == "RAW_DBL" && m.as_double() == Some(3.25))
    );
    assert!(
        got.iter()
            .any(|m| m.key == "RAW_STR" && m.as_str() == Some("hello, moos"))
    );
    assert!(
        got.iter()
            .any(|m| m.key == "RAW_BIN" && m.as_binary() == Some(&[0, 1, 2, 3, 4, 5, 6, 7][..]))
    );
    // Duplicate name → POISON with the DB's text; wrong banner → nothing sent back.
    let poisoned: Vec<_> = cap02
        .conns
        .values()
        .filter_map(|[_, db]| db.packets.first())
        .filter_map(|(_, m)| match parse_handshake_reply(m) {
            Err(MoosError::Poisoned(t)) => Some(t),
            _ => None,
        })
        .collect();
    assert_eq!(
        poisoned,
        vec![r#"A client of this name ("rawsilent") already exists"#.to_owned()]
    );
    let bad: Vec<_> = cap02
        .conns
        .values()
        .filter(|[c, _]| c.banner.as_ref().is_some_and(|b| !banner_ok(b)))
        .collect();
    assert_eq!(bad.len(), 1);
    assert!(bad[0][1].packets.is_empty());
    // Interval 1.0: FAST_VAR only 16, 27, 38, 48, 59 (the first via REGISTER, id -1).
    let [_, db] = find(&cap02, "rawperiod");
    let fast: Vec<f64> = mail(db)
        .iter()
        .filter(|m| m.key == "FAST_VAR")
        .filter_map(|m| m.as_double())
        .collect();
    assert_eq!(fast, vec![16.0, 27.0, 38.0, 48.0, 59.0]);
    let first = mail(db).into_iter().find(|m| m.key == "FAST_VAR").unwrap();
    assert_eq!(first.id, -1);

    // Held mail: only echoes until the client's NOTIFY, then 4 DB_TIME at once.
    let cap04 = load("cap04_heldmail");
    let [_, db] = find(&cap04, "rawheld");
    let first_mail = db
        .packets
        .iter()
        .position(|(_, m)| m.iter().any(|x| x.key == "DB_TIME"))
        .unwrap();
    assert!(
        db.packets[2..first_mail]
            .iter()
            .all(|(_, m)| m.len() == 1 && m[0].msg_type == MsgType::Timing)
    );
    let held: Vec<_> = db.packets[first_mail..]
        .iter()
        .flat_map(|(_, m)| m)
        .filter(|m| m.key == "DB_TIME")
        .collect();
    assert_eq!(held.len(), 4);

    // Type lock: the subscriber got 1.5 and 2.5 on TL_VAR, never the string; TL_NOSRC nothing.
    let cap05 = load("cap05_typelock");
    let [_, db] = find(&cap05, "rawtype");
    let tl: Vec<_> = mail(db)
        .iter()
        .filter(|m| m.key == "TL_VAR")
        .map(|m| m.value())
        .collect();
    assert_eq!(
        tl,
        vec![
            frontseat_moos::MoosValue::Double(1.5),
            frontseat_moos::MoosValue::Double(2.5)
        ]
    );
    assert!(mail(db).iter().all(|m| m.key != "TL_NOSRC"));
}

/// Replay the type-lock client of cap05 (handshake, TIMING + REGISTERs including one with an
/// empty source, D 1.5, S on the same variable, D 2.5) into our broker: it must answer with the
/// same packets MOOSDB did — except the DB's own clock readings (WELCOME time/skew, echo value).
#[tokio::test]
async fn broker_answers_the_cap05_replay_like_moosdb() {
    use tokio::io::{AsyncReadExt, AsyncWriteExt};
    let cap05 = load("cap05_typelock");
    let [c, db] = find(&cap05, "rawtype");
    let b = frontseat_moos::Broker::bind_with(
        "127.0.0.1:0",
        frontseat_moos::BrokerConfig {
            community: "cap".into(),
            hostname: "vm".into(),
            ..Default::default()
        },
    )
    .await
    .unwrap();
    let mut s = tokio::net::TcpStream::connect(b.local_addr())
        .await
        .unwrap();
    s.write_all(c.banner.as_ref().unwrap()).await.unwrap();
    for (frame, _) in &c.packets {
        s.write_all(frame).await.unwrap();
    }
    let dec = PacketDecoder::default();
    let mut buf = BytesMut::new();
    let mut got = vec![];
    while got.len() < db.packets.len() {
        match dec.decode(&mut buf).unwrap() {
            Some(m) => got.push(m),
            None => {
                let n =
                    tokio::time::timeout(std::time::Duration::from_secs(5), s.read_buf(&mut buf))
                        .await
                        .expect("broker sent fewer packets than MOOSDB")
                        .unwrap();
                assert!(n > 0, "broker closed early");
            }
        }
    }
    // Nothing more than MOOSDB sent.
    let extra =
        tokio::time::timeout(std::time::Duration::from_millis(200), s.read_buf(&mut buf)).await;
    assert!(
        extra.is_err() && buf.is_empty(),
        "broker sent more than MOOSDB"
    );
    for (i, (mine, (_, theirs))) in got.iter().zip(&db.packets).enumerate() {
        let clock_free = |m: &MoosMessage| {
            let mut m = m.clone();
            match m.msg_type {
                MsgType::Welcome => (m.time, m.double_val) = (0.0, 0.0),
                MsgType::Timing => m.double_val = 0.0,
                _ => {}
            }
            render(&m)
        };
        let a: Vec<String> = mine.iter().map(clock_free).collect();
        let b: Vec<String> = theirs.iter().map(clock_free).collect();
        assert_eq!(a, b, "DB->C packet #{i}");
    }
    assert_eq!(b.counters().type_rejected, 1);
    b.shutdown().await;
}
