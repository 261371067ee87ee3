//! The supervision tree with real parts: a root supervisor over the basic simulator's server (real
//! loopback TCP) and the FrontSeatInterface with its DriverActor, as `frontseat interface`,
//! `frontseat sim` and the demo compose them. Failure semantics asserted here:
//! - the interface actor panics → the root restarts it (its old DriverActor stopped), NAV flows on the bus again and the
//!   restart is visible on `frontseat::supervision::status`;
//! - the driver's own restart limit exhausted → not restarted by the root: the process's exit is
//!   the driver limit's (3), as before the root supervisor existed;
//! - a helm-side child failing again and again, far past its restart limit → restarted without
//!   end, the process degraded but alive, the driver's connection to the frontseat never closed;
//! - the driver crashing under its own supervisor (nested in the interface) → pending commands
//!   fail with DRIVER_FAILED, the restarted driver's first status brings back COMMAND.
//!
//! Every wait has a deadline.

use frontseat_actors::bus::test_util::UntypedBus as _;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use frontseat_actors::bus::Bus;
use frontseat_actors::driver::{Driver, DriverContext, DriverFactory, DriverIoEvent, SignalSink};
use frontseat_actors::groups;
use frontseat_actors::interface::{
    FsiMsg, InterfaceService, InterfaceSettings, ServiceExit, error_code,
};
use frontseat_actors::proto::frontseat::protobuf::{ChaosFault, chaos_fault};
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CommandRequest, DesiredCourse, FrontSeatState, HelmState, HelmStateReport, InterfaceData,
    InterfaceState, InterfaceStatus, Raw,
};
use frontseat_actors::service_child::{BoxFuture, Service, StartService, service_child};
use frontseat_actors::supervisor::{ChildFailure, ChildSpec, Policy, SupervisorHandle};
use frontseat_config::RestartPolicy;
use frontseat_config::{InterfaceConfig, RestartConfig};
use frontseat_sim::{SimOptions, SimServer};
use ractor::ActorRef;

const DEADLINE: Duration = Duration::from_secs(20);

type Current = Arc<Mutex<Option<ActorRef<FsiMsg>>>>;

fn interface_child(cfg: InterfaceConfig, bus: Bus, current: Current) -> ChildSpec {
    let policy: Policy = (&cfg.supervision.interface).into();
    let start: StartService = Arc::new(move || {
        let (cfg, bus, current) = (cfg.clone(), bus.clone(), current.clone());
        Box::pin(async move {
            let s = InterfaceService::start(&cfg, &bus, frontseat_drivers::BUILT_IN)
                .await
                .map_err(|e| e.to_string())?;
            *current.lock().unwrap() = Some(s.actor().clone());
            Ok(Box::new(s) as Box<dyn Service>)
        })
    });
    service_child("FrontSeatInterface", policy, start)
}

async fn tree(max_driver_restarts: u32) -> (Bus, SupervisorHandle, Current) {
    let bus = Bus::new();
    let sim = SimServer::bind(([127, 0, 0, 1], 0).into(), SimOptions::default())
        .await
        .unwrap();
    let mut cfg = InterfaceConfig {
        name: "tree-auv".into(),
        sim_warp_factor: 10.0,
        ..Default::default()
    };
    cfg.driver.basic_simulator.tcp_port = sim.local_addr().port();
    cfg.supervision.max_restarts = max_driver_restarts;
    // The faults below reach the interface and its driver through their fault ports.
    cfg.chaos.enabled = true;
    cfg.supervision.interface = RestartConfig {
        backoff_initial_ms: 10,
        ..cfg.supervision.interface.clone()
    };
    let sim_start: StartService = Arc::new(move || {
        let sim = sim.clone();
        Box::pin(async move { Ok(Box::new(sim) as Box<dyn Service>) })
    });
    let current = Current::default();
    let children = vec![
        service_child("SimServer", (&RestartConfig::default()).into(), sim_start),
        interface_child(cfg, bus.clone(), current.clone()),
    ];
    let root = SupervisorHandle::start("root", children, Some(&bus))
        .await
        .unwrap();
    (bus, root, current)
}

/// Waits for a NAV (node_status) published after this call.
async fn nav_flows(bus: &Bus) {
    let (_sub, mut rx) = bus.subscribe_channel(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS,
        "test-nav",
        64,
    );
    tokio::time::timeout(DEADLINE, rx.recv())
        .await
        .expect("node_status within the deadline")
        .expect("bus open");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_panicked_interface_is_restarted_and_nav_flows_again() {
    let (bus, root, current) = tree(10).await;
    let (_sup_sub, mut statuses) =
        bus.subscribe_channel(&groups::FRONTSEAT_SUPERVISION_STATUS, "test-sup", 64);
    nav_flows(&bus).await;
    let first = current
        .lock()
        .unwrap()
        .clone()
        .expect("the interface started");
    let first_driver = first.get_children();
    assert_eq!(
        first_driver.len(),
        1,
        "the interface supervises its DriverActor"
    );
    // A panic, as a bug in the interface would cause one.
    let reached = bus.publish(
        &groups::FRONTSEAT_CHAOS_FAULT,
        ChaosFault {
            fault: Some(chaos_fault::Fault::InterfacePanic(true)),
        },
    );
    assert!(reached.delivered >= 1, "the interface's fault port is open");
    // The root restarts it: a new actor, and the restart on the status group.
    let restarted = async {
        loop {
            let s = statuses.recv().await.expect("bus open");
            let fsi = s
                .msg
                .children
                .iter()
                .find(|c| c.name.as_deref() == Some("FrontSeatInterface"))
                .cloned()
                .expect("the interface is a child of the root");
            if fsi.restarts == Some(1) && fsi.up == Some(true) {
                return fsi;
            }
        }
    };
    let fsi = tokio::time::timeout(DEADLINE, restarted)
        .await
        .expect("restart reported within the deadline");
    assert!(fsi.last_failure.is_some(), "{fsi:?}");
    let second = current.lock().unwrap().clone().unwrap();
    assert_ne!(first.get_id(), second.get_id());
    nav_flows(&bus).await;
    // The killed interface's driver went with it: one frontseat connection, not two.
    tokio::time::timeout(DEADLINE, first_driver[0].wait(None))
        .await
        .expect("the old DriverActor stopped")
        .unwrap();
    let snap = root.snapshot(DEADLINE).await.unwrap();
    let sim = snap
        .children
        .iter()
        .find(|c| c.name == "SimServer")
        .unwrap();
    assert_eq!(sim.restarts, 0, "the simulator was not touched: {snap:?}");
    root.shutdown(Duration::from_secs(10)).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_drivers_exhausted_limit_ends_the_process_with_exit_3() {
    // max_restarts = 0: the driver's first failure ends the interface with its restart limit.
    let (bus, mut root, current) = tree(0).await;
    nav_flows(&bus).await;
    let fsi = current.lock().unwrap().clone().unwrap();
    bus.publish(
        &groups::FRONTSEAT_CHAOS_FAULT,
        ChaosFault {
            fault: Some(chaos_fault::Fault::DriverPanic(true)),
        },
    );
    let exit = tokio::time::timeout(DEADLINE, root.wait())
        .await
        .expect("the root gives up within the deadline");
    assert_eq!(exit.code(), 3, "{exit:?}");
    let again = current.lock().unwrap().clone().unwrap();
    assert_eq!(
        fsi.get_id(),
        again.get_id(),
        "the interface was not restarted"
    );
    root.shutdown(Duration::from_secs(10)).await;
}

/// A helm-side part that fails as soon as it has started, every time (a gateway that keeps
/// failing, a panic tripped again and again by some helm input).
struct FailsAtOnce;

impl Service for FailsAtOnce {
    fn ended(&mut self) -> BoxFuture<'_, Result<(), ChildFailure>> {
        Box::pin(async { Err(ChildFailure::new("tripped by helm input, again")) })
    }
    fn stop(self: Box<Self>, _within: Duration) -> BoxFuture<'static, ()> {
        Box::pin(async {})
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_helm_side_child_failing_without_end_never_ends_the_process_nor_the_vehicle_link() {
    use tokio::io::AsyncBufReadExt;
    const FAILURES: u32 = 30;
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let mut cfg = InterfaceConfig {
        name: "helm-fault-auv".into(),
        sim_warp_factor: 10.0,
        ..Default::default()
    };
    cfg.driver.basic_simulator.tcp_port = listener.local_addr().unwrap().port();
    let bus = Bus::new();
    let (_sup_sub, mut statuses) =
        bus.subscribe_channel(&groups::FRONTSEAT_SUPERVISION_STATUS, "test-sup", 10_000);
    // Its limit is 2 restarts a minute: on the vehicle side the 3rd failure would end the process.
    let flaky = service_child(
        "FlakyGateway",
        Policy {
            restart: RestartPolicy::OnFailure,
            max_restarts: 2,
            window: Duration::from_secs(60),
            backoff_initial: Duration::from_millis(1),
            backoff_max: Duration::from_millis(5),
            ..Policy::from(&RestartConfig::default())
        }
        .helm_side(),
        Arc::new(|| Box::pin(async { Ok(Box::new(FailsAtOnce) as Box<dyn Service>) })),
    );
    let current = Current::default();
    let root = SupervisorHandle::start(
        "root",
        vec![interface_child(cfg, bus.clone(), current), flaky],
        Some(&bus),
    )
    .await
    .unwrap();
    let (sock, _) = tokio::time::timeout(DEADLINE, listener.accept())
        .await
        .expect("the driver connects")
        .unwrap();
    let mut sock = tokio::io::BufReader::new(sock);
    let mut start = String::new();
    tokio::time::timeout(DEADLINE, sock.read_line(&mut start))
        .await
        .expect("START")
        .unwrap();
    assert!(start.starts_with("START,"), "{start:?}");

    // Restarted far past its limit, reported degraded (which child, since when) while down.
    let mut degraded_seen = false;
    tokio::time::timeout(DEADLINE, async {
        loop {
            let s = statuses.recv().await.expect("bus open");
            let flaky = s
                .msg
                .children
                .iter()
                .find(|c| c.name.as_deref() == Some("FlakyGateway"))
                .cloned()
                .expect("a child of the root");
            assert_eq!(flaky.side.as_deref(), Some("helm"));
            assert_ne!(s.msg.gave_up, Some(true), "the root gave up: {:?}", s.msg);
            if flaky.up == Some(false) {
                assert!(flaky.down_since.is_some(), "{flaky:?}");
                assert_eq!(s.msg.degraded, Some(true), "{:?}", s.msg);
                degraded_seen = true;
            }
            if flaky.restarts.unwrap_or(0) >= FAILURES {
                return;
            }
        }
    })
    .await
    .expect("the helm-side child is restarted again and again");
    assert!(degraded_seen);

    assert_eq!(root.exit_now(), None, "the process goes on");
    let snap = root.snapshot(DEADLINE).await.expect("the root answers");
    let fsi = snap
        .children
        .iter()
        .find(|c| c.name == "FrontSeatInterface")
        .unwrap();
    assert!(
        fsi.up && fsi.restarts == 0,
        "vehicle side untouched: {fsi:?}"
    );
    // The driver's connection is still the first one, and open: reading finds no end of stream.
    let mut buf = [0u8; 256];
    loop {
        match sock.get_ref().try_read(&mut buf) {
            Ok(0) => panic!("the driver closed the frontseat connection"),
            Ok(_) => continue,
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => break,
            Err(e) => panic!("frontseat connection: {e}"),
        }
    }
    root.shutdown(Duration::from_secs(10)).await;
}

/// A frontseat that accepts commands and never answers them; a command with request id
/// `CRASH_ON` makes it panic, as a driver bug would.
struct Mute;

const CRASH_ON: i32 = 99;

impl Driver for Mute {
    fn name(&self) -> &str {
        "mute"
    }
    fn start(&mut self, _ctx: DriverContext) {}
    fn handle_io(&mut self, _ev: DriverIoEvent, _now: Duration, _sig: &mut dyn SignalSink) {}
    fn send_command_to_frontseat(
        &mut self,
        req: &CommandRequest,
        _now: Duration,
        _sig: &mut dyn SignalSink,
    ) {
        assert_ne!(req.request_id, Some(CRASH_ON), "the mute driver crashes");
    }
    fn send_data_to_frontseat(&mut self, _: &InterfaceData, _: Duration, _: &mut dyn SignalSink) {}
    fn send_raw_to_frontseat(&mut self, _: &Raw, _: Duration, _: &mut dyn SignalSink) {}
    fn do_loop(&mut self, _now: Duration, _sig: &mut dyn SignalSink) {}
    fn frontseat_state(&self) -> FrontSeatState {
        FrontSeatState::FrontseatAcceptingCommands
    }
    fn frontseat_providing_data(&self) -> bool {
        true
    }
}

/// Waits for an InterfaceStatus in `state`.
async fn until_state(
    rx: &mut tokio::sync::mpsc::UnboundedReceiver<frontseat_actors::bus::Envelope<InterfaceStatus>>,
    state: InterfaceState,
) {
    tokio::time::timeout(DEADLINE, async {
        while let Some(s) = rx.recv().await {
            if s.msg.state() == state {
                return;
            }
        }
        panic!("status group closed");
    })
    .await
    .unwrap_or_else(|_| panic!("no {state:?} within the deadline"));
}

/// The driver's restart is its supervisor's, and the interface still plays its part: a command
/// pending when the driver crashes fails with DRIVER_FAILED, the interface leaves COMMAND, and
/// once the supervisor restarted the driver the new driver's very first status (it sends no
/// other) brings the interface back to COMMAND.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_driver_crash_fails_pending_commands_and_its_supervisor_restarts_it() {
    let bus = Bus::new();
    let (_st_sub, mut statuses) = bus.subscribe_channel(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_STATUS,
        "test-status",
        1024,
    );
    let (_resp_sub, mut responses) = bus.subscribe_channel(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_COMMAND_RESPONSE,
        "test-responses",
        64,
    );
    let mut cfg = InterfaceConfig::default();
    cfg.supervision.restart_initial_delay_ms = 10;
    let factory: DriverFactory = Arc::new(|| Box::new(Mute) as Box<dyn Driver>);
    let service = InterfaceService::start_with(InterfaceSettings::from_config(&cfg), &bus, factory)
        .await
        .unwrap();
    let helm = {
        let bus = bus.clone();
        tokio::spawn(async move {
            loop {
                bus.publish(
                    &groups::GOBY_MIDDLEWARE_FRONTSEAT_HELM_STATE,
                    HelmStateReport {
                        state: HelmState::HelmDrive as i32,
                    },
                );
                tokio::time::sleep(Duration::from_millis(50)).await;
            }
        })
    };
    until_state(&mut statuses, InterfaceState::InterfaceCommand).await;

    let ask = |id: i32| CommandRequest {
        desired_course: Some(DesiredCourse {
            heading: Some(90.0),
            speed: Some(1.0),
            ..Default::default()
        }),
        response_requested: Some(true),
        request_id: Some(id),
        cancel_request_id: None,
    };
    bus.publish(&groups::GOBY_MIDDLEWARE_FRONTSEAT_COMMAND_REQUEST, ask(7));
    bus.publish(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_COMMAND_REQUEST,
        ask(CRASH_ON),
    );
    let mut failed = Vec::new();
    while failed.len() < 2 {
        let r = tokio::time::timeout(DEADLINE, responses.recv())
            .await
            .expect("the pending commands are answered")
            .expect("bus open");
        assert_eq!(r.msg.request_successful, Some(false), "{:?}", r.msg);
        assert_eq!(
            r.msg.error_code,
            Some(error_code::DRIVER_FAILED),
            "{:?}",
            r.msg
        );
        failed.push(r.msg.request_id);
    }
    failed.sort();
    assert_eq!(failed, vec![Some(7), Some(CRASH_ON)]);

    until_state(&mut statuses, InterfaceState::InterfaceFsError).await;
    until_state(&mut statuses, InterfaceState::InterfaceCommand).await;
    let snap = service
        .snapshot(Duration::from_secs(2))
        .await
        .expect("the interface answers");
    assert_eq!(snap.driver_restarts, 1, "{snap:?}");
    assert!(snap.driver_up, "{snap:?}");
    helm.abort();
    assert_eq!(
        service.shutdown(Duration::from_secs(3)).await,
        ServiceExit::Clean
    );
}
