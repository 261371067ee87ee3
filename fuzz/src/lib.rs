//! The fuzz target bodies, one function per target, shared by the cargo-fuzz binaries in
//! `fuzz_targets/` and by the root's `tests/fuzz_corpus.rs` (which includes this file), so the
//! checked-in corpus replays exactly what the fuzzer ran. A vehicle's target and corpus live in
//! its own folder (`vehicles/<vehicle>/fuzz/`) and are compiled in here as modules. Each body asserts properties beyond
//! "does not panic": what decodes re-encodes, what is accepted is valid.
//!
//! No type of the `bytes` crate is named here (the root package does not depend on it): the
//! MOOS buffers are inferred from the codec's signatures.
#![forbid(unsafe_code)]

use frontseat_actors::driver::SignalSink;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CommandResponse, InterfaceData, Raw,
};
use frontseat_config::{InterfaceConfig, ServiceConfig};
use frontseat_sim::codec::{self, Inbound, Outbound};

// Each vehicle's target lives with the vehicle (`vehicles/<vehicle>/fuzz/`, beside its corpus).
#[path = "../../vehicles/ardupilot/fuzz/target.rs"]
mod ardupilot;
#[path = "../../vehicles/basic_simulator/fuzz/target.rs"]
mod basic_simulator;
#[path = "../../vehicles/bluefin/fuzz/target.rs"]
mod bluefin;
#[path = "../../vehicles/dune/fuzz/target.rs"]
mod dune;
#[path = "../../vehicles/iver3/fuzz/target.rs"]
mod iver3;
#[path = "../../vehicles/waveglider_sv2/fuzz/target.rs"]
mod waveglider_sv2;

pub use ardupilot::mavlink_frame;
pub use basic_simulator::driver_line;
pub use bluefin::bluefin_codec;
pub use dune::imc_packet;
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
