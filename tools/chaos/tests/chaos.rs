//! The chaos harness as a CI test: a short seeded run (≈200 faults at high warp) of the real
//! simulator, interface, helm and MOOS bridge; every invariant must hold. The report is printed
//! (`cargo test --test chaos -- --nocapture`) so a failure shows its table.

use std::time::Duration;

use frontseat_chaos::{self, ChaosHarnessError, ChaosOptions, FaultKind};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn seeded_chaos_run_keeps_every_invariant() {
    let cfg = frontseat_chaos::default_config().unwrap();
    let opts = ChaosOptions {
        seed: 9,
        faults: 200,
        warp: Some(100.0),
        recovery_bound: Duration::from_secs(5),
        ..Default::default()
    };
    let run = tokio::time::timeout(
        Duration::from_secs(120),
        frontseat_chaos::run(cfg, opts, |p| eprintln!("chaos: {p}")),
    )
    .await
    .expect("the chaos run ends by itself");
    let report = run.unwrap();
    println!("{}", report.render());
    assert!(report.passed(), "{}", report.render());
    // The run really injected what it claims: driver crashes and every other kind.
    let injected: u32 = report.by_kind.values().map(|k| k.injected).sum();
    assert_eq!(injected, 200);
    for k in [
        FaultKind::DriverPanic,
        FaultKind::DriverKill,
        FaultKind::SimRestart,
        FaultKind::StalledSubscriber,
        FaultKind::MoosRestart,
    ] {
        assert!(
            report.by_kind.get(&k).is_some_and(|s| s.injected > 0),
            "{k:?}"
        );
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_config_without_chaos_is_refused_before_anything_starts() {
    let mut cfg = frontseat_chaos::default_config().unwrap();
    cfg.chaos.enabled = false;
    let r = frontseat_chaos::run(cfg, ChaosOptions::default(), |_| {}).await;
    let e = r.expect_err("refused");
    assert!(matches!(e, ChaosHarnessError::Refused(_)), "{e}");
    assert!(e.to_string().contains("enabled = true"), "{e}");
}
