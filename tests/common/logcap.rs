//! The log of a test binary captured in memory: a global tracing subscriber (INFO and up, no
//! colours) writing into a shared buffer, for tests that check what a person would read in the
//! journal. Install it once per test binary, in a binary with one such test, so nothing else writes
//! there.

use std::io::Write;
use std::sync::{Arc, Mutex};

/// The captured log, shared with the subscriber's writer.
#[derive(Clone, Default)]
pub struct Captured(Arc<Mutex<Vec<u8>>>);

impl Write for Captured {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .extend_from_slice(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Captured {
    /// Installs the global subscriber writing here.
    pub fn install() -> Self {
        let captured = Self::default();
        let writer = captured.clone();
        tracing_subscriber::fmt()
            .with_ansi(false)
            .with_max_level(tracing::Level::INFO)
            .with_writer(move || writer.clone())
            .init();
        captured
    }

    pub fn text(&self) -> String {
        String::from_utf8_lossy(&self.0.lock().unwrap_or_else(|p| p.into_inner())).to_string()
    }
}

/// The sum of N over every "…and N more `what` in the last" in `text` (ratelog's summaries).
pub fn summarised(text: &str, what: &str) -> u64 {
    let needle = format!("more {what} in the last");
    text.lines()
        .filter_map(|l| l.split("…and ").nth(1))
        .filter(|rest| rest.contains(&needle))
        .filter_map(|rest| rest.split_whitespace().next()?.parse::<u64>().ok())
        .sum()
}

/// WARN lines that contain `what`.
pub fn warned(text: &str, what: &str) -> u64 {
    text.lines()
        .filter(|l| l.contains(" WARN ") && l.contains(what))
        .count() as u64
}
