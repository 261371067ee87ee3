//! `frontseat replay --onto gobyd` in the real binary, through the stand-in gobyd (the manager
//! handshake and XPUB/XSUB proxy recorded from gobyd 3.1.5a, on IPC sockets in a scratch
//! directory): a Goby3 helm-side client receives every recorded node_status, in order, paced as
//! recorded; a Goby3 client standing where a vehicle's interface would subscribe receives none
//! of the recording's desired_course (commands are never replayed).

mod common;

use common::goby3::goby3_client;

use frontseat_actors::bus::test_util::UntypedBus as _;
use std::path::Path;
use std::process::Stdio;
use std::time::Duration;

use common::procs::{Kill, scratch};
use frontseat_actors::bus::{Bus, Origin};
use frontseat_actors::groups;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{DesiredCourse, NodeStatus};
use frontseat_helm_side::goby3::Goby3Handle;
use frontseat_helm_side::goby3::standin::{StandinGobyd, StandinTransport};
use frontseat_record::recorder::{RecordMeta, Recorder, RecorderOptions};
use tokio::time::{Instant, timeout_at};

const LONG: Duration = Duration::from_secs(60);
/// Recorded interval between two node_status.
const STEP: Duration = Duration::from_millis(100);
const N: u32 = 10;

/// A recording of a vehicle: N node_status STEP apart, and a desired_course with each.
fn record(path: &Path) {
    let bus = Bus::new();
    let meta = RecordMeta {
        vehicle: "auv1".into(),
        ..Default::default()
    };
    let mut opts = RecorderOptions::file(path);
    // A few kilobytes: the disk guard must not stop this recording on a test machine whose temp
    // dir has little free (it has its own test, `a_disk_below_the_floor_stops_writing_and_counts_the_drops`, in record/tests/record_read_replay.rs).
    opts.min_free_bytes = 0;
    let rec = Recorder::start(&bus, opts, meta).unwrap();
    for i in 0..N {
        if i > 0 {
            // Making the data: the recorded intervals are what the replay must keep.
            std::thread::sleep(STEP);
        }
        let mut n = NodeStatus {
            time: 1000.0 + f64::from(i),
            name: Some("auv1".into()),
            ..Default::default()
        };
        n.global_fix.lat = 42.0 + f64::from(i) * 1e-4;
        n.global_fix.lon = -70.0;
        bus.publish(&groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS, n);
        bus.publish(
            &groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE,
            DesiredCourse {
                time: 1000.0 + f64::from(i),
                heading: Some(10.0),
                speed: Some(1.0),
                ..Default::default()
            },
        );
    }
    let until = std::time::Instant::now() + LONG;
    while rec.stats().written < u64::from(2 * N) {
        assert!(std::time::Instant::now() < until, "{:?}", rec.stats());
        std::thread::sleep(Duration::from_millis(5));
    }
    rec.stop();
}

async fn until_up(h: &Goby3Handle) {
    let deadline = Instant::now() + LONG;
    while !h.link_up() {
        assert!(
            Instant::now() < deadline,
            "the Goby3 client never joined gobyd"
        );
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_replay_reaches_goby3_clients_through_gobyd_with_its_timing_and_no_commands() {
    let dir = scratch("record", "replay_gobyd");
    let file = dir.join("run.mcap");
    let _ = std::fs::remove_file(&file);
    record(&file);
    let base = dir.join("goby_auv1").display().to_string();
    let gobyd = StandinGobyd::start(StandinTransport::Ipc { base: base.clone() }, &[])
        .await
        .unwrap();

    // Helm side: subscribes node_status (as goby_moos_gateway would for pHelmIvP).
    let helm_bus = Bus::new();
    let helm = goby3_client(
        &helm_bus,
        &base,
        "goby_moos_gateway",
        "FrontSeatTranslation",
    );
    let (_s, mut nav) =
        helm_bus.subscribe_channel(&groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS, "t", 1000);
    // Vehicle side: subscribes desired_course (as goby_frontseat_interface would).
    let vehicle_bus = Bus::new();
    let vehicle = goby3_client(
        &vehicle_bus,
        &base,
        "goby_frontseat_interface",
        "FrontSeatInterface",
    );
    let (_c, mut courses) =
        vehicle_bus.subscribe_channel(&groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE, "t", 1000);
    until_up(&helm).await;
    until_up(&vehicle).await;

    let log = dir.join("replay.log");
    let mut child = Kill(
        std::process::Command::new(env!("CARGO_BIN_EXE_frontseat"))
            .args(["replay", "--onto", "gobyd", "--goby-socket", &base])
            .arg(&file)
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(&log).unwrap())
            .spawn()
            .unwrap(),
    );
    let deadline = Instant::now() + LONG;
    let status = loop {
        if let Some(s) = child.0.try_wait().unwrap() {
            break s;
        }
        assert!(Instant::now() < deadline, "the replay did not end");
        tokio::time::sleep(Duration::from_millis(20)).await;
    };
    let err = std::fs::read_to_string(&log).unwrap_or_default();
    assert!(status.success(), "{err}");
    assert!(err.contains(&format!("replayed {N} messages")), "{err}");

    let mut got = Vec::new();
    let deadline = Instant::now() + LONG;
    while got.len() < N as usize {
        let env = timeout_at(deadline, nav.recv())
            .await
            .unwrap_or_else(|_| {
                let times: Vec<f64> = got.iter().map(|g: &(f64, _)| g.0).collect();
                panic!(
                    "{} of {N} node_status arrived ({times:?}); replay: {err}",
                    got.len()
                )
            })
            .unwrap();
        assert_eq!(env.origin, Origin::Goby3, "came in through gobyd");
        got.push((env.msg.time, env.published_at));
    }
    let times: Vec<f64> = got.iter().map(|g| g.0).collect();
    let want: Vec<f64> = (0..N).map(|i| 1000.0 + f64::from(i)).collect();
    assert_eq!(times, want, "every node_status, in order");
    // Paced as recorded: arrivals span at least most of the recorded 0.9 s (a replay that
    // dumped the file at once would arrive within a few ms). Slowness only lengthens it.
    let span = got[got.len() - 1].1 - got[0].1;
    assert!(
        span >= STEP * (N - 1) * 8 / 10,
        "arrivals spanned {span:?}, recorded {:?}",
        STEP * (N - 1)
    );
    assert!(
        courses.try_recv().is_err(),
        "a recorded desired_course reached a vehicle-side client"
    );
    helm.close().await;
    vehicle.close().await;
    gobyd.stop().await;
    let _ = std::fs::remove_dir_all(&dir);
}
