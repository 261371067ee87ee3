//! End to end through the interface: drivers loaded at run time. The basic simulator driver
//! built as a plugin drives the real simulator (over loopback TCP) to COMMAND; a C driver that
//! segfaults on its 5th command takes down only its driver-host child, and the interface reports
//! FS_ERROR(NOT_CONNECTED), restarts it and returns to COMMAND; an ABI mismatch is refused before
//! the interface starts. Waits are on published statuses, with deadlines.

mod common;

use frontseat_actors::bus::test_util::UntypedBus as _;
use std::time::Duration;

use common::*;
use frontseat_actors::bus::Bus;
use frontseat_actors::drivers::DriverSelectError;
use frontseat_actors::groups;
use frontseat_actors::interface::{InterfaceService, InterfaceSettings, ServiceExit};
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    DesiredCourse, FrontSeatError, HelmState, HelmStateReport, InterfaceState,
};
use frontseat_config::InterfaceConfig;
use frontseat_driver_sdk::Error;
use frontseat_drivers::factory_with_env;
use frontseat_sim::{SimHandle, SimOptions, SimServer};

const LONG: Duration = Duration::from_secs(20);

async fn start_sim() -> SimHandle {
    SimServer::bind(([127, 0, 0, 1], 0).into(), SimOptions::default())
        .await
        .unwrap()
}

fn config(port: u16) -> InterfaceConfig {
    let d = InterfaceConfig::default();
    let mut driver = d.driver.clone();
    driver.basic_simulator.tcp_port = port;
    driver.basic_simulator.start.lat = d.origin.lat;
    driver.basic_simulator.start.lon = d.origin.lon;
    let mut supervision = d.supervision.clone();
    supervision.restart_initial_delay_ms = 20;
    supervision.restart_max_delay_ms = 200;
    InterfaceConfig {
        name: "plugin-auv".into(),
        sim_warp_factor: 10.0,
        status_period: 0.0,
        driver,
        supervision,
        ..d
    }
}

fn helm_drive(bus: &Bus) -> tokio::task::JoinHandle<()> {
    let bus = bus.clone();
    tokio::spawn(async move {
        loop {
            bus.publish(
                &groups::GOBY_MIDDLEWARE_FRONTSEAT_HELM_STATE,
                HelmStateReport {
                    state: HelmState::HelmDrive as i32,
                },
            );
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
    })
}

fn course(heading: f64) -> DesiredCourse {
    DesiredCourse {
        time: 0.0,
        heading: Some(heading),
        speed: Some(2.0),
        depth: Some(0.0),
        ..Default::default()
    }
}

async fn basic_sim_plugin_reaches_command(isolation: &str) {
    let sim = start_sim().await;
    let bus = Bus::new();
    let mut status = StatusWatch::new(&bus);
    let (_s, mut nav) = bus.subscribe_channel(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS,
        "test",
        100_000,
    );
    let cfg = config(sim.local_addr().port());
    let env = env_with(vec![
        ("FRONTSEAT_DRIVER_LIBRARY", path_str(&rust_plugin())),
        ("FRONTSEAT_DRIVER_HOST", path_str(&driver_host())),
        ("FRONTSEAT_DRIVER_ISOLATION", isolation.to_string()),
    ]);
    let factory = factory_with_env(&cfg, &env).unwrap();
    let helm = helm_drive(&bus);
    let service = InterfaceService::start_with(InterfaceSettings::from_config(&cfg), &bus, factory)
        .await
        .unwrap();
    status
        .until_state(InterfaceState::InterfaceCommand, LONG)
        .await;
    assert_eq!(
        status.states(),
        vec![
            InterfaceState::InterfaceStandby,
            InterfaceState::InterfaceListen,
            InterfaceState::InterfaceCommand
        ]
    );
    // Steer east through the plugin; the simulator's NAV (back through the plugin) turns there.
    let deadline = tokio::time::Instant::now() + LONG;
    loop {
        bus.publish(
            &groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE,
            course(90.0),
        );
        let env = tokio::time::timeout_at(deadline, nav.recv())
            .await
            .expect("NAV keeps coming while steering")
            .unwrap();
        let heading = env.msg.pose.heading();
        if (heading - 90.0).abs() < 1.0 {
            break;
        }
    }
    let snap = service.snapshot(Duration::from_secs(1)).await.unwrap();
    assert_eq!(snap.driver_restarts, 0);
    helm.abort();
    assert_eq!(
        service.shutdown(Duration::from_secs(3)).await,
        ServiceExit::Clean
    );
    sim.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn basic_sim_plugin_drives_the_simulator_to_command() {
    basic_sim_plugin_reaches_command("process").await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn basic_sim_plugin_in_process_drives_the_simulator_to_command() {
    basic_sim_plugin_reaches_command("in-process").await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn c_plugin_segfault_is_fs_error_then_restart_then_command() {
    let lib = build_c_plugin("e2e_crash5", &["-DFSD_EXAMPLE_CRASH_ON_COMMAND=5"]);
    let bus = Bus::new();
    let mut status = StatusWatch::new(&bus);
    // driver.library in the config this time (no FRONTSEAT_DRIVER_LIBRARY).
    let mut cfg = config(1);
    cfg.driver.library = Some(path_str(&lib));
    let env = env_with(vec![("FRONTSEAT_DRIVER_HOST", path_str(&driver_host()))]);
    let factory = factory_with_env(&cfg, &env).unwrap();
    let helm = helm_drive(&bus);
    let service = InterfaceService::start_with(InterfaceSettings::from_config(&cfg), &bus, factory)
        .await
        .unwrap();
    status
        .until_state(InterfaceState::InterfaceCommand, LONG)
        .await;
    for i in 0..5 {
        bus.publish(
            &groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE,
            course(f64::from(i) * 10.0),
        );
    }
    status
        .until("error:fs (not connected) after the segfault", LONG, |s| {
            s.state() == InterfaceState::InterfaceFsError
                && s.frontseat_error() == FrontSeatError::ErrorFrontseatNotConnected
        })
        .await;
    status
        .until_state(InterfaceState::InterfaceCommand, LONG)
        .await;
    assert_eq!(
        status.states(),
        vec![
            InterfaceState::InterfaceStandby,
            InterfaceState::InterfaceListen,
            InterfaceState::InterfaceCommand,
            InterfaceState::InterfaceFsError,
            InterfaceState::InterfaceStandby,
            InterfaceState::InterfaceListen,
            InterfaceState::InterfaceCommand,
        ]
    );
    let snap = service.snapshot(Duration::from_secs(1)).await.unwrap();
    assert_eq!(snap.driver_restarts, 1, "one restart after the crash");
    helm.abort();
    assert_eq!(
        service.shutdown(Duration::from_secs(3)).await,
        ServiceExit::Clean
    );
}

#[test]
fn abi_mismatch_is_refused_before_the_interface_starts() {
    let lib = build_c_plugin("e2e_abi99", &["-DFSD_EXAMPLE_ABI_VERSION=99"]);
    let cfg = config(1);
    let env = env_with(vec![
        ("FRONTSEAT_DRIVER_LIBRARY", path_str(&lib)),
        ("FRONTSEAT_DRIVER_HOST", path_str(&driver_host())),
    ]);
    let e = factory_with_env(&cfg, &env).err().unwrap();
    assert!(
        matches!(
            e,
            DriverSelectError::Plugin(Error::AbiMismatch { found: 99, .. })
        ),
        "{e}"
    );
    assert!(e.to_string().contains("ABI version mismatch"), "{e}");
}
