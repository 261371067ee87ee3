// The fuzz target of the DUNE vehicle's IMC codec, kept beside the vehicle (corpus in `corpus/`);
// compiled as a module of `fuzz/src/lib.rs` (the cargo-fuzz crate and the root's
// `tests/fuzz_corpus.rs`), which gives it `Count`, the signal sink that checks what the driver
// publishes.

use std::time::Duration;

use frontseat_actors::driver::{Driver, DriverIoEvent};
use frontseat_config::InterfaceConfig;

use super::Count;

/// IMC from a DUNE vehicle: the `frontseat_dune` deframer over a byte stream (whole and byte by
/// byte must cut the same packets, holding at most MAX_FRAME bytes), decode of every packet (a
/// decoded message re-encodes to a packet that decodes and re-encodes to the same bytes, in both
/// byte orders), the DUNE driver's packet handling (raw_in once per packet, every fix finite, no
/// command response unasked, nothing but the end of a plan of ours written outside COMMAND), and
/// the emulator's input side.
pub fn imc_packet(data: &[u8]) {
    use frontseat_actors::link::LineWriter;
    use frontseat_dune::emulator::{DuneOptions, DuneSession};
    use frontseat_dune::imc::{ByteOrder, Deframer, MAX_FRAME, decode, encode};
    use frontseat_dune::{DuneDriver, Settings};
    use frontseat_sim::emulator::Session;

    let mut whole = Vec::new();
    let mut d = Deframer::new();
    d.feed(data, &mut |r| whole.push(r));
    assert!(d.buffered() <= MAX_FRAME);
    let mut split = Vec::new();
    let mut d = Deframer::new();
    for b in data {
        d.feed(std::slice::from_ref(b), &mut |r| split.push(r));
        assert!(d.buffered() <= MAX_FRAME);
    }
    let frames = |v: &Vec<Result<Vec<u8>, _>>| -> Vec<Vec<u8>> {
        v.iter().filter_map(|r| r.as_ref().ok().cloned()).collect()
    };
    let frames_whole = frames(&whole);
    assert_eq!(
        frames_whole,
        frames(&split),
        "packets depend on how reads are cut"
    );
    // Whole input as one packet too (decode is also called on frames nobody cut).
    let _ = decode(data);

    let mut driver = DuneDriver::new(Settings::from_config(&InterfaceConfig::default()));
    let mut sink = Count::default();
    let (w, mut rx) = LineWriter::for_test();
    driver.handle_io(DriverIoEvent::Connected(w), Duration::ZERO, &mut sink);
    let mut now = Duration::ZERO;
    for f in &frames_whole {
        assert!(f.len() <= MAX_FRAME);
        if let Ok((h, msg)) = decode(f) {
            for order in [ByteOrder::Little, ByteOrder::Big] {
                let once = encode(&h, &msg, order).expect("a decoded message encodes");
                let (h2, again) = decode(&once).expect("a re-encoded message decodes");
                let twice = encode(&h2, &again, order).expect("encodes again");
                assert_eq!(once, twice, "message does not round-trip");
            }
        }
        now += Duration::from_millis(50);
        driver.handle_io(DriverIoEvent::Frame(f.clone()), now, &mut sink);
        driver.do_loop(now, &mut sink);
    }
    driver.do_loop(now + Duration::from_secs(60), &mut sink);
    assert_eq!(sink.raw_in, frames_whole.len());
    assert_eq!(sink.responses, 0);
    // Outside COMMAND the driver may only end a plan of ours it finds running (MANDONE, STOP).
    while let Ok(b) = rx.try_recv() {
        use frontseat_dune::imc::{Message, consts};
        let (_, m) = decode(&b).expect("the driver writes whole packets");
        let ending = match &m {
            Message::Reference(r) => r.flags == consts::reference::MANDONE,
            Message::PlanControl(p) => p.op == consts::plan_control::STOP,
            _ => false,
        };
        assert!(ending, "the driver wrote {m:?} outside COMMAND");
    }

    let mut emu = DuneSession::new(DuneOptions::default());
    let mut out = Vec::new();
    emu.on_bytes(data, &mut out);
    emu.step(0.1, &mut out);
}
