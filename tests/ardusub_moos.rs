//! pHelmIvP's depth behaviours reach an ArduSub: over real loopback TCP, the in-crate MOOS
//! broker, a scripted pHelmIvP (IVPHELM_STATE=DRIVE, DESIRED_DEPTH / DESIRED_SPEED /
//! DESIRED_HEADING at 4 Hz, in pHelmIvP's order), the FrontSeatTranslation, the interface with
//! the real `ardupilot` driver (`vehicle = "sub"`) and the Sub emulator. The Sub dives to the
//! DESIRED_DEPTH and the helm reads it back as NAV_DEPTH.

mod common;

use frontseat_actors::bus::test_util::UntypedBus as _;
use std::time::Duration;

use common::*;
use frontseat_actors::bus::Bus;
use frontseat_actors::groups;
use frontseat_actors::interface::InterfaceService;
use frontseat_actors::proto::frontseat::protobuf::ardupilot::ardupilot_command::Action;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::InterfaceState;
use frontseat_ardupilot::modes::sub;
use frontseat_ardupilot::sub_emulator::{SubOptions, SubSession};
use frontseat_config::{ArdupilotVehicle, InterfaceConfig, MoosConfig};
use frontseat_helm_side::translation;
use frontseat_moos::{Broker, MoosClient, MoosClientConfig, MoosEvent};
use frontseat_sim::emulator::{Emulator, Endpoint};
use tokio::time::{Instant, timeout_at};

const LONG: Duration = Duration::from_secs(60);

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn phelmivp_desired_depth_dives_the_sub_and_comes_back_as_nav_depth() {
    let broker = Broker::bind("127.0.0.1:0").await.unwrap();
    let port = broker.local_addr().port();
    let emu = Emulator::start(
        SubSession::new(SubOptions::default()),
        Endpoint::Tcp(([127, 0, 0, 1], 0).into()),
        WARP,
    )
    .await
    .unwrap();
    let bus = Bus::new();
    let mut status = StatusWatch::new(&bus);
    let mut cfg = InterfaceConfig {
        name: "test-sub".into(),
        sim_warp_factor: WARP,
        status_period: 0.0,
        ..Default::default()
    };
    cfg.driver.name = "ardupilot".into();
    cfg.driver.ardupilot.vehicle = ArdupilotVehicle::Sub;
    cfg.driver.ardupilot.address = format!("tcpout:{}", emu.tcp_addr().unwrap());
    cfg.driver.ardupilot.allow_mode_commands = true;
    cfg.driver.ardupilot.pilot_input_keepalive = true;
    let service = InterfaceService::start(&cfg, &bus, frontseat_drivers::BUILT_IN)
        .await
        .unwrap();
    let moos_cfg = MoosConfig {
        server: "127.0.0.1".into(),
        port,
        community: "frontseat".into(),
        app_name: "iFrontSeat".into(),
        time_warp: 1.0,
        desired_timeout_s: 5.0,
    };
    let _translation = translation::spawn(&moos_cfg, "test-sub", &bus)
        .await
        .unwrap();

    // The scripted pHelmIvP.
    let (helm, mut events) = MoosClient::start(MoosClientConfig {
        server: format!("127.0.0.1:{port}"),
        reconnect_initial: Duration::from_millis(50),
        reconnect_max: Duration::from_millis(200),
        ..MoosClientConfig::new("pHelmIvP")
    })
    .unwrap();
    helm.register("NAV_DEPTH", 0.0).unwrap();
    let posting = {
        let helm = helm.clone();
        tokio::spawn(async move {
            let mut tick = tokio::time::interval(Duration::from_millis(250));
            loop {
                tick.tick().await;
                let _ = helm.notify_string("IVPHELM_STATE", "DRIVE", None);
                let _ = helm.notify_double("DESIRED_DEPTH", 4.0, None);
                let _ = helm.notify_double("DESIRED_SPEED", 0.4, None);
                let _ = helm.notify_double("DESIRED_HEADING", 270.0, None);
            }
        })
    };

    // The pilot arms and selects GUIDED (the interface never does by itself).
    status
        .until_state(InterfaceState::InterfaceListen, LONG)
        .await;
    let (_s, mut responses) = bus.subscribe_channel(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_COMMAND_RESPONSE,
        "t",
        10_000,
    );
    until_accepted(&bus, &mut responses, Action::Arm, 100, LONG).await;
    until_accepted(&bus, &mut responses, Action::Guided, 200, LONG).await;
    status
        .until_state(InterfaceState::InterfaceCommand, LONG)
        .await;
    assert_eq!(emu.session().mode(), sub::GUIDED);

    // The Sub dives to DESIRED_DEPTH on DESIRED_HEADING; the helm reads NAV_DEPTH ≈ 4.
    let deadline = Instant::now() + LONG;
    loop {
        match timeout_at(deadline, events.recv()).await {
            Ok(Some(MoosEvent::Mail(m)))
                if m.key == "NAV_DEPTH" && m.as_double().is_some_and(|d| (d - 4.0).abs() < 0.1) =>
            {
                break;
            }
            Ok(Some(_)) => {}
            other => panic!("NAV_DEPTH never reached 4 m: {other:?}"),
        }
    }
    {
        let s = emu.session();
        assert!((s.depth() - 4.0).abs() < 0.2, "{}", s.depth());
        assert!(
            (s.vehicle().heading - 270.0).abs() < 2.0,
            "{}",
            s.vehicle().heading
        );
    }
    posting.abort();
    helm.shutdown().await;
    service.shutdown(Duration::from_secs(5)).await;
}
