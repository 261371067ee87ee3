//! The recorder's files against what is already on the disk (issue 37, item 2): a fixed
//! `path` that exists is kept byte for byte and the run records to a new name; a symlink planted
//! under the name is never followed; retention removes only the files the recorder named itself
//! (exact pattern, regular files); `replace` (the demo's `--force`) renames onto the file at the
//! end without following a planted `.part`.

use frontseat_actors::bus::Bus;
use frontseat_actors::bus::test_util::UntypedBus as _;
use frontseat_actors::groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS as NODE_STATUS;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::NodeStatus;
use frontseat_record::recorder::{RecordMeta, Recorder, RecorderOptions, Target, is_ours};
use frontseat_record::{Recording, info};
use std::path::Path;
use std::time::Duration;

fn node_status(i: u32) -> NodeStatus {
    NodeStatus {
        time: 1000.0 + f64::from(i),
        name: Some("auv1".into()),
        ..Default::default()
    }
}

fn opts(path: &Path) -> RecorderOptions {
    let mut o = RecorderOptions::file(path);
    o.min_free_bytes = 0;
    o
}

fn meta() -> RecordMeta {
    RecordMeta {
        vehicle: "auv1".into(),
        ..Default::default()
    }
}

fn wait_written(r: &Recorder, n: u64) {
    let until = std::time::Instant::now() + Duration::from_secs(10);
    while r.stats().written + r.stats().dropped() < n {
        assert!(std::time::Instant::now() < until, "stuck: {:?}", r.stats());
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// Records `n` node_status into `o`; the file the recorder wrote.
fn record(o: RecorderOptions, n: u32) -> std::path::PathBuf {
    let bus = Bus::new();
    let rec = Recorder::start(&bus, o, meta()).unwrap();
    for i in 0..n {
        bus.publish(&NODE_STATUS, node_status(i));
    }
    wait_written(&rec, u64::from(n));
    let file = rec.current_file().expect("a file was opened");
    let s = rec.stop();
    assert_eq!(s.written, u64::from(n), "{s:?}");
    file
}

fn messages(p: &Path) -> u64 {
    info::info(Recording::open(p).unwrap()).unwrap().messages
}

#[test]
fn a_fixed_path_that_exists_is_kept_and_the_run_records_to_a_new_name() {
    let d = tempfile::tempdir().unwrap();
    let path = d.path().join("run.mcap");
    let first = record(opts(&path), 3);
    assert_eq!(first, path);
    let before = std::fs::read(&path).unwrap();
    // The restart with the same config: the first file stays as it was.
    let second = record(opts(&path), 5);
    assert_eq!(second, d.path().join("run.1.mcap"));
    let third = record(opts(&path), 7);
    assert_eq!(third, d.path().join("run.2.mcap"));
    assert_eq!(
        std::fs::read(&path).unwrap(),
        before,
        "the first file is untouched"
    );
    assert_eq!(
        (messages(&path), messages(&second), messages(&third)),
        (3, 5, 7)
    );
}

#[test]
fn a_symlink_planted_under_the_record_name_is_not_followed() {
    let d = tempfile::tempdir().unwrap();
    let victim = d.path().join("victim.txt");
    std::fs::write(&victim, b"not a recording").unwrap();
    let path = d.path().join("run.mcap");
    std::os::unix::fs::symlink(&victim, &path).unwrap();
    // A dangling one too: O_CREAT alone would create its target.
    let dangling_target = d.path().join("created-through-a-link");
    std::os::unix::fs::symlink(&dangling_target, d.path().join("run.1.mcap")).unwrap();
    let file = record(opts(&path), 2);
    assert_eq!(file, d.path().join("run.2.mcap"));
    assert_eq!(std::fs::read(&victim).unwrap(), b"not a recording");
    assert!(!dangling_target.exists());
    assert_eq!(messages(&file), 2);
}

#[test]
fn retention_removes_only_the_files_the_recorder_named() {
    let d = tempfile::tempdir().unwrap();
    let dir = d.path().join("rec");
    std::fs::create_dir(&dir).unwrap();
    // Not ours, though each starts with `auv1_` and ends with `.mcap`.
    let keep = [
        "auv1_survey_final.mcap",
        "auv1_20260101T000000Z_0001.mcap.bak",
        "auv1_20260101T000000Z_1.mcap",
        "auv1_2026010T000000Z_0001.mcap",
        "auv1x_20260101T000000Z_0001.mcap",
    ];
    for k in keep {
        std::fs::write(dir.join(k), vec![7u8; 50_000]).unwrap();
    }
    // Named as ours, but a symlink (to a file outside) and a directory: never removed.
    let outside = d.path().join("precious.mcap");
    std::fs::write(&outside, vec![1u8; 50_000]).unwrap();
    std::os::unix::fs::symlink(&outside, dir.join("auv1_20200101T000000Z_0001.mcap")).unwrap();
    std::fs::create_dir(dir.join("auv1_20200101T000000Z_0002.mcap")).unwrap();

    let mut o = opts(Path::new("unused"));
    o.target = Target::Dir {
        dir: dir.clone(),
        prefix: "auv1".into(),
    };
    o.rotate_bytes = 1;
    o.budget_bytes = 20_000;
    let bus = Bus::new();
    let rec = Recorder::start(&bus, o, meta()).unwrap();
    for i in 0..20 {
        bus.publish(&NODE_STATUS, node_status(i));
        wait_written(&rec, u64::from(i) + 1);
    }
    let s = rec.stop();
    assert!(s.files_removed > 0, "{s:?}");
    for k in keep {
        assert_eq!(std::fs::metadata(dir.join(k)).unwrap().len(), 50_000, "{k}");
    }
    assert!(
        std::fs::symlink_metadata(dir.join("auv1_20200101T000000Z_0001.mcap"))
            .unwrap()
            .file_type()
            .is_symlink()
    );
    assert_eq!(std::fs::read(&outside).unwrap(), vec![1u8; 50_000]);
    assert!(dir.join("auv1_20200101T000000Z_0002.mcap").is_dir());
    let ours = std::fs::read_dir(&dir)
        .unwrap()
        .filter(|e| {
            let e = e.as_ref().unwrap();
            e.file_type().unwrap().is_file() && is_ours(e.file_name().to_str().unwrap(), "auv1")
        })
        .count();
    assert!(ours < 20, "{ours} of our files kept");
}

#[test]
fn the_pattern_is_exact() {
    assert!(is_ours("auv1_20261127T120000Z_0001.mcap", "auv1"));
    assert!(is_ours("auv1_20261127T120000Z_12345.mcap", "auv1"));
    for n in [
        "auv1_survey_final.mcap",
        "auv1_20261127T120000Z_0001.mcap.part",
        "auv1_20261127T120000_0001.mcap",
        "auv1_20261127T120000Z_001.mcap",
        "auv1_20261127T120000Z_0001_x.mcap",
        "auv2_20261127T120000Z_0001.mcap",
        "auv1_20261127T12000aZ_0001.mcap",
    ] {
        assert!(!is_ours(n, "auv1"), "{n}");
    }
}

#[test]
fn replace_renames_onto_the_file_at_the_end_and_never_follows_a_planted_part() {
    let d = tempfile::tempdir().unwrap();
    let path = d.path().join("demo.mcap");
    std::fs::write(&path, b"an old run").unwrap();
    let victim = d.path().join("victim");
    std::fs::write(&victim, b"keep me").unwrap();
    std::os::unix::fs::symlink(&victim, d.path().join("demo.mcap.part")).unwrap();
    let mut o = opts(&path);
    o.replace = true;
    let temp = record(o, 4);
    // Recorded under a temporary name beside it, stepping over the planted `.part`.
    let t = temp.file_name().unwrap().to_str().unwrap();
    assert!(
        t.starts_with("demo.mcap.") && t.ends_with(".part") && t != "demo.mcap.part",
        "{t}"
    );
    assert_eq!(messages(&path), 4);
    assert_eq!(std::fs::read(&victim).unwrap(), b"keep me");
    // Only the planted link is left beside it: the temporary file was renamed.
    let mut names: Vec<_> = std::fs::read_dir(d.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    assert_eq!(names, ["demo.mcap", "demo.mcap.part", "victim"]);
}
