//! `frontseat demo --fleet 3`, the real binary: a simulator and three interface processes under
//! the launcher, the leader's homework path and two followers trailing it from the leader's
//! node_status over Zenoh. The tracks it writes must show the path flown and each follower in its
//! slot (computed here from the leader's CSV and the formation asked for) once settled.

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_frontseat");

#[derive(Debug, Clone)]
struct Row {
    t: f64,
    x: f64,
    y: f64,
    heading: f64,
    leg: String,
}

fn read_csv(path: &Path) -> Vec<Row> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("t_s,x_m,y_m,heading_deg,speed_mps,leg"),
        "{}",
        path.display()
    );
    lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            assert_eq!(f.len(), 6, "{l}");
            Row {
                t: f[0].parse().unwrap(),
                x: f[1].parse().unwrap(),
                y: f[2].parse().unwrap(),
                heading: f[3].parse().unwrap(),
                leg: f[5].to_string(),
            }
        })
        .collect()
}

/// The follower's row nearest in time to `t`.
fn at(track: &[Row], t: f64) -> &Row {
    track
        .iter()
        .min_by(|a, b| (a.t - t).abs().total_cmp(&(b.t - t).abs()))
        .unwrap()
}

/// The slot `behind` metres behind and `side` metres right of the leader's row.
fn slot(l: &Row, behind: f64, side: f64) -> (f64, f64) {
    let h = l.heading.to_radians();
    (
        l.x - behind * h.sin() + side * h.cos(),
        l.y - behind * h.cos() - side * h.sin(),
    )
}

#[test]
fn three_vehicles_fly_the_trail_and_the_followers_end_in_their_slots() {
    let out = std::env::temp_dir().join(format!("frontseat-fleet-demo-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let (behind, side) = (20.0, 12.0);
    let mut child = Command::new(BIN)
        .args(["demo", "--fleet", "3", "--warp", "20", "--lines", "--out"])
        .arg(&out)
        .args(["--trail-behind", &behind.to_string()])
        .args(["--trail-side", &side.to_string()])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // Bounded: the path is ~210 simulated seconds, ~11 s at warp 20.
    let deadline = Instant::now() + Duration::from_secs(120);
    while child.try_wait().unwrap().is_none() {
        if Instant::now() > deadline {
            let _ = child.kill();
            panic!("demo --fleet did not finish");
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    let output = child.wait_with_output().unwrap();
    let stdout = String::from_utf8_lossy(&output.stdout);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stdout}\n{stderr}");
    // Three interface processes, each started and stopped by the launcher.
    for v in ["leader", "follower1", "follower2"] {
        assert!(
            stderr.contains(&format!("ready process=interface-{v}")),
            "{stderr}"
        );
    }
    assert!(stdout.contains("heard over Zenoh"), "{stdout}");

    let leader = read_csv(&out.join("track-leader.csv"));
    let followers = [
        read_csv(&out.join("track-follower1.csv")),
        read_csv(&out.join("track-follower2.csv")),
    ];
    assert!(out.join("fleet.svg").exists());
    let svg = std::fs::read_to_string(out.join("fleet.svg")).unwrap();
    assert_eq!(svg.matches("<polyline").count(), 3, "one track per vehicle");
    // The leader flew the whole homework path.
    for leg in ["east", "south", "northwest"] {
        assert!(
            leader.iter().any(|r| r.leg == leg),
            "leader has no {leg} leg"
        );
    }
    let end = leader.last().unwrap();
    assert!(
        end.x.hypot(end.y) < 15.0,
        "leader ends near its start: {end:?}"
    );

    // Followers trail: right then left of the leader, `behind` back; checked where they had
    // time to settle (the last row of the east leg, and the end of the run).
    let east_end = leader.iter().rev().find(|r| r.leg == "east").unwrap();
    for (k, track) in followers.iter().enumerate() {
        assert!(
            track.iter().any(|r| r.leg == "trail"),
            "follower{} never trailed",
            k + 1
        );
        let s = if k == 0 { side } else { -side };
        for l in [east_end, end] {
            let (sx, sy) = slot(l, behind, s);
            let f = at(track, l.t);
            let err = (f.x - sx).hypot(f.y - sy);
            assert!(
                err < 3.0,
                "follower{} at t={:.1}: ({:.1}, {:.1}), slot ({sx:.1}, {sy:.1}): {err:.1} m off",
                k + 1,
                l.t,
                f.x,
                f.y
            );
        }
        // Trailing, not just parked: it covered about the leader's distance.
        let dist = |t: &[Row]| {
            t.windows(2)
                .map(|w| (w[1].x - w[0].x).hypot(w[1].y - w[0].y))
                .sum::<f64>()
        };
        assert!(
            dist(track) > 0.7 * dist(&leader),
            "follower{} barely moved",
            k + 1
        );
    }
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn a_fleet_of_one_is_refused() {
    let out = Command::new(BIN)
        .args(["demo", "--fleet", "1"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--fleet must be 2"));
}
