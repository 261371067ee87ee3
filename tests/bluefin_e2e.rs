//! The Bluefin driver against the Huxley emulator over real loopback TCP, inside the real
//! interface: reaching COMMAND and flying the homework triangle, Bluefin extension commands and
//! data on their groups, a refusing Huxley, and a Huxley that sends garbage. Every wait has a
//! deadline; the emulator and the interface run warped.

mod common;

use frontseat_actors::bus::test_util::UntypedBus as _;
use std::time::Duration;

use common::*;
use frontseat_actors::bus::Bus;
use frontseat_actors::clock::SimClock;
use frontseat_actors::groups;
use frontseat_actors::interface::InterfaceService;
use frontseat_actors::proto::frontseat::protobuf::bluefin as bf;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    BluefinExtraCommands, CommandRequest, DesiredCourse, FrontSeatError, HelmState, InterfaceState,
    bluefin_extra_commands::BluefinCommand,
};
use frontseat_bluefin::{HuxleyHandle, HuxleyOptions, HuxleyServer, HuxleyServerOptions, Refusal};
use frontseat_config::InterfaceConfig;
use frontseat_demo_helm::{self as demo_helm, DemoParams};
use tokio::io::{AsyncBufReadExt, AsyncWriteExt, BufReader};

const LONG: Duration = Duration::from_secs(30);
const BF_WARP: f64 = 20.0;

async fn huxley(refusal: Refusal) -> HuxleyHandle {
    let cfg = InterfaceConfig::default();
    HuxleyServer::bind(
        ([127, 0, 0, 1], 0).into(),
        HuxleyServerOptions {
            huxley: HuxleyOptions {
                lat: cfg.origin.lat,
                lon: cfg.origin.lon,
                refusal,
                ..Default::default()
            },
            warp: BF_WARP,
            ..Default::default()
        },
    )
    .await
    .expect("the emulator binds an ephemeral loopback port")
}

fn bluefin_config(port: u16) -> InterfaceConfig {
    let mut cfg = InterfaceConfig {
        name: "bluefin-auv".into(),
        sim_warp_factor: BF_WARP,
        status_period: 0.0,
        ..Default::default()
    };
    cfg.driver.name = "bluefin".into();
    cfg.driver.bluefin.huxley_tcp_port = port;
    cfg.supervision.restart_initial_delay_ms = 20;
    cfg.supervision.restart_max_delay_ms = 200;
    cfg
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_homework_triangle_flies_through_the_bluefin_driver() {
    let hux = huxley(Refusal::None).await;
    let bus = Bus::new();
    let mut status = StatusWatch::new(&bus);
    let service = InterfaceService::start(
        &bluefin_config(hux.local_addr().port()),
        &bus,
        frontseat_drivers::BUILT_IN,
    )
    .await
    .unwrap();
    let params = DemoParams {
        east_s: 20.0,
        south_s: 20.0,
        max_s: 200.0,
        ..Default::default()
    };
    let report = tokio::time::timeout(
        LONG,
        demo_helm::run(&bus, SimClock::new(BF_WARP), params, |_| {}),
    )
    .await
    .expect("the triangle is flown in time");
    assert!(report.reached_command, "COMMAND reached");
    assert!(report.completed, "the path was completed");
    let max_x = report.track.iter().map(|p| p.x).fold(f64::MIN, f64::max);
    let min_y = report.track.iter().map(|p| p.y).fold(f64::MAX, f64::min);
    assert!(max_x > 20.0, "went east: max x {max_x}");
    assert!(min_y < -20.0, "went south: min y {min_y}");
    assert!(
        report.closest_approach_m < 15.0,
        "came back towards the start: {}",
        report.closest_approach_m
    );
    status
        .until_state(InterfaceState::InterfaceCommand, LONG)
        .await;
    assert_eq!(
        status.states(),
        [
            InterfaceState::InterfaceStandby,
            InterfaceState::InterfaceListen,
            InterfaceState::InterfaceCommand
        ],
        "standby → listen → command"
    );
    service.shutdown(Duration::from_secs(5)).await;
    let stats = hux.stats();
    assert_eq!(stats.bad_lines, 0, "{stats:?}");
    assert_eq!(stats.unknown_lines, 0, "{stats:?}");
    assert!(stats.lines_in > 20, "{stats:?}");
    hux.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn bluefin_extension_commands_and_data_travel_on_their_groups() {
    let hux = huxley(Refusal::PendingFirst).await;
    let bus = Bus::new();
    let mut status = StatusWatch::new(&bus);
    let (_r, mut responses) = bus.subscribe_channel(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_COMMAND_RESPONSE,
        "test",
        1000,
    );
    let (_d, mut extra) = bus.subscribe_channel(
        &groups::FRONTSEAT_BLUEFIN_BLUEFIN_DATA_FROM_FRONTSEAT,
        "test",
        1000,
    );
    let helm = helm_heartbeat(&bus, HelmState::HelmDrive);
    let service = InterfaceService::start(
        &bluefin_config(hux.local_addr().port()),
        &bus,
        frontseat_drivers::BUILT_IN,
    )
    .await
    .unwrap();
    status
        .until_state(InterfaceState::InterfaceCommand, LONG)
        .await;
    let mut cmd = BluefinExtraCommands::default();
    cmd.set_command(BluefinCommand::BuoyancyAdjust);
    bus.publish(
        &groups::FRONTSEAT_BLUEFIN_BLUEFIN_COMMAND_REQUEST,
        bf::CommandRequest {
            response_requested: Some(true),
            request_id: Some(42),
            bluefin_command: Some(cmd),
            ..Default::default()
        },
    );
    let r = tokio::time::timeout(LONG, responses.recv())
        .await
        .expect("an answer")
        .expect("open");
    assert_eq!(
        (r.msg.request_id, r.msg.request_successful),
        (Some(42), Some(true))
    );
    // The Huxley reports the buoyancy adjustment on $BFBOY → bluefin_data.buoyancy_status.
    let deadline = tokio::time::Instant::now() + LONG;
    loop {
        let d = tokio::time::timeout_at(deadline, extra.recv())
            .await
            .expect("buoyancy status in time")
            .expect("open");
        if let Some(b) = d
            .msg
            .bluefin_data
            .as_ref()
            .and_then(|b| b.buoyancy_status.as_ref())
        {
            assert_eq!(b.status, Some(2));
            break;
        }
    }
    helm.abort();
    service.shutdown(Duration::from_secs(5)).await;
    hux.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_refusing_huxley_answers_failures_and_the_interface_recovers() {
    let hux = huxley(Refusal::Commands).await;
    let bus = Bus::new();
    let mut status = StatusWatch::new(&bus);
    let (_r, mut responses) = bus.subscribe_channel(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_COMMAND_RESPONSE,
        "test",
        1000,
    );
    let helm = helm_heartbeat(&bus, HelmState::HelmDrive);
    let service = InterfaceService::start(
        &bluefin_config(hux.local_addr().port()),
        &bus,
        frontseat_drivers::BUILT_IN,
    )
    .await
    .unwrap();
    status
        .until_state(InterfaceState::InterfaceCommand, LONG)
        .await;
    for id in 1..=3 {
        bus.publish(
            &groups::GOBY_MIDDLEWARE_FRONTSEAT_COMMAND_REQUEST,
            CommandRequest {
                desired_course: Some(DesiredCourse {
                    heading: Some(90.0),
                    speed: Some(1.0),
                    ..Default::default()
                }),
                response_requested: Some(true),
                request_id: Some(id),
                ..Default::default()
            },
        );
        let r = tokio::time::timeout(LONG, responses.recv())
            .await
            .expect("an answer")
            .expect("open");
        assert_eq!(r.msg.request_id, Some(id));
        assert_eq!(r.msg.request_successful, Some(false));
        assert_eq!(r.msg.error_string.as_deref(), Some("refused by emulator"));
    }
    // Three refusals in a row: IGNORING_COMMANDS, which (unlike Goby3) clears by itself.
    status
        .until("ignoring commands", LONG, |s| {
            is_fs_error(s, FrontSeatError::ErrorFrontseatIgnoringCommands)
        })
        .await;
    status
        .until_state(InterfaceState::InterfaceCommand, LONG)
        .await;
    helm.abort();
    service.shutdown(Duration::from_secs(5)).await;
    hux.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn garbage_from_the_huxley_is_survived_and_an_oversized_line_reconnects() {
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let port = listener.local_addr().unwrap().port();
    let bus = Bus::new();
    let (_n, mut nav) =
        bus.subscribe_channel(&groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS, "test", 1000);
    let service = InterfaceService::start(&bluefin_config(port), &bus, frontseat_drivers::BUILT_IN)
        .await
        .unwrap();
    let (sock, _) = tokio::time::timeout(LONG, listener.accept())
        .await
        .expect("the driver connects")
        .unwrap();
    let (rd, mut wr) = sock.into_split();
    let mut rd = BufReader::new(rd);
    let mut first = String::new();
    rd.read_line(&mut first).await.unwrap();
    assert_eq!(first, "$BPLOG,ACK,ON*1E\r\n");
    let mut garbage = Vec::new();
    garbage.extend_from_slice(b"$BFNVG,1*00\r\n");
    garbage.extend_from_slice(b"\xff\xfe not utf-8\r\n");
    garbage.extend_from_slice(b"hello\r\n");
    garbage.extend_from_slice(b"$BFXYZ,120000.000\r\n");
    garbage.extend_from_slice(b"$BFNVR,120002.010,1.50,0.00,0.00,0.10,0.00,0.20*7B\r\n");
    garbage.extend_from_slice(
        b"$BFNVG,120002.000,4221.5040,N,07105.2560,W,1,25.3,0.0,90.0,0.5,-1.2,120001.950*42\r\n",
    );
    garbage.extend_from_slice(b"$BFNVR,120002.010,1.50,0.00,0.00,0.10,0.00,0.20*7B\r\n");
    wr.write_all(&garbage).await.unwrap();
    let ns = tokio::time::timeout(LONG, nav.recv())
        .await
        .expect("the valid fix after the garbage is published")
        .unwrap();
    assert!((ns.msg.global_fix.lat - 42.3584).abs() < 1e-9);
    // An oversized line: the link closes it, and the driver connects again.
    wr.write_all(&vec![b'$'; 64 * 1024]).await.unwrap();
    let (sock2, _) = tokio::time::timeout(LONG, listener.accept())
        .await
        .expect("the driver reconnects after an oversized line")
        .unwrap();
    let mut rd2 = BufReader::new(sock2);
    let mut again = String::new();
    rd2.read_line(&mut again).await.unwrap();
    assert_eq!(
        again, "$BPLOG,ACK,ON*1E\r\n",
        "re-initialised on the new connection"
    );
    assert!(
        service.snapshot(Duration::from_secs(5)).await.is_some(),
        "the interface still answers"
    );
    service.shutdown(Duration::from_secs(5)).await;
}
