//! `frontseat log recover` on the file a real `frontseat interface` leaves when SIGKILLed (issue
//! 46, item 4): the Python `mcap` reader's ordinary open (`make_reader`, the seeking reader
//! scripts and Foxglove use) fails on it before, and reads every message the cut file held after
//! (the same messages byte for byte as the bounded reader read up to the last whole chunk).
//! What the command refuses, and its exit codes: a live recorder's file (2, untouched), a
//! symlink (2), a file frontseat did not write (2, untouched), not MCAP (1), missing (1); a
//! complete file is left as it is (0).

mod common;

use std::os::unix::fs::MetadataExt as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use common::mcap_python::{make_reader, python_reader};
use common::procs::{Kill, frontseat_sim, scratch};
use frontseat_record::crafted::message_digest;
use frontseat_record::{Recording, info};

fn frontseat() -> Command {
    Command::new(env!("CARGO_BIN_EXE_frontseat"))
}

fn recover(file: &Path) -> Output {
    frontseat()
        .args(["log", "recover"])
        .arg(file)
        .output()
        .unwrap()
}

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn node_status_count(file: &Path) -> u64 {
    Recording::open(file)
        .ok()
        .and_then(|r| info::info(r).ok())
        .and_then(|i| {
            i.groups
                .iter()
                .find(|g| g.group == "goby::middleware::frontseat::node_status")
                .map(|g| g.count)
        })
        .unwrap_or(0)
}

fn text(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn log_recover_finishes_a_sigkilled_interface_recording_for_make_reader() {
    let python = python_reader();
    let dir = scratch("record", "recover");
    let logs = dir.join("logs");
    let _ = std::fs::remove_dir_all(&logs);
    let (_sim, sim_port) = frontseat_sim(Stdio::null()).await;
    let cfg = format!(
        r#"name = "cut-auv"
require_helm = false
sim_warp_factor = 10.0
[driver.basic_simulator]
tcp_port = {sim_port}
[record]
enabled = true
dir = "{}"
flush_s = 0.2
# Not a test of the disk guard.
min_free_mb = 0
"#,
        logs.display()
    );
    let cfg_path = dir.join("interface.toml");
    std::fs::write(&cfg_path, cfg).unwrap();
    let mut interface = Kill(
        frontseat()
            .arg("interface")
            .arg("-c")
            .arg(&cfg_path)
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(dir.join("interface.log")).unwrap())
            .spawn()
            .unwrap(),
    );
    let deadline = Instant::now() + Duration::from_secs(60);
    let file = loop {
        let found = std::fs::read_dir(&logs).ok().and_then(|rd| {
            rd.filter_map(Result::ok)
                .map(|e| e.path())
                .find(|p| p.extension().is_some_and(|x| x == "mcap"))
        });
        if let Some(f) = found
            && node_status_count(&f) >= 10
        {
            break f;
        }
        assert!(
            Instant::now() < deadline,
            "no node_status recorded within 60 s"
        );
        tokio::time::sleep(Duration::from_millis(100)).await;
    };

    // While the interface records it: refused, and the file is the same file afterwards.
    let ino = std::fs::metadata(&file).unwrap().ino();
    let live = recover(&file);
    assert_eq!(live.status.code(), Some(2), "{}", text(&live));
    assert!(text(&live).contains("running recorder"), "{}", text(&live));
    assert_eq!(std::fs::metadata(&file).unwrap().ino(), ino);

    // std's kill is SIGKILL: no summary, no footer.
    interface.0.kill().unwrap();
    interface.0.wait().unwrap();
    let cut = info::info(Recording::open(&file).unwrap()).unwrap();
    assert!(cut.truncated.is_some(), "killed: no summary");
    let before = message_digest(Recording::open(&file).unwrap()).unwrap();
    assert!(before.0 >= 10, "{before:?}");
    if python {
        let e = make_reader(&repo(), &file).expect_err("make_reader opens a file with no summary");
        println!("make_reader on the killed file: {e}");
    }

    let done = recover(&file);
    assert!(done.status.success(), "{}", text(&done));
    assert!(
        text(&done).contains(&format!("{} messages kept", before.0)),
        "{}",
        text(&done)
    );
    assert_eq!(
        message_digest(Recording::open(&file).unwrap()).unwrap(),
        before,
        "every message up to the last whole chunk, byte for byte"
    );
    if python {
        assert_eq!(
            make_reader(&repo(), &file).expect("make_reader opens the finished file"),
            before,
            "make_reader reads every message the cut file held"
        );
    }
    let shown = frontseat()
        .args(["log", "info"])
        .arg(&file)
        .output()
        .unwrap();
    assert!(shown.status.success());
    let shown = String::from_utf8_lossy(&shown.stdout);
    assert!(
        shown.contains("recovered:") && shown.contains("closed properly"),
        "{shown}"
    );
    assert_eq!(
        info::info(Recording::open(&file).unwrap())
            .unwrap()
            .run
            .get("vehicle")
            .map(String::as_str),
        Some("cut-auv")
    );

    // Again: complete already, left as it is.
    let bytes = std::fs::read(&file).unwrap();
    let again = recover(&file);
    assert!(again.status.success(), "{}", text(&again));
    assert!(
        text(&again).contains("complete already"),
        "{}",
        text(&again)
    );
    assert_eq!(std::fs::read(&file).unwrap(), bytes);

    // A symlink is never followed.
    let link = dir.join("link.mcap");
    let _ = std::fs::remove_file(&link);
    std::os::unix::fs::symlink(&file, &link).unwrap();
    let l = recover(&link);
    assert_eq!(l.status.code(), Some(2), "{}", text(&l));
    assert!(text(&l).contains("symbolic link"), "{}", text(&l));

    // Another writer's file (here: our header's profile changed), cut: refused, untouched.
    let mut foreign = bytes.clone();
    let at = foreign
        .windows(9)
        .position(|w| w == b"frontseat")
        .expect("the profile in the header");
    foreign[at] = b'F';
    foreign.truncate(foreign.len() - 100);
    let foreign_path = dir.join("foreign.mcap");
    std::fs::write(&foreign_path, &foreign).unwrap();
    let f = recover(&foreign_path);
    assert_eq!(f.status.code(), Some(2), "{}", text(&f));
    assert!(
        text(&f).contains("not written by frontseat"),
        "{}",
        text(&f)
    );
    assert_eq!(std::fs::read(&foreign_path).unwrap(), foreign);

    // Not MCAP, and missing: failures (exit 1).
    let junk = dir.join("junk.mcap");
    std::fs::write(&junk, b"not an mcap file at all").unwrap();
    let j = recover(&junk);
    assert_eq!(j.status.code(), Some(1), "{}", text(&j));
    assert!(text(&j).contains("not an MCAP file"), "{}", text(&j));
    let m = recover(&dir.join("missing.mcap"));
    assert_eq!(m.status.code(), Some(1), "{}", text(&m));
    // No temporary copy left behind anywhere.
    for d in [&dir, &logs] {
        let left: Vec<_> = std::fs::read_dir(d)
            .unwrap()
            .filter_map(Result::ok)
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| n.ends_with(".part"))
            .collect();
        assert!(left.is_empty(), "{left:?}");
    }
}
