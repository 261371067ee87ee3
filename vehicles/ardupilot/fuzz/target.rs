// The fuzz target of one vehicle's codec, kept beside the vehicle (corpus in `corpus/`); compiled
// as a module of `fuzz/src/lib.rs` (the cargo-fuzz crate and the root's `tests/fuzz_corpus.rs`),
// which gives it `Count`, the signal sink that checks what the driver publishes.

use std::time::Duration;

use frontseat_actors::driver::{Driver, DriverIoEvent};
use frontseat_config::InterfaceConfig;

use super::Count;

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

    for f in &frames_whole {
        assert!(f.len() <= MAX_FRAME);
        if let Ok((h, msg)) = decode(f) {
            let once = encode(h.system_id, h.component_id, h.sequence, &msg);
            let (_, again) = decode(&once).expect("a re-encoded message decodes");
            let twice = encode(h.system_id, h.component_id, h.sequence, &again);
            assert_eq!(once, twice, "message does not round-trip");
        }
    }
    // The Rover driver, and the Sub driver with every Sub path on (ALT_HOLD commands, the
    // pilot-input keepalive).
    let rover = InterfaceConfig::default();
    let mut sub = InterfaceConfig::default();
    sub.driver.ardupilot.vehicle = frontseat_config::ArdupilotVehicle::Sub;
    sub.driver.ardupilot.alt_hold_accepts_commands = true;
    sub.driver.ardupilot.pilot_input_keepalive = true;
    for cfg in [rover, sub] {
        let mut driver = ArdupilotDriver::new(ApSettings::from_config(&cfg));
        let mut sink = Count::default();
        let (w, _rx) = LineWriter::for_test();
        driver.handle_io(DriverIoEvent::Connected(w), Duration::ZERO, &mut sink);
        let mut now = Duration::ZERO;
        for f in &frames_whole {
            now += Duration::from_millis(50);
            driver.handle_io(DriverIoEvent::Frame(f.clone()), now, &mut sink);
            driver.do_loop(now, &mut sink);
        }
        driver.do_loop(now + Duration::from_secs(60), &mut sink);
        assert_eq!(sink.raw_in, frames_whole.len());
        assert_eq!(sink.responses, 0);
    }
}
