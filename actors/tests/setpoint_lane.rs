//! The setpoint lane (`frontseat_actors::setpoint_lane`) with real parts: the interface with the
//! basic simulator's driver over loopback TCP to a frontseat on plain OS threads, courses
//! published from a plain thread as a helm's task would.
//!
//! What must hold: a course in command goes to the vehicle from its publisher's thread (counted
//! as such); whatever path each setpoint takes — the lane, or the actors for a command_request
//! or a refused course — the vehicle reads them in the order they were published; a course the
//! envelope refuses never reaches it; outside command nothing does.

mod common;

use std::sync::mpsc;
use std::time::Duration;

use common::frontseat::{Frontseat, drive_until_command, states};
use common::lane::{self, course};
use frontseat_actors::bus::Bus;
use frontseat_actors::bus::test_util::UntypedBus as _;
use frontseat_actors::groups;
use frontseat_actors::interface::{InterfaceService, Snapshot};
use frontseat_config::InterfaceConfig;

const DEADLINE: Duration = Duration::from_secs(10);

/// The DEPTH a CMD line carries.
fn depth_of(line: &str) -> f64 {
    line.split(',')
        .find_map(|f| f.strip_prefix("DEPTH:"))
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no DEPTH in {line}"))
}

async fn interface(fs: &Frontseat, bus: &Bus) -> InterfaceService {
    let mut cfg = InterfaceConfig {
        name: "lane-auv".into(),
        ..Default::default()
    };
    cfg.driver.basic_simulator.tcp_port = fs.port;
    InterfaceService::start(&cfg, bus, frontseat_drivers::BUILT_IN)
        .await
        .expect("the interface starts")
}

/// The interface in command with the frontseat connected, and its snapshot then.
async fn in_command() -> (Frontseat, Bus, InterfaceService, Snapshot) {
    let fs = Frontseat::start();
    let bus = Bus::new();
    let (_status, status_rx) = states(&bus);
    let service = interface(&fs, &bus).await;
    drive_until_command(&bus, &status_rx, DEADLINE);
    let before = service.snapshot(DEADLINE).await.expect("a snapshot");
    (fs, bus, service, before)
}

/// The next `n` CMD lines the frontseat reads, each within the deadline.
fn read_cmds(fs: &Frontseat, n: usize) -> Vec<String> {
    lane::recv_n(&fs.cmds, n, DEADLINE, "CMD line")
        .into_iter()
        .map(|(line, _)| line)
        .collect()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn courses_reach_the_vehicle_in_publish_order_whichever_path_each_takes() {
    let (fs, bus, service, before) = in_command().await;

    // From a plain thread, back to back: courses (the lane's), every 10th a command_request
    // carrying its course (the actors' path), every 7th a course over the speed limit (refused).
    const N: u32 = 300;
    let (mix, fs) = lane::mix_arrives_in_order(&bus, N, false, fs, |fs, n| {
        read_cmds(fs, n).iter().map(|l| depth_of(l)).collect()
    })
    .await;

    let after = service.snapshot(DEADLINE).await.expect("a snapshot");
    // The command_requests (every 10th) always take the actors; a course published while one of
    // them (or a refused course) is still on its way there follows it, so the lane took fewer
    // than all — but it took courses, or it never ran.
    let direct = lane::took_the_lane(&before, &after, mix.expected.len(), mix.refused);
    let via_actors = mix.expected.len() as u64 - direct;
    assert!(via_actors >= u64::from(N / 10) - u64::from(N / 70));

    // Nothing more came: one further course, and it is the next line the vehicle reads.
    bus.publish(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE,
        course(0.5, 1.0),
    );
    let next = tokio::task::spawn_blocking(move || read_cmds(&fs, 1))
        .await
        .unwrap();
    assert_eq!(depth_of(&next[0]), 0.5);
    let _ = service.shutdown(Duration::from_secs(2)).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_lone_course_in_command_is_written_from_its_publishers_thread() {
    let (fs, bus, service, before) = in_command().await;

    // One at a time, each read before the next: nothing is ever on its way through the actors,
    // so every one takes the lane.
    const LONE: u32 = 20;
    let fs = tokio::task::spawn_blocking(move || {
        for i in 1..=LONE {
            bus.publish(
                &groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE,
                course(f64::from(i), 1.0),
            );
            let line = read_cmds(&fs, 1).remove(0);
            assert_eq!(depth_of(&line), f64::from(i));
        }
        fs
    })
    .await
    .unwrap();
    let after = service.snapshot(DEADLINE).await.expect("a snapshot");
    assert_eq!(
        after.setpoints_direct - before.setpoints_direct,
        u64::from(LONE),
        "each lone course was written by its publisher"
    );
    drop(fs);
    let _ = service.shutdown(Duration::from_secs(2)).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn outside_command_no_course_reaches_the_vehicle() {
    let fs = Frontseat::start();
    let bus = Bus::new();
    let (_status, status_rx) = states(&bus);
    let service = interface(&fs, &bus).await;
    // Connected, the frontseat in PAYLOAD, but no helm: not in command.
    let (tx, rx) = mpsc::channel();
    let b = bus.clone();
    std::thread::spawn(move || {
        for i in 1..=50 {
            b.publish(
                &groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE,
                course(f64::from(i), 1.0),
            );
        }
        let _ = tx.send(());
    });
    rx.recv_timeout(DEADLINE).expect("the publisher finished");
    drive_until_command(&bus, &status_rx, DEADLINE);
    bus.publish(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE,
        course(0.25, 1.0),
    );
    // The first CMD the vehicle reads is the one published in command.
    let first = tokio::task::spawn_blocking(move || read_cmds(&fs, 1))
        .await
        .unwrap();
    assert_eq!(depth_of(&first[0]), 0.25, "{first:?}");
    let snap = service.snapshot(DEADLINE).await.expect("a snapshot");
    assert!(
        snap.commands_gated >= 50,
        "the courses outside command were refused by the gate: {}",
        snap.commands_gated
    );
    let _ = service.shutdown(Duration::from_secs(2)).await;
}
