//! A launch file's `[record]` with the real binary: `--check` shows where each vehicle records,
//! and a real launch of a simulator and two interfaces leaves one closed, readable MCAP file per
//! vehicle (its own directory) holding that vehicle's node_status.

mod common;

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use common::procs::{Kill, free_port, scratch};
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::NodeStatus;
use frontseat_record::{Recording, info};
use prost::Message as _;

const BIN: &str = env!("CARGO_BIN_EXE_frontseat");
const BOUND: Duration = Duration::from_secs(40);
const NODE_STATUS: &str = "goby::middleware::frontseat::node_status";

/// The one `.mcap` file in `dir`, if there is exactly one.
fn only_file(dir: &Path) -> Option<PathBuf> {
    let files: Vec<PathBuf> = std::fs::read_dir(dir)
        .ok()?
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "mcap"))
        .collect();
    (files.len() == 1).then(|| files[0].clone())
}

/// node_status messages readable in `file` now (a file being written reads up to its last chunk).
fn node_statuses(file: &Path) -> Vec<NodeStatus> {
    let Ok(mut rec) = Recording::open(file) else {
        return Vec::new();
    };
    let mut out = Vec::new();
    while let Ok(Some(m)) = rec.next_message() {
        if rec
            .channel(m.channel_id)
            .is_some_and(|c| &*c.topic == NODE_STATUS)
        {
            out.push(NodeStatus::decode(m.data.as_slice()).unwrap());
        }
    }
    out
}

#[test]
fn a_launch_record_leaves_one_readable_file_per_vehicle_with_its_node_status() {
    let dir = scratch("launch", "record");
    let _ = std::fs::remove_dir_all(dir.join("rec"));
    let file = dir.join("fleet.toml");
    let sim = free_port();
    std::fs::write(
        &file,
        format!(
            r#"
run_dir = "run"
stop_timeout_s = 5
[record]
enabled = true
dir = "rec"
flush_s = 0.1
# Not a test of the disk guard: record however little the test machine's disk has free.
min_free_mb = 0
[[process]]
name = "sim"
command = ["frontseat", "sim", "--port", "{sim}"]
ready = {{ kind = "notify" }}
[[vehicle]]
name = "auv1"
sim_port = {sim}
zenoh_listen = ["tcp/127.0.0.1:{z1}"]
[[vehicle]]
name = "auv2"
sim_port = {sim}
zenoh_listen = ["tcp/127.0.0.1:{z2}"]
start = {{ lat = 42.36, lon = -71.08 }}
"#,
            z1 = free_port(),
            z2 = free_port(),
        ),
    )
    .unwrap();
    let rec_dir = |v: &str| dir.join("rec").join(v);

    // --check: each vehicle's own directory, named after it.
    let check = Command::new(BIN)
        .args(["launch", "--check", "-c"])
        .arg(&file)
        .output()
        .unwrap();
    let out = String::from_utf8_lossy(&check.stdout);
    assert!(check.status.success(), "{check:?}");
    for v in ["auv1", "auv2"] {
        let want = format!(
            "record: {v} -> {}/{v}_<UTC start>_<seq>.mcap",
            rec_dir(v).display()
        );
        assert!(out.contains(&want), "{want:?} not in:\n{out}");
    }

    let mut child = Kill(
        Command::new(BIN)
            .args(["launch", "-c"])
            .arg(&file)
            .env("RUST_LOG", "info")
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap(),
    );
    let (tx, lines) = mpsc::channel();
    let stderr = child.0.stderr.take().unwrap();
    std::thread::spawn(move || {
        for l in BufReader::new(stderr).lines().map_while(Result::ok) {
            let _ = tx.send(l);
        }
    });
    let mut seen = Vec::new();
    let deadline = Instant::now() + BOUND;
    // Both vehicles record node_status while they run: read the open files until they do.
    let recording = loop {
        while let Ok(l) = lines.try_recv() {
            seen.push(l);
        }
        let files: Vec<Option<PathBuf>> = ["auv1", "auv2"]
            .iter()
            .map(|v| only_file(&rec_dir(v)))
            .collect();
        if files
            .iter()
            .all(|f| f.as_deref().is_some_and(|f| node_statuses(f).len() >= 3))
        {
            break files.into_iter().flatten().collect::<Vec<_>>();
        }
        if Instant::now() > deadline || child.0.try_wait().unwrap().is_some() {
            panic!(
                "no node_status recorded by both vehicles; files {files:?}; saw:\n{}",
                seen.join("\n")
            );
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    let ok = Command::new("kill")
        .args(["-TERM", &child.0.id().to_string()])
        .status()
        .unwrap();
    assert!(ok.success());
    let status = loop {
        if let Some(s) = child.0.try_wait().unwrap() {
            break s;
        }
        assert!(
            Instant::now() < deadline + Duration::from_secs(15),
            "launch did not end"
        );
        std::thread::sleep(Duration::from_millis(20));
    };
    while let Ok(l) = lines.recv_timeout(Duration::from_millis(200)) {
        seen.push(l);
    }
    assert!(status.success(), "{status:?}:\n{}", seen.join("\n"));

    // Each file is closed (its summary written), says whose it is, and holds only that vehicle.
    for (v, f) in ["auv1", "auv2"].iter().zip(&recording) {
        assert!(
            f.file_name()
                .unwrap()
                .to_string_lossy()
                .starts_with(&format!("{v}_")),
            "{f:?}"
        );
        let i = info::info(Recording::open(f).unwrap()).unwrap();
        assert_eq!(
            i.truncated, None,
            "{v}: the interface closed its file on SIGTERM"
        );
        assert_eq!(i.run.get("vehicle").map(String::as_str), Some(*v));
        let ns = node_statuses(f);
        assert!(ns.len() >= 3, "{v}: {} node_status", ns.len());
        assert!(
            ns.iter().all(|n| n.name.as_deref() == Some(*v)),
            "{v}: another vehicle's node_status in its file"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Issue 37: a vehicle named `..` would record in the parent of the record directory. The real
/// binary's `launch --check` refuses it as a config error naming the field, and nothing is
/// written outside the launch file's directory.
#[test]
fn a_vehicle_named_dot_dot_is_a_config_error() {
    let dir = scratch("launch", "dotdot");
    let inner = dir.join("inner");
    let _ = std::fs::remove_dir_all(&inner);
    std::fs::create_dir_all(&inner).unwrap();
    let file = inner.join("fleet.toml");
    std::fs::write(
        &file,
        "run_dir = \"run\"\n[record]\nenabled = true\ndir = \"rec\"\n[[vehicle]]\nname = \"..\"\n",
    )
    .unwrap();
    let out = Command::new(BIN)
        .args(["launch", "--check", "-c"])
        .arg(&file)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("vehicle[0].name") && err.contains("`.` and `..` are not names"),
        "{err}"
    );
    let mut left: Vec<_> = std::fs::read_dir(&inner)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    left.sort();
    assert_eq!(
        left,
        ["fleet.toml"],
        "nothing written beside the launch file"
    );
}
