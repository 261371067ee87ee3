//! The recorder, reader and replay against each other on a real bus and real files: what is
//! recorded reads back (self-described), the budget removes old files, a torn file reads to
//! its last chunk, and a replay keeps order and timing.

use frontseat_actors::bus::test_util::UntypedBus as _;
use std::time::Duration;

use frontseat_actors::bus::{Bus, Origin};
use frontseat_actors::groups::{
    GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE as DESIRED,
    GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS as NODE_STATUS,
};
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{DesiredCourse, NodeStatus};
use frontseat_record::recorder::{RecordMeta, Recorder, RecorderOptions, Target};
use frontseat_record::replay::{ReplayOptions, Speed, replay};
use frontseat_record::{Recording, export, info};

fn node_status(i: u32) -> NodeStatus {
    let mut n = NodeStatus {
        time: 1000.0 + f64::from(i),
        name: Some("auv1".into()),
        ..Default::default()
    };
    n.global_fix.lat = 42.0 + f64::from(i) * 1e-5;
    n.global_fix.lon = -71.0;
    n.pose.heading = Some(f64::from(i % 360));
    n
}

/// A file recorder that writes however little the test machine's disk has free: these tests
/// record a few kilobytes, and the disk guard (below half of `min_free_mb` the recorder stops
/// writing) has its own test, `a_disk_below_the_floor_stops_writing_and_counts_the_drops`.
fn small_file(path: impl Into<std::path::PathBuf>) -> RecorderOptions {
    let mut o = RecorderOptions::file(path);
    o.min_free_bytes = 0;
    o
}

fn meta() -> RecordMeta {
    RecordMeta {
        vehicle: "auv1".into(),
        datum_lat: 42.0,
        datum_lon: -71.0,
        config_digest: "fnv1a64:0".into(),
        version: "test".into(),
        driver: "basic_simulator".into(),
        ..Default::default()
    }
}

/// Waits (bounded) until the recorder has taken `n` messages off the bus.
fn wait_written(r: &Recorder, n: u64) {
    let until = std::time::Instant::now() + Duration::from_secs(10);
    while r.stats().written + r.stats().dropped() < n {
        assert!(
            std::time::Instant::now() < until,
            "recorder stuck: {:?}",
            r.stats()
        );
        std::thread::sleep(Duration::from_millis(5));
    }
}

#[test]
fn recorded_messages_read_back_with_their_schema_metadata_and_origin() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("run.mcap");
    let bus = Bus::new();
    let rec = Recorder::start(&bus, small_file(&path), meta()).unwrap();
    assert!(
        rec.groups().contains(&NODE_STATUS.name()),
        "both layers, every group"
    );
    assert!(
        rec.groups()
            .iter()
            .any(|g| g.starts_with("frontseat::driver")),
        "interthread too"
    );
    for i in 0..200 {
        bus.publish(&NODE_STATUS, node_status(i));
    }
    bus.publish_with(
        &DESIRED,
        std::sync::Arc::new(DesiredCourse {
            time: 5.0,
            speed: Some(1.5),
            ..Default::default()
        }),
        frontseat_actors::bus::PublishMeta {
            trace: None,
            origin: Origin::Imported,
        },
    );
    wait_written(&rec, 201);
    let stats = rec.stop();
    assert_eq!((stats.written, stats.dropped()), (201, 0), "{stats:?}");

    let i = info::info(Recording::open(&path).unwrap()).unwrap();
    assert_eq!(i.messages, 201);
    assert_eq!(i.truncated, None, "closed properly");
    assert_eq!(i.dropped, Some(0));
    assert_eq!(i.run.get("vehicle").map(String::as_str), Some("auv1"));
    assert_eq!(
        i.run.get("driver").map(String::as_str),
        Some("basic_simulator")
    );
    let ns = i
        .groups
        .iter()
        .find(|g| g.group == NODE_STATUS.name())
        .unwrap();
    assert_eq!(ns.count, 200);
    assert_eq!(
        ns.type_name,
        "goby.middleware.frontseat.protobuf.NodeStatus"
    );
    let dc = i.groups.iter().find(|g| g.group == DESIRED.name()).unwrap();
    assert_eq!(dc.not_local, 1, "the imported origin is kept");
    assert!(
        i.render()
            .contains("goby::middleware::frontseat::node_status")
    );

    // Decoded from the file's own schema: fields flattened by path.
    let mut csv = Vec::new();
    let done = export::export(
        Recording::open(&path).unwrap(),
        NODE_STATUS.name(),
        export::Format::Csv,
        &mut csv,
    )
    .unwrap();
    assert_eq!(done.rows, 200);
    let csv = String::from_utf8(csv).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let lat = header
        .iter()
        .position(|h| *h == "global_fix.lat")
        .expect("flattened column");
    let heading = header.iter().position(|h| *h == "pose.heading").unwrap();
    let row: Vec<&str> = lines.nth(7).unwrap().split(',').collect();
    assert_eq!(row[heading], "7.0");
    assert!(row[lat].starts_with("42.00007"), "{}", row[lat]);
    let mut json = Vec::new();
    export::export(
        Recording::open(&path).unwrap(),
        DESIRED.name(),
        export::Format::Json,
        &mut json,
    )
    .unwrap();
    let v: serde_json::Value =
        serde_json::from_slice(json.split(|b| *b == b'\n').next().unwrap()).unwrap();
    assert_eq!(v["msg"]["speed"], 1.5);
    assert!(matches!(
        export::export(
            Recording::open(&path).unwrap(),
            "no::such",
            export::Format::Json,
            &mut Vec::new()
        ),
        Err(export::ExportError::NoSuchGroup(_))
    ));
}

#[test]
fn include_and_exclude_choose_groups() {
    let dir = tempfile::tempdir().unwrap();
    let mut o = small_file(dir.path().join("x.mcap"));
    o.include = vec![regex::Regex::new("^goby::").unwrap()];
    o.exclude = vec![regex::Regex::new("desired_course$").unwrap()];
    let bus = Bus::new();
    let rec = Recorder::start(&bus, o, meta()).unwrap();
    assert!(rec.groups().contains(&NODE_STATUS.name()));
    assert!(!rec.groups().contains(&DESIRED.name()));
    assert!(rec.groups().iter().all(|g| g.starts_with("goby::")));
}

#[test]
fn a_file_cut_mid_chunk_reads_up_to_its_last_whole_chunk() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("torn.mcap");
    let bus = Bus::new();
    let mut o = small_file(&path);
    o.flush = Duration::from_millis(50);
    let rec = Recorder::start(&bus, o, meta()).unwrap();
    for i in 0..100 {
        bus.publish(&NODE_STATUS, node_status(i));
    }
    wait_written(&rec, 100);
    // Wait (bounded) for the flush to put the chunk on disk, then copy the file as a crash
    // would leave it, with half a record of garbage after it.
    let until = std::time::Instant::now() + Duration::from_secs(10);
    let mut bytes;
    loop {
        bytes = std::fs::read(&path).unwrap();
        let n = info::info(Recording::new(bytes.as_slice()))
            .map(|i| i.messages)
            .unwrap_or(0);
        if n == 100 {
            break;
        }
        assert!(
            std::time::Instant::now() < until,
            "no chunk flushed within 10 s"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    drop(rec);
    bytes.extend_from_slice(&[0x06, 0xff, 0xff, 0, 0, 0, 0, 0, 0, 1, 2, 3]);
    let i = info::info(Recording::new(bytes.as_slice())).unwrap();
    assert_eq!(i.messages, 100);
    assert!(i.truncated.is_some());
    assert_eq!(i.dropped, None, "unknown when the file was not closed");
}

#[test]
fn a_disk_below_the_floor_stops_writing_and_counts_the_drops() {
    // No disk has this much free, so the guard trips at start: the file is closed (and readable,
    // its metadata says nothing was written) and every message is a counted drop, not an error.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("full.mcap");
    let bus = Bus::new();
    let mut o = RecorderOptions::file(&path);
    o.min_free_bytes = u64::MAX;
    let rec = Recorder::start(&bus, o, meta()).unwrap();
    for i in 0..10 {
        bus.publish(&NODE_STATUS, node_status(i));
    }
    wait_written(&rec, 10);
    let s = rec.stop();
    assert_eq!(s.written, 0, "{s:?}");
    assert_eq!(s.dropped_unwritable, 10, "{s:?}");
    assert!(s.disk_low >= 1, "{s:?}");
    let i = info::info(Recording::open(&path).unwrap()).unwrap();
    assert_eq!(i.messages, 0);
    assert_eq!(
        i.dropped,
        Some(0),
        "closed when the disk ran low, before any drop"
    );
}

#[test]
fn a_tiny_budget_keeps_removing_the_oldest_files() {
    let dir = tempfile::tempdir().unwrap();
    let bus = Bus::new();
    let mut o = RecorderOptions::file("unused");
    o.target = Target::Dir {
        dir: dir.path().to_path_buf(),
        prefix: "auv1".into(),
    };
    // Every message starts a new file (the header alone is past 1 byte); each file is a few
    // KiB (the NodeStatus schema), so the budget holds a handful of the 30.
    o.rotate_bytes = 1;
    o.budget_bytes = 20_000;
    o.min_free_bytes = 0;
    let rec = Recorder::start(&bus, o, meta()).unwrap();
    for i in 0..30 {
        bus.publish(&NODE_STATUS, node_status(i));
        wait_written(&rec, u64::from(i) + 1);
    }
    let stats = rec.stop();
    assert!(stats.files_opened >= 30, "{stats:?}");
    assert!(stats.files_removed > 0, "{stats:?}");
    let files: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap())
        .collect();
    let total: u64 = files.iter().map(|e| e.metadata().unwrap().len()).sum();
    // The budget is checked when a file is opened, so the last closed file may overshoot it.
    let largest = files
        .iter()
        .map(|e| e.metadata().unwrap().len())
        .max()
        .unwrap();
    assert!(files.len() < 30, "{} files", files.len());
    assert!(total <= 20_000 + largest, "{total} bytes kept");
    for f in &files {
        let name = f.file_name().into_string().unwrap();
        assert!(
            name.starts_with("auv1_") && name.ends_with(".mcap"),
            "{name}"
        );
        assert!(
            info::info(Recording::open(&f.path()).unwrap())
                .unwrap()
                .truncated
                .is_none()
        );
    }
}

#[tokio::test(start_paused = true)]
async fn replay_keeps_order_and_timing_and_marks_origin() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("vehicle.mcap");
    {
        // Record node_status at 10 Hz (real time: the recorder stamps with the bus's clock).
        let bus = Bus::new();
        let rec = Recorder::start(&bus, small_file(&path), meta()).unwrap();
        for i in 0..20 {
            bus.publish(&NODE_STATUS, node_status(i));
            bus.publish(&DESIRED, DesiredCourse::default());
            std::thread::sleep(Duration::from_millis(10));
        }
        wait_written(&rec, 40);
        rec.stop();
    }
    let rec_times: Vec<u64> = {
        let mut r = Recording::open(&path).unwrap();
        let mut v = Vec::new();
        while let Some(m) = r.next_message().unwrap() {
            if &*r.channel(m.channel_id).unwrap().topic == NODE_STATUS.name() {
                v.push(m.log_time);
            }
        }
        v
    };
    assert_eq!(rec_times.len(), 20);

    let bus = Bus::new();
    let (_s, mut rx) = bus.subscribe_channel(&NODE_STATUS, "helm", 100);
    let (_d, mut drx) = bus.subscribe_channel(&DESIRED, "vehicle", 100);
    let opts = ReplayOptions {
        speed: Speed::Factor(2.0),
        ..Default::default()
    };
    let start = tokio::time::Instant::now();
    let stats = tokio::time::timeout(Duration::from_secs(60), replay(&bus, &path, &opts))
        .await
        .expect("replay ends")
        .unwrap();
    assert_eq!(stats.published, 20);
    assert_eq!(
        stats.skipped, 20,
        "desired_course commands a vehicle: never replayed"
    );
    assert!(drx.try_recv().is_err());
    let mut got = Vec::new();
    while let Ok(e) = rx.try_recv() {
        assert_eq!(e.origin, Origin::Replayed);
        got.push((e.msg.time, e.published_at));
    }
    assert_eq!(got.len(), 20);
    for (i, (t, _)) in got.iter().enumerate() {
        assert_eq!(*t, 1000.0 + i as f64, "order kept");
    }
    // At speed 2 the replay lasts half the recorded span (paused clock: exact).
    let span = Duration::from_nanos(rec_times[19] - rec_times[0]);
    let took = tokio::time::Instant::now() - start;
    let want = span / 2;
    assert!(
        took >= want && took <= want + Duration::from_millis(2),
        "took {took:?}, want {want:?}"
    );
}

#[tokio::test(start_paused = true)]
async fn replay_window_and_group_filter() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("w.mcap");
    {
        let bus = Bus::new();
        let rec = Recorder::start(&bus, small_file(&path), meta()).unwrap();
        for i in 0..30 {
            bus.publish(&NODE_STATUS, node_status(i));
            std::thread::sleep(Duration::from_millis(10));
        }
        wait_written(&rec, 30);
        rec.stop();
    }
    let bus = Bus::new();
    let (_s, mut rx) = bus.subscribe_channel(&NODE_STATUS, "helm", 100);
    // The middle of the recording only: roughly messages 10..=20 (10 ms apart).
    let opts = ReplayOptions {
        speed: Speed::Max,
        from_s: Some(0.095),
        to_s: Some(0.205),
        ..Default::default()
    };
    let s = replay(&bus, &path, &opts).await.unwrap();
    let mut got = Vec::new();
    while let Ok(e) = rx.try_recv() {
        got.push(e.msg.time - 1000.0);
    }
    assert_eq!(s.published as usize, got.len());
    assert!(!got.is_empty() && got.len() < 30, "{got:?}");
    assert!(
        got.windows(2).all(|w| w[1] == w[0] + 1.0),
        "contiguous and in order: {got:?}"
    );
    assert!(got[0] >= 5.0 && *got.last().unwrap() <= 25.0, "{got:?}");
    // A group regex that matches nothing replays nothing (and does not loop forever).
    let bus = Bus::new();
    let opts = ReplayOptions {
        speed: Speed::Max,
        groups: Some(regex::Regex::new("^no_such_group$").unwrap()),
        looped: true,
        ..Default::default()
    };
    let s = tokio::time::timeout(Duration::from_secs(5), replay(&bus, &path, &opts))
        .await
        .expect("an empty loop ends")
        .unwrap();
    assert_eq!((s.published, s.skipped), (0, 30));
}

#[test]
fn an_unwritable_disk_degrades_the_recorder_never_the_publisher() {
    // /proc takes no new file, for root either: a disk that refuses from the start. (The
    // recorder only ever creates new files, so /dev/full, an existing file, is not a target.)
    let path = std::path::Path::new("/proc/self/frontseat-record-test.mcap");
    let bus = Bus::new();
    let mut o = RecorderOptions::file(path);
    o.min_free_bytes = 0;
    let rec = Recorder::start(&bus, o, meta()).expect("a full disk does not fail the start");
    let t0 = std::time::Instant::now();
    for i in 0..1000 {
        let r = bus.publish(&NODE_STATUS, node_status(i));
        assert_eq!(r.dropped, 0, "the bus never drops for the recorder");
    }
    assert!(
        t0.elapsed() < Duration::from_secs(5),
        "publishing was slowed"
    );
    wait_written(&rec, 1000);
    let s = rec.stop();
    assert_eq!(s.written, 0);
    assert_eq!(s.dropped(), 1000, "{s:?}");
    assert!(s.write_errors >= 1, "{s:?}");
    assert_eq!(s.files_opened, 0);
}

#[test]
fn plot_reads_the_interface_state_as_a_band_of_its_changes() {
    use frontseat_actors::groups::GOBY_MIDDLEWARE_FRONTSEAT_STATUS as STATUS;
    use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
        InterfaceState, InterfaceStatus,
    };
    use frontseat_record::plot;
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("run.mcap");
    let bus = Bus::new();
    let rec = Recorder::start(&bus, small_file(&path), meta()).unwrap();
    let status = |s: InterfaceState| InterfaceStatus {
        state: Some(s as i32),
        ..Default::default()
    };
    let mut n = 0;
    for (i, s) in [
        InterfaceState::InterfaceListen,
        InterfaceState::InterfaceListen,
        InterfaceState::InterfaceCommand,
        InterfaceState::InterfaceCommand,
        InterfaceState::InterfaceHelmError,
    ]
    .into_iter()
    .enumerate()
    {
        bus.publish(&NODE_STATUS, node_status(i as u32));
        bus.publish(&STATUS, status(s));
        n += 2;
    }
    bus.publish(
        &DESIRED,
        DesiredCourse {
            time: 5.0,
            heading: Some(90.0),
            ..Default::default()
        },
    );
    wait_written(&rec, n + 1);
    rec.stop();

    let s = plot::series(Recording::open(&path).unwrap()).unwrap();
    let states: Vec<&str> = s.states.iter().map(|c| c.state.as_str()).collect();
    assert_eq!(
        states,
        [
            "INTERFACE_LISTEN",
            "INTERFACE_COMMAND",
            "INTERFACE_HELM_ERROR"
        ],
        "changes only, named from the file's schema"
    );
    assert!(s.states.windows(2).all(|w| w[0].t <= w[1].t));
    let svg = plot::time_svg(&s);
    let drawn: Vec<&str> = svg
        .lines()
        .filter(|l| l.starts_with(r#"<rect class="state""#))
        .filter_map(|l| l.split("data-state=\"").nth(1)?.split('"').next())
        .collect();
    assert_eq!(drawn, states, "{svg}");
    assert!(svg.contains(r##"data-state="INTERFACE_COMMAND" "##) && svg.contains("#31a354"));
    assert_eq!(s.actual.len(), 5);
    assert_eq!(s.commanded.len(), 1);
    assert!(!svg.contains("NaN"));
}
