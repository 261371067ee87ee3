//! The Iver3 and Wave Glider SV2 drivers end to end: the vehicle emulators on real
//! pseudo-terminals (or loopback TCP), the real interface with the real driver opening the pty
//! with tokio-serial, and a test helm on the bus. Each step awaits the published messages with
//! a deadline; the emulators and the interface run warped.

mod common;

use frontseat_actors::bus::test_util::UntypedBus as _;
use std::net::SocketAddr;
use std::time::Duration;

use common::*;
use frontseat_actors::bus::Bus;
use frontseat_actors::groups;
use frontseat_actors::interface::{InterfaceService, ServiceExit};
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CommandRequest, CommandResponse, DesiredCourse, FrontSeatError, FrontSeatState, HelmState,
    InterfaceState,
};
use frontseat_config::{InterfaceConfig, TransportKind};
use frontseat_iver3::{IverOptions, IverSession};
use frontseat_sim::emulator::{Emulator, Endpoint};
use frontseat_waveglider_sv2::codec::{Message, Packet};
use frontseat_waveglider_sv2::{Sv2Options, Sv2Session};
use tokio::sync::mpsc::UnboundedReceiver;

const LONG: Duration = Duration::from_secs(30);

fn iver_config(path: &str) -> InterfaceConfig {
    let mut cfg = InterfaceConfig {
        name: "test-iver".into(),
        sim_warp_factor: WARP,
        ..Default::default()
    };
    cfg.driver.name = "iver3".into();
    cfg.driver.iver3.serial_port = path.into();
    cfg.driver.iver3.remote_helm_version_major = Some(4);
    cfg.driver.iver3.link.reconnect_initial_ms = 20;
    cfg.driver.iver3.link.reconnect_max_ms = 200;
    cfg
}

fn sv2_config(path: &str) -> InterfaceConfig {
    let mut cfg = InterfaceConfig {
        name: "test-glider".into(),
        sim_warp_factor: WARP,
        ..Default::default()
    };
    cfg.driver.name = "waveglider_sv2".into();
    cfg.driver.waveglider_sv2.pm_serial_port = path.into();
    cfg.driver.waveglider_sv2.publish_navigation = true;
    cfg
}

fn request(heading: f64, id: i32) -> CommandRequest {
    CommandRequest {
        desired_course: Some(DesiredCourse {
            time: 0.0,
            heading: Some(heading),
            speed: Some(1.5),
            depth: Some(3.0),
            ..Default::default()
        }),
        response_requested: Some(true),
        request_id: Some(id),
        ..Default::default()
    }
}

/// Sends `req` until a response with its id comes back (a command can race the state change).
async fn command(
    bus: &Bus,
    rx: &mut UnboundedReceiver<frontseat_actors::bus::Envelope<CommandResponse>>,
    req: CommandRequest,
) -> CommandResponse {
    bus.publish(&groups::GOBY_MIDDLEWARE_FRONTSEAT_COMMAND_REQUEST, req);
    let deadline = tokio::time::Instant::now() + LONG;
    loop {
        let env = tokio::time::timeout_at(deadline, rx.recv())
            .await
            .expect("a command response in time")
            .expect("bus alive");
        if env.msg.request_id == req.request_id {
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

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn iver3_over_a_pty_reaches_command_steers_in_feet_and_acks() {
    let emu = Emulator::start(
        IverSession::new(IverOptions {
            remote_helm_version_major: 4,
            ..Default::default()
        }),
        Endpoint::Pty,
        WARP,
    )
    .await
    .unwrap();
    let path = emu.pty_path().unwrap().to_string_lossy().into_owned();
    let bus = Bus::new();
    let mut status = StatusWatch::new(&bus);
    let (_s1, mut responses) = bus.subscribe_channel(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_COMMAND_RESPONSE,
        "t",
        1000,
    );
    let (_s2, mut nav) =
        bus.subscribe_channel(&groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS, "t", 100_000);
    let helm = helm_heartbeat(&bus, HelmState::HelmDrive);
    let service = InterfaceService::start(&iver_config(&path), &bus, frontseat_drivers::BUILT_IN)
        .await
        .unwrap();
    status
        .until_state(InterfaceState::InterfaceCommand, LONG)
        .await;

    let r = command(&bus, &mut responses, request(90.0, 11)).await;
    assert_eq!(r.request_successful, Some(true), "{r:?}");
    let oms = emu.session().stats.last_oms.clone().unwrap();
    assert_eq!(oms.depth, 9.8, "Remote Helm 4 gets feet");
    assert_eq!(oms.speed_kn, 2.9, "knots on the wire");

    // Keep the command fresh (the UVC drops it after oms_timeout) until the vehicle heads east.
    let deadline = tokio::time::Instant::now() + LONG;
    loop {
        bus.publish(
            &groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE,
            DesiredCourse {
                time: 0.0,
                heading: Some(90.0),
                speed: Some(1.5),
                depth: Some(3.0),
                ..Default::default()
            },
        );
        let env = tokio::time::timeout_at(deadline, nav.recv())
            .await
            .expect("node_status keeps coming")
            .unwrap();
        let ns = &env.msg;
        if (ns.pose.heading() - 90.0).abs() < 0.5
            && ns.local_fix.as_ref().is_some_and(|l| l.x > 1.0)
            && (ns.global_fix.depth() - 3.0).abs() < 0.1
            // Metres and m/s here, though the wire carried feet and knots (9.8 ft, 2.9 kn).
            && (ns.speed.over_ground - 1.5).abs() < 0.1
        {
            break;
        }
    }

    // The UVC parks: IN_CONTROL; stopped: IDLE; both take the interface out of COMMAND.
    emu.session().set_mode("P");
    status
        .until("IN_CONTROL", LONG, |s| {
            s.frontseat_state() == FrontSeatState::FrontseatInControl
        })
        .await;
    emu.session().set_mode("S");
    let s = status
        .until("IDLE", LONG, |s| {
            s.frontseat_state() == FrontSeatState::FrontseatIdle
        })
        .await;
    assert_ne!(s.state(), InterfaceState::InterfaceCommand);
    emu.session().set_mode("N");
    status
        .until_state(InterfaceState::InterfaceCommand, LONG)
        .await;

    helm.abort();
    assert_eq!(
        service.shutdown(Duration::from_secs(3)).await,
        ServiceExit::Clean
    );
}

/// The response to request `id`, within the deadline.
async fn response_to(
    rx: &mut UnboundedReceiver<frontseat_actors::bus::Envelope<CommandResponse>>,
    id: i32,
) -> CommandResponse {
    let deadline = tokio::time::Instant::now() + LONG;
    loop {
        let env = tokio::time::timeout_at(deadline, rx.recv())
            .await
            .expect("a command response in time")
            .expect("bus alive");
        if env.msg.request_id == Some(id) {
            return (*env.msg).clone();
        }
    }
}

/// Waits for the Iver's iver_state extension to report `want`.
async fn until_mode(
    rx: &mut UnboundedReceiver<
        frontseat_actors::bus::Envelope<
            frontseat_actors::proto::frontseat::protobuf::iver::InterfaceData,
        >,
    >,
    want: frontseat_actors::proto::goby::middleware::frontseat::protobuf::iver_state::IverMissionMode,
) {
    let deadline = tokio::time::Instant::now() + LONG;
    loop {
        let env = tokio::time::timeout_at(deadline, rx.recv())
            .await
            .unwrap_or_else(|_| panic!("iver_state {want:?} in time"))
            .expect("bus alive");
        if env.msg.iver_state.as_ref().map(|s| s.mode()) == Some(want) {
            assert!(env.msg.node_status.is_some());
            return;
        }
    }
}

/// Goby3's iver_command extension over the real pty: START_MISSION and STOP_MISSION go through
/// the interface's gate to `$OMSTART`/`$OMSTOP`, the UVC's `$ACK` answers them, and the mode the
/// UVC then reports comes back as the iver_state extension.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn iver3_mission_commands_and_mode_over_a_pty() {
    use frontseat_actors::proto::frontseat::protobuf::iver;
    use frontseat_actors::proto::goby::middleware::frontseat::protobuf::IverExtraCommands;
    use frontseat_actors::proto::goby::middleware::frontseat::protobuf::iver_extra_commands::IverCommand;
    use frontseat_actors::proto::goby::middleware::frontseat::protobuf::iver_state::IverMissionMode;

    let emu = Emulator::start(
        IverSession::new(IverOptions::default()),
        Endpoint::Pty,
        WARP,
    )
    .await
    .unwrap();
    let path = emu.pty_path().unwrap().to_string_lossy().into_owned();
    let bus = Bus::new();
    let mut status = StatusWatch::new(&bus);
    let (_s1, mut responses) = bus.subscribe_channel(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_COMMAND_RESPONSE,
        "t",
        1000,
    );
    let (_s2, mut modes) = bus.subscribe_channel(
        &groups::FRONTSEAT_IVER_IVER_DATA_FROM_FRONTSEAT,
        "t",
        100_000,
    );
    let mission = |cmd: IverCommand, name: &str, id: i32| iver::CommandRequest {
        response_requested: Some(true),
        request_id: Some(id),
        iver_command: Some(IverExtraCommands {
            command: Some(cmd as i32),
            mission: Some(name.to_string()),
        }),
        ..Default::default()
    };
    let service = InterfaceService::start(&iver_config(&path), &bus, frontseat_drivers::BUILT_IN)
        .await
        .unwrap();
    // Before COMMAND (no helm yet) the gate refuses it, as any command.
    bus.publish(
        &groups::FRONTSEAT_IVER_IVER_COMMAND_REQUEST,
        mission(IverCommand::StartMission, "early.mis", 20),
    );
    let r = response_to(&mut responses, 20).await;
    assert_eq!(r.request_successful, Some(false), "{r:?}");
    assert_eq!(emu.session().stats.omstart, 0);

    let helm = helm_heartbeat(&bus, HelmState::HelmDrive);
    status
        .until_state(InterfaceState::InterfaceCommand, LONG)
        .await;
    until_mode(&mut modes, IverMissionMode::IverModeNormal).await;

    bus.publish(
        &groups::FRONTSEAT_IVER_IVER_COMMAND_REQUEST,
        mission(IverCommand::StartMission, "survey.mis", 21),
    );
    let r = response_to(&mut responses, 21).await;
    assert_eq!(r.request_successful, Some(true), "{r:?}");
    assert_eq!(emu.session().stats.omstart, 1);
    assert_eq!(emu.session().mission, "survey.mis");
    until_mode(&mut modes, IverMissionMode::IverModeMissionMode).await;

    bus.publish(
        &groups::FRONTSEAT_IVER_IVER_COMMAND_REQUEST,
        mission(IverCommand::StopMission, "", 22),
    );
    let r = response_to(&mut responses, 22).await;
    assert_eq!(r.request_successful, Some(true), "{r:?}");
    assert_eq!(emu.session().stats.omstop, 1);
    until_mode(&mut modes, IverMissionMode::IverModeNormal).await;

    helm.abort();
    assert_eq!(service.shutdown(LONG).await, ServiceExit::Clean);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn iver3_survives_line_noise_and_a_vanished_port() {
    let emu = Emulator::start(
        IverSession::new(IverOptions::default()),
        Endpoint::Pty,
        WARP,
    )
    .await
    .unwrap();
    let dir = std::env::temp_dir().join(format!("frontseat-iver-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let link = dir.join("ttyIVER");
    let _ = std::fs::remove_file(&link);
    std::os::unix::fs::symlink(emu.pty_path().unwrap(), &link).unwrap();
    let mut cfg = iver_config(&link.to_string_lossy());
    cfg.driver.iver3.remote_helm_version_major = Some(5);
    let bus = Bus::new();
    let mut status = StatusWatch::new(&bus);
    let (_s, mut nav) =
        bus.subscribe_channel(&groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS, "t", 100_000);
    let helm = helm_heartbeat(&bus, HelmState::HelmDrive);
    let service = InterfaceService::start(&cfg, &bus, frontseat_drivers::BUILT_IN)
        .await
        .unwrap();
    status
        .until_state(InterfaceState::InterfaceCommand, LONG)
        .await;

    // Noise of every kind between the UVC's sentences.
    let mut junk = vec![b'#'; 3000];
    junk.extend_from_slice(b"\r\n\xff\xfe\xfd\r\n$OSI,1,2,3*00\r\n$C1P2R*11\r\n\r\n");
    emu.inject_bytes(junk);
    while nav.try_recv().is_ok() {}
    tokio::time::timeout(LONG, nav.recv())
        .await
        .expect("navigation continues after the noise")
        .unwrap();
    let s = status.seen.last().copied().unwrap();
    assert_eq!(s.state(), InterfaceState::InterfaceCommand);

    // Unplugged: the frontseat is NOT_CONNECTED (Goby3 never noticed).
    drop(emu);
    std::fs::remove_file(&link).unwrap();
    status
        .until("NOT_CONNECTED", LONG, |s| {
            s.frontseat_state() == FrontSeatState::FrontseatNotConnected
        })
        .await;
    // Plugged back in behind the same name: back to COMMAND.
    let emu2 = Emulator::start(
        IverSession::new(IverOptions::default()),
        Endpoint::Pty,
        WARP,
    )
    .await
    .unwrap();
    std::os::unix::fs::symlink(emu2.pty_path().unwrap(), &link).unwrap();
    status
        .until_state(InterfaceState::InterfaceCommand, LONG)
        .await;
    wait_for("polls on the new port", || emu2.session().stats.osd > 0).await;

    helm.abort();
    assert_eq!(
        service.shutdown(Duration::from_secs(3)).await,
        ServiceExit::Clean
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn iver3_over_tcp_for_serial_over_ip_adapters() {
    let emu = Emulator::start(
        IverSession::new(IverOptions::default()),
        Endpoint::Tcp(SocketAddr::from(([127, 0, 0, 1], 0))),
        WARP,
    )
    .await
    .unwrap();
    let mut cfg = iver_config("");
    cfg.driver.iver3.remote_helm_version_major = Some(5);
    cfg.driver.iver3.link.transport = TransportKind::Tcp;
    cfg.driver.iver3.link.tcp_port = emu.tcp_addr().unwrap().port();
    let bus = Bus::new();
    let mut status = StatusWatch::new(&bus);
    let (_s1, mut responses) = bus.subscribe_channel(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_COMMAND_RESPONSE,
        "t",
        1000,
    );
    let helm = helm_heartbeat(&bus, HelmState::HelmDrive);
    let service = InterfaceService::start(&cfg, &bus, frontseat_drivers::BUILT_IN)
        .await
        .unwrap();
    status
        .until_state(InterfaceState::InterfaceCommand, LONG)
        .await;
    let r = command(&bus, &mut responses, request(180.0, 5)).await;
    assert_eq!(r.request_successful, Some(true));
    assert_eq!(emu.session().stats.last_oms.clone().unwrap().depth, 3.0);
    helm.abort();
    assert_eq!(
        service.shutdown(Duration::from_secs(3)).await,
        ServiceExit::Clean
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn waveglider_sv2_over_a_pty_pulls_commands_and_survives_naks_and_noise() {
    let emu = Emulator::start(Sv2Session::new(Sv2Options::default()), Endpoint::Pty, WARP)
        .await
        .unwrap();
    let path = emu.pty_path().unwrap().to_string_lossy().into_owned();
    let bus = Bus::new();
    let mut status = StatusWatch::new(&bus);
    let (_s1, mut responses) = bus.subscribe_channel(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_COMMAND_RESPONSE,
        "t",
        1000,
    );
    let helm = helm_heartbeat(&bus, HelmState::HelmDrive);
    let service = InterfaceService::start(&sv2_config(&path), &bus, frontseat_drivers::BUILT_IN)
        .await
        .unwrap();
    status
        .until_state(InterfaceState::InterfaceCommand, LONG)
        .await;

    let r = command(&bus, &mut responses, request(-90.0, 21)).await;
    assert_eq!(r.request_successful, Some(true), "{r:?}");
    assert_eq!(emu.session().stats.last_heading, Some(270), "wrapped");
    wait_for("the glider turns west", || {
        (emu.session().vehicle().heading - 270.0).abs() < 1.0
    })
    .await;

    // A generic NAK (Goby3 went deaf on it), line noise, a bad CRC and a truncated frame.
    let nak = Packet {
        dest: 0x0301,
        src: 0,
        transaction_id: 99,
        message: Message::Nak {
            original_msg_type: 0x0022,
            response_code: 1,
            details: vec![],
        },
    }
    .encode()
    .unwrap();
    let mut junk = nak.clone();
    junk.extend_from_slice(b"\x00\x01noise\x7d\x7d");
    let mut bad = nak.clone();
    let n = bad.len();
    bad[n - 3] ^= 0x10;
    junk.extend_from_slice(&bad);
    junk.extend_from_slice(&nak[..6]);
    emu.inject_bytes(junk);
    let before = emu.session().stats.status_replies;
    wait_for("status replies after the NAK", || {
        emu.session().stats.status_replies >= before + 3
    })
    .await;
    let r = command(&bus, &mut responses, request(45.0, 22)).await;
    assert_eq!(r.request_successful, Some(true), "{r:?}");
    assert_eq!(emu.session().stats.last_heading, Some(45));

    // The C&C stops polling: not providing data after 30 s (sim).
    emu.session().paused = true;
    status
        .until("NOT_PROVIDING_DATA", LONG, |s| {
            is_fs_error(s, FrontSeatError::ErrorFrontseatNotProvidingData)
        })
        .await;
    emu.session().paused = false;
    status
        .until_state(InterfaceState::InterfaceCommand, LONG)
        .await;

    helm.abort();
    assert_eq!(
        service.shutdown(Duration::from_secs(3)).await,
        ServiceExit::Clean
    );
}

/// `frontseat demo --vehicle …`: the real binary flies the homework triangle through the real
/// driver over a real pty and exits 0 with a closed track.
#[test]
fn demo_flies_both_vehicles_through_their_drivers() {
    for vehicle in ["iver3", "waveglider_sv2"] {
        let out =
            std::env::temp_dir().join(format!("frontseat-demo-{vehicle}-{}", std::process::id()));
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_frontseat"))
            .args([
                "demo",
                "--vehicle",
                vehicle,
                "--warp",
                "50",
                "--lines",
                "--out",
            ])
            .arg(&out)
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&o.stdout);
        assert!(
            o.status.success(),
            "{vehicle}: {}\n{}",
            stdout,
            String::from_utf8_lossy(&o.stderr)
        );
        assert!(stdout.contains("leg=northwest"), "{vehicle}: {stdout}");
        assert!(stdout.contains("track: "), "{vehicle}: {stdout}");
        let csv = std::fs::read_to_string(out.join("track.csv")).unwrap();
        assert!(csv.lines().count() > 50, "{vehicle}: short track");
        let _ = std::fs::remove_dir_all(&out);
    }
}
