// The fuzz target of one vehicle's codec, kept beside the vehicle (corpus in `corpus/`); compiled
// as a module of `fuzz/src/lib.rs` (the cargo-fuzz crate and the root's `tests/fuzz_corpus.rs`),
// which gives it `Count`, the signal sink that checks what the driver publishes.

use std::time::Duration;

use frontseat_actors::driver::{Driver, DriverIoEvent};
use frontseat_config::InterfaceConfig;

use super::Count;

/// The Bluefin Huxley sentence codec and driver: every line through `Sentence::parse` and the
/// typed decoders of both directions, and through the Bluefin driver (connected to a channel,
/// with its loop ticking). What parses formats back to a line that parses to the same thing;
/// every line reaches raw_in once; no command response without a command; fixes are finite.
pub fn bluefin_codec(data: &[u8]) {
    use frontseat_bluefin::codec::{FromHuxley, FromPayload, Sentence};
    use frontseat_bluefin::{BluefinDriver, Settings as BfSettings};

    let mut cfg = InterfaceConfig::default();
    cfg.driver.name = "bluefin".into();
    let mut driver = BluefinDriver::with_wall_clock(
        BfSettings::from_config(&cfg),
        Box::new(|now: Duration| 1_700_000_000.0 + now.as_secs_f64()),
    );
    let (w, mut rx) = frontseat_actors::link::LineWriter::for_test();
    let mut sink = Count::default();
    let mut now = Duration::ZERO;
    driver.handle_io(DriverIoEvent::Connected(w), now, &mut sink);
    let mut lines = 0;
    for raw in data.split(|b| *b == b'\n') {
        now += Duration::from_millis(100);
        let raw = raw.strip_suffix(b"\r").unwrap_or(raw);
        let Ok(line) = std::str::from_utf8(raw) else {
            driver.handle_io(
                DriverIoEvent::BadInput("invalid UTF-8".into()),
                now,
                &mut sink,
            );
            continue;
        };
        if let Ok(s) = Sentence::parse(line) {
            let again = Sentence::parse(&s.format());
            assert_eq!(again.as_ref(), Ok(&s), "sentence {s:?} does not round trip");
            if let Ok(m) = FromHuxley::from_sentence(&s) {
                let back = FromHuxley::from_sentence(&m.to_sentence());
                assert!(
                    back.is_ok(),
                    "{m:?} formats to a sentence that does not decode: {back:?}"
                );
            }
            if let Ok(m) = FromPayload::from_sentence(&s) {
                let back = FromPayload::from_sentence(&m.to_sentence());
                assert!(
                    back.is_ok(),
                    "{m:?} formats to a sentence that does not decode: {back:?}"
                );
            }
        }
        lines += 1;
        driver.handle_io(DriverIoEvent::Line(line.to_string()), now, &mut sink);
        driver.do_loop(now, &mut sink);
        while rx.try_recv().is_ok() {}
    }
    assert_eq!(sink.raw_in, lines, "every line once on raw_in");
    assert_eq!(sink.responses, 0, "no command response without a command");
}
