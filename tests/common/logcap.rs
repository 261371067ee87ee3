//! For tests that check what a person would read in the journal: the log of a test binary
//! captured in memory (a global tracing subscriber, INFO and up, no colours, writing into a shared
//! buffer: install it once, in a binary with one such test, so nothing else writes there), and a
//! frontseat the test plays itself over loopback to feed the interface bad input.

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

/// A frontseat played by the test: a loopback listener, and an interface config named `name`
/// (warp 10, so a 10 s limiter window passes in one wall second; no periodic status) whose
/// basic-simulator driver connects to it.
pub async fn played_frontseat(
    name: &str,
) -> (tokio::net::TcpListener, frontseat_config::InterfaceConfig) {
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let port = listener.local_addr().unwrap().port();
    let mut cfg = frontseat_config::InterfaceConfig {
        name: name.into(),
        sim_warp_factor: 10.0,
        status_period: 0.0,
        ..Default::default()
    };
    cfg.driver.basic_simulator.tcp_port = port;
    (listener, cfg)
}

/// Accepts the driver's connection and reads its START line (20 s for each).
pub async fn accept_start(
    listener: &tokio::net::TcpListener,
) -> (
    tokio::io::BufReader<tokio::net::tcp::OwnedReadHalf>,
    tokio::net::tcp::OwnedWriteHalf,
) {
    use tokio::io::AsyncBufReadExt;
    let wait = std::time::Duration::from_secs(20);
    let (sock, _) = tokio::time::timeout(wait, listener.accept())
        .await
        .expect("the driver connects within 20 s")
        .unwrap();
    let (rd, wr) = sock.into_split();
    let mut rd = tokio::io::BufReader::new(rd);
    let mut start = String::new();
    tokio::time::timeout(wait, rd.read_line(&mut start))
        .await
        .expect("the driver sends START")
        .unwrap();
    assert!(start.starts_with("START,"), "{start:?}");
    (rd, wr)
}
