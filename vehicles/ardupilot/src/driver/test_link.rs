//! What the driver's Rover and Sub tests share: a frame by name from a pymavlink fixture file, a
//! driver connected to a test link, a frame fed at a time, and the frames the driver wrote.

use std::time::Duration;

use tokio::sync::mpsc::Receiver;

use super::{ArdupilotDriver, Settings};
use crate::codec::{self, MavMessage};
use frontseat_actors::driver::{Driver, DriverIoEvent, RecordingSink};
use frontseat_actors::link::LineWriter;
use frontseat_config::InterfaceConfig;

pub(super) type Sink = RecordingSink;

/// The frame `name` of a fixture file (`name hex` lines).
pub(super) fn fixture_frame(fixture: &str, name: &str) -> Vec<u8> {
    let hex = fixture
        .lines()
        .find_map(|l| l.strip_prefix(name).and_then(|r| r.strip_prefix(' ')))
        .unwrap_or_else(|| panic!("no fixture {name}"));
    (0..hex.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&hex[i..i + 2], 16).unwrap())
        .collect()
}

/// A driver on `cfg`, its link just connected.
pub(super) fn connected(cfg: &InterfaceConfig) -> (ArdupilotDriver, Receiver<Vec<u8>>, Sink) {
    let mut d = ArdupilotDriver::new(Settings::from_config(cfg));
    let mut sink = Sink::default();
    let (w, rx) = LineWriter::for_test();
    d.handle_io(DriverIoEvent::Connected(w), Duration::ZERO, &mut sink);
    (d, rx, sink)
}

pub(super) fn feed_frame(d: &mut ArdupilotDriver, sink: &mut Sink, frame: Vec<u8>, t: f64) {
    d.handle_io(
        DriverIoEvent::Frame(frame),
        Duration::from_secs_f64(t),
        sink,
    );
}

/// Everything the driver wrote, with the sender's system id.
pub(super) fn written(rx: &mut Receiver<Vec<u8>>) -> Vec<(u8, MavMessage)> {
    let mut v = Vec::new();
    while let Ok(b) = rx.try_recv() {
        let mut d = codec::Deframer::new();
        d.feed(&b, &mut |r| {
            let (h, m) = codec::decode(&r.unwrap()).unwrap();
            v.push((h.system_id, m));
        });
    }
    v
}
