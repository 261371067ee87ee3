//! ArduSub end to end over real loopback sockets: the Sub emulator on an ephemeral TCP port, the
//! interface with the real `ardupilot` driver (`vehicle = "sub"`), a helm on the bus. The pilot
//! arms and selects GUIDED through the extension; the helm's heading, speed and depth reach the
//! vehicle as LOCAL_NED targets and it dives; a depth beyond `[limits] max_depth` is refused by
//! the command gate; the driver's neutral MANUAL_CONTROL keeps the pilot-input failsafe fed; a
//! leak and the pilot's mode change take the interface out of COMMAND; bad depths from the Sub
//! are refused by the navigation gate and counted.

mod common;

use frontseat_actors::bus::test_util::UntypedBus as _;
use std::time::Duration;

use common::*;
use frontseat_actors::bus::{Bus, Envelope, Subscription};
use frontseat_actors::groups;
use frontseat_actors::interface::InterfaceService;
use frontseat_actors::nav_gate::NavField;
use frontseat_actors::proto::frontseat::protobuf::ardupilot::ardupilot_command::Action;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CommandRequest, CommandResponse, DesiredCourse, HelmState, InterfaceState,
};
use frontseat_ardupilot::codec::{MavMessage, Sender};
use frontseat_ardupilot::dialect::LOCAL_POSITION_NED_DATA;
use frontseat_ardupilot::modes::sub;
use frontseat_ardupilot::sub_emulator::{SubOptions, SubSession};
use frontseat_config::{ArdupilotVehicle, InterfaceConfig};
use frontseat_sim::emulator::{Emulator, Endpoint};
use tokio::sync::mpsc::UnboundedReceiver;

const LONG: Duration = Duration::from_secs(60);

fn config(addr: std::net::SocketAddr) -> InterfaceConfig {
    let mut cfg = InterfaceConfig {
        name: "test-sub".into(),
        sim_warp_factor: WARP,
        status_period: 0.0,
        ..Default::default()
    };
    cfg.driver.name = "ardupilot".into();
    cfg.driver.ardupilot.vehicle = ArdupilotVehicle::Sub;
    cfg.driver.ardupilot.address = format!("tcpout:{addr}");
    cfg.driver.ardupilot.allow_mode_commands = true;
    cfg.driver.ardupilot.pilot_input_keepalive = true;
    cfg.driver.ardupilot.reconnect_initial_ms = 20;
    cfg.limits.max_depth = 20.0;
    cfg
}

async fn emulator() -> Emulator<SubSession> {
    Emulator::start(
        SubSession::new(SubOptions::default()),
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

fn course(heading: f64, speed: f64, depth: f64) -> DesiredCourse {
    DesiredCourse {
        time: 0.0,
        heading: Some(heading),
        speed: Some(speed),
        depth: Some(depth),
        ..Default::default()
    }
}

struct Flying {
    emu: Emulator<SubSession>,
    bus: Bus,
    status: StatusWatch,
    _responses_sub: Subscription,
    responses: UnboundedReceiver<Envelope<CommandResponse>>,
    service: InterfaceService,
    helm: tokio::task::JoinHandle<()>,
}

/// Starts the emulator and the interface and flies to COMMAND (armed, GUIDED).
async fn in_command() -> Flying {
    let emu = emulator().await;
    let bus = Bus::new();
    let mut status = StatusWatch::new(&bus);
    let (s, mut responses) = bus.subscribe_channel(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_COMMAND_RESPONSE,
        "t",
        10_000,
    );
    let helm = helm_heartbeat(&bus, HelmState::HelmDrive);
    let service = InterfaceService::start(
        &config(emu.tcp_addr().unwrap()),
        &bus,
        frontseat_drivers::BUILT_IN,
    )
    .await
    .unwrap();
    status
        .until_state(InterfaceState::InterfaceListen, LONG)
        .await;
    assert!(!emu.session().armed(), "the interface never arms by itself");
    until_accepted(&bus, &mut responses, Action::Arm, 100, LONG).await;
    until_accepted(&bus, &mut responses, Action::Guided, 200, LONG).await;
    status
        .until_state(InterfaceState::InterfaceCommand, LONG)
        .await;
    assert_eq!(emu.session().mode(), sub::GUIDED);
    Flying {
        emu,
        bus,
        status,
        _responses_sub: s,
        responses,
        service,
        helm,
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn helm_dives_an_ardusub_through_the_gates_and_failsafes_take_it_out_of_command() {
    let Flying {
        emu,
        bus,
        mut status,
        _responses_sub,
        mut responses,
        service,
        helm,
    } = in_command().await;
    let (_n, mut nav) =
        bus.subscribe_channel(&groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS, "t", 100_000);
    let steer = {
        let bus = bus.clone();
        tokio::spawn(async move {
            loop {
                bus.publish(
                    &groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE,
                    course(90.0, 0.5, 5.0),
                );
                tokio::time::sleep(Duration::from_millis(50)).await;
            }
        })
    };
    wait_for("the Sub at 5 m heading east at 0.5 m/s", || {
        let s = emu.session();
        (s.depth() - 5.0).abs() < 0.1
            && (s.vehicle().heading - 90.0).abs() < 1.0
            && (s.vehicle().speed - 0.5).abs() < 0.02
    })
    .await;
    // Armed all along: the driver's neutral MANUAL_CONTROL fed the pilot-input failsafe.
    assert!(emu.session().armed());
    assert_eq!(emu.session().stats.pilot_failsafes, 0);
    assert!(emu.session().stats.manual_controls > 0);
    // NodeStatus depth is the vehicle's LOCAL_POSITION_NED.z.
    while nav.try_recv().is_ok() {}
    let ns = tokio::time::timeout(LONG, nav.recv())
        .await
        .unwrap()
        .unwrap();
    let d = ns.msg.global_fix.depth.unwrap();
    assert!((d - 5.0).abs() < 0.2, "NodeStatus depth {d}");
    assert!(ns.msg.pose.pitch.is_some() && ns.msg.pose.roll.is_some());

    // Beyond [limits] max_depth: the command gate refuses it; the vehicle stays at 5 m.
    steer.abort();
    bus.publish(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_COMMAND_REQUEST,
        CommandRequest {
            desired_course: Some(course(90.0, 0.5, 25.0)),
            response_requested: Some(true),
            request_id: Some(7),
            ..Default::default()
        },
    );
    let r = response(&mut responses, 7).await;
    assert_eq!(r.request_successful, Some(false));
    assert!(r.error_string().contains("depth"), "{r:?}");
    let snap = service.snapshot(Duration::from_secs(5)).await.unwrap();
    assert!(snap.setpoints_refused >= 1);
    assert!(emu.session().depth() < 5.5);

    // A leak: status CRITICAL, the interface leaves COMMAND.
    {
        let mut out = Vec::new();
        emu.session().inject_leak(&mut out);
        emu.inject_bytes(out);
    }
    status
        .until_state(InterfaceState::InterfaceListen, LONG)
        .await;
    helm.abort();
    service.shutdown(Duration::from_secs(5)).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_pilots_mode_change_leaves_command_and_nothing_is_sent_after_it() {
    let Flying {
        emu,
        bus,
        mut status,
        service,
        helm,
        ..
    } = in_command().await;
    let steer = {
        let bus = bus.clone();
        tokio::spawn(async move {
            loop {
                bus.publish(
                    &groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE,
                    course(180.0, 0.3, 3.0),
                );
                tokio::time::sleep(Duration::from_millis(50)).await;
            }
        })
    };
    wait_for("targets followed", || {
        emu.session().stats.targets_followed > 5
    })
    .await;
    {
        let mut out = Vec::new();
        emu.session().pilot_sets_mode(sub::MANUAL, &mut out);
        emu.inject_bytes(out);
    }
    status
        .until_state(InterfaceState::InterfaceListen, LONG)
        .await;
    let dropped = emu.session().stats.targets_dropped;
    tokio::time::sleep(Duration::from_millis(500)).await;
    assert_eq!(
        emu.session().stats.targets_dropped,
        dropped,
        "no targets sent into the pilot's mode"
    );
    assert_eq!(emu.session().mode(), sub::MANUAL, "never changes mode back");
    steer.abort();
    helm.abort();
    service.shutdown(Duration::from_secs(5)).await;
}

/// Bad depths from a Sub: NaN, 1e9 m, 200 m above the surface, and a pressure sensor that jumps
/// 40 m between two messages — each refused by the navigation gate and counted on global_fix.depth.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn bad_depths_from_a_sub_are_refused_by_the_navigation_gate_and_counted() {
    let emu = emulator().await;
    let bus = Bus::new();
    let mut status = StatusWatch::new(&bus);
    let service = InterfaceService::start(
        &config(emu.tcp_addr().unwrap()),
        &bus,
        frontseat_drivers::BUILT_IN,
    )
    .await
    .unwrap();
    status
        .until_state(InterfaceState::InterfaceListen, LONG)
        .await;
    let depth_violations =
        |s: &frontseat_actors::interface::Snapshot| s.nav_field_violations[NavField::Depth.index()];
    let before = service.snapshot(Duration::from_secs(5)).await.unwrap();
    assert_eq!(depth_violations(&before), 0);
    let mut tx = Sender::new(1, 1);
    for z in [f32::NAN, 1e9, -200.0, 40.0] {
        // The bad reading, then a position to carry it to the gate (the emulator's own stream
        // follows with the true depth).
        let mut bytes = tx.frame(&MavMessage::LOCAL_POSITION_NED(LOCAL_POSITION_NED_DATA {
            z,
            ..Default::default()
        }));
        bytes.extend(tx.frame(&MavMessage::GLOBAL_POSITION_INT(
            frontseat_ardupilot::dialect::GLOBAL_POSITION_INT_DATA {
                lat: 423_584_560,
                lon: -710_875_890,
                hdg: 0,
                ..Default::default()
            },
        )));
        let n = service.snapshot(Duration::from_secs(5)).await.unwrap();
        emu.inject_bytes(bytes);
        let deadline = tokio::time::Instant::now() + LONG;
        loop {
            let s = service.snapshot(Duration::from_secs(5)).await.unwrap();
            if depth_violations(&s) > depth_violations(&n) {
                assert!(s.nav_refused > n.nav_refused, "{z}: the message refused");
                break;
            }
            assert!(tokio::time::Instant::now() < deadline, "{z} never refused");
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
    }
    let snap = service.snapshot(Duration::from_secs(5)).await.unwrap();
    assert_eq!(snap.driver_restarts, 0);
    assert!(snap.providing_data, "good navigation still flows");
    service.shutdown(Duration::from_secs(5)).await;
}
