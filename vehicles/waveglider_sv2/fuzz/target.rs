// The fuzz target of one vehicle's codec, kept beside the vehicle (corpus in `corpus/`); compiled
// as a module of `fuzz/src/lib.rs` (the cargo-fuzz crate and the root's `tests/fuzz_corpus.rs`),
// which gives it `Count`, the signal sink that checks what the driver publishes.

use std::time::Duration;

use frontseat_actors::driver::{Driver, DriverIoEvent};
use frontseat_config::InterfaceConfig;

use super::Count;

/// The SV2 frame decoder over an arbitrary byte stream, then every frame through the message
/// decoder and the Wave Glider driver. Memory stays bounded (a frame never exceeds 557 bytes);
/// a frame re-encodes to the bytes it came from; a message that decodes re-encodes to a frame
/// that decodes to the same message; the driver publishes raw_in once per frame and never
/// answers a command it was not given.
pub fn sv2_frame(data: &[u8]) {
    use frontseat_waveglider_sv2::codec::{FrameDecoder, MAX_FRAME, Packet};
    use frontseat_waveglider_sv2::{Settings as Sv2Settings, WavegliderSv2Driver};

    let mut cfg = InterfaceConfig::default();
    cfg.driver.waveglider_sv2.pm_serial_port = "/dev/null".into();
    cfg.driver.waveglider_sv2.publish_navigation = true;
    let mut driver = WavegliderSv2Driver::new(Sv2Settings::from_config(&cfg));
    let mut sink = Count::default();
    let mut frames = Vec::new();
    let mut decoder = FrameDecoder::new();
    decoder.feed(data, &mut |r| {
        if let Ok(f) = r {
            frames.push(f);
        }
    });
    for f in &frames {
        let bytes = f.unescaped().expect("a decoded frame fits the protocol");
        assert!(bytes.len() <= MAX_FRAME);
        let mut again = Vec::new();
        FrameDecoder::new().feed(&f.encode().unwrap(), &mut |r| again.push(r));
        assert_eq!(again, vec![Ok(f.clone())], "frame does not round-trip");
        if let Ok(p) = Packet::from_frame(f) {
            let back = Packet::from_frame(&p.to_frame()).expect("re-encoded message decodes");
            assert_eq!(back, p, "message does not round-trip");
        }
        driver.handle_io(DriverIoEvent::Frame(bytes), Duration::ZERO, &mut sink);
    }
    driver.do_loop(Duration::from_secs(60), &mut sink);
    assert_eq!(sink.raw_in, frames.len());
    assert_eq!(sink.responses, 0);
}
