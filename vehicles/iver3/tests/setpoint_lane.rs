//! The setpoint lane for the Iver3 (ARCHITECTURE.md "The lane per vehicle family"): the real
//! interface with the real Iver3 driver, over a real pseudo-terminal (and loopback TCP, as a
//! serial-over-IP adapter) to the Iver3 emulator, courses published from plain threads as a
//! helm's task would.
//!
//! What must hold: a course in command is written as `$OMS` by its publisher's thread (counted
//! as such); whatever path each setpoint takes — the lane, or the actors for a command_request
//! or a refused course — the UVC reads them in the order they were published; a refused course
//! never reaches it; every command_request that asked for an answer gets exactly one.

#[path = "../../../actors/tests/common/lane.rs"]
mod lane;

use std::net::SocketAddr;
use std::sync::mpsc;
use std::time::Duration;

use frontseat_actors::bus::Bus;
use frontseat_actors::bus::test_util::UntypedBus as _;
use frontseat_actors::groups;
use frontseat_actors::interface::{InterfaceService, Snapshot};
use frontseat_config::InterfaceConfig;
use frontseat_iver3::codec::Sentence;
use frontseat_iver3::{IverOptions, IverSession};
use frontseat_sim::emulator::{Emulator, Endpoint, Session};
use lane::course;

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

struct Rig {
    _emu: Emulator<Recording>,
    oms: mpsc::Receiver<f64>,
    bus: Bus,
    service: InterfaceService,
    before: Snapshot,
    helm: lane::Helm,
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
        // A helm that keeps saying it drives, as pHelmIvP does.
        let (bus, service, helm) = lane::in_command(&cfg, DEADLINE).await;
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
        lane::recv_n(&self.oms, n, DEADLINE, "$OMS")
    }

    async fn end(self) {
        self.helm.stop();
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
    let (_r, mut responses) = lane::responses(&rig.bus);
    // Back to back from a plain thread: courses (the lane's), every 10th a command_request
    // asking for an answer (the actors' path), every 7th a course over the speed limit
    // (refused: it goes the actors' way and never reaches the UVC). Fewer than the driver's 64
    // awaiting an `$ACK`: past that the oldest is answered as overflowed, whichever path.
    const N: u32 = 60;
    let bus = rig.bus.clone();
    let (mix, rig) = lane::mix_arrives_in_order(&bus, N, true, rig, Rig::read_oms).await;
    // One answer per command_request that asked (the UVC acks every $OMS), and no more.
    let after = lane::one_answer_each(&mut responses, &mix.asked, &rig.service, DEADLINE).await;
    lane::took_the_lane(&rig.before, &after, mix.expected.len(), mix.refused);
    rig.end().await;
}
