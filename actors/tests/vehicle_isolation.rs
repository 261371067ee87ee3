//! A slow or stuck helm side never delays the vehicle side, shown with real parts: the
//! FrontSeatInterface with the basic simulator's driver over loopback TCP to a frontseat on plain
//! OS threads, in a process whose async runtime the helm side has wedged — every worker thread
//! blocked by a helm-side task, and a bus subscriber that never reads. NAV must still reach the
//! interface's state machine (its node_status comes out), because the vehicle side runs on its own
//! thread (`frontseat-vehicle`), and each setpoint must still reach the vehicle's link (a course
//! in command is written by its publisher's thread through the setpoint lane; one that is not
//! would go through the vehicle thread).
//!
//! While the runtime is wedged its timers and I/O do not run, so this test waits on plain
//! `std::sync::mpsc` channels with `recv_timeout`; every wait has a deadline, and the blocked
//! workers are released at the end (or after their own bound).

mod common;

use common::frontseat::Frontseat;
use frontseat_actors::bus::test_util::UntypedBus as _;
use std::sync::{Arc, Mutex, mpsc};
use std::time::{Duration, Instant};

use frontseat_actors::bus::Bus;
use frontseat_actors::groups;
use frontseat_actors::interface::InterfaceService;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CommandRequest, DesiredCourse,
};
use frontseat_config::InterfaceConfig;

const WORKERS: usize = 2;
/// Each step on the vehicle side must happen within this, while the helm side is wedged.
const ON_TIME: Duration = Duration::from_secs(1);
/// How long the wedged workers stay blocked at most (they are released before).
const WEDGE_BOUND: Duration = Duration::from_secs(20);
const DEADLINE: Duration = Duration::from_secs(10);

/// Blocks every worker thread of the current runtime with a helm-side task that never yields,
/// until `release` is dropped (or WEDGE_BOUND passes); returns once all of them are blocked.
fn wedge_the_runtime() -> mpsc::Sender<()> {
    let (release_tx, release_rx) = mpsc::channel::<()>();
    let release_rx = Arc::new(Mutex::new(release_rx));
    let (blocked_tx, blocked_rx) = mpsc::channel();
    let all = Arc::new(std::sync::Barrier::new(WORKERS));
    for _ in 0..WORKERS {
        let (release_rx, blocked_tx, all) = (release_rx.clone(), blocked_tx.clone(), all.clone());
        tokio::spawn(async move {
            // Both workers reach this point before either reports: each holds its own.
            all.wait();
            let _ = blocked_tx.send(());
            let until = Instant::now() + WEDGE_BOUND;
            while Instant::now() < until {
                match release_rx
                    .lock()
                    .unwrap()
                    .recv_timeout(Duration::from_millis(50))
                {
                    Err(mpsc::RecvTimeoutError::Timeout) => {}
                    _ => return,
                }
            }
        });
    }
    for _ in 0..WORKERS {
        blocked_rx
            .recv_timeout(DEADLINE)
            .expect("the helm-side tasks block every worker");
    }
    release_tx
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_wedged_helm_side_never_delays_nav_or_setpoints() {
    let fs = Frontseat::start();
    let bus = Bus::new();
    let mut cfg = InterfaceConfig {
        name: "isolated-auv".into(),
        ..Default::default()
    };
    cfg.driver.basic_simulator.tcp_port = fs.port;
    // Observers that live on the vehicle side's thread: their deliver functions run on the
    // publisher's thread and hand over through std channels, which need no runtime.
    let (_status, status_rx) = common::frontseat::states(&bus);
    let (nav_tx, nav_rx) = mpsc::channel();
    let nav_tx = Mutex::new(nav_tx);
    let _nav = bus.subscribe(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS,
        "test-nav",
        1024,
        move |env| {
            let _ = nav_tx
                .lock()
                .unwrap()
                .send((env.msg.global_fix.depth(), Instant::now()));
            Ok(())
        },
    );
    // A stuck helm-side client: subscribed to everything the vehicle publishes, never reading.
    let (_stuck_ns, _never_read_ns) = bus.subscribe_channel(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS,
        "stuck-client",
        4,
    );
    let (_stuck_raw, _never_read_raw) =
        bus.subscribe_channel(&groups::GOBY_MIDDLEWARE_FRONTSEAT_RAW_IN, "stuck-client", 4);

    let service = InterfaceService::start(&cfg, &bus, frontseat_drivers::BUILT_IN)
        .await
        .expect("the interface starts");
    common::frontseat::drive_until_command(&bus, &status_rx, DEADLINE);

    // The helm side wedges the process's runtime: from here on no task of it runs.
    let release = wedge_the_runtime();
    while nav_rx.try_recv().is_ok() {}

    // NAV: the frontseat's next lines come out of the interface, through its gate and state
    // machine, on time.
    let mut fresh = 0;
    while fresh < 5 {
        let (_, at) = nav_rx
            .recv_timeout(ON_TIME)
            .expect("NAV reaches the interface while the helm side is wedged");
        assert!(at.elapsed() < ON_TIME);
        fresh += 1;
    }
    // Setpoints: each reaches the vehicle's link on time. Published from this (non-worker)
    // thread, as a helm's task would; the publish itself never waits.
    for i in 1..=5 {
        let sent = Instant::now();
        let report = bus.publish(
            &groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE,
            DesiredCourse {
                heading: Some(90.0),
                speed: Some(1.0),
                depth: Some(f64::from(i)),
                ..Default::default()
            },
        );
        assert!(
            report.delivered >= 1,
            "the interface subscribes to desired_course"
        );
        let (line, read) = fs
            .cmds
            .recv_timeout(ON_TIME)
            .expect("the setpoint reaches the vehicle while the helm side is wedged");
        assert!(line.contains(&format!("DEPTH:{i}")), "{line}");
        assert!(read.duration_since(sent) < ON_TIME);
    }
    // A command_request goes through both actors, on the vehicle thread: on time as well.
    let sent = Instant::now();
    bus.publish(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_COMMAND_REQUEST,
        CommandRequest {
            desired_course: Some(DesiredCourse {
                heading: Some(90.0),
                speed: Some(1.0),
                depth: Some(42.0),
                ..Default::default()
            }),
            ..Default::default()
        },
    );
    let (line, read) = fs
        .cmds
        .recv_timeout(ON_TIME)
        .expect("a command_request reaches the vehicle while the helm side is wedged");
    assert!(line.contains("DEPTH:42"), "{line}");
    assert!(read.duration_since(sent) < ON_TIME);
    // The stuck client missed what it did not read, counted, and held nothing up.
    assert!(
        bus.total_dropped() > 0,
        "the stuck client's misses are counted"
    );

    drop(release);
    tokio::time::timeout(DEADLINE, service.shutdown(Duration::from_secs(2)))
        .await
        .expect("an orderly shutdown once the runtime runs again");
}
