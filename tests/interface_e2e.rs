//! End to end over real loopback TCP: the real simulator, the real interface with the basic
//! simulator driver, and a test helm on the bus. Each test awaits the published statuses with a
//! deadline; the sim runs warped so sim-time timeouts pass quickly.

mod common;

use frontseat_actors::bus::test_util::UntypedBus as _;
use std::sync::Arc;
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::Duration;

use common::*;
use frontseat_actors::bus::Bus;
use frontseat_actors::driver::{Driver, DriverContext, DriverFactory, DriverIoEvent, SignalSink};
use frontseat_actors::groups;
use frontseat_actors::interface::{InterfaceService, InterfaceSettings, ServiceExit};
use frontseat_actors::proto::frontseat::protobuf::{SimFault, sim_fault};
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CommandRequest, DesiredCourse, FrontSeatError, FrontSeatState, HelmError, HelmState,
    InterfaceData, InterfaceState, Raw,
};
use frontseat_basic_simulator::{BasicSimulatorDriver, Settings};

const LONG: Duration = Duration::from_secs(20);

fn ctrl(c: sim_fault::Ctrl) -> SimFault {
    SimFault {
        vehicle: None,
        fault: Some(sim_fault::Fault::Ctrl(c as i32)),
    }
}

fn course(heading: f64, speed: f64) -> DesiredCourse {
    DesiredCourse {
        time: 0.0,
        heading: Some(heading),
        speed: Some(speed),
        depth: Some(0.0),
        ..Default::default()
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn reaches_command_steers_and_reports_ground_truth() {
    let sim = start_sim().await;
    let bus = Bus::new();
    let _emb = frontseat_actors::sim_glue::embed(&sim, &bus);
    let mut status = StatusWatch::new(&bus);
    let (_s1, mut nav) = bus.subscribe_channel(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS,
        "test",
        100_000,
    );
    let (_s2, mut truth) =
        bus.subscribe_channel(&groups::FRONTSEAT_SIM_GROUND_TRUTH, "test", 100_000);
    let cfg = config_for(&sim, WARP);
    let helm = helm_heartbeat(&bus, HelmState::HelmDrive);
    let service = InterfaceService::start(&cfg, &bus, frontseat_drivers::BUILT_IN)
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
        ],
        "standby → listen → command, each state published"
    );

    // Steer east; the heading must converge to 90.
    let deadline = tokio::time::Instant::now() + LONG;
    let last;
    loop {
        bus.publish(
            &groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE,
            course(90.0, 2.0),
        );
        let env = tokio::time::timeout_at(deadline, nav.recv())
            .await
            .expect("node_status keeps coming")
            .unwrap();
        let ns = env.msg.clone();
        assert_eq!(
            ns.name.as_deref(),
            Some("test-auv"),
            "compute_missing fills the name"
        );
        assert!(ns.local_fix.is_some(), "compute_missing fills local_fix");
        if (ns.pose.heading() - 90.0).abs() < 0.5 && ns.speed.over_ground > 1.9 {
            last = Some(ns);
            break;
        }
    }
    let reported = last.unwrap();
    // The interface's node_status must agree with the simulator's ground truth: find the truth
    // sample closest in position (they come from the same tick).
    // The truth of that tick travels another path (broadcast → bus), so it may still be on its
    // way: read until it comes, with a deadline.
    let mut best = f64::INFINITY;
    let truth_deadline = tokio::time::Instant::now() + Duration::from_secs(5);
    while best >= 1e-7 {
        let Ok(Some(t)) = tokio::time::timeout_at(truth_deadline, truth.recv()).await else {
            break;
        };
        let d = (t.msg.global_fix.lat - reported.global_fix.lat).abs()
            + (t.msg.global_fix.lon - reported.global_fix.lon).abs();
        best = best.min(d);
        if d < 1e-7 {
            let lt = t.msg.local_fix.unwrap();
            let lr = reported.local_fix.unwrap();
            assert!(
                (lt.x - lr.x).abs() < 0.05 && (lt.y - lr.y).abs() < 0.05,
                "{lt:?} vs {lr:?}"
            );
            assert!((t.msg.pose.heading() - reported.pose.heading()).abs() < 1e-6);
        }
    }
    assert!(
        best < 1e-7,
        "no ground truth sample matches the reported position ({best})"
    );
    assert!(reported.local_fix.unwrap().x > 0.0, "moved east");
    helm.abort();
    assert_eq!(
        service.shutdown(Duration::from_secs(3)).await,
        ServiceExit::Clean
    );
    sim.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn helm_errors_not_running_parked_and_cleared_by_drive() {
    let sim = start_sim().await;
    let bus = Bus::new();
    let mut status = StatusWatch::new(&bus);
    let mut cfg = config_for(&sim, WARP);
    cfg.helm_running_timeout = 5.0;
    let service = InterfaceService::start(&cfg, &bus, frontseat_drivers::BUILT_IN)
        .await
        .unwrap();

    let s = status
        .until("helm error not running", LONG, |s| {
            is_helm_error(s, HelmError::ErrorHelmNotRunning)
        })
        .await;
    assert_eq!(s.helm_state(), HelmState::HelmNotRunning);

    let helm = helm_heartbeat(&bus, HelmState::HelmDrive);
    status
        .until_state(InterfaceState::InterfaceCommand, LONG)
        .await;
    helm.abort();
    let park = helm_heartbeat(&bus, HelmState::HelmPark);
    status
        .until("helm error parked", LONG, |s| {
            is_helm_error(s, HelmError::ErrorHelmParked)
        })
        .await;
    park.abort();
    let drive = helm_heartbeat(&bus, HelmState::HelmDrive);
    status
        .until_state(InterfaceState::InterfaceStandby, LONG)
        .await;
    status
        .until_state(InterfaceState::InterfaceCommand, LONG)
        .await;
    drive.abort();
    service.shutdown(Duration::from_secs(3)).await;
    sim.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn ctrl_auv_idle_and_duration_move_command_to_listen_and_back() {
    let sim = start_sim().await;
    let bus = Bus::new();
    let _emb = frontseat_actors::sim_glue::embed(&sim, &bus);
    let mut status = StatusWatch::new(&bus);
    let mut cfg = config_for(&sim, WARP);
    // DURATION 30 s of sim time: the simulator goes IDLE on its own at the end.
    cfg.driver.basic_simulator.start.duration = 30.0;
    let helm = helm_heartbeat(&bus, HelmState::HelmDrive);
    let service = InterfaceService::start(&cfg, &bus, frontseat_drivers::BUILT_IN)
        .await
        .unwrap();
    status
        .until_state(InterfaceState::InterfaceCommand, LONG)
        .await;

    bus.publish(&groups::FRONTSEAT_SIM_FAULT, ctrl(sim_fault::Ctrl::Auv));
    let s = status
        .until_state(InterfaceState::InterfaceListen, LONG)
        .await;
    assert_eq!(s.frontseat_state(), FrontSeatState::FrontseatInControl);
    bus.publish(&groups::FRONTSEAT_SIM_FAULT, ctrl(sim_fault::Ctrl::Payload));
    status
        .until_state(InterfaceState::InterfaceCommand, LONG)
        .await;

    // DURATION runs out: CTRL,STATE:IDLE → listen (then NAV stops → not providing data).
    let s = status
        .until("listen with frontseat idle", LONG, |s| {
            s.state() == InterfaceState::InterfaceListen
                && s.frontseat_state() == FrontSeatState::FrontseatIdle
        })
        .await;
    assert_eq!(s.frontseat_state(), FrontSeatState::FrontseatIdle);
    helm.abort();
    service.shutdown(Duration::from_secs(3)).await;
    sim.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn nav_stops_gives_not_providing_data_and_recovers() {
    let sim = start_sim().await;
    let bus = Bus::new();
    let _emb = frontseat_actors::sim_glue::embed(&sim, &bus);
    let mut status = StatusWatch::new(&bus);
    let mut cfg = config_for(&sim, WARP);
    cfg.driver.basic_simulator.nav_timeout = 2.0;
    let helm = helm_heartbeat(&bus, HelmState::HelmDrive);
    let service = InterfaceService::start(&cfg, &bus, frontseat_drivers::BUILT_IN)
        .await
        .unwrap();
    status
        .until_state(InterfaceState::InterfaceCommand, LONG)
        .await;

    bus.publish(
        &groups::FRONTSEAT_SIM_FAULT,
        SimFault {
            vehicle: None,
            fault: Some(sim_fault::Fault::StopNavSeconds(20.0)),
        },
    );
    status
        .until("fs error not providing data", LONG, |s| {
            is_fs_error(s, FrontSeatError::ErrorFrontseatNotProvidingData)
        })
        .await;
    status
        .until_state(InterfaceState::InterfaceCommand, LONG)
        .await;
    let states = status.states();
    let tail = &states[states.len() - 4..];
    assert_eq!(
        tail,
        &[
            InterfaceState::InterfaceFsError,
            InterfaceState::InterfaceStandby,
            InterfaceState::InterfaceListen,
            InterfaceState::InterfaceCommand
        ]
    );
    helm.abort();
    service.shutdown(Duration::from_secs(3)).await;
    sim.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn commands_outside_command_state_get_a_failed_response() {
    let sim = start_sim().await;
    let bus = Bus::new();
    let mut status = StatusWatch::new(&bus);
    let (_s, mut responses) = bus.subscribe_channel(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_COMMAND_RESPONSE,
        "test",
        100,
    );
    let cfg = config_for(&sim, WARP);
    let service = InterfaceService::start(&cfg, &bus, frontseat_drivers::BUILT_IN)
        .await
        .unwrap();
    // No helm: the interface stays out of COMMAND (listen once data flows).
    status
        .until_state(InterfaceState::InterfaceListen, LONG)
        .await;
    bus.publish(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_COMMAND_REQUEST,
        CommandRequest {
            desired_course: Some(course(10.0, 1.0)),
            response_requested: Some(true),
            request_id: Some(41),
            ..Default::default()
        },
    );
    let r = tokio::time::timeout(LONG, responses.recv())
        .await
        .unwrap()
        .unwrap();
    assert_eq!(r.msg.request_id, Some(41));
    assert_eq!(r.msg.request_successful, Some(false));
    assert!(
        r.msg.error_string().contains("not in command state"),
        "{:?}",
        r.msg
    );

    // In COMMAND the frontseat answers it.
    let helm = helm_heartbeat(&bus, HelmState::HelmDrive);
    status
        .until_state(InterfaceState::InterfaceCommand, LONG)
        .await;
    bus.publish(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_COMMAND_REQUEST,
        CommandRequest {
            desired_course: Some(course(10.0, 1.0)),
            response_requested: Some(true),
            request_id: Some(42),
            ..Default::default()
        },
    );
    let r = tokio::time::timeout(LONG, responses.recv())
        .await
        .unwrap()
        .unwrap();
    assert_eq!(r.msg.request_id, Some(42));
    assert_eq!(r.msg.request_successful, Some(true));
    helm.abort();
    service.shutdown(Duration::from_secs(3)).await;
    sim.shutdown().await;
}

/// The basic driver, except that the Nth command overall (across restarts) panics.
struct PanickyDriver {
    inner: BasicSimulatorDriver,
    commands: Arc<AtomicU32>,
    panic_on: u32,
}

impl Driver for PanickyDriver {
    fn name(&self) -> &str {
        "panicky"
    }
    fn start(&mut self, ctx: DriverContext) {
        self.inner.start(ctx)
    }
    fn handle_io(&mut self, ev: DriverIoEvent, now: Duration, sig: &mut dyn SignalSink) {
        self.inner.handle_io(ev, now, sig)
    }
    fn send_command_to_frontseat(
        &mut self,
        req: &CommandRequest,
        now: Duration,
        sig: &mut dyn SignalSink,
    ) {
        if self.commands.fetch_add(1, Ordering::SeqCst) + 1 == self.panic_on {
            panic!("injected driver panic on command {}", self.panic_on);
        }
        self.inner.send_command_to_frontseat(req, now, sig)
    }
    fn send_data_to_frontseat(
        &mut self,
        d: &InterfaceData,
        now: Duration,
        sig: &mut dyn SignalSink,
    ) {
        self.inner.send_data_to_frontseat(d, now, sig)
    }
    fn send_raw_to_frontseat(&mut self, r: &Raw, now: Duration, sig: &mut dyn SignalSink) {
        self.inner.send_raw_to_frontseat(r, now, sig)
    }
    fn do_loop(&mut self, now: Duration, sig: &mut dyn SignalSink) {
        self.inner.do_loop(now, sig)
    }
    fn frontseat_state(&self) -> FrontSeatState {
        self.inner.frontseat_state()
    }
    fn frontseat_providing_data(&self) -> bool {
        self.inner.frontseat_providing_data()
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn driver_panic_maps_to_fs_error_and_recovers_by_itself() {
    let sim = start_sim().await;
    let bus = Bus::new();
    let mut status = StatusWatch::new(&bus);
    let cfg = config_for(&sim, WARP);
    let settings = Settings::from_config(&cfg);
    let helm = helm_heartbeat(&bus, HelmState::HelmDrive);
    let commands = Arc::new(AtomicU32::new(0));
    let c = commands.clone();
    let factory: DriverFactory = Arc::new(move || {
        Box::new(PanickyDriver {
            inner: BasicSimulatorDriver::new(settings.clone()),
            commands: c.clone(),
            panic_on: 3,
        }) as Box<dyn Driver>
    });
    let service = InterfaceService::start_with(InterfaceSettings::from_config(&cfg), &bus, factory)
        .await
        .unwrap();
    status
        .until_state(InterfaceState::InterfaceCommand, LONG)
        .await;
    for _ in 0..3 {
        bus.publish(
            &groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE,
            course(45.0, 1.0),
        );
    }
    status
        .until("fs error not connected after the panic", LONG, |s| {
            is_fs_error(s, FrontSeatError::ErrorFrontseatNotConnected)
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
    assert_eq!(snap.driver_restarts, 1);
    // After the restart, commands flow to the simulator again.
    bus.publish(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE,
        course(45.0, 1.0),
    );
    helm.abort();
    assert_eq!(
        service.shutdown(Duration::from_secs(3)).await,
        ServiceExit::Clean
    );
    sim.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn dropped_connection_recovers_to_command() {
    let sim = start_sim().await;
    let bus = Bus::new();
    let _emb = frontseat_actors::sim_glue::embed(&sim, &bus);
    let mut status = StatusWatch::new(&bus);
    let cfg = config_for(&sim, WARP);
    let helm = helm_heartbeat(&bus, HelmState::HelmDrive);
    let service = InterfaceService::start(&cfg, &bus, frontseat_drivers::BUILT_IN)
        .await
        .unwrap();
    status
        .until_state(InterfaceState::InterfaceCommand, LONG)
        .await;
    bus.publish(
        &groups::FRONTSEAT_SIM_FAULT,
        SimFault {
            vehicle: None,
            fault: Some(sim_fault::Fault::DropConnection(true)),
        },
    );
    status
        .until("fs error not connected", LONG, |s| {
            is_fs_error(s, FrontSeatError::ErrorFrontseatNotConnected)
        })
        .await;
    status
        .until_state(InterfaceState::InterfaceCommand, LONG)
        .await;
    let states = status.states();
    assert_eq!(
        &states[states.len() - 4..],
        &[
            InterfaceState::InterfaceFsError,
            InterfaceState::InterfaceStandby,
            InterfaceState::InterfaceListen,
            InterfaceState::InterfaceCommand
        ],
        "{states:?}"
    );
    helm.abort();
    service.shutdown(Duration::from_secs(3)).await;
    sim.shutdown().await;
}

/// A driver that panics as soon as it starts handling anything.
struct AlwaysPanics;

impl Driver for AlwaysPanics {
    fn name(&self) -> &str {
        "always-panics"
    }
    fn start(&mut self, _ctx: DriverContext) {}
    fn handle_io(&mut self, _ev: DriverIoEvent, _now: Duration, _sig: &mut dyn SignalSink) {}
    fn send_command_to_frontseat(
        &mut self,
        _: &CommandRequest,
        _: Duration,
        _: &mut dyn SignalSink,
    ) {
    }
    fn send_data_to_frontseat(&mut self, _: &InterfaceData, _: Duration, _: &mut dyn SignalSink) {}
    fn send_raw_to_frontseat(&mut self, _: &Raw, _: Duration, _: &mut dyn SignalSink) {}
    fn do_loop(&mut self, _now: Duration, _sig: &mut dyn SignalSink) {
        panic!("this driver always fails");
    }
    fn frontseat_state(&self) -> FrontSeatState {
        FrontSeatState::FrontseatNotConnected
    }
    fn frontseat_providing_data(&self) -> bool {
        false
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn restart_limit_ends_the_service_with_an_error() {
    let bus = Bus::new();
    let mut cfg = frontseat_config::InterfaceConfig::default();
    cfg.supervision.max_restarts = 3;
    cfg.supervision.restart_initial_delay_ms = 5;
    cfg.supervision.restart_max_delay_ms = 20;
    let factory: DriverFactory = Arc::new(|| Box::new(AlwaysPanics) as Box<dyn Driver>);
    let mut service =
        InterfaceService::start_with(InterfaceSettings::from_config(&cfg), &bus, factory)
            .await
            .unwrap();
    let exit = tokio::time::timeout(LONG, service.wait()).await.unwrap();
    assert!(matches!(exit, ServiceExit::RestartLimit(_)), "{exit:?}");
    assert_ne!(exit.code(), 0);
}

/// The basic driver, except that its loop blocks its thread once, for `hang`, when told to.
/// A driver whose next loop tick blocks its thread until the test releases it (or `limit`
/// passes), saying while it is blocked: the test then waits for the watchdog's verdict instead of
/// racing a fixed-length hang.
struct HangingDriver {
    inner: BasicSimulatorDriver,
    hang_now: Arc<std::sync::atomic::AtomicBool>,
    /// Notified when the hang starts.
    started: Arc<tokio::sync::Notify>,
    hanging: Arc<std::sync::atomic::AtomicBool>,
    /// A message (or the test's end) releases it.
    release: Arc<std::sync::Mutex<std::sync::mpsc::Receiver<()>>>,
    limit: Duration,
}

impl Driver for HangingDriver {
    fn name(&self) -> &str {
        "hanging"
    }
    fn start(&mut self, ctx: DriverContext) {
        self.inner.start(ctx)
    }
    fn handle_io(&mut self, ev: DriverIoEvent, now: Duration, sig: &mut dyn SignalSink) {
        self.inner.handle_io(ev, now, sig)
    }
    fn send_command_to_frontseat(
        &mut self,
        req: &CommandRequest,
        now: Duration,
        sig: &mut dyn SignalSink,
    ) {
        self.inner.send_command_to_frontseat(req, now, sig)
    }
    fn send_data_to_frontseat(
        &mut self,
        d: &InterfaceData,
        now: Duration,
        sig: &mut dyn SignalSink,
    ) {
        self.inner.send_data_to_frontseat(d, now, sig)
    }
    fn send_raw_to_frontseat(&mut self, r: &Raw, now: Duration, sig: &mut dyn SignalSink) {
        self.inner.send_raw_to_frontseat(r, now, sig)
    }
    fn do_loop(&mut self, now: Duration, sig: &mut dyn SignalSink) {
        if self.hang_now.swap(false, Ordering::SeqCst) {
            // A driver stuck in blocking code: exactly what the watchdog must notice.
            self.hanging.store(true, Ordering::SeqCst);
            self.started.notify_one();
            if let Ok(rx) = self.release.lock() {
                let _ = rx.recv_timeout(self.limit);
            }
            self.hanging.store(false, Ordering::SeqCst);
        }
        self.inner.do_loop(now, sig)
    }
    fn frontseat_state(&self) -> FrontSeatState {
        self.inner.frontseat_state()
    }
    fn frontseat_providing_data(&self) -> bool {
        self.inner.frontseat_providing_data()
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 3)]
async fn a_driver_stuck_in_a_handler_is_reported_unresponsive() {
    use frontseat_actors::interface::DRIVER_HUNG_AFTER;
    let sim = start_sim().await;
    let bus = Bus::new();
    let mut status = StatusWatch::new(&bus);
    let cfg = config_for(&sim, WARP);
    let settings = Settings::from_config(&cfg);
    let hang_now = Arc::new(std::sync::atomic::AtomicBool::new(false));
    let started = Arc::new(tokio::sync::Notify::new());
    let hanging = Arc::new(std::sync::atomic::AtomicBool::new(false));
    let (release, release_rx) = std::sync::mpsc::channel();
    let release_rx = Arc::new(std::sync::Mutex::new(release_rx));
    let (h, st, g) = (hang_now.clone(), started.clone(), hanging.clone());
    let factory: DriverFactory = Arc::new(move || {
        Box::new(HangingDriver {
            inner: BasicSimulatorDriver::new(settings.clone()),
            hang_now: h.clone(),
            started: st.clone(),
            hanging: g.clone(),
            release: release_rx.clone(),
            limit: Duration::from_secs(60),
        }) as Box<dyn Driver>
    });
    let service = InterfaceService::start_with(InterfaceSettings::from_config(&cfg), &bus, factory)
        .await
        .unwrap();
    status
        .until_state(InterfaceState::InterfaceListen, LONG)
        .await;
    let snap = service.snapshot(Duration::from_secs(1)).await.unwrap();
    assert!(snap.driver_up && snap.driver_responsive, "{snap:?}");

    // What the systemd watchdog probe asks: did the interface answer in time, and is its driver
    // ticking? A driver blocking its thread can also hold up tasks queued behind it on that worker,
    // so either answer may be the one that reveals it.
    let alive = |snap: Option<frontseat_actors::interface::Snapshot>| {
        snap.is_some_and(|s| s.driver_responsive)
    };
    hang_now.store(true, Ordering::SeqCst);
    tokio::time::timeout(LONG, started.notified())
        .await
        .expect("the driver never ran its loop tick");
    // It stays blocked until released: the verdict must come once DRIVER_HUNG_AFTER has passed,
    // however slowly this machine runs.
    let deadline = tokio::time::Instant::now() + DRIVER_HUNG_AFTER + LONG;
    while alive(service.snapshot(Duration::from_millis(500)).await) {
        assert!(
            tokio::time::Instant::now() < deadline,
            "a driver blocked for {:?} was never reported",
            DRIVER_HUNG_AFTER + LONG
        );
        assert!(
            hanging.load(Ordering::SeqCst),
            "the driver stopped hanging on its own"
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    release.send(()).unwrap();
    // Once it returns, it ticks again and is reported alive.
    let deadline = tokio::time::Instant::now() + DRIVER_HUNG_AFTER + LONG;
    while !alive(service.snapshot(Duration::from_millis(500)).await) {
        assert!(tokio::time::Instant::now() < deadline, "never recovered");
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    service.shutdown(Duration::from_secs(3)).await;
    sim.shutdown().await;
}
