// The fuzz target of one vehicle's codec, kept beside the vehicle (corpus in `corpus/`); compiled
// as a module of `fuzz/src/lib.rs` (the cargo-fuzz crate and the root's `tests/fuzz_corpus.rs`),
// which gives it `Count`, the signal sink that checks what the driver publishes.

use std::time::Duration;

use frontseat_actors::driver::{Driver, DriverIoEvent};
use frontseat_config::InterfaceConfig;

use super::Count;

/// Iver Remote Helm sentences: `Sentence::parse` on every line, and every line through the
/// Iver3 driver. A parsed sentence formats to a line that parses to the same kind; the driver
/// publishes raw_in once per line, never a non-finite fix, and no command response unasked.
pub fn iver_sentence(data: &[u8]) {
    use frontseat_iver3::codec::Sentence;
    use frontseat_iver3::{Iver3Driver, Settings as IverSettings};

    let mut cfg = InterfaceConfig::default();
    cfg.driver.iver3.serial_port = "/dev/null".into();
    cfg.driver.iver3.remote_helm_version_major = Some(5);
    let mut driver = Iver3Driver::new(IverSettings::from_config(&cfg));
    let mut sink = Count::default();
    let mut lines = 0;
    let text = String::from_utf8_lossy(data);
    for line in text.split('\n') {
        if let Ok(s) = Sentence::parse(line)
            // Absurd numbers (1e300 degrees) can format past the length bound; those lines are
            // rejected as too long, which is the bound doing its job.
            && s.to_line().len() <= frontseat_iver3::codec::MAX_SENTENCE
        {
            let again = Sentence::parse(&s.to_line());
            assert!(
                again
                    .as_ref()
                    .is_ok_and(|a| std::mem::discriminant(a) == std::mem::discriminant(&s)),
                "{s:?} formats to a line that parses as {again:?}"
            );
        }
        lines += 1;
        driver.handle_io(
            DriverIoEvent::Line(line.trim_end_matches('\r').to_string()),
            Duration::ZERO,
            &mut sink,
        );
        driver.do_loop(Duration::from_millis(100 * lines as u64), &mut sink);
    }
    assert_eq!(sink.raw_in, lines);
    assert_eq!(sink.responses, 0);
}
