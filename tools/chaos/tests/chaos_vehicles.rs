//! The chaos harness over every vehicle family, as a CI test: per family, the family's emulator
//! behind the chaos link, its real driver, a helm, and a short seeded schedule of the family's
//! faults (link drops, garbage and truncated frames of its protocol, a silent vehicle, a slow
//! link, driver crashes, PARK and a stalled subscriber, and for ArduPilot Rover, ArduSub and DUNE
//! the vehicle refusing commands and changing mode on its own); every invariant must hold. Each family runs the fixed seed 9
//! and one seed drawn from the clock (printed), so CI keeps exploring; re-run a seed with
//! `FRONTSEAT_CHAOS_SEEDS=1234 cargo test -p frontseat-chaos --test chaos_vehicles -- --nocapture`
//! (and `FRONTSEAT_CHAOS_FAULTS=200` for a longer schedule).

use std::time::{Duration, SystemTime, UNIX_EPOCH};

use frontseat_chaos::{ChaosOptions, Family, FaultKind, Rng};

const FIXED_SEED: u64 = 9;
/// Faults per seed in CI: seconds per family.
const CI_FAULTS: u32 = 16;

fn seeds(family: Family) -> Vec<u64> {
    if let Ok(list) = std::env::var("FRONTSEAT_CHAOS_SEEDS") {
        let v: Vec<u64> = list
            .split(',')
            .filter_map(|s| s.trim().parse().ok())
            .collect();
        assert!(!v.is_empty(), "FRONTSEAT_CHAOS_SEEDS={list}: no seed in it");
        return v;
    }
    let nanos = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos() as u64);
    let mut r = Rng::new(nanos ^ family as u64);
    vec![FIXED_SEED, r.next_u64() % 1_000_000]
}

fn faults() -> u32 {
    std::env::var("FRONTSEAT_CHAOS_FAULTS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(CI_FAULTS)
}

async fn family_keeps_every_invariant(family: Family) {
    let seeds = seeds(family);
    let faults = faults();
    eprintln!(
        "chaos {}: seeds {seeds:?}, {faults} faults each (re-run one: FRONTSEAT_CHAOS_SEEDS=<seed> cargo test -p frontseat-chaos --test chaos_vehicles {} -- --nocapture)",
        family.key(),
        family.key()
    );
    let mut failed = Vec::new();
    for seed in seeds {
        let cfg = frontseat_chaos::default_config().unwrap();
        let opts = ChaosOptions {
            seed,
            faults,
            recovery_bound: Duration::from_secs(5),
            moos: false,
            ..Default::default()
        };
        let key = family.key();
        let run = tokio::time::timeout(
            Duration::from_secs(120),
            frontseat_chaos::run_family(family, cfg, opts, |p| {
                eprintln!("chaos {key} seed {seed}: {p}")
            }),
        )
        .await
        .unwrap_or_else(|_| panic!("the {key} chaos run at seed {seed} did not end by itself"));
        let report = run.unwrap();
        println!("{}", report.render());
        // The run injected what it claims, and only the family's faults.
        let injected: u32 = report.by_kind.values().map(|k| k.injected).sum();
        assert_eq!(injected, faults, "{key} seed {seed}");
        let kinds = family.kinds();
        for k in report.by_kind.keys() {
            assert!(kinds.contains(k), "{key} seed {seed}: {k:?} injected");
        }
        // Something was tried on the line at every seed.
        assert!(
            report
                .by_kind
                .keys()
                .any(|k| FaultKind::VEHICLE.contains(k)),
            "{key} seed {seed}: no fault on the vehicle's link"
        );
        if !report.passed() {
            failed.push(seed);
        }
    }
    assert!(
        failed.is_empty(),
        "{} chaos failed at seeds {failed:?}: re-run with FRONTSEAT_CHAOS_SEEDS={}",
        family.key(),
        failed
            .iter()
            .map(u64::to_string)
            .collect::<Vec<_>>()
            .join(",")
    );
}

// One test per family, so a failure names the family; the harness's panic accounting is
// process-wide, so they run one at a time (a mutex, as `--test-threads=1` is not CI's command).
static ONE_AT_A_TIME: tokio::sync::Mutex<()> = tokio::sync::Mutex::const_new(());

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn bluefin() {
    let _g = ONE_AT_A_TIME.lock().await;
    family_keeps_every_invariant(Family::Bluefin).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn iver3() {
    let _g = ONE_AT_A_TIME.lock().await;
    family_keeps_every_invariant(Family::Iver3).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn waveglider_sv2() {
    let _g = ONE_AT_A_TIME.lock().await;
    family_keeps_every_invariant(Family::WavegliderSv2).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn ardupilot() {
    let _g = ONE_AT_A_TIME.lock().await;
    family_keeps_every_invariant(Family::Ardupilot).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn ardusub() {
    let _g = ONE_AT_A_TIME.lock().await;
    family_keeps_every_invariant(Family::Ardusub).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn dune() {
    let _g = ONE_AT_A_TIME.lock().await;
    family_keeps_every_invariant(Family::Dune).await;
}
