//! The setpoint lane for the Bluefin (ARCHITECTURE.md "The lane per vehicle family"): the real
//! interface with the real Bluefin driver over loopback TCP to the Huxley emulator, through a
//! relay on plain threads that keeps every `$BPRMB` the payload writes, in order; courses are
//! published from plain threads as a helm's task would.
//!
//! What must hold: a course in command is written as `$BPRMB` by its publisher's thread when
//! nothing is in flight (counted as such), and stop-and-wait holds whichever thread wrote it
//! (the Huxley acknowledges every one, nothing is resent or dropped); whatever path each setpoint
//! takes — the lane, or the actors for a command_request or a refused course — the Huxley reads
//! them in publish order, a refused one never; every command_request that asked gets exactly one
//! answer.

#[path = "../../../actors/tests/common/lane.rs"]
mod lane;

use std::io::{BufRead, BufReader, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::mpsc;
use std::time::Duration;

use frontseat_actors::bus::Bus;
use frontseat_actors::bus::test_util::UntypedBus as _;
use frontseat_actors::groups;
use frontseat_actors::interface::{InterfaceService, Snapshot};
use frontseat_bluefin::{HuxleyHandle, HuxleyOptions, HuxleyServer, HuxleyServerOptions};
use frontseat_config::InterfaceConfig;
use lane::course;

const DEADLINE: Duration = Duration::from_secs(20);

/// A relay between the payload and the Huxley: bytes pass both ways as they come; the depth
/// (the `vertical` field) of every `$BPRMB` the payload writes goes to `rmb`.
fn relay(huxley: std::net::SocketAddr, rmb: mpsc::Sender<f64>) -> u16 {
    let listener = TcpListener::bind(("127.0.0.1", 0)).expect("the relay binds");
    let port = listener.local_addr().unwrap().port();
    std::thread::spawn(move || {
        // One connection is all a run makes; a reconnect would show as a test failure.
        let Ok((payload, _)) = listener.accept() else {
            return;
        };
        let Ok(vehicle) = TcpStream::connect(huxley) else {
            return;
        };
        let _ = payload.set_nodelay(true);
        let _ = vehicle.set_nodelay(true);
        let (mut to_payload, from_vehicle) =
            (payload.try_clone().unwrap(), vehicle.try_clone().unwrap());
        std::thread::spawn(move || {
            let _ = std::io::copy(&mut BufReader::new(from_vehicle), &mut to_payload);
        });
        let mut to_vehicle = vehicle;
        let mut lines = BufReader::new(payload);
        let mut line = String::new();
        while lines.read_line(&mut line).is_ok_and(|n| n > 0) {
            if line.starts_with("$BPRMB")
                && let Some(depth) = line.split(',').nth(3).and_then(|v| v.parse().ok())
            {
                let _ = rmb.send(depth);
            }
            if to_vehicle.write_all(line.as_bytes()).is_err() {
                return;
            }
            line.clear();
        }
    });
    port
}

struct Rig {
    hux: HuxleyHandle,
    rmb: mpsc::Receiver<f64>,
    bus: Bus,
    service: InterfaceService,
    before: Snapshot,
    helm: lane::Helm,
}

impl Rig {
    async fn in_command() -> Self {
        let cfg = InterfaceConfig::default();
        let hux = HuxleyServer::bind(
            ([127, 0, 0, 1], 0).into(),
            HuxleyServerOptions {
                huxley: HuxleyOptions {
                    lat: cfg.origin.lat,
                    lon: cfg.origin.lon,
                    ..Default::default()
                },
                ..Default::default()
            },
        )
        .await
        .expect("the emulator binds");
        let (tx, rmb) = mpsc::channel();
        let port = relay(hux.local_addr(), tx);
        let mut cfg = InterfaceConfig {
            name: "lane-bluefin".into(),
            ..Default::default()
        };
        cfg.driver.name = "bluefin".into();
        cfg.driver.bluefin.huxley_tcp_port = port;
        // A loaded machine must not turn a slow $BFACK into a resend the order check would see.
        cfg.driver.bluefin.nmea_resend_interval = 30;
        let (bus, service, helm) = lane::in_command(&cfg, DEADLINE).await;
        let before = service.snapshot(DEADLINE).await.expect("a snapshot");
        Self {
            hux,
            rmb,
            bus,
            service,
            before,
            helm,
        }
    }

    fn read_rmb(&self, n: usize) -> Vec<f64> {
        lane::recv_n(&self.rmb, n, DEADLINE, "$BPRMB")
    }

    async fn end(self) -> HuxleyHandle {
        self.helm.stop();
        let _ = self.service.shutdown(Duration::from_secs(3)).await;
        self.hux
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_lone_course_is_written_from_its_publishers_thread_and_acknowledged() {
    let rig = Rig::in_command().await;
    // One at a time, each read before the next and given time for its $BFACK: nothing of the
    // driver's is in flight, so every course takes the lane.
    const LONE: u32 = 10;
    let rig = tokio::task::spawn_blocking(move || {
        for i in 1..=LONE {
            // The heartbeat ($BPSTS) may be in flight: the course then waits its turn on the
            // actors' path, which is right; publish until this one is read.
            rig.bus.publish(
                &groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE,
                course(f64::from(i), 1.0),
            );
            assert_eq!(rig.read_rmb(1), vec![f64::from(i)]);
            // Time for its $BFACK to be read and handled: then nothing is in flight.
            std::thread::sleep(Duration::from_millis(100));
        }
        rig
    })
    .await
    .unwrap();
    let after = rig.service.snapshot(DEADLINE).await.expect("a snapshot");
    let direct = after.setpoints_direct - rig.before.setpoints_direct;
    println!("{direct} of {LONE} lone courses through the lane");
    // A course that found the heartbeat in flight went the actors' way: most, not all, are the
    // lane's.
    assert!(
        direct >= u64::from(LONE) / 2,
        "only {direct} of {LONE} lone courses took the lane"
    );
    let hux = rig.end().await;
    let stats = hux.stats();
    assert_eq!(stats.bad_lines, 0, "{stats:?}");
    hux.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn setpoints_reach_the_huxley_in_publish_order_whichever_path_each_takes() {
    let rig = Rig::in_command().await;
    let (_r, mut responses) = lane::responses(&rig.bus);
    // Back to back from a plain thread: courses, every 10th a command_request asking for an
    // answer, every 7th a course over the speed limit (refused, never written).
    const N: u32 = 100;
    let bus = rig.bus.clone();
    let (mix, rig) = lane::mix_arrives_in_order(&bus, N, true, rig, Rig::read_rmb).await;
    let after = lane::one_answer_each(&mut responses, &mix.asked, &rig.service, DEADLINE).await;
    lane::took_the_lane(&rig.before, &after, mix.expected.len(), mix.refused);
    let hux = rig.end().await;
    hux.shutdown().await;
}
