//! Logs stay quiet under attack: a frontseat (a TCP listener in this test, on loopback) that
//! sends 100 garbage NAV lines to the basic simulator driver gets a handful of WARNs and one
//! summary for the rest, not 100 WARNs. The interface runs in this process; the log is captured
//! by a global tracing subscriber writing into memory (one test in this binary, so nothing else
//! writes there).

mod common;

use std::time::Duration;

use common::logcap::{Captured, accept_start, played_frontseat, summarised as summarised_as};
use frontseat_actors::bus::Bus;
use frontseat_actors::interface::InterfaceService;
use tokio::io::AsyncWriteExt;

const GARBAGE: usize = 100;

/// The N of every "…and N more bad lines in the last" in `text`.
fn summarised(text: &str) -> u64 {
    summarised_as(text, "bad lines")
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_hundred_garbage_lines_give_a_few_warnings_and_a_summary() {
    let captured = Captured::install();

    // The frontseat: accepts the driver, then sends garbage.
    let (listener, cfg) = played_frontseat("noisy-auv").await;
    let bus = Bus::new();
    let service = InterfaceService::start(&cfg, &bus, frontseat_drivers::BUILT_IN)
        .await
        .unwrap();
    let (_rd, mut wr) = accept_start(&listener).await;
    let mut burst = String::new();
    for i in 0..GARBAGE {
        burst.push_str(&format!("NAV,LAT:{i},LON:garbage\r\n"));
    }
    wr.write_all(burst.as_bytes()).await.unwrap();

    // Every line is counted; the summary comes once the window ends, with no further input.
    let deadline = tokio::time::Instant::now() + Duration::from_secs(30);
    let text = loop {
        let text = captured.text();
        let warned = text
            .lines()
            .filter(|l| l.contains(" WARN ") && l.contains("bad NAV line from the frontseat"))
            .count() as u64;
        if warned + summarised(&text) >= GARBAGE as u64 {
            break text;
        }
        assert!(
            tokio::time::Instant::now() < deadline,
            "no summary of the suppressed bad lines within 30 s:\n{text}"
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    };
    let _ = service.shutdown(Duration::from_secs(3)).await;

    let warns: Vec<&str> = text.lines().filter(|l| l.contains(" WARN ")).collect();
    let bad: Vec<&&str> = warns
        .iter()
        .filter(|l| l.contains("bad NAV line from the frontseat"))
        .collect();
    println!("{}", warns.join("\n"));
    assert!(
        (1..=10).contains(&bad.len()),
        "{} WARNs for {GARBAGE} bad lines:\n{text}",
        bad.len()
    );
    assert_eq!(
        bad.len() as u64 + summarised(&text),
        GARBAGE as u64,
        "every bad line is either logged or summarised:\n{text}"
    );
    assert!(
        warns.len() <= 20,
        "{} WARN lines in all: the log is not quiet\n{text}",
        warns.len()
    );
    assert_eq!(
        frontseat_telemetry::metrics::bad_lines(),
        GARBAGE as u64,
        "every bad line counted for the metrics"
    );
}
