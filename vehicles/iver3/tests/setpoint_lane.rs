//! The setpoint lane for the Iver3 (ARCHITECTURE.md "The lane per vehicle family"): the real
//! interface with the real Iver3 driver, over a real pseudo-terminal (and loopback TCP, as a
//! serial-over-IP adapter) to the Iver3 emulator, courses published from plain threads as a
//! helm's task would.
//!
//! What must hold: a course in command is written as `$OMS` by its publisher's thread (counted
//! as such); whatever path each setpoint takes — the lane, or the actors for a command_request
//! or a refused course — the UVC reads them in the order they were published; a refused course
//! never reaches it; every command_request that asked for an answer gets exactly one.

use std::collections::HashMap;
use std::net::SocketAddr;
use std::sync::mpsc;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use frontseat_actors::bus::Bus;
use frontseat_actors::bus::test_util::UntypedBus as _;
use frontseat_actors::groups;
use frontseat_actors::interface::{InterfaceService, Snapshot};
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CommandRequest, DesiredCourse, HelmState, HelmStateReport, InterfaceState,
};
use frontseat_config::InterfaceConfig;
use frontseat_iver3::codec::Sentence;
use frontseat_iver3::{IverOptions, IverSession};
use frontseat_sim::emulator::{Emulator, Endpoint, Session};

const DEADLINE: Duration = Duration::from_secs(20);

/// The emulated UVC, keeping the depth of every `$OMS` it reads, in order (Remote Helm 5:
/// metres on the wire, so the depth is the sequence number).
struct Recording {
    inner: IverSession,
    line: Vec<u8>,
    oms: mpsc::Sender<f64>,
}

impl Session for Recording {
    fn on_bytes(&mut self, bytes: &[u8], out: &mut Vec<u8>) {
        for &b in bytes {
            if b == b'\n' {
                let text = String::from_utf8_lossy(&self.line).trim().to_string();
                self.line.clear();
                if let Ok(Sentence::Oms(o)) = Sentence::parse(&text) {
                    let _ = self.oms.send(o.depth);
                }
            } else if self.line.len() < 1024 {
                self.line.push(b);
            }
        }
        self.inner.on_bytes(bytes, out);
    }
    fn step(&mut self, dt: f64, out: &mut Vec<u8>) {
        self.inner.step(dt, out);
    }
    fn reset_input(&mut self) {
        self.line.clear();
        self.inner.reset_input();
    }
}

fn course(depth: f64, speed: f64) -> DesiredCourse {
    DesiredCourse {
        heading: Some(90.0),
        speed: Some(speed),
        depth: Some(depth),
        ..Default::default()
    }
}

struct Rig {
    _emu: Emulator<Recording>,
    oms: mpsc::Receiver<f64>,
    bus: Bus,
    service: InterfaceService,
    before: Snapshot,
    helm: Arc<std::sync::atomic::AtomicBool>,
}

impl Rig {
    /// The emulator on `endpoint`, the interface on it, a helm driving, in COMMAND.
    async fn in_command(endpoint: Endpoint) -> Self {
        let (tx, oms) = mpsc::channel();
        let emu = Emulator::start(
            Recording {
                inner: IverSession::new(IverOptions {
                    remote_helm_version_major: 5,
                    ..Default::default()
                }),
                line: Vec::new(),
                oms: tx,
            },
            endpoint,
            1.0,
        )
        .await
        .expect("the emulator starts");
        let mut cfg = InterfaceConfig {
            name: "lane-iver".into(),
            ..Default::default()
        };
        cfg.driver.name = "iver3".into();
        cfg.driver.iver3.remote_helm_version_major = Some(5);
        cfg.driver.iver3.link.reconnect_initial_ms = 20;
        cfg.driver.iver3.link.reconnect_max_ms = 200;
        match (emu.pty_path(), emu.tcp_addr()) {
            (Some(p), _) => cfg.driver.iver3.serial_port = p.to_string_lossy().into_owned(),
            (None, Some(a)) => {
                cfg.driver.iver3.link.transport = frontseat_config::TransportKind::Tcp;
                cfg.driver.iver3.link.tcp_address = a.ip().to_string();
                cfg.driver.iver3.link.tcp_port = a.port();
            }
            _ => panic!("the emulator has no endpoint"),
        }
        let bus = Bus::new();
        let (state_tx, states) = mpsc::channel();
        let state_tx = Mutex::new(state_tx);
        let _status = bus.subscribe(
            &groups::GOBY_MIDDLEWARE_FRONTSEAT_STATUS,
            "test-status",
            1024,
            move |env| {
                let _ = state_tx.lock().unwrap().send(env.msg.state());
                Ok(())
            },
        );
        let service = InterfaceService::start(&cfg, &bus, frontseat_drivers::BUILT_IN)
            .await
            .expect("the interface starts");
        // A helm that keeps saying it drives, as pHelmIvP does.
        let helm = Arc::new(std::sync::atomic::AtomicBool::new(true));
        {
            let (bus, helm) = (bus.clone(), helm.clone());
            std::thread::spawn(move || {
                while helm.load(std::sync::atomic::Ordering::Acquire) {
                    bus.publish(
                        &groups::GOBY_MIDDLEWARE_FRONTSEAT_HELM_STATE,
                        HelmStateReport {
                            state: HelmState::HelmDrive as i32,
                        },
                    );
                    std::thread::sleep(Duration::from_millis(100));
                }
            });
        }
        let states = tokio::task::spawn_blocking(move || {
            let until = Instant::now() + DEADLINE;
            loop {
                let left = until.saturating_duration_since(Instant::now());
                match states.recv_timeout(left) {
                    Ok(InterfaceState::InterfaceCommand) => return Ok(states),
                    Ok(_) => {}
                    Err(e) => return Err(e),
                }
            }
        })
        .await
        .unwrap();
        let _states = states.expect("the interface reached COMMAND");
        let before = service.snapshot(DEADLINE).await.expect("a snapshot");
        Self {
            _emu: emu,
            oms,
            bus,
            service,
            before,
            helm,
        }
    }

    /// The next `n` `$OMS` depths the UVC reads, each within the deadline.
    fn read_oms(&self, n: usize) -> Vec<f64> {
        (0..n)
            .map(|i| {
                self.oms
                    .recv_timeout(DEADLINE)
                    .unwrap_or_else(|_| panic!("$OMS {i} of {n} never reached the UVC"))
            })
            .collect()
    }

    async fn end(self) {
        self.helm.store(false, std::sync::atomic::Ordering::Release);
        let _ = self.service.shutdown(Duration::from_secs(3)).await;
    }
}

/// One at a time, each read by the UVC before the next: nothing is ever on its way through the
/// actors, so every course is written by its publisher's thread.
async fn lone_courses_take_the_lane(endpoint: Endpoint) {
    let rig = Rig::in_command(endpoint).await;
    const LONE: u32 = 20;
    let rig = tokio::task::spawn_blocking(move || {
        for i in 1..=LONE {
            rig.bus.publish(
                &groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE,
                course(f64::from(i), 1.0),
            );
            assert_eq!(rig.read_oms(1), vec![f64::from(i)]);
        }
        rig
    })
    .await
    .unwrap();
    let after = rig.service.snapshot(DEADLINE).await.expect("a snapshot");
    assert_eq!(
        after.setpoints_direct - rig.before.setpoints_direct,
        u64::from(LONE),
        "each lone course was written by its publisher"
    );
    rig.end().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn over_a_pty_a_lone_course_is_written_from_its_publishers_thread() {
    lone_courses_take_the_lane(Endpoint::Pty).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn over_tcp_a_lone_course_is_written_from_its_publishers_thread() {
    lone_courses_take_the_lane(Endpoint::Tcp(SocketAddr::from(([127, 0, 0, 1], 0)))).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn setpoints_reach_the_uvc_in_publish_order_whichever_path_each_takes() {
    let rig = Rig::in_command(Endpoint::Pty).await;
    let (_r, mut responses) = rig.bus.subscribe_channel(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_COMMAND_RESPONSE,
        "test-responses",
        10_000,
    );
    // Back to back from a plain thread: courses (the lane's), every 10th a command_request
    // asking for an answer (the actors' path), every 7th a course over the speed limit
    // (refused: it goes the actors' way and never reaches the UVC). Fewer than the driver's 64
    // awaiting an `$ACK`: past that the oldest is answered as overflowed, whichever path.
    const N: u32 = 60;
    let publisher = {
        let bus = rig.bus.clone();
        std::thread::spawn(move || {
            let mut expected = Vec::new();
            let mut asked = Vec::new();
            let mut refused = 0u64;
            for i in 1..=N {
                let depth = f64::from(i);
                if i % 7 == 0 {
                    bus.publish(
                        &groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE,
                        course(depth, 1e6),
                    );
                    refused += 1;
                    continue;
                }
                if i % 10 == 0 {
                    let id = i as i32;
                    bus.publish(
                        &groups::GOBY_MIDDLEWARE_FRONTSEAT_COMMAND_REQUEST,
                        CommandRequest {
                            desired_course: Some(course(depth, 1.0)),
                            response_requested: Some(true),
                            request_id: Some(id),
                            ..Default::default()
                        },
                    );
                    asked.push(id);
                } else {
                    bus.publish(
                        &groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE,
                        course(depth, 1.0),
                    );
                }
                expected.push(depth);
            }
            (expected, asked, refused)
        })
    };
    let (expected, asked, refused) = tokio::task::spawn_blocking(move || publisher.join().unwrap())
        .await
        .unwrap();
    let n = expected.len();
    let (read, rig) = tokio::task::spawn_blocking(move || (rig.read_oms(n), rig))
        .await
        .unwrap();
    assert_eq!(
        read, expected,
        "every setpoint that passed reached the UVC once, in publish order, none refused"
    );

    // One answer per command_request that asked (the UVC acks every $OMS), and no more.
    let mut answers: HashMap<i32, u32> = HashMap::new();
    let until = tokio::time::Instant::now() + DEADLINE;
    while answers.len() < asked.len() {
        let env = tokio::time::timeout_at(until, responses.recv())
            .await
            .expect("every asked command_request answered in time")
            .expect("bus alive");
        let id = env.msg.request_id.expect("an answer names its request");
        assert_eq!(env.msg.request_successful, Some(true), "{:?}", env.msg);
        *answers.entry(id).or_default() += 1;
    }
    let after = rig.service.snapshot(DEADLINE).await.expect("a snapshot");
    // Late duplicates would have come with the others' answers; none may.
    while let Ok(env) = responses.try_recv() {
        *answers.entry(env.msg.request_id.unwrap_or(-1)).or_default() += 1;
    }
    let mut want: Vec<i32> = asked.clone();
    want.sort_unstable();
    let mut got: Vec<i32> = answers.keys().copied().collect();
    got.sort_unstable();
    assert_eq!(got, want, "answers only to what asked");
    assert!(
        answers.values().all(|&c| c == 1),
        "exactly one answer each: {answers:?}"
    );

    assert_eq!(
        after.setpoints_refused - rig.before.setpoints_refused,
        refused
    );
    let direct = after.setpoints_direct - rig.before.setpoints_direct;
    println!(
        "{direct} courses through the lane, {} through the actors",
        n as u64 - direct
    );
    assert!(direct > 0, "no course went through the lane");
    rig.end().await;
}
