//! The fuzz target bodies, one function per target, shared by the cargo-fuzz binaries in
//! `fuzz_targets/` and by the root's `tests/fuzz_corpus.rs` (which includes this file), so the
//! checked-in corpus replays exactly what the fuzzer ran. A vehicle's target and corpus live in
//! its own folder (`vehicles/<vehicle>/fuzz/`) and are compiled in here as modules. Each body asserts properties beyond
//! "does not panic": what decodes re-encodes, what is accepted is valid.
//!
//! No type of the `bytes` crate is named here (the root package does not depend on it): the
//! MOOS buffers are inferred from the codec's signatures.
#![forbid(unsafe_code)]

use std::time::Duration;

use frontseat_actors::driver::{Driver, DriverIoEvent, SignalSink};
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CommandResponse, InterfaceData, Raw,
};
use frontseat_basic_simulator::{BasicSimulatorDriver, Settings, parse_nav};
use frontseat_config::{InterfaceConfig, ServiceConfig};
use frontseat_sim::codec::{self, Inbound, Outbound};

// Each vehicle's target lives with the vehicle (`vehicles/<vehicle>/fuzz/`, beside its corpus).
#[path = "../../vehicles/bluefin/fuzz/target.rs"]
mod bluefin;
#[path = "../../vehicles/iver3/fuzz/target.rs"]
mod iver3;
#[path = "../../vehicles/waveglider_sv2/fuzz/target.rs"]
mod waveglider_sv2;

pub use bluefin::bluefin_codec;
pub use iver3::iver_sentence;
pub use waveglider_sv2::sv2_frame;

/// The simulator's line codec: backseat lines (START, CMD) and simulator lines (NAV, CTRL, CMD
/// results). Whatever parses must format back to a line that parses to the same thing.
pub fn sim_codec(data: &[u8]) {
    let _ = codec::reply_due_for_bytes(data);
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    for line in text.split('\n') {
        match codec::parse_inbound(line) {
            Ok(Inbound::Cmd(c)) => {
                let again = codec::parse_inbound(&codec::format_cmd(&c));
                assert!(
                    matches!(again, Ok(Inbound::Cmd(_))),
                    "CMD {c:?} formats to a line that does not parse: {again:?}"
                );
            }
            Ok(Inbound::Start(p)) => {
                let again = codec::parse_inbound(&codec::format_start(&p));
                assert!(
                    matches!(again, Ok(Inbound::Start(_))),
                    "START {p:?} formats to a line that does not parse: {again:?}"
                );
            }
            Err(e) => {
                let _ = e.to_string();
            }
        }
        if let Ok(Outbound::Nav(n)) = codec::parse_outbound(line) {
            let again = codec::parse_outbound(&codec::format_nav(&n));
            assert!(
                matches!(again, Ok(Outbound::Nav(_))),
                "NAV {n:?} formats to a line that does not parse: {again:?}"
            );
        }
    }
}

#[derive(Default)]
struct Count {
    raw_in: usize,
    data: usize,
    responses: usize,
}

impl SignalSink for Count {
    fn command_response(&mut self, _: CommandResponse) {
        self.responses += 1;
    }
    fn data_from_frontseat(&mut self, d: InterfaceData) {
        if let Some(ns) = d.node_status {
            let g = ns.global_fix;
            assert!(
                g.lat.is_finite() && g.lon.is_finite(),
                "non-finite fix {g:?}"
            );
        }
        self.data += 1;
    }
    fn raw_from_frontseat(&mut self, _: Raw) {
        self.raw_in += 1;
    }
    fn raw_to_frontseat(&mut self, _: Raw) {}
}

/// The basic simulator driver's line handling: `parse_nav` on every line, and every line fed
/// to an unconnected driver. Every line is published on raw_in exactly once; only a line whose
/// key is NAV can become data; no command response without a command.
pub fn driver_line(data: &[u8]) {
    let mut driver = BasicSimulatorDriver::new(Settings::from_config(&InterfaceConfig::default()));
    let mut sink = Count::default();
    let mut lines = 0;
    let mut navs = 0;
    let mut now = Duration::ZERO;
    for raw in data.split(|b| *b == b'\n') {
        now += Duration::from_millis(100);
        let raw = raw.strip_suffix(b"\r").unwrap_or(raw);
        match std::str::from_utf8(raw) {
            Ok(line) => {
                if let Ok(ns) = parse_nav(line) {
                    assert!(ns.pose.heading().is_finite() && ns.speed.over_ground.is_finite());
                }
                if line.split(',').next() == Some("NAV") {
                    navs += 1;
                }
                lines += 1;
                driver.handle_io(DriverIoEvent::Line(line.to_string()), now, &mut sink);
            }
            Err(_) => driver.handle_io(
                DriverIoEvent::BadInput("invalid UTF-8".into()),
                now,
                &mut sink,
            ),
        }
        driver.do_loop(now, &mut sink);
        let _ = (driver.frontseat_state(), driver.frontseat_providing_data());
    }
    assert_eq!(sink.raw_in, lines, "every line once on raw_in");
    assert!(sink.data <= navs, "data only from NAV lines");
    assert_eq!(sink.responses, 0, "no command response without a command");
}

/// The MOOS packet decoder: a stream split into packets with a size bound, whole packets, and
/// single messages. A packet that decodes re-encodes to the same bytes (the compression flag,
/// which nobody reads, aside).
pub fn moos_decode(data: &[u8]) {
    let dec = frontseat_moos::PacketDecoder::new(64 * 1024);
    let mut stream = Default::default();
    extend(&mut stream, data);
    for _ in 0..1024 {
        match dec.decode(&mut stream) {
            Ok(Some(_)) => {}
            Ok(None) | Err(_) => break,
        }
    }
    let _ = dec.bytes_needed(data);

    let frame = data.to_vec().into();
    if let Ok(msgs) = frontseat_moos::codec::decode_packet(&frame) {
        let mut out = Default::default();
        frontseat_moos::codec::encode_packet(msgs.iter(), &mut out)
            .expect("a decoded packet re-encodes");
        let out = bytes_of(&out);
        let mut want = data.to_vec();
        if want.len() > 8 {
            want[8] = 0;
        }
        assert_eq!(out, want, "decode → encode changes the packet");
    }
    if let Ok(m) = frontseat_moos::codec::decode_message(&frame) {
        let _ = (m.value(), m.as_double(), m.as_str(), m.encoded_len());
    }
}

fn extend<B: Extend<u8>>(b: &mut B, data: &[u8]) {
    b.extend(data.iter().copied());
}

fn bytes_of<B: AsRef<[u8]>>(b: &B) -> Vec<u8> {
    b.as_ref().to_vec()
}

/// The config loader: TOML text → a validated InterfaceConfig, or an error with a location.
/// What is accepted passes validation.
pub fn config(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    match frontseat_config::parse::<InterfaceConfig>(text, "fuzz.toml") {
        Ok(cfg) => assert!(cfg.validate().is_empty(), "accepted but invalid"),
        Err(e) => {
            let _ = e.to_string();
        }
    }
}

/// The Goby3 link's ZMTP length guard (`frontseat_helm_side::goby3::guard::Meter`) over the bytes
/// gobyd sends: the verdict (and the limit it names) must not depend on how the stream is cut
/// into reads — whole, byte by byte, or split at a point the input picks — and a refusal is
/// always over the limit.
pub fn zmtp_guard(data: &[u8]) {
    use frontseat_helm_side::goby3::guard::Meter;
    let limit = 1024 + u64::from(data.first().copied().unwrap_or(0)) * 64;
    let whole = Meter::new(limit).feed(data);
    let mut m = Meter::new(limit);
    let bytewise = data
        .iter()
        .try_for_each(|b| m.feed(std::slice::from_ref(b)));
    assert_eq!(whole, bytewise, "whole vs byte by byte");
    let cut = data
        .get(1)
        .map_or(0, |&b| usize::from(b) * data.len() / 256);
    let mut m = Meter::new(limit);
    let split = m.feed(&data[..cut]).and_then(|()| m.feed(&data[cut..]));
    assert_eq!(whole, split, "whole vs split at {cut}");
    if let Err(o) = whole {
        assert!(o.size > o.limit && o.limit == limit, "{o:?}");
    }
}

/// MAVLink from an ArduPilot vehicle: the `frontseat_ardupilot` deframer over a byte stream
/// (whole and byte by byte must cut the same frames), decode of every frame, and the ArduPilot
/// driver's frame handling. Every frame is at most MAX_FRAME bytes and CRC-checked; a decoded
/// message re-encodes to a frame that decodes and re-encodes to the same bytes; raw_in once per
/// frame; every published fix finite; no command response unasked.
pub fn mavlink_frame(data: &[u8]) {
    use frontseat_actors::link::LineWriter;
    use frontseat_ardupilot::codec::{Deframer, MAX_FRAME, decode, encode};
    use frontseat_ardupilot::{ArdupilotDriver, Settings as ApSettings};

    let mut whole = Vec::new();
    Deframer::new().feed(data, &mut |r| whole.push(r));
    let mut split = Vec::new();
    let mut d = Deframer::new();
    for b in data {
        d.feed(std::slice::from_ref(b), &mut |r| split.push(r));
    }
    let frames = |v: &Vec<Result<Vec<u8>, _>>| -> Vec<Vec<u8>> {
        v.iter().filter_map(|r| r.as_ref().ok().cloned()).collect()
    };
    let frames_whole = frames(&whole);
    assert_eq!(
        frames_whole,
        frames(&split),
        "frames depend on how reads are cut"
    );

    let mut driver = ArdupilotDriver::new(ApSettings::from_config(&InterfaceConfig::default()));
    let mut sink = Count::default();
    let (w, _rx) = LineWriter::for_test();
    driver.handle_io(DriverIoEvent::Connected(w), Duration::ZERO, &mut sink);
    let mut now = Duration::ZERO;
    for f in &frames_whole {
        assert!(f.len() <= MAX_FRAME);
        if let Ok((h, msg)) = decode(f) {
            let once = encode(h.system_id, h.component_id, h.sequence, &msg);
            let (_, again) = decode(&once).expect("a re-encoded message decodes");
            let twice = encode(h.system_id, h.component_id, h.sequence, &again);
            assert_eq!(once, twice, "message does not round-trip");
        }
        now += Duration::from_millis(50);
        driver.handle_io(DriverIoEvent::Frame(f.clone()), now, &mut sink);
        driver.do_loop(now, &mut sink);
    }
    driver.do_loop(now + Duration::from_secs(60), &mut sink);
    assert_eq!(sink.raw_in, frames_whole.len());
    assert_eq!(sink.responses, 0);
}
