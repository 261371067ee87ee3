//! A short soak in CI (`frontseat chaos --soak` for the long ones): faults for 20 s wall at
//! warp 100 (over half an hour simulated), resources sampled every 2 s; every invariant holds
//! and RSS, open fds, threads and tasks do not drift.

use std::time::Duration;

use frontseat_chaos::{self, ChaosOptions};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_short_soak_keeps_every_invariant_and_flat_resources() {
    let cfg = frontseat_chaos::default_config().unwrap();
    let opts = ChaosOptions {
        seed: 31,
        soak: Some(Duration::from_secs(20)),
        sample_every: Duration::from_secs(2),
        warp: Some(100.0),
        ..Default::default()
    };
    let report = tokio::time::timeout(
        Duration::from_secs(90),
        frontseat_chaos::run(cfg, opts, |p| eprintln!("soak: {p}")),
    )
    .await
    .expect("the soak ends by itself")
    .unwrap();
    println!("{}", report.render());
    assert!(report.passed(), "{}", report.render());
    // A start sample, one every 2 s, and an end sample.
    assert!(report.samples.len() >= 8, "{:?}", report.samples);
    assert!(
        report
            .samples
            .iter()
            .all(|s| s.rss_kib.is_some() && s.fds.is_some())
    );
    assert!(
        report
            .invariants
            .iter()
            .any(|i| i.name.starts_with("soak:") && i.ok)
    );
    assert!(report.faults > 20, "only {} faults in 20 s", report.faults);
}
