//! Shared pieces of the end-to-end tests: a real simulator on an ephemeral loopback port, an
//! interface config pointing at it, and waiting for published statuses with a deadline.
#![allow(dead_code)]

pub mod ais;
pub mod goby3;
pub mod logcap;
pub mod mcap_python;
pub mod otlp;
pub mod phelm;
pub mod procs;
pub mod python;
pub mod temp_dir;

use frontseat_actors::bus::test_util::UntypedBus as _;
use std::time::Duration;

use frontseat_actors::bus::{Bus, Envelope};
use frontseat_actors::groups;
use frontseat_actors::proto::frontseat::protobuf::ardupilot::{
    self, ArdupilotCommand, ardupilot_command::Action,
};
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CommandResponse, FrontSeatError, HelmError, HelmState, HelmStateReport, InterfaceState,
    InterfaceStatus,
};
use frontseat_config::InterfaceConfig;
use frontseat_sim::{SimHandle, SimOptions, SimServer};
use tokio::sync::mpsc::UnboundedReceiver;

pub const WARP: f64 = 10.0;

pub async fn start_sim() -> SimHandle {
    SimServer::bind(([127, 0, 0, 1], 0).into(), SimOptions::default())
        .await
        .expect("simulator binds an ephemeral loopback port")
}

pub fn config_for(sim: &SimHandle, warp: f64) -> InterfaceConfig {
    let mut cfg = InterfaceConfig {
        name: "test-auv".into(),
        sim_warp_factor: warp,
        status_period: 0.0,
        ..Default::default()
    };
    cfg.driver.basic_simulator.tcp_port = sim.local_addr().port();
    cfg.driver.basic_simulator.start.lat = cfg.origin.lat;
    cfg.driver.basic_simulator.start.lon = cfg.origin.lon;
    cfg.supervision.restart_initial_delay_ms = 20;
    cfg.supervision.restart_max_delay_ms = 200;
    cfg
}

/// Every status the interface publishes, in order.
pub struct StatusWatch {
    rx: UnboundedReceiver<Envelope<InterfaceStatus>>,
    pub seen: Vec<InterfaceStatus>,
}

impl StatusWatch {
    pub fn new(bus: &Bus) -> Self {
        let (sub, rx) =
            bus.subscribe_channel(&groups::GOBY_MIDDLEWARE_FRONTSEAT_STATUS, "test", 10_000);
        std::mem::forget(sub);
        Self {
            rx,
            seen: Vec::new(),
        }
    }

    /// Waits (wall time) until a status satisfies `pred`; panics with the sequence seen.
    pub async fn until(
        &mut self,
        what: &str,
        within: Duration,
        pred: impl Fn(&InterfaceStatus) -> bool,
    ) -> InterfaceStatus {
        let deadline = tokio::time::Instant::now() + within;
        loop {
            match tokio::time::timeout_at(deadline, self.rx.recv()).await {
                Ok(Some(env)) => {
                    let s = *env.msg;
                    self.seen.push(s);
                    if pred(&s) {
                        return s;
                    }
                }
                Ok(None) => panic!("status channel closed while waiting for {what}"),
                Err(_) => panic!(
                    "timed out after {within:?} waiting for {what}; statuses seen: {:?}",
                    self.states()
                ),
            }
        }
    }

    pub async fn until_state(
        &mut self,
        state: InterfaceState,
        within: Duration,
    ) -> InterfaceStatus {
        self.until(&format!("{state:?}"), within, |s| s.state() == state)
            .await
    }

    pub fn states(&self) -> Vec<InterfaceState> {
        let mut v: Vec<InterfaceState> = Vec::new();
        for s in &self.seen {
            if v.last() != Some(&s.state()) {
                v.push(s.state());
            }
        }
        v
    }
}

pub fn is_fs_error(s: &InterfaceStatus, e: FrontSeatError) -> bool {
    s.state() == InterfaceState::InterfaceFsError && s.frontseat_error() == e
}

pub fn is_helm_error(s: &InterfaceStatus, e: HelmError) -> bool {
    s.state() == InterfaceState::InterfaceHelmError && s.helm_error() == e
}

/// Publishes helm_state `state` every 100 ms (wall) until the returned task is aborted.
pub fn helm_heartbeat(bus: &Bus, state: HelmState) -> tokio::task::JoinHandle<()> {
    let bus = bus.clone();
    tokio::spawn(async move {
        loop {
            bus.publish(
                &groups::GOBY_MIDDLEWARE_FRONTSEAT_HELM_STATE,
                HelmStateReport {
                    state: state as i32,
                },
            );
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
    })
}

/// The pilot's ArduPilot `action` as request `id`, asking for an answer.
pub fn mode_request(action: Action, id: i32) -> ardupilot::CommandRequest {
    ardupilot::CommandRequest {
        response_requested: Some(true),
        request_id: Some(id),
        ardupilot_command: Some(ArdupilotCommand {
            action: Some(action as i32),
        }),
        ..Default::default()
    }
}

/// The pilot's ArduPilot `action`, as command_requests with ids from `first_id` on, each
/// answered within `timeout` on `responses` (the COMMAND_RESPONSE group), again every 50 ms until
/// one is accepted; panics after 100 refusals.
pub async fn until_accepted(
    bus: &Bus,
    responses: &mut UnboundedReceiver<Envelope<CommandResponse>>,
    action: Action,
    first_id: i32,
    timeout: Duration,
) {
    for id in first_id..first_id + 100 {
        bus.publish(
            &groups::FRONTSEAT_ARDUPILOT_ARDUPILOT_COMMAND_REQUEST,
            mode_request(action, id),
        );
        let deadline = tokio::time::Instant::now() + timeout;
        let accepted = loop {
            let env = tokio::time::timeout_at(deadline, responses.recv())
                .await
                .unwrap_or_else(|_| panic!("no response to {id} in time"))
                .expect("bus alive");
            if env.msg.request_id == Some(id) {
                break env.msg.request_successful();
            }
        };
        if accepted {
            return;
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    panic!("{action:?} never accepted");
}
