//! ArduPilot end to end over real loopback sockets: the Rover emulator on an ephemeral TCP port,
//! the interface with the real `ardupilot` driver, a helm on the bus. The pilot's part (arm,
//! GUIDED) goes through the ArduPilot CommandRequest extension; the helm's course reaches the
//! vehicle as GUIDED targets re-sent at 5 Hz and stops when the helm stops; the autopilot's own
//! EKF failsafe to HOLD takes the interface out of COMMAND; line noise is survived.

mod common;

use frontseat_actors::bus::test_util::UntypedBus as _;
use std::time::Duration;

use common::*;
use frontseat_actors::bus::{Bus, Envelope};
use frontseat_actors::groups;
use frontseat_actors::interface::InterfaceService;
use frontseat_actors::proto::frontseat::protobuf::ardupilot::ardupilot_command::Action;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CommandResponse, DesiredCourse, HelmState, InterfaceState,
};
use frontseat_ardupilot::emulator::{RoverOptions, RoverSession};
use frontseat_ardupilot::infer::TARGET_TIMEOUT_TEXT;
use frontseat_ardupilot::modes::rover;
use frontseat_config::InterfaceConfig;
use frontseat_sim::emulator::{Emulator, Endpoint};
use tokio::sync::mpsc::UnboundedReceiver;

const LONG: Duration = Duration::from_secs(30);

fn config(addr: std::net::SocketAddr, allow: bool) -> InterfaceConfig {
    let mut cfg = InterfaceConfig {
        name: "test-boat".into(),
        sim_warp_factor: WARP,
        status_period: 0.0,
        ..Default::default()
    };
    cfg.driver.name = "ardupilot".into();
    cfg.driver.ardupilot.address = format!("tcpout:{addr}");
    cfg.driver.ardupilot.allow_mode_commands = allow;
    cfg.driver.ardupilot.reconnect_initial_ms = 20;
    cfg
}

async fn emulator() -> Emulator<RoverSession> {
    Emulator::start(
        RoverSession::new(RoverOptions::default()),
        Endpoint::Tcp(([127, 0, 0, 1], 0).into()),
        WARP,
    )
    .await
    .expect("emulator binds loopback")
}

async fn response(
    rx: &mut UnboundedReceiver<Envelope<CommandResponse>>,
    id: i32,
) -> CommandResponse {
    let deadline = tokio::time::Instant::now() + LONG;
    loop {
        let env = tokio::time::timeout_at(deadline, rx.recv())
            .await
            .unwrap_or_else(|_| panic!("no response to {id} in time"))
            .expect("bus alive");
        if env.msg.request_id == Some(id) {
            return (*env.msg).clone();
        }
    }
}

async fn wait_for(what: &str, mut cond: impl FnMut() -> bool) {
    tokio::time::timeout(LONG, async {
        while !cond() {
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
    })
    .await
    .unwrap_or_else(|_| panic!("timed out waiting for {what}"));
}

fn course(heading: f64, speed: f64) -> DesiredCourse {
    DesiredCourse {
        time: 0.0,
        heading: Some(heading),
        speed: Some(speed),
        ..Default::default()
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn helm_drives_an_ardupilot_boat_through_guided() {
    let emu = emulator().await;
    let addr = emu.tcp_addr().unwrap();
    let bus = Bus::new();
    let mut status = StatusWatch::new(&bus);
    let (_s, mut responses) = bus.subscribe_channel(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_COMMAND_RESPONSE,
        "t",
        10_000,
    );
    let (_n, mut nav) =
        bus.subscribe_channel(&groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS, "t", 100_000);
    let helm = helm_heartbeat(&bus, HelmState::HelmDrive);
    let service = InterfaceService::start(&config(addr, true), &bus, frontseat_drivers::BUILT_IN)
        .await
        .unwrap();

    // Navigation flows once the EKF is ready: listen; the interface never arms by itself.
    status
        .until_state(InterfaceState::InterfaceListen, LONG)
        .await;
    assert!(!emu.session().armed());
    let ns = tokio::time::timeout(LONG, nav.recv())
        .await
        .unwrap()
        .unwrap();
    assert!((ns.msg.global_fix.lat - RoverOptions::default().lat).abs() < 1e-4);
    assert!(ns.msg.local_fix.is_some(), "local grid from the datum");

    until_accepted(&bus, &mut responses, Action::Arm, 100, LONG).await;
    until_accepted(&bus, &mut responses, Action::Guided, 200, LONG).await;
    status
        .until_state(InterfaceState::InterfaceCommand, LONG)
        .await;
    assert_eq!(emu.session().mode(), rover::GUIDED);

    // The helm steers east at 2 m/s, publishing every 0.5 s of sim time; the driver re-sends at
    // 5 Hz of sim time.
    let steer = {
        let bus = bus.clone();
        tokio::spawn(async move {
            loop {
                bus.publish(
                    &groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE,
                    course(90.0, 2.0),
                );
                tokio::time::sleep(Duration::from_millis(50)).await;
            }
        })
    };
    wait_for("the boat heading east at speed", || {
        let s = emu.session();
        (s.vehicle().heading - 90.0).abs() < 1.0 && s.vehicle().speed > 1.9
    })
    .await;
    let (t0, n0) = {
        let s = emu.session();
        (s.sim_time(), s.stats.targets_followed)
    };
    wait_for("5 s of sim time", || emu.session().sim_time() >= t0 + 5.0).await;
    let (t1, n1) = {
        let s = emu.session();
        (s.sim_time(), s.stats.targets_followed)
    };
    let rate = (n1 - n0) as f64 / (t1 - t0);
    assert!(
        // 5 Hz nominal; room for loop ticks late on a loaded 2-core CI machine.
        (3.0..=7.5).contains(&rate),
        "targets at {rate:.1} Hz of sim time"
    );
    assert_eq!(emu.session().stats.target_timeouts, 0);

    // The helm stops: the driver stops re-sending and the vehicle's own 3 s timeout stops it.
    steer.abort();
    wait_for("the vehicle's target timeout", || {
        emu.session().stats.target_timeouts == 1
    })
    .await;
    assert!(
        emu.session()
            .stats
            .statustexts
            .iter()
            .any(|t| t == TARGET_TIMEOUT_TEXT)
    );
    wait_for("the boat stopping", || emu.session().vehicle().speed == 0.0).await;
    assert_eq!(emu.session().mode(), rover::GUIDED);

    // Line noise, bad CRCs, unknown ids and another system's frames: counted, survived.
    let mut junk = vec![0xFDu8; 600];
    junk.extend_from_slice(b"\x00\xff noise \r\n");
    let mut unknown = frontseat_ardupilot::codec::encode(
        1,
        1,
        0,
        &frontseat_ardupilot::codec::MavMessage::HEARTBEAT(Default::default()),
    );
    unknown[7] = 0x77;
    unknown[8] = 0x77;
    junk.extend_from_slice(&unknown);
    let foreign = frontseat_ardupilot::codec::encode(
        9,
        1,
        0,
        &frontseat_ardupilot::codec::MavMessage::HEARTBEAT(Default::default()),
    );
    junk.extend_from_slice(&foreign);
    for _ in 0..50 {
        emu.inject_bytes(junk.clone());
    }
    // The autopilot's EKF failsafe switches to HOLD by itself: the frontseat took control.
    {
        let mut out = Vec::new();
        emu.session().inject_ekf_failsafe(&mut out);
        emu.inject_bytes(out);
    }
    status
        .until_state(InterfaceState::InterfaceListen, LONG)
        .await;
    let snap = service.snapshot(Duration::from_secs(5)).await.unwrap();
    assert_eq!(
        snap.driver_restarts, 0,
        "bad input never crashes the driver"
    );
    // Still connected and navigating after the noise.
    while nav.try_recv().is_ok() {}
    tokio::time::timeout(LONG, nav.recv())
        .await
        .unwrap()
        .unwrap();

    helm.abort();
    service.shutdown(Duration::from_secs(5)).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn mode_commands_are_refused_unless_allowed() {
    let emu = emulator().await;
    let bus = Bus::new();
    let mut status = StatusWatch::new(&bus);
    let (_s, mut responses) = bus.subscribe_channel(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_COMMAND_RESPONSE,
        "t",
        10_000,
    );
    let service = InterfaceService::start(
        &config(emu.tcp_addr().unwrap(), false),
        &bus,
        frontseat_drivers::BUILT_IN,
    )
    .await
    .unwrap();
    status
        .until_state(InterfaceState::InterfaceListen, LONG)
        .await;
    bus.publish(
        &groups::FRONTSEAT_ARDUPILOT_ARDUPILOT_COMMAND_REQUEST,
        mode_request(Action::Arm, 1),
    );
    let r = response(&mut responses, 1).await;
    assert_eq!(r.request_successful, Some(false));
    assert!(r.error_string().contains("allow_mode_commands"), "{r:?}");
    tokio::time::sleep(Duration::from_millis(300)).await;
    assert!(!emu.session().armed());
    assert_eq!(
        emu.session().stats.commands,
        6,
        "only the six stream requests"
    );
    service.shutdown(Duration::from_secs(5)).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn mode_commands_wait_for_listen_and_early_navigation_is_not_published() {
    // An estimate that never becomes usable: the interface stays in standby.
    let emu = Emulator::start(
        RoverSession::new(RoverOptions {
            ekf_ready_s: 1e9,
            ..Default::default()
        }),
        Endpoint::Tcp(([127, 0, 0, 1], 0).into()),
        WARP,
    )
    .await
    .unwrap();
    let bus = Bus::new();
    let (_s, mut responses) = bus.subscribe_channel(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_COMMAND_RESPONSE,
        "t",
        10_000,
    );
    let (_n, mut nav) =
        bus.subscribe_channel(&groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS, "t", 1000);
    let service = InterfaceService::start(
        &config(emu.tcp_addr().unwrap(), true),
        &bus,
        frontseat_drivers::BUILT_IN,
    )
    .await
    .unwrap();
    // Streams asked and positions flowing (past INITIALISING), yet nothing published.
    wait_for("positions streamed by the vehicle", || {
        emu.session().stats.commands >= 6 && emu.session().sim_time() > 3.0
    })
    .await;
    tokio::time::sleep(Duration::from_millis(300)).await;
    assert!(
        nav.try_recv().is_err(),
        "no navigation from a backup estimate"
    );
    bus.publish(
        &groups::FRONTSEAT_ARDUPILOT_ARDUPILOT_COMMAND_REQUEST,
        mode_request(Action::Arm, 5),
    );
    let r = response(&mut responses, 5).await;
    assert_eq!(r.request_successful, Some(false));
    assert!(
        r.error_string().contains("not in listen or command"),
        "{r:?}"
    );
    assert!(!emu.session().armed());
    let snap = service.snapshot(Duration::from_secs(5)).await.unwrap();
    assert_eq!(snap.status.state(), InterfaceState::InterfaceStandby);
    service.shutdown(Duration::from_secs(5)).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn serial_address_reaches_listen_over_a_pty() {
    let emu = Emulator::start(
        RoverSession::new(RoverOptions::default()),
        Endpoint::Pty,
        WARP,
    )
    .await
    .unwrap();
    let path = emu.pty_path().unwrap().to_string_lossy().into_owned();
    let bus = Bus::new();
    let mut status = StatusWatch::new(&bus);
    let mut cfg = config(([127, 0, 0, 1], 1).into(), false);
    cfg.driver.ardupilot.address = format!("serial:{path}:57600");
    let service = InterfaceService::start(&cfg, &bus, frontseat_drivers::BUILT_IN)
        .await
        .unwrap();
    status
        .until_state(InterfaceState::InterfaceListen, LONG)
        .await;
    assert_eq!(
        emu.session().stats.commands,
        6,
        "stream requests arrived over the pty"
    );
    service.shutdown(Duration::from_secs(5)).await;
}
