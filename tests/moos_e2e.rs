//! End to end over real loopback TCP: the in-crate MOOS broker, a scripted pHelmIvP (a MOOS
//! client posting IVPHELM_STATE and DESIRED_* at 4 Hz in pHelmIvP's order), the
//! FrontSeatTranslation, the real interface and the real simulator. Every wait has a deadline.

mod common;

use frontseat_actors::bus::test_util::UntypedBus as _;
use std::collections::HashMap;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Duration;

use common::*;
use frontseat_actors::bus::{Bus, Envelope};
use frontseat_actors::groups;
use frontseat_actors::interface::{InterfaceService, ServiceExit};
use frontseat_actors::proto::frontseat::protobuf::TranslationStatus;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    DesiredCourse, HelmState, HelmStateReport, InterfaceState, NodeStatus,
};
use frontseat_config::MoosConfig;
use frontseat_helm_side::translation::{self, TranslationHandle};
use frontseat_moos::{Broker, MoosClient, MoosClientConfig, MoosEvent, MoosMessage};
use tokio::sync::mpsc::{self, UnboundedReceiver};
use tokio::time::{Instant, timeout_at};

const LONG: Duration = Duration::from_secs(30);
const HELM: &str = "pHelmIvP";
const NAV_KEYS: [&str; 10] = [
    "NAV_X",
    "NAV_Y",
    "NAV_LAT",
    "NAV_LONG",
    "NAV_Z",
    "NAV_DEPTH",
    "NAV_HEADING",
    "NAV_YAW",
    "NAV_SPEED",
    "GPS_UPDATE_RECEIVED",
];

fn moos_config(port: u16, desired_timeout_s: f64) -> MoosConfig {
    MoosConfig {
        server: "127.0.0.1".into(),
        port,
        community: "frontseat".into(),
        app_name: "iFrontSeat".into(),
        time_warp: 1.0,
        desired_timeout_s,
    }
}

/// What the scripted helm posts each iteration.
#[derive(Clone)]
struct Script {
    state: Arc<std::sync::Mutex<String>>,
    heading: Arc<AtomicU64>,
    speed: Arc<AtomicU64>,
    desired: Arc<AtomicBool>,
}

impl Script {
    fn new(state: &str, heading: f64, speed: f64, desired: bool) -> Self {
        Self {
            state: Arc::new(std::sync::Mutex::new(state.into())),
            heading: Arc::new(AtomicU64::new(heading.to_bits())),
            speed: Arc::new(AtomicU64::new(speed.to_bits())),
            desired: Arc::new(AtomicBool::new(desired)),
        }
    }
    fn set_heading(&self, h: f64) {
        self.heading.store(h.to_bits(), Ordering::Relaxed);
    }
    fn set(&self, state: &str, desired: bool) {
        *self.state.lock().unwrap() = state.into();
        self.desired.store(desired, Ordering::Relaxed);
    }
}

/// The scripted pHelmIvP: a MOOS client registered for the NAV_* it would read (and a few more
/// to check), and a 4 Hz loop posting like pHelmIvP's AppTick = 4.
struct Helm {
    moos: MoosClient,
    mail: UnboundedReceiver<MoosEvent>,
    seen: Vec<MoosMessage>,
    script: Script,
    task: Option<tokio::task::JoinHandle<()>>,
}

impl Helm {
    async fn start(port: u16, script: Script) -> Helm {
        let (moos, mut events) = MoosClient::start(MoosClientConfig {
            server: format!("127.0.0.1:{port}"),
            reconnect_initial: Duration::from_millis(50),
            reconnect_max: Duration::from_millis(200),
            ..MoosClientConfig::new(HELM)
        })
        .unwrap();
        for k in NAV_KEYS.iter().chain(&["IVPHELM_STATE", "HELM_PROBE"]) {
            moos.register(k, 0.0).unwrap();
        }
        let (tx, mut mail) = mpsc::unbounded_channel();
        tokio::spawn(async move {
            while let Some(ev) = events.recv().await {
                if tx.send(ev).is_err() {
                    return;
                }
            }
        });
        // Registered for sure once our own probe comes back (the DB handles a client's packets
        // in order).
        moos.notify_double("HELM_PROBE", 1.0, None).unwrap();
        let deadline = Instant::now() + LONG;
        loop {
            match timeout_at(deadline, mail.recv()).await {
                Ok(Some(MoosEvent::Mail(m))) if m.key == "HELM_PROBE" => break,
                Ok(Some(_)) => {}
                other => panic!("helm client never got its probe back: {other:?}"),
            }
        }
        Helm {
            moos,
            mail,
            seen: Vec::new(),
            script,
            task: None,
        }
    }

    /// Starts posting: IVPHELM_STATE every iteration, then DESIRED_DEPTH, DESIRED_SPEED,
    /// DESIRED_HEADING when the script says so (pHelmIvP's order within an iteration).
    fn run(&mut self) {
        let moos = self.moos.clone();
        let s = self.script.clone();
        self.task = Some(tokio::spawn(async move {
            let mut tick = tokio::time::interval(Duration::from_millis(250));
            loop {
                tick.tick().await;
                let state = s.state.lock().unwrap().clone();
                let _ = moos.notify_string("IVPHELM_STATE", &state, None);
                if s.desired.load(Ordering::Relaxed) {
                    let speed = f64::from_bits(s.speed.load(Ordering::Relaxed));
                    let heading = f64::from_bits(s.heading.load(Ordering::Relaxed));
                    let _ = moos.notify_double("DESIRED_DEPTH", 0.0, None);
                    let _ = moos.notify_double("DESIRED_SPEED", speed, None);
                    let _ = moos.notify_double("DESIRED_HEADING", heading, None);
                }
            }
        }));
    }

    /// Reads mail until `pred` holds for one message; returns it.
    async fn until(
        &mut self,
        what: &str,
        within: Duration,
        pred: impl Fn(&MoosMessage) -> bool,
    ) -> MoosMessage {
        let deadline = Instant::now() + within;
        loop {
            match timeout_at(deadline, self.mail.recv()).await {
                Ok(Some(MoosEvent::Mail(m))) => {
                    self.seen.push(m.clone());
                    if pred(&m) {
                        return m;
                    }
                }
                Ok(Some(_)) => {}
                Ok(None) => panic!("helm mail closed while waiting for {what}"),
                Err(_) => panic!("timed out after {within:?} waiting for {what} at the helm"),
            }
        }
    }

    /// Reads mail until `n` messages of `key` have arrived in all.
    async fn until_count(&mut self, key: &str, n: usize, within: Duration) {
        let deadline = Instant::now() + within;
        while self.count(key) < n {
            match timeout_at(deadline, self.mail.recv()).await {
                Ok(Some(MoosEvent::Mail(m))) => self.seen.push(m),
                Ok(Some(_)) => {}
                Ok(None) => panic!("helm mail closed while waiting for {n} {key}"),
                Err(_) => panic!(
                    "timed out after {within:?}: {} of {n} {key} reached the helm",
                    self.count(key)
                ),
            }
        }
    }

    /// Reads whatever mail has arrived without waiting.
    fn drain(&mut self) {
        while let Ok(ev) = self.mail.try_recv() {
            if let MoosEvent::Mail(m) = ev {
                self.seen.push(m);
            }
        }
    }

    fn count(&self, key: &str) -> usize {
        self.seen.iter().filter(|m| m.key == key).count()
    }

    async fn stop(mut self) {
        if let Some(t) = self.task.take() {
            t.abort();
        }
        self.moos.shutdown().await;
    }
}

fn is_near(m: &MoosMessage, key: &str, value: f64, tol: f64) -> bool {
    m.key == key && m.as_double().is_some_and(|v| (v - value).abs() <= tol)
}

/// Waits for a message on a bus channel satisfying `pred`.
async fn until_bus<T: std::fmt::Debug>(
    rx: &mut UnboundedReceiver<Envelope<T>>,
    what: &str,
    within: Duration,
    pred: impl Fn(&T) -> bool,
) -> Arc<T> {
    let deadline = Instant::now() + within;
    loop {
        match timeout_at(deadline, rx.recv()).await {
            Ok(Some(env)) if pred(&env.msg) => return env.msg,
            Ok(Some(_)) => {}
            Ok(None) => panic!("bus channel closed while waiting for {what}"),
            Err(_) => panic!("timed out after {within:?} waiting for {what}"),
        }
    }
}

/// Like `until_bus`, keeping every message read in `kept`.
async fn until_bus_kept<T: std::fmt::Debug>(
    rx: &mut UnboundedReceiver<Envelope<T>>,
    kept: &mut Vec<Arc<T>>,
    what: &str,
    within: Duration,
    pred: impl Fn(&T) -> bool,
) -> Arc<T> {
    let deadline = Instant::now() + within;
    loop {
        match timeout_at(deadline, rx.recv()).await {
            Ok(Some(env)) => {
                kept.push(env.msg.clone());
                if pred(&env.msg) {
                    return env.msg;
                }
            }
            Ok(None) => panic!("bus channel closed while waiting for {what}"),
            Err(_) => panic!("timed out after {within:?} waiting for {what}"),
        }
    }
}

/// The NAV_* posts of one node_status as the helm received them.
type Record = HashMap<String, Vec<f64>>;

/// Splits the helm's NAV mail into one record per node_status (each begins with NAV_X).
fn records(seen: &[MoosMessage]) -> Vec<Record> {
    let mut out: Vec<Record> = Vec::new();
    for m in seen {
        let key = m.key.to_string_lossy().into_owned();
        if !NAV_KEYS.contains(&key.as_str()) {
            continue;
        }
        if key == "NAV_X" {
            out.push(Record::new());
        }
        let Some(r) = out.last_mut() else {
            panic!("{key} arrived before any NAV_X");
        };
        r.entry(key)
            .or_default()
            .push(m.as_double().unwrap_or(f64::NAN));
    }
    out
}

fn one(r: &Record, key: &str) -> f64 {
    match r.get(key).map(Vec::as_slice) {
        Some([v]) => *v,
        other => panic!("{key} must be posted exactly once per node_status, got {other:?}"),
    }
}

async fn start_translation(port: u16, bus: &Bus, desired_timeout_s: f64) -> TranslationHandle {
    translation::spawn(&moos_config(port, desired_timeout_s), "test-auv", bus)
        .await
        .unwrap()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn helm_over_moos_steers_the_sim_and_nav_matches_ground_truth() {
    let broker = Broker::bind("127.0.0.1:0").await.unwrap();
    let port = broker.local_addr().port();
    let sim = start_sim().await;
    let bus = Bus::new();
    let _emb = frontseat_actors::sim_glue::embed(&sim, &bus);
    let mut status = StatusWatch::new(&bus);
    let (_s1, mut nav) = bus.subscribe_channel(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS,
        "test",
        1_000_000,
    );
    let (_s2, mut truth) =
        bus.subscribe_channel(&groups::FRONTSEAT_SIM_GROUND_TRUTH, "test", 1_000_000);
    let (_s3, mut tstatus) =
        bus.subscribe_channel(&groups::FRONTSEAT_TRANSLATION_STATUS, "test", 10_000);

    let script = Script::new("DRIVE", 90.0, 2.0, true);
    let mut helm = Helm::start(port, script.clone()).await;
    let translation = start_translation(port, &bus, 5.0).await;
    until_bus(&mut tstatus, "translation connected", LONG, |s| {
        s.moos_connected == Some(true)
    })
    .await;
    helm.run();
    let cfg = config_for(&sim, WARP);
    let service = InterfaceService::start(&cfg, &bus, frontseat_drivers::BUILT_IN)
        .await
        .unwrap();
    status
        .until_state(InterfaceState::InterfaceCommand, LONG)
        .await;

    // The helm steers east at 2 m/s, then to 200°: NAV_HEADING (and the truth) follow.
    helm.until("NAV_HEADING ~ 90", LONG, |m| {
        is_near(m, "NAV_HEADING", 90.0, 0.5)
    })
    .await;
    helm.until("NAV_SPEED ~ 2", LONG, |m| is_near(m, "NAV_SPEED", 2.0, 0.1))
        .await;
    script.set_heading(200.0);
    helm.until("NAV_HEADING ~ 200", LONG, |m| {
        is_near(m, "NAV_HEADING", 200.0, 0.5)
    })
    .await;
    let mut truths: Vec<Arc<NodeStatus>> = Vec::new();
    let t = until_bus_kept(
        &mut truth,
        &mut truths,
        "simulated heading ~ 200",
        LONG,
        |t| (t.pose.heading() - 200.0).abs() < 0.5,
    )
    .await;
    assert!(t.speed.over_ground > 1.5, "{t:?}");
    let s = translation.status();
    assert_eq!(s.moos_connected, Some(true));
    assert_eq!(s.helm_state(), HelmState::HelmDrive);
    assert_eq!(s.helm_driving, Some(true));
    assert_eq!(s.desired_stale, Some(false));
    // Steering to 90° then 200° took at least one course each.
    assert!(translation.counters().desired_course_published >= 2);

    // Stop the source of node_status, then every one of them must have reached the helm once.
    assert_eq!(
        service.shutdown(Duration::from_secs(3)).await,
        ServiceExit::Clean
    );
    let mut published: Vec<Arc<NodeStatus>> = Vec::new();
    while let Ok(env) = nav.try_recv() {
        published.push(env.msg);
    }
    assert!(published.len() > 20, "only {} node_status", published.len());
    let n = published.len();
    helm.until_count("NAV_SPEED", n, LONG).await;
    // Nothing more comes: no node_status was posted twice.
    tokio::time::sleep(Duration::from_millis(500)).await;
    helm.drain();
    let recs = records(&helm.seen);
    assert_eq!(recs.len(), n, "one NAV record per node_status");
    assert_eq!(helm.count("NAV_SPEED"), n);
    assert_eq!(
        helm.count("GPS_UPDATE_RECEIVED"),
        0,
        "the simulator's fixes are not GPS"
    );
    for (r, ns) in recs.iter().zip(&published) {
        let l = ns.local_fix.unwrap();
        assert_eq!(one(r, "NAV_X"), l.x);
        assert_eq!(one(r, "NAV_Y"), l.y);
        assert_eq!(one(r, "NAV_Z"), l.z());
        assert_eq!(one(r, "NAV_LAT"), ns.global_fix.lat);
        assert_eq!(one(r, "NAV_LONG"), ns.global_fix.lon);
        assert_eq!(one(r, "NAV_DEPTH"), ns.global_fix.depth());
        assert_eq!(one(r, "NAV_HEADING"), ns.pose.heading());
        assert_eq!(one(r, "NAV_SPEED"), ns.speed.over_ground);
        let yaw = one(r, "NAV_YAW");
        assert!(
            (yaw - translation::yaw_from_heading(ns.pose.heading())).abs() < 1e-12,
            "NAV_YAW {yaw} for heading {}",
            ns.pose.heading()
        );
    }

    // NAV at the helm agrees with the simulator's ground truth: match each record to the truth
    // sample of the same tick (closest position).
    while let Ok(env) = truth.try_recv() {
        truths.push(env.msg);
    }
    let mut matched = 0;
    for r in &recs {
        let (lat, lon) = (one(r, "NAV_LAT"), one(r, "NAV_LONG"));
        let Some(t) = truths.iter().min_by(|a, b| {
            let da = (a.global_fix.lat - lat).abs() + (a.global_fix.lon - lon).abs();
            let db = (b.global_fix.lat - lat).abs() + (b.global_fix.lon - lon).abs();
            da.total_cmp(&db)
        }) else {
            panic!("no ground truth at all");
        };
        if (t.global_fix.lat - lat).abs() + (t.global_fix.lon - lon).abs() > 1e-7 {
            continue;
        }
        matched += 1;
        let tl = t.local_fix.unwrap();
        assert!(
            (tl.x - one(r, "NAV_X")).abs() < 0.05 && (tl.y - one(r, "NAV_Y")).abs() < 0.05,
            "truth {tl:?} vs NAV_X/Y {:?}/{:?}",
            r["NAV_X"],
            r["NAV_Y"]
        );
        assert!((t.pose.heading() - one(r, "NAV_HEADING")).abs() < 0.01);
        assert!((t.global_fix.depth() - one(r, "NAV_DEPTH")).abs() < 0.01);
    }
    assert!(
        matched * 10 >= recs.len() * 9,
        "only {matched} of {} NAV records match a ground truth sample",
        recs.len()
    );

    // The translation never posts IVPHELM_STATE (pHelmIvP would disable itself).
    assert!(helm.count("IVPHELM_STATE") > 0);
    assert!(
        helm.seen
            .iter()
            .filter(|m| m.key == "IVPHELM_STATE")
            .all(|m| m.source == HELM)
    );
    translation.shutdown().await;
    helm.stop().await;
    sim.shutdown().await;
    broker.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn broker_restart_mid_run_is_survived() {
    let broker = Broker::bind("127.0.0.1:0").await.unwrap();
    let addr = broker.local_addr();
    let sim = start_sim().await;
    let bus = Bus::new();
    let mut status = StatusWatch::new(&bus);
    let (_s1, mut desired) = bus.subscribe_channel(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE,
        "test",
        100_000,
    );
    let (_s2, mut tstatus) =
        bus.subscribe_channel(&groups::FRONTSEAT_TRANSLATION_STATUS, "test", 10_000);
    let script = Script::new("DRIVE", 90.0, 2.0, true);
    let mut helm = Helm::start(addr.port(), script.clone()).await;
    let translation = start_translation(addr.port(), &bus, 5.0).await;
    helm.run();
    let service =
        InterfaceService::start(&config_for(&sim, WARP), &bus, frontseat_drivers::BUILT_IN)
            .await
            .unwrap();
    status
        .until_state(InterfaceState::InterfaceCommand, LONG)
        .await;
    helm.until("NAV_HEADING ~ 90", LONG, |m| {
        is_near(m, "NAV_HEADING", 90.0, 0.5)
    })
    .await;

    // The MOOSDB goes away: the translation says so on its status group.
    while tstatus.try_recv().is_ok() {}
    assert_eq!(translation.status().moos_connected, Some(true));
    broker.shutdown().await;
    let s = until_bus(&mut tstatus, "moos_connected = false", LONG, |s| {
        s.moos_connected == Some(false)
    })
    .await;
    assert_eq!(s.helm_driving, Some(false), "no helm without a MOOSDB");

    // It comes back on the same port: the translation reconnects and re-registers, NAV_* flow
    // to the helm again and the helm steers again.
    let broker = Broker::bind(addr).await.unwrap();
    let s = until_bus(&mut tstatus, "reconnected", LONG, |s| {
        s.moos_connected == Some(true)
    })
    .await;
    assert!(s.reconnects() >= 1, "{s:?}");
    helm.until("NAV_X after the restart", LONG, |m| m.key == "NAV_X")
        .await;
    script.set_heading(270.0);
    until_bus(
        &mut desired,
        "a DesiredCourse of 270° after the restart",
        LONG,
        |c| c.heading == Some(270.0),
    )
    .await;
    helm.until("NAV_HEADING ~ 270", LONG, |m| {
        is_near(m, "NAV_HEADING", 270.0, 0.5)
    })
    .await;
    assert!(translation.status().reconnects() >= 1);
    assert_eq!(translation.status().helm_driving, Some(true));

    service.shutdown(Duration::from_secs(3)).await;
    translation.shutdown().await;
    helm.stop().await;
    sim.shutdown().await;
    broker.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn health_follows_park_drive_and_silence_and_desired_is_buffered() {
    let broker = Broker::bind("127.0.0.1:0").await.unwrap();
    let port = broker.local_addr().port();
    let bus = Bus::new();
    let (_s1, mut desired) = bus.subscribe_channel(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE,
        "test",
        100_000,
    );
    let (_s2, mut helm_state) = bus.subscribe_channel(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_HELM_STATE,
        "test",
        100_000,
    );
    let (_s3, mut tstatus) =
        bus.subscribe_channel(&groups::FRONTSEAT_TRANSLATION_STATUS, "test", 10_000);
    let translation = start_translation(port, &bus, 0.5).await;

    // PARK, no DESIRED_*: parked, not driving, DESIRED_* stale.
    let script = Script::new(" Park ", 0.0, 0.0, false);
    let mut helm = Helm::start(port, script.clone()).await;
    helm.run();
    until_bus(&mut helm_state, "HELM_PARK", LONG, |h: &HelmStateReport| {
        h.state() == HelmState::HelmPark
    })
    .await;
    let s = until_bus(
        &mut tstatus,
        "parked and stale",
        LONG,
        |s: &TranslationStatus| {
            s.helm_state() == HelmState::HelmPark && s.desired_stale == Some(true)
        },
    )
    .await;
    assert_eq!(s.helm_driving, Some(false));
    assert_eq!(s.moos_connected, Some(true));
    assert!(
        desired.try_recv().is_err(),
        "no DESIRED_SPEED, no DesiredCourse"
    );

    // DRIVE with DESIRED_*: driving and fresh.
    script.set("drive", true);
    until_bus(&mut tstatus, "driving, fresh", LONG, |s| {
        s.helm_driving == Some(true) && s.desired_stale == Some(false)
    })
    .await;
    helm.task.take().unwrap().abort();

    // Exact buffering through the DB, with our own time stamps, one packet per helm iteration
    // (the DB holds mail and may merge packets, so each course is awaited before the next):
    // every DESIRED_* of the packet goes into its course, whatever the order; a HEADING in a
    // packet without SPEED waits for the next course; each value is used once.
    while desired.try_recv().is_ok() {}
    let m = &helm.moos;
    let in_window = |c: &DesiredCourse| (1000.0..1001.0).contains(&c.time);
    let mut got = Vec::new();
    m.notify_doubles(
        &[
            ("DESIRED_DEPTH", 3.0),
            ("DESIRED_SPEED", 1.5),
            ("DESIRED_HEADING", 45.0),
        ],
        Some(1000.2),
    )
    .unwrap();
    got.push(*until_bus(&mut desired, "DesiredCourse", LONG, in_window).await);
    m.notify_doubles(&[("DESIRED_HEADING", 50.0)], Some(1000.3))
        .unwrap();
    m.notify_doubles(&[("DESIRED_SPEED", 1.25)], Some(1000.4))
        .unwrap();
    got.push(*until_bus(&mut desired, "DesiredCourse", LONG, in_window).await);
    m.notify_doubles(&[("DESIRED_SPEED", 1.0)], Some(1000.5))
        .unwrap();
    got.push(*until_bus(&mut desired, "DesiredCourse", LONG, in_window).await);
    let course = |time, speed, heading, depth| DesiredCourse {
        time,
        speed: Some(speed),
        heading,
        depth,
        ..Default::default()
    };
    assert_eq!(
        got,
        vec![
            course(1000.2, 1.5, Some(45.0), Some(3.0)),
            course(1000.4, 1.25, Some(50.0), None),
            course(1000.5, 1.0, None, None),
        ]
    );

    // The helm falls silent: after desired_timeout_s it is reported not running, stale.
    let s = until_bus(&mut tstatus, "silent helm", LONG, |s| {
        s.helm_state() == HelmState::HelmNotRunning && s.desired_stale == Some(true)
    })
    .await;
    assert_eq!(s.helm_driving, Some(false));
    assert!(s.seconds_since_desired() > 0.5, "{s:?}");
    let c = translation.counters();
    assert!(
        c.helm_state_published >= 2 && c.desired_course_published >= 3,
        "{c:?}"
    );
    assert_eq!(c.bad_mail, 0);

    translation.shutdown().await;
    helm.stop().await;
    broker.shutdown().await;
}

/// The CMD lines the driver wrote to the frontseat (raw_out), parsed: (heading, speed, depth).
fn cmd_values(line: &str) -> Option<(f64, f64, f64)> {
    let rest = line.strip_prefix("CMD,")?;
    let get = |k: &str| -> f64 {
        rest.split(',')
            .find_map(|f| f.strip_prefix(k))
            .and_then(|v| v.parse().ok())
            .unwrap_or_else(|| panic!("CMD line without a numeric {k}: {line}"))
    };
    Some((get("HEADING:"), get("SPEED:"), get("DEPTH:")))
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_hostile_helm_over_moos_never_reaches_the_frontseat() {
    use frontseat_actors::proto::goby::middleware::frontseat::protobuf::Raw;
    let broker = Broker::bind("127.0.0.1:0").await.unwrap();
    let port = broker.local_addr().port();
    let sim = start_sim().await;
    let bus = Bus::new();
    let mut status = StatusWatch::new(&bus);
    let (_s1, mut raw_out) = bus.subscribe_channel(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_RAW_OUT,
        "test",
        1_000_000,
    );
    let (_s2, mut tstatus) =
        bus.subscribe_channel(&groups::FRONTSEAT_TRANSLATION_STATUS, "test", 10_000);
    let translation = start_translation(port, &bus, 5.0).await;
    until_bus(&mut tstatus, "translation connected", LONG, |s| {
        s.moos_connected == Some(true)
    })
    .await;
    let drive = helm_heartbeat(&bus, HelmState::HelmDrive);
    let service =
        InterfaceService::start(&config_for(&sim, WARP), &bus, frontseat_drivers::BUILT_IN)
            .await
            .unwrap();
    status
        .until_state(InterfaceState::InterfaceCommand, LONG)
        .await;
    let helm = Helm::start(port, Script::new("DRIVE", 0.0, 0.0, false)).await;
    // One helm iteration, in pHelmIvP's order (DEPTH, SPEED, HEADING); None = not posted.
    // (One packet, as pHelmIvP's iteration: the broker holds it and hands it over whole.)
    let iteration = |depth: Option<f64>, speed: f64, heading: Option<f64>| {
        let mut v = Vec::new();
        if let Some(d) = depth {
            v.push(("DESIRED_DEPTH", d));
        }
        v.push(("DESIRED_SPEED", speed));
        if let Some(h) = heading {
            v.push(("DESIRED_HEADING", h));
        }
        helm.moos.notify_doubles(&v, None).unwrap();
    };
    // Waits until the interface has refused `n` setpoints in all (bounded; the event is a count).
    let refused = async |n: u64| {
        let deadline = Instant::now() + LONG;
        loop {
            let snap = service.snapshot(LONG).await.expect("snapshot");
            if snap.setpoints_refused >= n {
                return snap.setpoints_refused;
            }
            assert!(
                Instant::now() < deadline,
                "only {} setpoints refused, waiting for {n}",
                snap.setpoints_refused
            );
            tokio::time::sleep(Duration::from_millis(5)).await;
        }
    };
    let mut written: Vec<String> = Vec::new();
    // Waits for the CMD the sentinel heading produces; everything written before it is kept.
    let mut until_cmd = async |what: &str, pred: &dyn Fn(f64, f64, f64) -> bool| {
        let deadline = Instant::now() + LONG;
        loop {
            let env = match timeout_at(deadline, raw_out.recv()).await {
                Ok(Some(env)) => env,
                other => panic!("waiting for {what}: {other:?}; written so far {written:?}"),
            };
            let raw: &Raw = &env.msg;
            let line = String::from_utf8_lossy(raw.raw()).to_string();
            let values = cmd_values(&line);
            written.push(line);
            if let Some((h, s, d)) = values
                && pred(h, s, d)
            {
                return;
            }
        }
    };
    iteration(Some(0.0), 1.0, Some(10.0));
    until_cmd("a valid course", &|h, s, d| (h, s, d) == (10.0, 1.0, 0.0)).await;
    let hostile: [(Option<f64>, f64, Option<f64>); 7] = [
        (Some(0.0), 1.0, Some(f64::NAN)),
        (Some(0.0), 1e308, Some(45.0)),
        (Some(0.0), f64::INFINITY, Some(45.0)),
        (Some(0.0), -1.0, Some(45.0)),
        (Some(-5.0), 1.0, Some(45.0)),
        (Some(1e6), 1.0, Some(45.0)),
        (Some(f64::NAN), 1.0, Some(45.0)),
    ];
    for (i, (d, s, h)) in hostile.into_iter().enumerate() {
        iteration(d, s, h);
        assert_eq!(refused(i as u64 + 1).await, i as u64 + 1);
        let sentinel = 20.0 + i as f64;
        iteration(Some(0.0), 1.0, Some(sentinel));
        until_cmd("the sentinel after a hostile course", &|h, _, _| {
            h == sentinel
        })
        .await;
    }
    // Out-of-range headings are wrapped, and a speed-only iteration keeps the last heading.
    iteration(Some(0.0), 1.0, Some(725.0));
    until_cmd("725° wrapped", &|h, _, _| h == 5.0).await;
    iteration(None, 1.2, None);
    until_cmd("speed-only keeps the heading", &|h, s, _| {
        s == 1.2 && h == 5.0
    })
    .await;

    for line in &written {
        if let Some((h, s, d)) = cmd_values(line) {
            assert!(
                (0.0..360.0).contains(&h) && (0.0..=5.0).contains(&s) && (0.0..=300.0).contains(&d),
                "the frontseat received {line}; all written: {written:?}"
            );
        }
    }
    let snap = service.snapshot(LONG).await.expect("snapshot");
    assert_eq!(snap.setpoints_refused, hostile.len() as u64, "{written:?}");
    assert_eq!(snap.status.state(), InterfaceState::InterfaceCommand);
    assert_eq!(
        sim.stats().cmd_errors,
        0,
        "the simulator never saw a bad CMD"
    );
    drive.abort();
    helm.stop().await;
    translation.shutdown().await;
    service.shutdown(LONG).await;
    sim.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_panic_in_the_translation_is_restarted_and_the_bridge_flows_again() {
    use frontseat_actors::chaos::{FaultPort, FaultTarget};
    use frontseat_actors::proto::frontseat::protobuf::{ChaosFault, chaos_fault};
    use frontseat_actors::proto::goby::middleware::frontseat::protobuf::Raw;
    use frontseat_actors::supervisor::SupervisorHandle;
    let broker = Broker::bind("127.0.0.1:0").await.unwrap();
    let port = broker.local_addr().port();
    let sim = start_sim().await;
    let bus = Bus::new();
    let mut status = StatusWatch::new(&bus);
    let (_s1, mut raw_out) = bus.subscribe_channel(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_RAW_OUT,
        "test",
        1_000_000,
    );
    let (_s2, mut supervision) =
        bus.subscribe_channel(&groups::FRONTSEAT_SUPERVISION_STATUS, "test", 10_000);
    let cfg = config_for(&sim, WARP);
    // The translation's fault port opens only for a config that enables chaos.
    let mut chaos_cfg = cfg.clone();
    chaos_cfg.chaos.enabled = true;
    let faults = FaultPort::open(&chaos_cfg, &bus, FaultTarget::Translation).unwrap();
    let root = SupervisorHandle::start(
        "root",
        vec![translation::child_spec(
            translation::TranslationArgs {
                cfg: moos_config(port, 5.0),
                vehicle: "test-auv".into(),
                bus: bus.clone(),
                faults: Some(faults),
                observer: Default::default(),
            },
            (&cfg.supervision.translation).into(),
        )],
        Some(&bus),
    )
    .await
    .unwrap();
    let script = Script::new("DRIVE", 90.0, 1.0, true);
    let mut helm = Helm::start(port, script.clone()).await;
    helm.run();
    let service = InterfaceService::start(&cfg, &bus, frontseat_drivers::BUILT_IN)
        .await
        .unwrap();
    status
        .until_state(InterfaceState::InterfaceCommand, LONG)
        .await;
    helm.until("NAV_X before the panic", LONG, |m| m.key == "NAV_X")
        .await;

    // The translation's data path panics: its supervisor restarts it.
    bus.publish(
        &groups::FRONTSEAT_CHAOS_FAULT,
        ChaosFault {
            fault: Some(chaos_fault::Fault::TranslationPanic(true)),
        },
    );
    let deadline = Instant::now() + LONG;
    let restarted_at = loop {
        let snap = root.snapshot(LONG).await.expect("supervisor answers");
        let t = &snap.children[0];
        if t.restarts == 1 && t.up {
            assert!(
                t.last_failure
                    .as_deref()
                    .is_some_and(|f| f.contains("chaos: FrontSeatTranslation panic")),
                "{t:?}"
            );
            break Instant::now();
        }
        assert!(Instant::now() < deadline, "never restarted: {snap:?}");
        tokio::time::sleep(Duration::from_millis(5)).await;
    };
    // Re-registered with the MOOSDB: NAV_* reach the helm again...
    helm.drain();
    helm.until("NAV_X after the restart", LONG, |m| m.key == "NAV_X")
        .await;
    eprintln!(
        "NAV_X flowing again {:?} after the restart",
        restarted_at.elapsed()
    );
    // ...and the helm's setpoints are accepted again: a new heading reaches the frontseat.
    script.set_heading(200.0);
    let deadline = Instant::now() + LONG;
    loop {
        match timeout_at(deadline, raw_out.recv()).await {
            Ok(Some(env)) => {
                let raw: &Raw = &env.msg;
                if raw.raw().starts_with(b"CMD,HEADING:200,") {
                    break;
                }
            }
            other => panic!("no CMD with the new heading after the restart: {other:?}"),
        }
    }
    let snap = root.snapshot(LONG).await.unwrap();
    assert_eq!(snap.children[0].restarts, 1);
    // The restart is visible on the bus (and so over Zenoh, Goby3 and the web scope).
    until_bus(
        &mut supervision,
        "supervision status with the restart",
        LONG,
        |s| {
            s.children.iter().any(|c| {
                c.name() == "FrontSeatTranslation"
                    && c.restarts() == 1
                    && c.up()
                    && c.last_failure().contains("panic")
            })
        },
    )
    .await;
    helm.stop().await;
    root.shutdown(LONG).await;
    service.shutdown(LONG).await;
    sim.shutdown().await;
}
