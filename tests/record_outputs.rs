//! What `frontseat log export|plot|import` and `demo --record` do to files already on the disk
//! (issue 37, item 2), through the real binary: an existing output is refused (exit 2) unless
//! `--force`; an output that is the input — the same path, `./in.mcap`, a hard link — is refused
//! even with `--force` and the input is left byte for byte; a symlink at the output or at its
//! `.part` name is never written through.
//!
//! Inputs: `fuzz/corpus/mcap_reader/zstd_whole.mcap` (a recording of 6 messages by our recorder,
//! checked in for the fuzz corpus) and `fuzz/corpus/goby_import/sample_whole.goby` (the
//! goby_logger fixture of `record/tests/fixtures`, whole).

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A fresh, empty scratch directory named after the test.
struct Scratch(PathBuf);

impl Scratch {
    fn new(name: &str) -> Self {
        let d = common::procs::scratch("record-outputs", name);
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        Self(d)
    }
    fn path(&self) -> &Path {
        &self.0
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn frontseat(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_frontseat"))
        .args(args)
        .current_dir(dir)
        .env_remove("RUST_LOG")
        .output()
        .unwrap()
}

fn fixture(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(rel)
}

fn code(o: &Output) -> Option<i32> {
    o.status.code()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A fresh directory holding `in.mcap`; the group to export from it.
fn setup(name: &str) -> (Scratch, String) {
    let d = Scratch::new(name);
    std::fs::copy(
        fixture("fuzz/corpus/mcap_reader/zstd_whole.mcap"),
        d.path().join("in.mcap"),
    )
    .unwrap();
    let o = frontseat(d.path(), &["log", "info", "--json", "in.mcap"]);
    assert_eq!(code(&o), Some(0), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let group = v["groups"][0]["group"].as_str().unwrap().to_string();
    (d, group)
}

#[test]
fn export_refuses_an_existing_output_without_force_and_replaces_it_with() {
    let (d, group) = setup("exists");
    let args = |extra: &[&'static str]| {
        let mut a = vec![
            "log", "export", "in.mcap", "--group", &group, "-o", "out.csv",
        ];
        a.extend_from_slice(extra);
        a.into_iter().map(String::from).collect::<Vec<_>>()
    };
    let run = |a: Vec<String>| {
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        frontseat(d.path(), &a)
    };
    assert_eq!(code(&run(args(&[]))), Some(0));
    let written = std::fs::read(d.path().join("out.csv")).unwrap();
    assert!(written.starts_with(b"log_time,"));
    std::fs::write(d.path().join("out.csv"), b"mine").unwrap();
    let o = run(args(&[]));
    assert_eq!(code(&o), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("exists (--force to replace it)"),
        "{}",
        stderr(&o)
    );
    assert_eq!(std::fs::read(d.path().join("out.csv")).unwrap(), b"mine");
    assert_eq!(code(&run(args(&["--force"]))), Some(0));
    assert_eq!(std::fs::read(d.path().join("out.csv")).unwrap(), written);
    // Nothing left beside it.
    let mut names: Vec<_> = std::fs::read_dir(d.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    assert_eq!(names, ["in.mcap", "out.csv"]);
}

#[test]
fn an_output_that_is_the_input_is_refused_even_with_force() {
    let (d, group) = setup("same");
    let input = std::fs::read(d.path().join("in.mcap")).unwrap();
    std::fs::hard_link(d.path().join("in.mcap"), d.path().join("link.mcap")).unwrap();
    std::os::unix::fs::symlink("in.mcap", d.path().join("sym.mcap")).unwrap();
    for out in ["in.mcap", "./in.mcap", "link.mcap", "sym.mcap"] {
        let o = frontseat(
            d.path(),
            &[
                "log", "export", "in.mcap", "--group", &group, "-o", out, "--force",
            ],
        );
        assert_eq!(code(&o), Some(2), "{out}: {}", stderr(&o));
        assert!(
            stderr(&o).contains("this is the input file"),
            "{}",
            stderr(&o)
        );
        assert_eq!(
            std::fs::read(d.path().join("in.mcap")).unwrap(),
            input,
            "{out}"
        );
    }
    // The same for plot (into the input's own directory and name) and import.
    std::fs::create_dir(d.path().join("p")).unwrap();
    std::fs::hard_link(d.path().join("in.mcap"), d.path().join("p/track.svg")).unwrap();
    let o = frontseat(
        d.path(),
        &["log", "plot", "in.mcap", "--out", "p", "--force"],
    );
    assert_eq!(code(&o), Some(2), "{}", stderr(&o));
    assert_eq!(std::fs::read(d.path().join("in.mcap")).unwrap(), input);
    std::fs::copy(
        fixture("fuzz/corpus/goby_import/sample_whole.goby"),
        d.path().join("in.goby"),
    )
    .unwrap();
    let o = frontseat(
        d.path(),
        &["log", "import", "in.goby", "-o", "./in.goby", "--force"],
    );
    assert_eq!(code(&o), Some(2), "{}", stderr(&o));
    assert!(std::fs::metadata(d.path().join("in.goby")).unwrap().len() > 0);
}

#[test]
fn symlinks_at_the_output_or_its_part_name_are_never_written_through() {
    let (d, group) = setup("symlinks");
    let victim = d.path().join("victim.txt");
    std::fs::write(&victim, b"precious").unwrap();
    // A symlink as the output: exists → refused; with --force the link itself is replaced.
    std::os::unix::fs::symlink(&victim, d.path().join("a.csv")).unwrap();
    let o = frontseat(
        d.path(),
        &["log", "export", "in.mcap", "--group", &group, "-o", "a.csv"],
    );
    assert_eq!(code(&o), Some(2), "{}", stderr(&o));
    let o = frontseat(
        d.path(),
        &[
            "log", "export", "in.mcap", "--group", &group, "-o", "a.csv", "--force",
        ],
    );
    assert_eq!(code(&o), Some(0), "{}", stderr(&o));
    assert!(
        std::fs::symlink_metadata(d.path().join("a.csv"))
            .unwrap()
            .is_file()
    );
    assert_eq!(std::fs::read(&victim).unwrap(), b"precious");
    // A `.part` symlink planted beside the output of each command.
    std::os::unix::fs::symlink(&victim, d.path().join("b.csv.part")).unwrap();
    let o = frontseat(
        d.path(),
        &["log", "export", "in.mcap", "--group", &group, "-o", "b.csv"],
    );
    assert_eq!(code(&o), Some(0), "{}", stderr(&o));
    std::fs::create_dir(d.path().join("plot")).unwrap();
    std::os::unix::fs::symlink(&victim, d.path().join("plot/track.svg.part")).unwrap();
    let o = frontseat(d.path(), &["log", "plot", "in.mcap", "--out", "plot"]);
    assert_eq!(code(&o), Some(0), "{}", stderr(&o));
    std::fs::copy(
        fixture("fuzz/corpus/goby_import/sample_whole.goby"),
        d.path().join("in.goby"),
    )
    .unwrap();
    std::os::unix::fs::symlink(&victim, d.path().join("out.mcap.part")).unwrap();
    let o = frontseat(d.path(), &["log", "import", "in.goby", "-o", "out.mcap"]);
    assert_eq!(code(&o), Some(0), "{}", stderr(&o));
    assert_eq!(std::fs::read(&victim).unwrap(), b"precious");
    for written in ["b.csv", "plot/track.svg", "plot/time.svg", "out.mcap"] {
        assert!(
            std::fs::symlink_metadata(d.path().join(written))
                .unwrap()
                .is_file(),
            "{written}"
        );
    }
    // Plot and import refuse to replace without --force too.
    let o = frontseat(d.path(), &["log", "plot", "in.mcap", "--out", "plot"]);
    assert_eq!(code(&o), Some(2), "{}", stderr(&o));
    let o = frontseat(d.path(), &["log", "import", "in.goby", "-o", "out.mcap"]);
    assert_eq!(code(&o), Some(2), "{}", stderr(&o));
}

#[test]
fn demo_record_refuses_an_existing_file_without_force() {
    let d = Scratch::new("demo-exists");
    std::fs::write(d.path().join("run.mcap"), b"yesterday").unwrap();
    let o = frontseat(
        d.path(),
        &["demo", "--lines", "--record", "run.mcap", "--out", "out"],
    );
    assert_eq!(code(&o), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("exists (--force to replace it)"),
        "{}",
        stderr(&o)
    );
    assert_eq!(
        std::fs::read(d.path().join("run.mcap")).unwrap(),
        b"yesterday"
    );
}

#[test]
fn demo_record_force_replaces_at_the_end_without_following_a_planted_part() {
    let d = Scratch::new("demo-force");
    std::fs::write(d.path().join("run.mcap"), b"yesterday").unwrap();
    let victim = d.path().join("victim.txt");
    std::fs::write(&victim, b"precious").unwrap();
    std::os::unix::fs::symlink(&victim, d.path().join("run.mcap.part")).unwrap();
    let o = frontseat(
        d.path(),
        &[
            "demo", "--lines", "--warp", "50", "--east", "20", "--south", "20", "--record",
            "run.mcap", "--force", "--out", "out",
        ],
    );
    assert_eq!(code(&o), Some(0), "{}", stderr(&o));
    assert_eq!(std::fs::read(&victim).unwrap(), b"precious");
    let o = frontseat(d.path(), &["log", "info", "run.mcap"]);
    assert_eq!(code(&o), Some(0), "{}", stderr(&o));
    assert!(
        String::from_utf8_lossy(&o.stdout).contains("end: closed properly"),
        "{}",
        String::from_utf8_lossy(&o.stdout)
    );
}
