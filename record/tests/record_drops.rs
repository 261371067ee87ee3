//! Recorder drops are visible while the process runs, not only in the file: a recorder whose
//! queue overflows counts the drops in the process metrics (`frontseat.record.dropped`, and the
//! `record_dropped` of every interface's detail status, which reads the same counter) and in the
//! closing metadata of its file, and the two agree. One test in this binary: the metrics are
//! process-wide.

use frontseat_actors::bus::test_util::UntypedBus as _;
use std::time::Duration;

use frontseat_actors::bus::Bus;
use frontseat_actors::groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS as NODE_STATUS;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::NodeStatus;
use frontseat_record::recorder::{RecordMeta, Recorder, RecorderOptions};
use frontseat_record::{META_RECORDER, Recording, info};
use frontseat_telemetry::metrics;

#[test]
fn an_overflowing_queue_counts_its_drops_in_the_metrics_and_the_file() {
    assert_eq!(
        metrics::recorder_drops_if_recording(),
        None,
        "not recording yet"
    );
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("drops.mcap");
    let bus = Bus::new();
    let mut o = RecorderOptions::file(&path);
    o.queue = 16;
    // About the queue, not the disk: a CI machine with little free space in its temp dir (the
    // recorder stops writing below half of min_free_mb) must not turn every message into a drop.
    o.min_free_bytes = 0;
    let rec = Recorder::start(&bus, o, RecordMeta::default()).unwrap();
    assert_eq!(metrics::recorder_drops_if_recording(), Some(0));
    // Bursts far faster than a 16-message queue drains; bounded number of tries.
    let mut published = 0u64;
    for _ in 0..200 {
        for i in 0..2000u32 {
            let n = NodeStatus {
                time: f64::from(i),
                name: Some("auv1".into()),
                ..Default::default()
            };
            bus.publish(&NODE_STATUS, n);
            published += 1;
        }
        if rec.stats().dropped_queue > 0 {
            break;
        }
    }
    let until = std::time::Instant::now() + Duration::from_secs(20);
    while rec.stats().written + rec.stats().dropped() < published {
        assert!(std::time::Instant::now() < until, "{:?}", rec.stats());
        std::thread::sleep(Duration::from_millis(5));
    }
    let live = rec.stats();
    assert!(
        live.dropped_queue > 0,
        "the queue never overflowed: {live:?}"
    );
    assert_eq!(
        metrics::recorder_drops_if_recording(),
        Some(live.dropped()),
        "the metrics say what the recorder counted, while it runs"
    );
    let s = rec.stop();
    assert_eq!(s.written + s.dropped(), published);

    let i = info::info(Recording::open(&path).unwrap()).unwrap();
    assert_eq!(i.dropped, Some(s.dropped()), "the file's metadata");
    assert_eq!(i.messages, s.written);
    let mut r = Recording::open(&path).unwrap();
    while r.next_message().unwrap().is_some() {}
    let closing = r
        .metadata()
        .iter()
        .find(|(n, _)| n == META_RECORDER)
        .map(|(_, m)| m.clone())
        .expect("closing metadata");
    assert_eq!(closing["dropped_queue"], s.dropped_queue.to_string());
    // Still reported after the recorder stopped: the drops happened in this run.
    assert_eq!(metrics::recorder_drops_if_recording(), Some(s.dropped()));
}
