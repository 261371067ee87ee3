//! `frontseat bench --quick` runs the whole table and exits 0: proves the benchmark runs (CI).
//! Timings are never asserted — only that every row is there and none failed.

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const ROWS: [&str; 39] = [
    "L0", "L1", "L2", "L3", "L4", "P1", "P2", "P3", "P4", "P5", "P6", "M1", "M2", "G1", "G2", "Z1",
    "Z2", "Z3", "T1", "C1", "C2", "C3", "W1", "R1", "R2", "F1", "F2", "B1", "B2", "I1", "I2", "S1",
    "S2", "A1", "A2", "U1", "U2", "D1", "D2",
];

/// One bench at a time: two at once on a 2-core machine starve each other's children (the
/// rows measure a machine, not a contest).
static ONE_AT_A_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// Runs the binary with a deadline (it spawns children of its own; a hang must fail the test).
fn run_bench(args: &[&str]) -> (bool, String, String) {
    let _one = ONE_AT_A_TIME.lock().unwrap_or_else(|p| p.into_inner());
    let mut child = Command::new(env!("CARGO_BIN_EXE_frontseat"))
        .arg("bench")
        .args(args)
        .env("RUST_LOG", "warn")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(120);
    loop {
        if child.try_wait().unwrap().is_some() {
            break;
        }
        if Instant::now() > deadline {
            child.kill().unwrap();
            panic!("frontseat bench {args:?} did not finish within 120 s");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let out = child.wait_with_output().unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn quick_bench_prints_every_row_and_exits_0() {
    let (ok, stdout, stderr) = run_bench(&["--quick"]);
    assert!(ok, "bench failed\nstdout:\n{stdout}\nstderr:\n{stderr}");
    let header = stdout.lines().take(2).collect::<Vec<_>>().join("\n");
    assert!(header.contains("build"), "{header}");
    assert!(header.contains("cores"), "{header}");
    for id in ROWS {
        let row = stdout
            .lines()
            .find(|l| l.starts_with(&format!("| {id} |")))
            .unwrap_or_else(|| panic!("row {id} missing from\n{stdout}"));
        assert!(!row.contains("FAILED"), "{row}");
        // Every row is measured: a latency (µs/ms/s) or a result with a number in it.
        assert!(!row.contains("n/a"), "{row}");
        assert!(row.chars().any(|c| c.is_ascii_digit()), "{row}");
    }
    let mut latency_rows = vec![
        "L0", "L1", "L2", "L3", "L4", "P1", "P2", "P5", "M1", "M2", "G1", "G2", "Z1", "Z2", "W1",
        "B1", "B2", "I1", "I2", "S1", "S2", "A1", "A2", "U1", "U2", "D1", "D2",
    ];
    // The ROS 2 rows need python3 with cyclonedds; without them (and not required) they say so.
    if std::env::var_os("FRONTSEAT_REQUIRE_PYTHON_HELM").is_some() {
        latency_rows.extend(["C1", "C2"]);
    }
    for id in latency_rows {
        let row = stdout
            .lines()
            .find(|l| l.starts_with(&format!("| {id} |")))
            .unwrap();
        let cells: Vec<&str> = row.split('|').map(str::trim).collect();
        // | id | path | p50 | p99 | max | … : a latency row fills its three figures.
        for cell in &cells[3..6] {
            assert!(
                cell.ends_with("µs") || cell.ends_with("ms") || cell.ends_with(" s"),
                "{id}: `{cell}` in {row}"
            );
        }
        // The data-path rows are also given as ratios over their own floor of the same run:
        // a blocking reader's for the rows ending at the scripted frontseat, a pseudo-terminal's
        // for the serial vehicles, L0's for the rest.
        let floor = match id {
            "L0" | "L1" | "L2" | "L3" | "L4" | "P5" => None,
            "W1" => Some("L3"),
            // A Zenoh subscriber woken by a put in another process.
            "Z1" => Some("L4"),
            "P2" | "M2" | "G2" | "Z2" | "B2" | "C2" => Some("L1"),
            "I1" | "I2" | "S1" | "S2" => Some("L2"),
            _ => Some("L0"),
        };
        if let Some(f) = floor {
            assert!(row.contains(&format!("over {f} (p50 / p99)")), "{row}");
        }
    }
}

#[test]
fn quick_bench_json_has_every_row() {
    let (ok, stdout, stderr) = run_bench(&["--quick", "--json"]);
    assert!(
        ok,
        "bench --json failed\nstdout:\n{stdout}\nstderr:\n{stderr}"
    );
    let v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert!(v["machine"]["cores"].as_u64().unwrap() >= 1);
    assert_eq!(v["quick"], true);
    let ids: Vec<&str> = v["rows"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["id"].as_str().unwrap())
        .collect();
    assert_eq!(ids, ROWS);
    let p1 = &v["rows"][0];
    assert!(p1["p99_us"].as_f64().unwrap() > 0.0, "{p1}");
    assert!(p1["samples"].as_u64().unwrap() > 0, "{p1}");
}

#[test]
fn rows_picks_rows_and_refuses_unknown_ones() {
    let (ok, stdout, stderr) = run_bench(&["--quick", "--json", "--rows", "p1,M2"]);
    assert!(
        ok,
        "bench --rows failed\nstdout:\n{stdout}\nstderr:\n{stderr}"
    );
    let v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    let rows = v["rows"].as_array().unwrap();
    let ids: Vec<&str> = rows.iter().map(|r| r["id"].as_str().unwrap()).collect();
    // L0 always, for the ratios, and M2's own floor (its last hop is a blocking reader: L1);
    // M1 shares M2's setup but was not asked for.
    assert_eq!(ids, ["L0", "L1", "P1", "M2"]);
    for r in &rows[2..] {
        assert!(r["p50_over_l0"].as_f64().unwrap() > 0.0, "{r}");
        assert!(r["p50_over_floor"].as_f64().unwrap() > 0.0, "{r}");
        assert!(r["samples"].as_u64().unwrap() > 0, "{r}");
    }

    let (ok, stdout, stderr) = run_bench(&["--quick", "--rows", "P1,X9"]);
    assert!(!ok, "an unknown row must fail: {stdout}");
    assert!(stderr.contains("unknown row `X9`"), "{stderr}");
    assert!(stderr.contains("L0, L1, L2, L3, L4, P1"), "{stderr}");
}

#[test]
fn against_compares_two_builds_over_alternating_runs() {
    let me = env!("CARGO_BIN_EXE_frontseat");
    let (ok, stdout, stderr) = run_bench(&[
        "--quick",
        "--json",
        "--rows",
        "P1",
        "--against",
        me,
        "--pairs",
        "2",
    ]);
    assert!(
        ok,
        "bench --against failed\nstdout:\n{stdout}\nstderr:\n{stderr}"
    );
    // Each build ran twice, alternating: this, other, other, this.
    let order: Vec<&str> = stderr
        .lines()
        .filter_map(|l| l.split(", ").nth(1))
        .filter_map(|l| l.split(' ').next())
        .collect();
    assert_eq!(order, ["this", "other", "other", "this"], "{stderr}");
    let v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    let rows = v["rows"].as_array().unwrap();
    let ids: Vec<&str> = rows.iter().map(|r| r["id"].as_str().unwrap()).collect();
    assert_eq!(ids, ["L0", "P1"]);
    for r in rows {
        for side in ["this", "other"] {
            assert_eq!(r[side]["n"], 2, "{r}");
            let p50 = &r[side]["p50_us"];
            assert!(p50["mean"].as_f64().unwrap() > 0.0, "{r}");
            assert!(p50["median"].as_f64().unwrap() > 0.0, "{r}");
        }
        assert!(r["p50_change_pct"]["mean"].as_f64().is_some(), "{r}");
    }
}
