//! The ROS 2 gateway against a real DDS: Eclipse Cyclone DDS (PyPI `cyclonedds`, the DDS of
//! rmw_cyclonedds_cpp) in another process, `tests/python/ros2_peer.py`, with ROS 2's topic and
//! type names. `frontseat sim` + `frontseat interface` with `[ros2]` (and Zenoh, for the
//! vehicle's own node_status) run as children; the ArduSub test runs the emulator, the interface
//! and the gateway in this process, as tests/ardusub_e2e.rs does, with its pilot on the bus.
//! Everything stays on 127.0.0.1 (the peer sets CYCLONEDDS_URI; the gateway is loopback-only by
//! default); each test uses its own DDS domain. With FRONTSEAT_REQUIRE_PYTHON_HELM set (CI), a
//! missing `cyclonedds` fails instead of skipping.
#![cfg(feature = "ros2")]

mod common;

use common::procs::{Kill, free_port, frontseat_interface, frontseat_sim, scratch, wait_for_tcp};

use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use frontseat_actors::bus::test_util::UntypedBus as _;
use frontseat_actors::groups;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::NodeStatus;
use frontseat_helm_side::key_for;
use frontseat_helm_side::zenoh;
use prost::Message;
use serde_json::Value;

const LONG: Duration = Duration::from_secs(90);

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Whether python3 can import cyclonedds; false (reported SKIPPED) only when
/// FRONTSEAT_REQUIRE_PYTHON_HELM is unset.
fn cyclonedds_can_run(test: &str) -> bool {
    common::python::can_import(test, "cyclonedds.domain", "tests/python/requirements.txt")
}

/// A DDS domain of this test process and test: 7400 + 250·domain must not meet another run's.
fn domain(test: u16) -> u16 {
    10 + (std::process::id() % 40) as u16 * 5 + test
}

/// The peer in another process; its JSON lines are collected as they come.
struct Peer {
    child: Kill,
    lines: Arc<Mutex<Vec<Value>>>,
    reader: Option<std::thread::JoinHandle<()>>,
}

impl Peer {
    fn spawn(args: &[&str]) -> Peer {
        let mut child: Child = Command::new("python3")
            .arg(root().join("tests/python/ros2_peer.py"))
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("python3 runs");
        let out = child.stdout.take().expect("piped");
        let lines = Arc::new(Mutex::new(Vec::new()));
        let l = lines.clone();
        let reader = std::thread::spawn(move || {
            for line in BufReader::new(out).lines().map_while(Result::ok) {
                let v: Value = serde_json::from_str(&line)
                    .unwrap_or_else(|e| panic!("the peer printed {line:?}: {e}"));
                l.lock().unwrap().push(v);
            }
        });
        Peer {
            child: Kill(child),
            lines,
            reader: Some(reader),
        }
    }

    /// Waits for the peer to end by itself (it bounds itself with --seconds) and returns its lines.
    fn finish(mut self) -> Vec<Value> {
        let deadline = std::time::Instant::now() + LONG;
        let status = loop {
            if let Some(s) = self.child.0.try_wait().unwrap() {
                break s;
            }
            assert!(std::time::Instant::now() < deadline, "the peer never ended");
            std::thread::sleep(Duration::from_millis(50));
        };
        if let Some(r) = self.reader.take() {
            r.join().expect("reader thread");
        }
        assert!(status.success(), "the peer failed: {status}");
        std::mem::take(&mut *self.lines.lock().unwrap())
    }

    fn snapshot(&self) -> Vec<Value> {
        self.lines.lock().unwrap().clone()
    }
}

fn of<'a>(lines: &'a [Value], topic: &str) -> Vec<&'a Value> {
    lines.iter().filter(|l| l["topic"] == topic).collect()
}

fn f(v: &Value) -> f64 {
    v.as_f64().unwrap_or(f64::NAN)
}

/// `frontseat sim` + `frontseat interface` with `[ros2]` on `domain` (and Zenoh on a free port).
struct Stack {
    dir: PathBuf,
    zenoh: u16,
    _sim: Kill,
    interface: Kill,
}

impl Stack {
    async fn start(name: &str, platform: &str, domain: u16, warp: f64) -> Stack {
        let dir = scratch("ros2", name);
        let (sim, sim_port) =
            frontseat_sim(std::fs::File::create(dir.join("sim.log")).unwrap()).await;
        let zport = free_port();
        let cfg = format!(
            r#"name = "{platform}"
sim_warp_factor = {warp}
status_period = 0.5
helm_running_timeout = 10.0
[driver]
name = "basic_simulator"
[driver.basic_simulator]
tcp_port = {sim_port}
[interprocess]
enabled = true
listen = ["tcp/127.0.0.1:{zport}"]
[ros2]
enabled = true
domain_id = {domain}
"#
        );
        let interface = frontseat_interface(&dir, &cfg);
        wait_for_tcp(zport).await;
        Stack {
            dir,
            zenoh: zport,
            _sim: sim,
            interface,
        }
    }

    fn log(&self) -> String {
        std::fs::read_to_string(self.dir.join("interface.log")).unwrap_or_default()
    }
}

/// (sec, nanosec) of a NodeStatus time, as the gateway stamps its headers.
fn stamp(t: f64) -> (i64, i64) {
    let sec = t.floor();
    (
        sec as i64,
        ((t - sec) * 1e9).round().min(999_999_999.0) as i64,
    )
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn cyclone_receives_odometry_fix_and_node_status_matching_the_vehicle() {
    if !cyclonedds_can_run("cyclone_receives_odometry_fix_and_node_status_matching_the_vehicle") {
        return;
    }
    let d = domain(0);
    let stack = Stack::start("listen", "rosauv", d, 10.0).await;
    // The vehicle's own node_status, over Zenoh: what the DDS side must match.
    let session = zenoh::open(
        frontseat_helm_side::client_config(&[format!("tcp/127.0.0.1:{}", stack.zenoh)]).unwrap(),
    )
    .await
    .unwrap();
    let seen: Arc<Mutex<Vec<NodeStatus>>> = Arc::default();
    let s2 = seen.clone();
    let _sub = session
        .declare_subscriber(key_for(
            "rosauv",
            groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS.name(),
        ))
        .callback(move |s| {
            if let Ok(n) = NodeStatus::decode(&*s.payload().to_bytes()) {
                s2.lock().unwrap().push(n);
            }
        })
        .await
        .unwrap();
    let peer = Peer::spawn(&[
        "listen",
        "--domain",
        &d.to_string(),
        "--namespace",
        "rosauv",
        "--seconds",
        "6",
    ]);
    let lines = tokio::task::spawn_blocking(move || peer.finish())
        .await
        .unwrap();
    let vehicle = seen.lock().unwrap().clone();
    let odom = of(&lines, "/rosauv/frontseat/odom");
    let fix = of(&lines, "/rosauv/frontseat/fix");
    let nsd = of(&lines, "/rosauv/frontseat/node_status");
    let status = of(&lines, "/rosauv/frontseat/status");
    let diag = of(&lines, "/diagnostics");
    assert!(
        odom.len() >= 10 && fix.len() >= 10 && nsd.len() >= 10,
        "odom {} fix {} node_status {}\n{}",
        odom.len(),
        fix.len(),
        nsd.len(),
        stack.log()
    );
    assert!(
        !status.is_empty() && !diag.is_empty(),
        "status and diagnostics"
    );
    assert_eq!(odom[0]["type"], "nav_msgs/msg/Odometry");
    assert_eq!(fix[0]["type"], "sensor_msgs/msg/NavSatFix");
    assert_eq!(nsd[0]["type"], "frontseat_msgs/msg/NodeStatus");

    // Every DDS node_status that Zenoh also saw is the vehicle's, field for field; its Odometry
    // and NavSatFix (same stamp) carry the same position, heading and speed.
    let (mut matched, mut odom_matched, mut fix_matched) = (0, 0, 0);
    for n in &nsd {
        let data = &n["data"];
        let Some(v) = vehicle.iter().find(|v| v.time == f(&data["time"])) else {
            continue;
        };
        matched += 1;
        assert_eq!(f(&data["global_fix"]["lat"]), v.global_fix.lat);
        assert_eq!(f(&data["global_fix"]["lon"]), v.global_fix.lon);
        assert_eq!(f(&data["pose"]["heading"]), v.pose.heading.unwrap());
        assert_eq!(data["pose"]["has_heading"], true);
        assert_eq!(data["pose"]["has_roll_rate"], v.pose.roll_rate.is_some());
        assert_eq!(f(&data["speed"]["over_ground"]), v.speed.over_ground);
        assert_eq!(data["name"], "rosauv");
        let local = v.local_fix.expect("the interface computes the local fix");
        let (sec, nsec) = stamp(v.time);
        let same = |m: &&&Value| {
            m["data"]["header"]["stamp"]["sec"].as_i64() == Some(sec)
                && m["data"]["header"]["stamp"]["nanosec"].as_i64() == Some(nsec)
        };
        // Sensor-data readers (best effort, keep last 5) may miss some: judge those that came.
        if let Some(o) = odom.iter().find(same) {
            odom_matched += 1;
            let od = &o["data"];
            assert_eq!(od["header"]["frame_id"], "odom");
            assert_eq!(od["child_frame_id"], "base_link");
            assert_eq!(f(&od["pose"]["pose"]["position"]["x"]), local.x);
            assert_eq!(f(&od["pose"]["pose"]["position"]["y"]), local.y);
            let q = &od["pose"]["pose"]["orientation"];
            let yaw = 2.0 * f(&q["z"]).atan2(f(&q["w"]));
            let heading = (90.0 - yaw.to_degrees()).rem_euclid(360.0);
            let dh = (heading - v.pose.heading.unwrap()).rem_euclid(360.0);
            assert!(
                dh.min(360.0 - dh) < 1e-6,
                "heading {heading} vs {:?}",
                v.pose.heading
            );
            assert_eq!(f(&od["twist"]["twist"]["linear"]["x"]), v.speed.over_ground);
        }
        if let Some(x) = fix.iter().find(same) {
            fix_matched += 1;
            assert_eq!(f(&x["data"]["latitude"]), v.global_fix.lat);
            assert_eq!(f(&x["data"]["longitude"]), v.global_fix.lon);
            assert_eq!(x["data"]["status"]["status"], 0, "FIX");
        }
    }
    assert!(
        odom_matched >= 5 && fix_matched >= 5,
        "Odometry {odom_matched}, NavSatFix {fix_matched} of the vehicle's node_status times"
    );
    assert!(
        matched >= 5,
        "only {matched} DDS node_status matched one seen over Zenoh ({} seen)",
        vehicle.len()
    );
    // The interface's state and the driver's health on /diagnostics.
    let last = diag.last().unwrap();
    let names: Vec<&str> = last["data"]["status"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["name"].as_str().unwrap())
        .collect();
    assert_eq!(
        names,
        [
            "/rosauv/frontseat: interface",
            "/rosauv/frontseat: driver",
            "/rosauv/frontseat: ros2 gateway"
        ]
    );
}

/// The Cyclone helm's last node_status lines: (heading, speed, depth).
fn last_nav(lines: &[Value]) -> Option<(f64, f64, f64)> {
    let n = lines.iter().rfind(|l| {
        l["topic"]
            .as_str()
            .is_some_and(|t| t.ends_with("/node_status"))
    })?;
    let d = &n["data"];
    Some((
        f(&d["pose"]["heading"]),
        f(&d["speed"]["over_ground"]),
        f(&d["global_fix"]["depth"]),
    ))
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_cyclone_helm_turns_the_basic_simulator() {
    if !cyclonedds_can_run("a_cyclone_helm_turns_the_basic_simulator") {
        return;
    }
    let d = domain(1);
    let stack = Stack::start("helm", "rhelm", d, 10.0).await;
    let peer = Peer::spawn(&[
        "helm",
        "--domain",
        &d.to_string(),
        "--namespace",
        "rhelm",
        "--heading",
        "200",
        "--speed",
        "2",
        "--seconds",
        "60",
    ]);
    let deadline = tokio::time::Instant::now() + LONG;
    loop {
        if let Some((h, s, _)) = last_nav(&peer.snapshot())
            && (h - 200.0).abs() < 1.0
            && (s - 2.0).abs() < 0.05
        {
            break;
        }
        assert!(
            tokio::time::Instant::now() < deadline,
            "the vehicle never turned to 200 at 2 m/s: {:?}\n{}",
            last_nav(&peer.snapshot()),
            stack.log()
        );
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    // It started elsewhere: the turn is the Cyclone helm's doing.
    let first = peer.snapshot()[0]["data"]["pose"]["heading"].clone();
    assert!((f(&first) - 200.0).abs() > 10.0, "first heading {first}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_flooding_peer_is_refused_and_counted_while_nav_keeps_flowing() {
    if !cyclonedds_can_run("a_flooding_peer_is_refused_and_counted_while_nav_keeps_flowing") {
        return;
    }
    let d = domain(2);
    // Warp 1: NAV at the simulator's own rate, so a stall would show as a gap in vehicle time.
    let mut stack = Stack::start("flood", "rflood", d, 1.0).await;
    // The vehicle side's NAV, seen by another helm transport (Zenoh): the flood must not slow it.
    let session = zenoh::open(
        frontseat_helm_side::client_config(&[format!("tcp/127.0.0.1:{}", stack.zenoh)]).unwrap(),
    )
    .await
    .unwrap();
    let vehicle_times: Arc<Mutex<Vec<f64>>> = Arc::default();
    let vt = vehicle_times.clone();
    let _sub = session
        .declare_subscriber(key_for(
            "rflood",
            groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS.name(),
        ))
        .callback(move |s| {
            if let Ok(n) = NodeStatus::decode(&*s.payload().to_bytes()) {
                vt.lock().unwrap().push(n.time);
            }
        })
        .await
        .unwrap();
    let listen = Peer::spawn(&[
        "listen",
        "--domain",
        &d.to_string(),
        "--namespace",
        "rflood",
        "--seconds",
        "14",
    ]);
    // NAV flowing before the flood starts.
    let deadline = tokio::time::Instant::now() + LONG;
    while of(&listen.snapshot(), "/rflood/frontseat/node_status").len() < 5 {
        assert!(
            tokio::time::Instant::now() < deadline,
            "no NAV before the flood"
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    let t0 = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_secs_f64();
    let flood = Peer::spawn(&[
        "flood",
        "--domain",
        &d.to_string(),
        "--namespace",
        "rflood",
        "--seconds",
        "6",
    ]);
    let flood_out = tokio::task::spawn_blocking(move || flood.finish())
        .await
        .unwrap();
    let t1 = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_secs_f64();
    let lines = tokio::task::spawn_blocking(move || listen.finish())
        .await
        .unwrap();
    let summary = flood_out.last().expect("the flood's summary line");
    assert!(f(&summary["sent"]) > 100.0, "{summary}");
    // The vehicle side kept its pace through the flood: its node_status (over Zenoh) covers the
    // flood with no gap over 2 s of vehicle time (NAV is 10 Hz here).
    let in_flood = |t: &f64| *t >= t0 - 1.0 && *t <= t1 + 1.0;
    let mut times: Vec<f64> = vehicle_times
        .lock()
        .unwrap()
        .iter()
        .copied()
        .filter(in_flood)
        .collect();
    times.sort_by(f64::total_cmp);
    assert!(
        times.len() >= 10,
        "{} node_status during the flood",
        times.len()
    );
    let gap = times.windows(2).map(|w| w[1] - w[0]).fold(0.0, f64::max);
    assert!(
        gap < 2.0,
        "a {gap:.2} s gap in the vehicle's NAV during the flood\n{}",
        stack.log()
    );
    assert!(times[0] < t0 + 2.0 && *times.last().unwrap() > t1 - 2.0);
    // And the ROS 2 side kept receiving it, through the same participant the flood hits (the
    // peer's sensor-data reader is best effort: some may be lost, none is required in order).
    let ros_nav = of(&lines, "/rflood/frontseat/node_status")
        .iter()
        .filter(|l| in_flood(&f(&l["data"]["time"])))
        .count();
    assert!(
        ros_nav >= 10,
        "{ros_nav} node_status over DDS during the flood"
    );
    // The bad samples were refused and counted, as /diagnostics says.
    let diag = of(&lines, "/diagnostics");
    let gw = diag.last().expect("diagnostics")["data"]["status"]
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s["name"] == "/rflood/frontseat: ros2 gateway")
        .cloned()
        .expect("the gateway's status");
    let value = |k: &str| -> u64 {
        gw["values"]
            .as_array()
            .unwrap()
            .iter()
            .find(|kv| kv["key"] == k)
            .and_then(|kv| kv["value"].as_str()?.parse().ok())
            .unwrap_or(0)
    };
    assert!(value("refused_malformed") > 0, "{gw}");
    assert!(value("refused_not_finite") > 0, "{gw}");
    assert!(value("imported") > 0, "{gw}");
    assert!(
        value("refused_rate") > 0,
        "the flood was over [ros2] max_command_rate_hz: {gw}"
    );
    assert_eq!(gw["level"], 1, "WARN while refusing");
    // The interface is still there and never panicked.
    assert!(stack.interface.0.try_wait().unwrap().is_none());
    assert!(!stack.log().contains("panicked"), "{}", stack.log());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn ros_graph_discovery_shows_the_node_and_its_topics() {
    if !cyclonedds_can_run("ros_graph_discovery_shows_the_node_and_its_topics") {
        return;
    }
    let d = domain(3);
    let stack = Stack::start("graph", "rgraph", d, 10.0).await;
    let peer = Peer::spawn(&["graph", "--domain", &d.to_string(), "--seconds", "4"]);
    let lines = tokio::task::spawn_blocking(move || peer.finish())
        .await
        .unwrap();
    let node = lines
        .iter()
        .find(|l| l["node"] == "/rgraph/frontseat")
        .unwrap_or_else(|| panic!("no /rgraph/frontseat in {lines:?}\n{}", stack.log()));
    assert_eq!(node["namespace"], "/rgraph");
    assert_eq!(node["name"], "frontseat");
    assert_eq!(node["writers"].as_array().unwrap().len(), 6, "{node}");
    assert_eq!(node["readers"].as_array().unwrap().len(), 3, "{node}");
    let topic = |t: &str, ty: &str, e: &str| {
        assert!(
            lines
                .iter()
                .any(|l| l["topic"] == t && l["type"] == ty && l["endpoint"] == e),
            "{t} {ty} {e} in {lines:?}"
        );
    };
    topic("/rgraph/frontseat/odom", "nav_msgs/msg/Odometry", "writer");
    topic(
        "/rgraph/frontseat/fix",
        "sensor_msgs/msg/NavSatFix",
        "writer",
    );
    topic(
        "/diagnostics",
        "diagnostic_msgs/msg/DiagnosticArray",
        "writer",
    );
    topic(
        "/rgraph/frontseat/desired_course",
        "frontseat_msgs/msg/DesiredCourse",
        "reader",
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_cyclone_helm_dives_the_ardusub_emulator() {
    use frontseat_actors::interface::InterfaceService;
    use frontseat_actors::proto::frontseat::protobuf::ardupilot::ardupilot_command::Action;
    use frontseat_actors::proto::goby::middleware::frontseat::protobuf::InterfaceState;
    use frontseat_ardupilot::sub_emulator::{SubOptions, SubSession};
    use frontseat_config::{ArdupilotVehicle, InterfaceConfig, Ros2Config};
    use frontseat_sim::emulator::{Emulator, Endpoint};

    if !cyclonedds_can_run("a_cyclone_helm_dives_the_ardusub_emulator") {
        return;
    }
    let d = domain(4);
    let emu = Emulator::start(
        SubSession::new(SubOptions::default()),
        Endpoint::Tcp(([127, 0, 0, 1], 0).into()),
        common::WARP,
    )
    .await
    .expect("emulator binds loopback");
    let mut cfg = InterfaceConfig {
        name: "rsub".into(),
        sim_warp_factor: common::WARP,
        status_period: 0.0,
        ..Default::default()
    };
    cfg.driver.name = "ardupilot".into();
    cfg.driver.ardupilot.vehicle = ArdupilotVehicle::Sub;
    cfg.driver.ardupilot.address = format!("tcpout:{}", emu.tcp_addr().unwrap());
    cfg.driver.ardupilot.allow_mode_commands = true;
    cfg.driver.ardupilot.pilot_input_keepalive = true;
    cfg.driver.ardupilot.reconnect_initial_ms = 20;
    cfg.limits.max_depth = 20.0;
    cfg.ros2 = Ros2Config {
        enabled: true,
        domain_id: d,
        ..Default::default()
    };
    let bus = frontseat_actors::bus::Bus::new();
    let mut status = common::StatusWatch::new(&bus);
    let (_r, mut responses) = bus.subscribe_channel(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_COMMAND_RESPONSE,
        "t",
        10_000,
    );
    let gateway = frontseat_ros2::start(&bus, &cfg.ros2, cfg.platform_name()).unwrap();
    let _service = InterfaceService::start(&cfg, &bus, frontseat_drivers::BUILT_IN)
        .await
        .unwrap();
    // The ROS 2 helm: DRIVE, heading east at 0.5 m/s, 5 m deep.
    let peer = Peer::spawn(&[
        "helm",
        "--domain",
        &d.to_string(),
        "--namespace",
        "rsub",
        "--heading",
        "90",
        "--speed",
        "0.5",
        "--depth",
        "5",
        "--seconds",
        "80",
    ]);
    status
        .until_state(InterfaceState::InterfaceListen, LONG)
        .await;
    // The pilot arms and selects GUIDED through the ArduPilot extension, as ardusub_e2e's does.
    common::until_accepted(&bus, &mut responses, Action::Arm, 100, LONG).await;
    common::until_accepted(&bus, &mut responses, Action::Guided, 200, LONG).await;
    status
        .until_state(InterfaceState::InterfaceCommand, LONG)
        .await;
    let deadline = tokio::time::Instant::now() + LONG;
    loop {
        let (depth, heading) = {
            let s = emu.session();
            (s.depth(), s.vehicle().heading)
        };
        if (depth - 5.0).abs() < 0.1 && (heading - 90.0).abs() < 1.0 {
            break;
        }
        assert!(
            tokio::time::Instant::now() < deadline,
            "the Sub never reached 5 m heading east: depth {depth} heading {heading}; gateway {:?}",
            gateway.stats()
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    // The helm saw the dive in its node_status over DDS.
    let deadline = tokio::time::Instant::now() + LONG;
    while !last_nav(&peer.snapshot()).is_some_and(|(_, _, z)| (z - 5.0).abs() < 0.3) {
        assert!(
            tokio::time::Instant::now() < deadline,
            "no node_status at 5 m over DDS: {:?}",
            last_nav(&peer.snapshot())
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    assert!(gateway.stats().get("imported") > 0);
    assert_eq!(gateway.stats().refused(), 0, "{:?}", gateway.stats());
    drop(peer);
}
