//! `helm_state_timeout`, the rule a fleet across links relies on: with it set, a helm that stops
//! repeating helm_state takes the interface out of COMMAND (helm error, helm not running) and a
//! helm heard again brings it back; with it 0 (the default, Goby3's), the last helm_state holds.
//! The real FrontSeatInterface against the real simulator over loopback.

mod common;

use std::time::Duration;

use common::{StatusWatch, WARP, config_for, helm_heartbeat, is_helm_error, start_sim};
use frontseat_actors::bus::Bus;
use frontseat_actors::interface::InterfaceService;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    HelmError, HelmState, InterfaceState,
};

const LONG: Duration = Duration::from_secs(20);

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_silent_helm_takes_the_vehicle_out_of_command_and_back_when_heard_again() {
    let sim = start_sim().await;
    let bus = Bus::new();
    let mut status = StatusWatch::new(&bus);
    let mut cfg = config_for(&sim, WARP);
    cfg.helm_state_timeout = 3.0; // sim seconds: 0.3 s of wall time at WARP 10
    let helm = helm_heartbeat(&bus, HelmState::HelmDrive);
    let service = InterfaceService::start(&cfg, &bus, frontseat_drivers::BUILT_IN)
        .await
        .unwrap();
    status
        .until_state(InterfaceState::InterfaceCommand, LONG)
        .await;

    helm.abort();
    status
        .until("helm error: helm not running", LONG, |s| {
            is_helm_error(s, HelmError::ErrorHelmNotRunning)
        })
        .await;

    let helm = helm_heartbeat(&bus, HelmState::HelmDrive);
    status
        .until_state(InterfaceState::InterfaceCommand, LONG)
        .await;
    helm.abort();
    service.shutdown(Duration::from_secs(3)).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn without_the_timeout_the_last_helm_state_holds_as_in_goby3() {
    let sim = start_sim().await;
    let bus = Bus::new();
    let mut status = StatusWatch::new(&bus);
    let mut cfg = config_for(&sim, WARP);
    cfg.status_period = 0.5; // a status every 50 ms of wall time, to watch the state
    let helm = helm_heartbeat(&bus, HelmState::HelmDrive);
    let service = InterfaceService::start(&cfg, &bus, frontseat_drivers::BUILT_IN)
        .await
        .unwrap();
    status
        .until_state(InterfaceState::InterfaceCommand, LONG)
        .await;
    helm.abort();
    // Twenty periodic statuses (10 s of sim time, 3 × a 3 s timeout) later: still COMMAND.
    for _ in 0..20 {
        let s = status.until("a periodic status", LONG, |_| true).await;
        assert_eq!(
            s.state(),
            InterfaceState::InterfaceCommand,
            "{:?}",
            status.states()
        );
    }
    service.shutdown(Duration::from_secs(3)).await;
}
