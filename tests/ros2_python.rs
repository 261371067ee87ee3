//! The Python/ROS 2 side of issue 48, run for real: the Cyclone DDS twins of the ROS 2 types
//! check themselves (`examples/ros2/frontseat_ros2_types.py --self-test`: hand-encoded golden
//! bytes, the frontseat_msgs .msg files, the type hashes) and catch a .msg they do not match; and
//! `examples/ros2/cyclone_helm.py`, the ROS 2 example helm's logic over Cyclone DDS, flies the
//! homework path through `frontseat sim` + `frontseat interface` with `[ros2]` enabled. DDS stays
//! on loopback (the scripts set CYCLONEDDS_URI; the gateway's allow_remote_peers is false). With
//! FRONTSEAT_REQUIRE_PYTHON_HELM set (CI), a missing `cyclonedds` fails instead of skipping.

mod common;

use common::procs::{Kill, finish_within, frontseat_interface, frontseat_sim, scratch};

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::Duration;

const WARP: f64 = 10.0;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Whether python3 can import cyclonedds; false (reported SKIPPED) only when
/// FRONTSEAT_REQUIRE_PYTHON_HELM is unset.
fn cyclonedds_can_run(test: &str) -> bool {
    common::python::can_import(test, "cyclonedds.domain", "tests/python/requirements.txt")
}

fn self_test(ros2_dir: Option<&Path>) -> Output {
    let mut cmd = Command::new("python3");
    cmd.arg(root().join("examples/ros2/frontseat_ros2_types.py"))
        .arg("--self-test");
    if let Some(d) = ros2_dir {
        cmd.arg("--ros2-dir").arg(d);
    }
    cmd.output().expect("python3 runs")
}

fn text(o: &Output) -> String {
    format!(
        "{}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

#[test]
fn the_python_twins_of_the_ros2_types_pass_their_self_test() {
    if !cyclonedds_can_run("the_python_twins_of_the_ros2_types_pass_their_self_test") {
        return;
    }
    let out = self_test(None);
    let all = text(&out);
    assert!(out.status.success(), "self-test failed:\n{all}");
    assert!(
        all.contains("self-test: PASS") && !all.contains("FAIL"),
        "{all}"
    );
    // Every frontseat_msgs message was compared, and the golden bytes were read.
    let msgs = std::fs::read_dir(root().join("ros2/frontseat_msgs/msg"))
        .unwrap()
        .filter(|e| {
            e.as_ref()
                .is_ok_and(|e| e.path().extension().is_some_and(|x| x == "msg"))
        })
        .count();
    let compared = all
        .lines()
        .filter(|l| l.starts_with("ok    frontseat_msgs/") && l.contains(" fields as in "))
        .count();
    assert!(
        msgs >= 6 && compared == msgs,
        "{compared} of {msgs}:\n{all}"
    );
    assert!(
        all.contains("golden/odometry_heading030.hex (724 B)"),
        "{all}"
    );
}

#[test]
fn the_self_test_fails_when_a_msg_file_and_its_twin_differ() {
    if !cyclonedds_can_run("the_self_test_fails_when_a_msg_file_and_its_twin_differ") {
        return;
    }
    // A copy of ros2/ (the .msg files, CMakeLists.txt, type_hashes.txt) with one field added.
    let dir = scratch("ros2py", "msgdrift");
    let src = root().join("ros2");
    let msg = dir.join("frontseat_msgs/msg");
    std::fs::create_dir_all(&msg).unwrap();
    for e in std::fs::read_dir(src.join("frontseat_msgs/msg")).unwrap() {
        let p = e.unwrap().path();
        std::fs::copy(&p, msg.join(p.file_name().unwrap())).unwrap();
    }
    std::fs::copy(
        src.join("frontseat_msgs/CMakeLists.txt"),
        dir.join("frontseat_msgs/CMakeLists.txt"),
    )
    .unwrap();
    std::fs::copy(src.join("type_hashes.txt"), dir.join("type_hashes.txt")).unwrap();
    // The unchanged copy passes: the failure below is the drift's.
    let same = self_test(Some(&dir));
    assert!(same.status.success(), "{}", text(&same));
    let course = msg.join("DesiredCourse.msg");
    let mut body = std::fs::read_to_string(&course).unwrap();
    body.push_str("float64 surge_limit\n");
    std::fs::write(&course, body).unwrap();
    let drift = self_test(Some(&dir));
    let all = text(&drift);
    assert_eq!(drift.status.code(), Some(1), "{all}");
    assert!(
        all.contains("FAIL  frontseat_msgs/DesiredCourse: 16 fields as in DesiredCourse.msg"),
        "{all}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A DDS domain of this test process (ports 7400 + 250 x domain): concurrent test binaries
/// rarely share one, and the namespace keeps them apart when they do.
fn domain() -> u16 {
    100 + (std::process::id() % 100) as u16
}

/// `frontseat sim` and `frontseat interface` with `[ros2]` enabled in `domain` under `platform`.
struct Stack {
    dir: PathBuf,
    _sim: Kill,
    _interface: Kill,
}

impl Stack {
    fn log(&self) -> String {
        std::fs::read_to_string(self.dir.join("interface.log")).unwrap_or_default()
    }
}

async fn start_stack(name: &str, platform: &str, domain: u16) -> Stack {
    let dir = scratch("ros2py", name);
    let (sim, sim_port) = frontseat_sim(std::fs::File::create(dir.join("sim.log")).unwrap()).await;
    let cfg = format!(
        r#"name = "{platform}"
sim_warp_factor = {WARP}
status_period = 0.5
helm_running_timeout = 5.0
[driver]
name = "basic_simulator"
[driver.basic_simulator]
tcp_port = {sim_port}
[ros2]
enabled = true
domain_id = {domain}
"#
    );
    let interface = frontseat_interface(&dir, &cfg);
    Stack {
        dir,
        _sim: sim,
        _interface: interface,
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_cyclone_dds_helm_flies_the_homework_path_over_ros2_topics() {
    if !cyclonedds_can_run("the_cyclone_dds_helm_flies_the_homework_path_over_ros2_topics") {
        return;
    }
    let domain = domain();
    let stack = start_stack("helm", "r2auv", domain).await;
    let mut helm = Kill(
        Command::new("python3")
            .arg(root().join("examples/ros2/cyclone_helm.py"))
            .args(["--domain", &domain.to_string(), "--platform", "r2auv"])
            .args(["--warp", &WARP.to_string()])
            .args(["--t1", "60", "--t2", "60", "--timeout", "90"])
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap(),
    );
    // The helm bounds itself (--timeout 90); this bounds the test if it hangs anyway.
    let (status, out, err) =
        finish_within(&mut helm, Duration::from_secs(120), "the Cyclone DDS helm").await;
    assert!(
        status.success(),
        "cyclone_helm.py failed: {status}\n{out}\n{err}\ninterface log:\n{}",
        stack.log()
    );
    for what in [
        "interface state INTERFACE_COMMAND",
        "leg east",
        "leg south",
        "leg northwest",
        "triangle done",
    ] {
        assert!(out.contains(what), "no {what:?} in:\n{out}");
    }
    // Each leg moved the vehicle the way it was commanded (1.5 m/s for 60 s: about 90 m).
    let at = |leg: &str| -> (f64, f64) {
        let l = out
            .lines()
            .find(|l| l.starts_with(&format!("leg {leg} at")))
            .unwrap();
        let p = l.rsplit_once("position (").unwrap().1.trim_end_matches(')');
        let (x, y) = p.split_once(", ").unwrap();
        (x.parse().unwrap(), y.parse().unwrap())
    };
    let (e, s, nw) = (at("east"), at("south"), at("northwest"));
    assert!(
        s.0 - e.0 > 60.0 && (s.1 - e.1).abs() < 15.0,
        "east leg {e:?} -> {s:?}:\n{out}"
    );
    assert!(
        s.1 - nw.1 > 60.0 && (nw.0 - s.0).abs() < 15.0,
        "south leg {s:?} -> {nw:?}:\n{out}"
    );
    // Equal legs: the northwest leg passes near the start.
    let closest: f64 = out
        .lines()
        .find_map(|l| l.strip_prefix("triangle done: closest approach "))
        .and_then(|r| r.split(' ').next())
        .and_then(|v| v.parse().ok())
        .expect("closest approach printed");
    assert!(closest < 15.0, "closest approach {closest} m:\n{out}");
}
