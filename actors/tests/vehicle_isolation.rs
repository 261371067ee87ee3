//! A slow or stuck helm side never delays the vehicle side, shown with real parts: the
//! FrontSeatInterface with the basic simulator's driver over loopback TCP to a frontseat on plain
//! OS threads, in a process whose async runtime the helm side has wedged — every worker thread
//! blocked by a helm-side task, and a bus subscriber that never reads. NAV must still reach the
//! interface's state machine (its node_status comes out) and each setpoint must still reach the
//! vehicle's link, because the vehicle side runs on its own thread (`frontseat-vehicle`).
//!
//! While the runtime is wedged its timers and I/O do not run, so this test waits on plain
//! `std::sync::mpsc` channels with `recv_timeout`; every wait has a deadline, and the blocked
//! workers are released at the end (or after their own bound).

use frontseat_actors::bus::test_util::UntypedBus as _;
use std::io::{BufRead, BufReader, Write};
use std::net::{Ipv4Addr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, mpsc};
use std::time::{Duration, Instant};

use frontseat_actors::bus::Bus;
use frontseat_actors::groups;
use frontseat_actors::interface::InterfaceService;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    DesiredCourse, HelmState, HelmStateReport, InterfaceState,
};
use frontseat_config::InterfaceConfig;

const WORKERS: usize = 2;
/// Each step on the vehicle side must happen within this, while the helm side is wedged.
const ON_TIME: Duration = Duration::from_secs(1);
/// How long the wedged workers stay blocked at most (they are released before).
const WEDGE_BOUND: Duration = Duration::from_secs(20);
const DEADLINE: Duration = Duration::from_secs(10);

/// A basic-simulator frontseat on plain threads: answers START with PAYLOAD, acknowledges every
/// CMD (and reports it), and writes a NAV line every 20 ms.
struct Frontseat {
    port: u16,
    cmds: mpsc::Receiver<(String, Instant)>,
    stop: Arc<AtomicBool>,
}

impl Frontseat {
    fn start() -> Self {
        let listener = TcpListener::bind((Ipv4Addr::LOCALHOST, 0)).unwrap();
        let port = listener.local_addr().unwrap().port();
        let stop = Arc::new(AtomicBool::new(false));
        let (tx, cmds) = mpsc::channel();
        let halt = stop.clone();
        std::thread::spawn(move || {
            let Ok((stream, _)) = listener.accept() else {
                return;
            };
            stream.set_nodelay(true).unwrap();
            let conn = Arc::new(Mutex::new(stream.try_clone().unwrap()));
            let send = |c: &Mutex<TcpStream>, line: &str| {
                c.lock().unwrap().write_all(line.as_bytes()).is_ok()
            };
            let (nav_conn, nav_halt) = (conn.clone(), halt.clone());
            std::thread::spawn(move || {
                let mut n = 0u64;
                while !nav_halt.load(Ordering::Acquire) {
                    n += 1;
                    // 0.1 m a line at 50 Hz: 5 m/s, inside the navigation gate's depth-rate
                    // bound, so every line is a NAV the interface takes.
                    let line = format!(
                        "NAV,LAT:42.358456,LON:-71.087589,DEPTH:{:.1},HEADING:90,SPEED:1.5\r\n",
                        n as f64 * 0.1
                    );
                    if !send(&nav_conn, &line) {
                        return;
                    }
                    std::thread::sleep(Duration::from_millis(20));
                }
            });
            for line in BufReader::new(stream).lines() {
                let Ok(line) = line else { return };
                if line.starts_with("START,") {
                    send(&conn, "CTRL,STATE:PAYLOAD\r\n");
                } else if line.starts_with("CMD,") {
                    let _ = tx.send((line, Instant::now()));
                    send(&conn, "CMD,RESULT:OK\r\n");
                }
                if halt.load(Ordering::Acquire) {
                    return;
                }
            }
        });
        Self { port, cmds, stop }
    }
}

impl Drop for Frontseat {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Release);
    }
}

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
    let (status_tx, status_rx) = mpsc::channel();
    let status_tx = Mutex::new(status_tx);
    let _status = bus.subscribe(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_STATUS,
        "test-status",
        1024,
        move |env| {
            let _ = status_tx.lock().unwrap().send(env.msg.state());
            Ok(())
        },
    );
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
    bus.publish(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_HELM_STATE,
        HelmStateReport {
            state: HelmState::HelmDrive as i32,
        },
    );
    let until = Instant::now() + DEADLINE;
    loop {
        let left = until.saturating_duration_since(Instant::now());
        if status_rx
            .recv_timeout(left)
            .expect("a status within the deadline")
            == InterfaceState::InterfaceCommand
        {
            break;
        }
    }

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
