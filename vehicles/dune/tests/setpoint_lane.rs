//! The setpoint lane for DUNE (ARCHITECTURE.md "The lane per vehicle family"): the real
//! interface with the real DUNE driver over loopback TCP to the DUNE emulator, courses published
//! from plain threads as a helm's task would. The emulator is wrapped to keep the bearing of
//! every Reference it reads (from where the vehicle is to the Reference's point: the course's
//! heading, the point being ahead on it), in order.
//!
//! What must hold: while our FollowReference plan runs, a new course's Reference is written by
//! its publisher's thread (counted as such); whatever path each setpoint takes — the lane, or the
//! actors for a command_request — the vehicle's References follow the publish order (a re-send
//! never brings an older course back after a newer one); a refused course never reaches it.

#[path = "../../../actors/tests/common/lane.rs"]
mod lane;

use std::sync::mpsc;
use std::time::{Duration, Instant};

use frontseat_actors::bus::test_util::UntypedBus as _;
use frontseat_actors::groups;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CommandRequest, DesiredCourse,
};
use frontseat_config::InterfaceConfig;
use frontseat_dune::emulator::{DuneOptions, DuneSession};
use frontseat_dune::imc::{self, Message};
use frontseat_sim::emulator::{Emulator, Endpoint, Session};

const DEADLINE: Duration = Duration::from_secs(20);

/// The emulated vehicle, sending the bearing (degrees) of every Reference it reads.
struct Recording {
    inner: DuneSession,
    deframer: imc::Deframer,
    bearings: mpsc::Sender<f64>,
}

impl Session for Recording {
    fn on_bytes(&mut self, bytes: &[u8], out: &mut Vec<u8>) {
        let (lat, lon) = self.inner.vehicle().clone().lat_lon();
        let mut refs = Vec::new();
        self.deframer.feed(bytes, &mut |f| {
            if let Ok(f) = f
                && let Ok((_, Message::Reference(r))) = imc::decode(&f)
                && r.flags & imc::consts::reference::MANDONE == 0
            {
                refs.push((r.lat, r.lon));
            }
        });
        for (rlat, rlon) in refs {
            let (p1, p2) = (lat.to_radians(), rlat);
            let dl = rlon - lon.to_radians();
            let b =
                (dl.sin() * p2.cos()).atan2(p1.cos() * p2.sin() - p1.sin() * p2.cos() * dl.cos());
            let _ = self.bearings.send(b.to_degrees().rem_euclid(360.0));
        }
        self.inner.on_bytes(bytes, out);
    }
    fn step(&mut self, dt: f64, out: &mut Vec<u8>) {
        self.inner.step(dt, out);
    }
    fn reset_input(&mut self) {
        self.deframer = imc::Deframer::new();
        self.inner.reset_input();
    }
}

fn course(heading: f64, speed: f64) -> DesiredCourse {
    DesiredCourse {
        heading: Some(heading),
        speed: Some(speed),
        depth: Some(2.0),
        ..Default::default()
    }
}

/// Whether `b` is `h` (the vehicle moved a little since the driver's last fix).
fn near(b: f64, h: f64) -> bool {
    let d = (b - h).rem_euclid(360.0);
    d.min(360.0 - d) < 3.0
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn courses_take_the_lane_in_publish_order_and_a_refused_one_never_steers() {
    let cfg0 = InterfaceConfig::default();
    let (tx, bearings) = mpsc::channel();
    let emu = Emulator::start(
        Recording {
            inner: DuneSession::new(DuneOptions {
                lat: cfg0.origin.lat,
                lon: cfg0.origin.lon,
                ..Default::default()
            }),
            deframer: imc::Deframer::new(),
            bearings: tx,
        },
        Endpoint::Tcp(([127, 0, 0, 1], 0).into()),
        1.0,
    )
    .await
    .expect("the emulator binds");
    let addr = emu.tcp_addr().unwrap();
    let mut cfg = InterfaceConfig {
        name: "lane-dune".into(),
        ..Default::default()
    };
    cfg.driver.name = "dune".into();
    cfg.driver.dune.address = addr.ip().to_string();
    cfg.driver.dune.port = addr.port();
    cfg.driver.dune.reconnect_initial_ms = 20;
    let (bus, service, helm) = lane::in_command(&cfg, DEADLINE).await;
    // Our plan runs once the driver started it in COMMAND and the vehicle took it.
    let until = tokio::time::Instant::now() + DEADLINE;
    while !emu.session().inner.maneuver_running() {
        assert!(tokio::time::Instant::now() < until, "our plan never ran");
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    let before = service.snapshot(DEADLINE).await.expect("a snapshot");

    // Lone courses, each a new heading, each awaited at the vehicle: the lane's.
    let (bearings, bus) = tokio::task::spawn_blocking(move || {
        for h in [30.0, 60.0, 90.0, 120.0, 150.0] {
            bus.publish(
                &groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE,
                course(h, 1.0),
            );
            let until = Instant::now() + DEADLINE;
            loop {
                let b = bearings
                    .recv_timeout(until.saturating_duration_since(Instant::now()))
                    .unwrap_or_else(|_| panic!("no Reference toward {h} reached the vehicle"));
                if near(b, h) {
                    break;
                }
            }
        }
        (bearings, bus)
    })
    .await
    .unwrap();
    let mid = service.snapshot(DEADLINE).await.expect("a snapshot");
    assert_eq!(
        mid.setpoints_direct - before.setpoints_direct,
        5,
        "each lone new course was written by its publisher"
    );

    // Back to back: courses, every 3rd a command_request (the actors' path), a refused one
    // (over the speed limit) in between; the References the vehicle reads, consecutive re-sends
    // folded, follow the publish order, and none points where the refused course did.
    let headings = [
        200.0, 210.0, 220.0, 230.0, 240.0, 250.0, 260.0, 270.0, 280.0,
    ];
    let refused_heading = 330.0;
    {
        let bus = bus.clone();
        tokio::task::spawn_blocking(move || {
            for (i, h) in headings.iter().enumerate() {
                if i == 4 {
                    bus.publish(
                        &groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE,
                        course(refused_heading, 1e6),
                    );
                }
                if i % 3 == 2 {
                    bus.publish(
                        &groups::GOBY_MIDDLEWARE_FRONTSEAT_COMMAND_REQUEST,
                        CommandRequest {
                            desired_course: Some(course(*h, 1.0)),
                            ..Default::default()
                        },
                    );
                } else {
                    bus.publish(
                        &groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE,
                        course(*h, 1.0),
                    );
                }
            }
        })
        .await
        .unwrap();
    }
    let seen = tokio::task::spawn_blocking(move || {
        let mut seen: Vec<f64> = Vec::new();
        let until = Instant::now() + DEADLINE;
        while !seen.last().is_some_and(|b| near(*b, 280.0)) {
            let b = bearings
                .recv_timeout(until.saturating_duration_since(Instant::now()))
                .expect("the last course's Reference reached the vehicle");
            if !seen.last().is_some_and(|l| near(*l, b)) {
                seen.push(b);
            }
        }
        // A second more: a re-send of an older course after the newest would show here.
        let until = Instant::now() + Duration::from_millis(1500);
        while let Ok(b) = bearings.recv_timeout(until.saturating_duration_since(Instant::now())) {
            if !seen.last().is_some_and(|l| near(*l, b)) {
                seen.push(b);
            }
        }
        seen
    })
    .await
    .unwrap();
    assert!(
        seen.iter().all(|b| !near(*b, refused_heading)),
        "a refused course steered the vehicle: {seen:?}"
    );
    // From the first of this burst on: each heading at most once, in order, ending on the last.
    let first = seen.iter().position(|b| near(*b, 200.0)).unwrap_or(0);
    let burst: Vec<f64> = seen[first..].to_vec();
    let mut at = 0;
    for b in &burst {
        let i = headings
            .iter()
            .position(|h| near(*b, *h))
            .unwrap_or_else(|| panic!("a Reference toward {b} was never asked for: {burst:?}"));
        assert!(
            i >= at,
            "a Reference went back to an older course: {burst:?}"
        );
        at = i;
    }
    assert!(near(*burst.last().unwrap(), 280.0), "{burst:?}");
    let after = service.snapshot(DEADLINE).await.expect("a snapshot");
    assert_eq!(after.setpoints_refused - mid.setpoints_refused, 1);
    helm.stop();
    let _ = service.shutdown(Duration::from_secs(3)).await;
}
