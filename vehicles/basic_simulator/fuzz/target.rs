// The fuzz target of one vehicle's codec, kept beside the vehicle (corpus in `corpus/`); compiled
// as a module of `fuzz/src/lib.rs` (the cargo-fuzz crate and the root's `tests/fuzz_corpus.rs`),
// which gives it `Count`, the signal sink that checks what the driver publishes.

use std::time::Duration;

use frontseat_basic_simulator::{BasicSimulatorDriver, Settings, parse_nav};

use frontseat_actors::driver::{Driver, DriverIoEvent};
use frontseat_config::InterfaceConfig;

use super::Count;

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
