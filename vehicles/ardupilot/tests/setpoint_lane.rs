//! The setpoint lane for ArduPilot Rover and ArduSub (ARCHITECTURE.md "The lane per vehicle
//! family"): the real interface with the real ArduPilot driver over loopback TCP to the Rover's
//! (the Sub's) emulator, left armed in GUIDED by its operator hook, courses published from plain
//! threads as a helm's task would.
//! The emulator is wrapped to send the heading of every GUIDED target it follows, in order, and
//! to count every target frame it reads in any mode.
//!
//! What must hold: armed in GUIDED, a new course's target is written by its publisher's thread
//! (counted as such); whatever path each setpoint takes — the lane, or the actors for a
//! command_request — the targets follow the publish order (a re-send never brings an older
//! course back after a newer one); a refused course never reaches the vehicle; once the vehicle
//! has left GUIDED and the interface COMMAND, no course reaches it by either path.

#[path = "../../../actors/tests/common/lane.rs"]
mod lane;

use std::sync::mpsc;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use frontseat_actors::bus::test_util::UntypedBus as _;
use frontseat_actors::groups;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CommandRequest, DesiredCourse, InterfaceState,
};
use frontseat_ardupilot::emulator::{RoverOptions, RoverSession, SubOptions, SubSession};
use frontseat_ardupilot::infer::{SubTarget, Target};
use frontseat_ardupilot::modes::{rover, sub};
use frontseat_config::{ArdupilotVehicle, InterfaceConfig};
use frontseat_sim::emulator::{Emulator, Endpoint, Session};

const DEADLINE: Duration = Duration::from_secs(20);

/// What the test reads off either firmware's emulator.
trait Autopilot: Session {
    /// Every target frame read: followed, or dropped (outside GUIDED, refused).
    fn targets(&self) -> u64;
    fn followed(&self) -> u64;
    /// The heading (yaw) of the last target followed.
    fn last_heading(&self) -> Option<f64>;
    /// The firmware would take GUIDED now.
    fn ready(&self) -> bool;
    fn arm_guided(&mut self);
    /// A pilot's switch out of GUIDED (Rover HOLD, Sub POSHOLD).
    fn leave_guided(&mut self);
    fn in_guided(&self) -> bool;
}

impl Autopilot for RoverSession {
    fn targets(&self) -> u64 {
        let s = &self.stats;
        s.targets_followed + s.targets_ignored + s.targets_refused
    }
    fn followed(&self) -> u64 {
        self.stats.targets_followed
    }
    fn last_heading(&self) -> Option<f64> {
        match self.stats.last_target {
            Some(Target::Course { heading, .. }) => Some(heading),
            _ => None,
        }
    }
    fn ready(&self) -> bool {
        self.ekf_ready()
    }
    fn arm_guided(&mut self) {
        self.operator_arms_guided();
    }
    fn leave_guided(&mut self) {
        self.change_mode(rover::HOLD);
    }
    fn in_guided(&self) -> bool {
        self.mode() == rover::GUIDED
    }
}

impl Autopilot for SubSession {
    fn targets(&self) -> u64 {
        let s = &self.stats;
        s.targets_followed + s.targets_dropped + s.attitude_targets
    }
    fn followed(&self) -> u64 {
        self.stats.targets_followed
    }
    fn last_heading(&self) -> Option<f64> {
        match self.stats.last_target {
            Some(SubTarget::PosVel { yaw, .. } | SubTarget::Vel { yaw, .. }) => yaw,
            _ => None,
        }
    }
    fn ready(&self) -> bool {
        self.position_ok()
    }
    fn arm_guided(&mut self) {
        self.operator_arms_guided();
    }
    fn leave_guided(&mut self) {
        self.change_mode(sub::POSHOLD);
    }
    fn in_guided(&self) -> bool {
        self.mode() == sub::GUIDED
    }
}

/// The emulated autopilot, sending the heading of every target it follows and counting every
/// target frame it reads.
struct Recording<A> {
    inner: A,
    headings: mpsc::Sender<f64>,
    frames: Arc<Mutex<u64>>,
    asked: bool,
}

impl<A: Autopilot> Session for Recording<A> {
    fn on_bytes(&mut self, bytes: &[u8], out: &mut Vec<u8>) {
        let (before, followed) = (self.inner.targets(), self.inner.followed());
        self.inner.on_bytes(bytes, out);
        *self.frames.lock().unwrap() += self.inner.targets() - before;
        if self.inner.followed() > followed
            && let Some(heading) = self.inner.last_heading()
        {
            let _ = self.headings.send(heading);
        }
    }
    fn step(&mut self, dt: f64, out: &mut Vec<u8>) {
        if !self.asked && self.inner.ready() {
            self.asked = true;
            self.inner.arm_guided();
        }
        self.inner.step(dt, out);
    }
    fn reset_input(&mut self) {
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

/// Whether target heading `b` is course heading `h` (the target's yaw is an f32 in radians).
fn near(b: f64, h: f64) -> bool {
    let d = (b - h).rem_euclid(360.0);
    d.min(360.0 - d) < 0.1
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn rover_courses_take_the_lane_in_order_armed_in_guided_and_none_outside_command() {
    let rover = RoverSession::new(RoverOptions {
        init_s: 0.2,
        ekf_ready_s: 0.5,
        ..Default::default()
    });
    lane_in_order_and_none_outside_command(rover, ArdupilotVehicle::Rover).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn sub_courses_take_the_lane_in_order_armed_in_guided_and_none_outside_command() {
    let sub = SubSession::new(SubOptions {
        init_s: 0.2,
        ekf_ready_s: 0.5,
        ..Default::default()
    });
    lane_in_order_and_none_outside_command(sub, ArdupilotVehicle::Sub).await;
}

async fn lane_in_order_and_none_outside_command<A: Autopilot>(
    vehicle: A,
    firmware: ArdupilotVehicle,
) {
    let (tx, headings) = mpsc::channel();
    let frames = Arc::new(Mutex::new(0));
    let emu = Emulator::start(
        Recording {
            inner: vehicle,
            headings: tx,
            frames: frames.clone(),
            asked: false,
        },
        Endpoint::Tcp(([127, 0, 0, 1], 0).into()),
        1.0,
    )
    .await
    .expect("the emulator binds");
    let addr = emu.tcp_addr().unwrap();
    let mut cfg = InterfaceConfig {
        name: "lane-ardupilot".into(),
        ..Default::default()
    };
    cfg.driver.name = "ardupilot".into();
    cfg.driver.ardupilot.vehicle = firmware;
    cfg.driver.ardupilot.address = format!("tcpout:{addr}");
    cfg.driver.ardupilot.reconnect_initial_ms = 20;
    // A BlueROV2 without RC disarms on its pilot-input failsafe unless fed neutral input.
    cfg.driver.ardupilot.pilot_input_keepalive = true;
    let (bus, service, helm) = lane::in_command(&cfg, DEADLINE).await;
    let before = service.snapshot(DEADLINE).await.expect("a snapshot");

    // Lone courses, each a new heading, each awaited at the vehicle: the lane's.
    let (headings, bus) = tokio::task::spawn_blocking(move || {
        for h in [30.0, 60.0, 90.0, 120.0, 150.0] {
            bus.publish(
                &groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE,
                course(h, 1.0),
            );
            let until = Instant::now() + DEADLINE;
            loop {
                let b = headings
                    .recv_timeout(until.saturating_duration_since(Instant::now()))
                    .unwrap_or_else(|_| panic!("no target of heading {h} reached the vehicle"));
                if near(b, h) {
                    break;
                }
            }
        }
        (headings, bus)
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
    // (over the speed limit) in between; the targets the vehicle follows, consecutive re-sends
    // folded, follow the publish order, and none has the refused heading.
    let sequence = [
        200.0, 210.0, 220.0, 230.0, 240.0, 250.0, 260.0, 270.0, 280.0,
    ];
    let refused_heading = 330.0;
    {
        let bus = bus.clone();
        tokio::task::spawn_blocking(move || {
            for (i, h) in sequence.iter().enumerate() {
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
            let b = headings
                .recv_timeout(until.saturating_duration_since(Instant::now()))
                .expect("the last course's target reached the vehicle");
            if !seen.last().is_some_and(|l| near(*l, b)) {
                seen.push(b);
            }
        }
        // A second more of 5 Hz re-sends: an older course after the newest would show here.
        let until = Instant::now() + Duration::from_millis(1000);
        while let Ok(b) = headings.recv_timeout(until.saturating_duration_since(Instant::now())) {
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
        "a refused course reached the vehicle: {seen:?}"
    );
    let first = seen.iter().position(|b| near(*b, 200.0)).unwrap_or(0);
    let burst: Vec<f64> = seen[first..].to_vec();
    let mut at = 0;
    for b in &burst {
        let i = sequence
            .iter()
            .position(|h| near(*b, *h))
            .unwrap_or_else(|| panic!("a target of heading {b} was never asked for: {burst:?}"));
        assert!(i >= at, "a target went back to an older course: {burst:?}");
        at = i;
    }
    assert!(near(*burst.last().unwrap(), 280.0), "{burst:?}");
    let after = service.snapshot(DEADLINE).await.expect("a snapshot");
    assert_eq!(after.setpoints_refused - mid.setpoints_refused, 1);
    assert!(
        after.setpoints_direct > mid.setpoints_direct,
        "no course of the burst took the lane"
    );

    // The pilot's switch out of GUIDED: the driver hears it, the interface leaves COMMAND; from
    // then on the helm's new courses reach the vehicle by neither path.
    emu.session().inner.leave_guided();
    let until = tokio::time::Instant::now() + DEADLINE;
    loop {
        let s = service.snapshot(DEADLINE).await.expect("a snapshot");
        if s.status.state() != InterfaceState::InterfaceCommand {
            break;
        }
        assert!(tokio::time::Instant::now() < until, "never left COMMAND");
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    // A re-send the driver wrote before it read the HEARTBEAT may still be on its way.
    tokio::time::sleep(Duration::from_millis(100)).await;
    let out = service.snapshot(DEADLINE).await.expect("a snapshot");
    let frames_out = *frames.lock().unwrap();
    {
        let bus = bus.clone();
        tokio::task::spawn_blocking(move || {
            for h in [10.0, 20.0, 30.0, 40.0, 50.0] {
                bus.publish(
                    &groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE,
                    course(h, 1.0),
                );
                std::thread::sleep(Duration::from_millis(20));
            }
        })
        .await
        .unwrap();
    }
    // Past the driver's 5 Hz re-send period twice: anything still sent would have arrived.
    tokio::time::sleep(Duration::from_millis(500)).await;
    let end = service.snapshot(DEADLINE).await.expect("a snapshot");
    assert_eq!(
        end.setpoints_direct, out.setpoints_direct,
        "the lane wrote out of COMMAND"
    );
    assert_eq!(
        *frames.lock().unwrap(),
        frames_out,
        "a target reached the vehicle out of COMMAND"
    );
    assert!(!emu.session().inner.in_guided());
    helm.stop();
    let _ = service.shutdown(Duration::from_secs(3)).await;
}
