//! `frontseat demo --vehicle ardusub`, the real binary: the Sub emulator on loopback TCP, the
//! interface with the real driver, the demo's pilot (arm, GUIDED) and its helm flying the
//! homework path at 5 m, then 10 m, then 5 m. The track CSV must carry `depth_m` showing each
//! leg's depth reached, and the demo prints its depth figures.

mod common;

use std::process::Command;

#[test]
fn demo_dives_the_homework_path_and_writes_depth_m() {
    let out = common::procs::scratch("ardusub_demo", "dive");
    let o = Command::new(env!("CARGO_BIN_EXE_frontseat"))
        .args([
            "demo",
            "--vehicle",
            "ardusub",
            "--warp",
            "20",
            "--east",
            "40",
            "--south",
            "40",
            "--lines",
            "--out",
        ])
        .arg(&out)
        .output()
        .expect("frontseat demo runs");
    let stdout = String::from_utf8_lossy(&o.stdout);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "demo failed:\n{stdout}\n{stderr}");
    let csv = std::fs::read_to_string(out.join("track.csv")).expect("track.csv written");
    let mut lines = csv.lines();
    assert_eq!(
        lines.next(),
        Some("t_s,x_m,y_m,heading_deg,speed_mps,leg,depth_m")
    );
    let rows: Vec<(String, f64, f64)> = lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            assert_eq!(f.len(), 7, "{l}");
            (
                f[5].to_string(),
                f[3].parse().unwrap(),
                f[6].parse().unwrap(),
            )
        })
        .collect();
    // Each leg ends at its depth (5, 10, 5 m) on its heading.
    for (leg, depth, heading) in [("east", 5.0, 90.0), ("south", 10.0, 180.0)] {
        let last = rows
            .iter()
            .rev()
            .find(|r| r.0 == leg)
            .unwrap_or_else(|| panic!("no {leg} leg in the track"));
        assert!((last.2 - depth).abs() < 0.3, "{leg}: depth {}", last.2);
        assert!((last.1 - heading).abs() < 2.0, "{leg}: heading {}", last.1);
    }
    let deepest = rows.iter().map(|r| r.2).fold(0.0, f64::max);
    assert!(
        deepest < 10.5,
        "never beyond the 10 m asked (plus overshoot): {deepest}"
    );
    for leg in ["east", "south", "northwest"] {
        assert!(
            stdout.lines().any(|l| l.starts_with("depth ")
                && l.contains(leg)
                && l.contains("within 0.3 m after")),
            "depth figures for {leg} in:\n{stdout}"
        );
    }
    let _ = std::fs::remove_dir_all(&out);
}
