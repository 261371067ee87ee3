//! DUNE end to end over real loopback sockets: the LAUV emulator's BackSeat TCP server on an
//! ephemeral port, the interface with the real `dune` driver, and the demo helm flying the
//! homework triangle at 2 m depth. The driver must start its FollowReference plan on COMMAND,
//! steer the vehicle to depth and around the triangle, and end the plan (MANDONE, STOP) when the
//! helm parks; line noise on the link is survived.

mod common;

use std::time::Duration;

use common::*;
use frontseat_actors::bus::Bus;
use frontseat_actors::clock::SimClock;
use frontseat_actors::interface::InterfaceService;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{HelmState, InterfaceState};
use frontseat_config::InterfaceConfig;
use frontseat_demo_helm::{self as demo_helm, DemoParams};
use frontseat_dune::emulator::{DuneOptions, DuneSession};
use frontseat_sim::emulator::{Emulator, Endpoint};

const LONG: Duration = Duration::from_secs(60);

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_demo_helm_flies_the_triangle_at_depth_through_the_dune_driver() {
    let mut cfg = InterfaceConfig {
        name: "test-lauv".into(),
        sim_warp_factor: WARP,
        status_period: 0.0,
        ..Default::default()
    };
    let emu = Emulator::start(
        DuneSession::new(DuneOptions {
            lat: cfg.origin.lat,
            lon: cfg.origin.lon,
            ..Default::default()
        }),
        Endpoint::Tcp(([127, 0, 0, 1], 0).into()),
        WARP,
    )
    .await
    .expect("emulator binds loopback");
    let addr = emu.tcp_addr().unwrap();
    cfg.driver.name = "dune".into();
    cfg.driver.dune.address = addr.ip().to_string();
    cfg.driver.dune.port = addr.port();
    cfg.driver.dune.reconnect_initial_ms = 20;
    let bus = Bus::new();
    let mut status = StatusWatch::new(&bus);
    let service = InterfaceService::start(&cfg, &bus, frontseat_drivers::BUILT_IN)
        .await
        .unwrap();

    // Noise on the link before anything else: the deframer resynchronises.
    emu.inject_bytes(b"\x00\xff noise \x54\xfe\x01".to_vec());

    let params = DemoParams {
        east_s: 40.0,
        south_s: 40.0,
        depths: [2.0; 3],
        max_s: 400.0,
        ..Default::default()
    };
    // Sim times of the plan's start, the first heading 90 ± 0.1 and depth 2 ± 0.3 after it,
    // read from the emulator while the demo runs (20 ms of wall time = 0.2 s of sim time).
    let emu = std::sync::Arc::new(emu);
    let watch = {
        let emu = emu.clone();
        tokio::spawn(async move {
            let (mut start, mut heading, mut depth) = (None, None, None);
            loop {
                {
                    let s = emu.session();
                    let t = s.time();
                    if start.is_none() && s.maneuver_running() {
                        start = Some(t);
                    }
                    if let Some(t0) = start {
                        let v = s.vehicle();
                        if heading.is_none()
                            && frontseat_sim::vehicle::short_turn(v.heading, 90.0).abs() < 0.1
                        {
                            heading = Some(t - t0);
                        }
                        if depth.is_none() && (v.depth - 2.0).abs() < 0.3 {
                            depth = Some(t - t0);
                        }
                    }
                    if heading.is_some() && depth.is_some() {
                        return (heading, depth);
                    }
                }
                tokio::time::sleep(Duration::from_millis(20)).await;
            }
        })
    };
    let report = tokio::time::timeout(
        LONG,
        demo_helm::run(&bus, SimClock::new(WARP), params, |_| {}),
    )
    .await
    .expect("the demo finishes");
    let (heading, depth) = tokio::time::timeout(Duration::from_secs(1), watch)
        .await
        .expect("heading and depth were both reached")
        .unwrap();
    println!(
        "DUNE demo: heading 90 ± 0.1 {:.1} s and depth 2 ± 0.3 {:.1} s (sim) after the plan started; \
         closest approach on the way back {:.1} m",
        heading.unwrap_or_default(),
        depth.unwrap_or_default(),
        report.closest_approach_m
    );
    assert!(report.reached_command, "never reached COMMAND");
    assert!(report.completed, "the triangle was not completed");
    assert!(
        report.closest_approach_m < 20.0,
        "closest approach {} m",
        report.closest_approach_m
    );
    {
        let s = emu.session();
        assert!(s.stats.plans_started >= 1);
        assert_eq!(
            s.stats.timeouts, 0,
            "References never stopped while driving"
        );
        assert!(s.stats.references > 100, "{:?}", s.stats);
        assert!(
            (s.vehicle().depth - 2.0).abs() < 0.3,
            "depth {} m at the end",
            s.vehicle().depth
        );
        assert!(s.stats.bad_input == 0);
    }
    // The helm parks: the interface leaves COMMAND and the driver ends the plan.
    let _park = helm_heartbeat(&bus, HelmState::HelmPark);
    status
        .until_state(InterfaceState::InterfaceListen, LONG)
        .await;
    tokio::time::timeout(LONG, async {
        while emu.session().maneuver_running() {
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
    })
    .await
    .expect("the plan ends when the helm parks");
    {
        let s = emu.session();
        assert_eq!(s.stats.mandone, 1);
        assert_eq!(s.stats.stops, 1);
        assert_eq!(
            s.stats.not_for_us, 0,
            "every packet went to the vehicle's id"
        );
    }
    service.shutdown(Duration::from_secs(5)).await;
}
