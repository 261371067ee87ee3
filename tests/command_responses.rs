//! Every CommandResponse a driver gives reaches the helm, whenever it comes, as in Goby3
//! (frontseat_interface.cpp:205-208): a "pending" and then the final answer are both forwarded,
//! and an answer after the interface's own timeout is forwarded too. The interface's timeout is
//! at least the selected driver's acknowledgement budget (here the Wave Glider's 10 s), so a slow
//! vehicle's success is not reported as a failure first.
//!
//! The driver is scripted (answers on simulated time); the interface, its state machine and the
//! bus are the real ones. The clock is warped 50× so 7 s of vehicle time pass in 0.14 s.

mod common;

use frontseat_actors::bus::test_util::UntypedBus as _;
use std::time::Duration;

use common::*;
use frontseat_actors::bus::Bus;
use frontseat_actors::driver::{Driver, DriverContext, DriverFactory, DriverIoEvent, SignalSink};
use frontseat_actors::drivers::select_with_env;
use frontseat_actors::groups;
use frontseat_actors::interface::{InterfaceService, InterfaceSettings, command_timeout};
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CommandRequest, CommandResponse, DesiredCourse, FrontSeatState, HelmState, InterfaceData,
    InterfaceState, Raw,
};

const LONG: Duration = Duration::from_secs(20);
/// When the scripted vehicle gives its final answer, in its own (simulated) time.
const ANSWER_AFTER: Duration = Duration::from_secs(7);

/// A vehicle that always accepts commands, optionally answers "pending" at once, and gives its
/// final answer ANSWER_AFTER later.
struct SlowVehicle {
    pending_first: bool,
    waiting: Vec<(Option<i32>, Duration)>,
}

impl Driver for SlowVehicle {
    fn name(&self) -> &str {
        "slow-vehicle"
    }
    fn start(&mut self, _ctx: DriverContext) {}
    fn handle_io(&mut self, _ev: DriverIoEvent, _now: Duration, _sig: &mut dyn SignalSink) {}
    fn send_command_to_frontseat(
        &mut self,
        req: &CommandRequest,
        now: Duration,
        sig: &mut dyn SignalSink,
    ) {
        if !req.response_requested() {
            return;
        }
        if self.pending_first {
            sig.command_response(CommandResponse {
                request_successful: Some(false),
                request_id: req.request_id,
                error_code: Some(0),
                error_string: Some("pending".into()),
            });
        }
        self.waiting.push((req.request_id, now + ANSWER_AFTER));
    }
    fn send_data_to_frontseat(&mut self, _: &InterfaceData, _: Duration, _: &mut dyn SignalSink) {}
    fn send_raw_to_frontseat(&mut self, _: &Raw, _: Duration, _: &mut dyn SignalSink) {}
    fn do_loop(&mut self, now: Duration, sig: &mut dyn SignalSink) {
        let (due, rest): (Vec<_>, Vec<_>) = self.waiting.drain(..).partition(|(_, t)| *t <= now);
        self.waiting = rest;
        for (request_id, _) in due {
            sig.command_response(CommandResponse {
                request_successful: Some(true),
                request_id,
                ..Default::default()
            });
        }
    }
    fn frontseat_state(&self) -> FrontSeatState {
        FrontSeatState::FrontseatAcceptingCommands
    }
    fn frontseat_providing_data(&self) -> bool {
        true
    }
}

/// Runs the interface on the scripted vehicle, sends one command asking for a response once in
/// COMMAND, and returns every response to it until the vehicle's final answer arrived.
async fn responses_to_one_command(
    cfg: frontseat_config::InterfaceConfig,
    pending_first: bool,
) -> Vec<CommandResponse> {
    let bus = Bus::new();
    let mut status = StatusWatch::new(&bus);
    let (_s, mut responses) = bus.subscribe_channel(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_COMMAND_RESPONSE,
        "test",
        100,
    );
    let factory: DriverFactory = std::sync::Arc::new(move || {
        Box::new(SlowVehicle {
            pending_first,
            waiting: Vec::new(),
        }) as Box<dyn Driver>
    });
    // The scripted vehicle stands in for the driver the config names: the interface waits by
    // that driver's acknowledgement budget (the registry's word), as it would for the real one.
    let selected = select_with_env(&cfg, &|_| None, frontseat_drivers::BUILT_IN).unwrap();
    let settings = InterfaceSettings::from_config(&cfg).for_driver(&selected);
    let service = InterfaceService::start_with(settings, &bus, factory)
        .await
        .unwrap();
    let helm = helm_heartbeat(&bus, HelmState::HelmDrive);
    status
        .until_state(InterfaceState::InterfaceCommand, LONG)
        .await;
    bus.publish(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_COMMAND_REQUEST,
        CommandRequest {
            desired_course: Some(DesiredCourse {
                time: 0.0,
                heading: Some(90.0),
                speed: Some(1.0),
                ..Default::default()
            }),
            response_requested: Some(true),
            request_id: Some(7),
            ..Default::default()
        },
    );
    let mut got = Vec::new();
    loop {
        let r = tokio::time::timeout(LONG, responses.recv())
            .await
            .expect("the vehicle's final answer never reached the helm")
            .expect("bus closed");
        assert_eq!(r.msg.request_id, Some(7), "{:?}", r.msg);
        let last = r.msg.request_successful == Some(true);
        got.push((*r.msg).clone());
        if last {
            break;
        }
    }
    helm.abort();
    service.shutdown(Duration::from_secs(3)).await;
    got
}

fn warped() -> frontseat_config::InterfaceConfig {
    frontseat_config::InterfaceConfig {
        sim_warp_factor: 50.0,
        ..Default::default()
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_pending_answer_and_the_final_one_both_reach_the_helm() {
    let got = responses_to_one_command(warped(), true).await;
    let strings: Vec<&str> = got.iter().map(|r| r.error_string()).collect();
    assert_eq!(got.len(), 2, "{got:?}");
    assert_eq!(strings[0], "pending");
    assert_eq!(got[1].request_successful, Some(true));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_slow_vehicle_within_its_drivers_ack_budget_is_answered_by_the_vehicle_alone() {
    let mut cfg = warped();
    cfg.driver.name = "waveglider_sv2".into();
    cfg.driver.waveglider_sv2.link.ack_timeout = 10.0;
    assert_eq!(timeout_for(&cfg), Duration::from_secs(11));
    let got = responses_to_one_command(cfg, false).await;
    assert_eq!(got.len(), 1, "only the vehicle's answer: {got:?}");
    assert_eq!(got[0].request_successful, Some(true));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_answer_after_the_interfaces_timeout_still_reaches_the_helm() {
    // The basic simulator answers at once, so the interface's own timeout is 5 s: the scripted
    // vehicle's answer at 7 s comes after our failure, and is forwarded all the same.
    let cfg = warped();
    assert_eq!(timeout_for(&cfg), Duration::from_secs(5));
    let got = responses_to_one_command(cfg, false).await;
    assert_eq!(got.len(), 2, "{got:?}");
    assert_eq!(got[0].request_successful, Some(false));
    assert!(got[0].error_string().contains("timed out") || got[0].error_code.is_some());
    assert_eq!(got[1].request_successful, Some(true));
}

#[test]
fn the_timeout_follows_the_bluefin_resend_budget() {
    let mut cfg = frontseat_config::InterfaceConfig::default();
    cfg.driver.name = "bluefin".into();
    cfg.driver.bluefin.nmea_resend_attempts = 3;
    cfg.driver.bluefin.nmea_resend_interval = 5;
    assert_eq!(timeout_for(&cfg), Duration::from_secs(16));
}

/// The interface's own answer time for the driver `cfg` selects (its ack budget, from the registry).
fn timeout_for(cfg: &frontseat_config::InterfaceConfig) -> Duration {
    let driver = select_with_env(cfg, &|_| None, frontseat_drivers::BUILT_IN)
        .map(|d| d.ack_budget)
        .unwrap_or(Duration::MAX);
    command_timeout(driver)
}
