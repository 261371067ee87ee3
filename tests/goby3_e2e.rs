//! Across real processes through a stand-in gobyd (the manager handshake and XPUB/XSUB proxy as
//! recorded from gobyd 3.1.5a, run in this test process on IPC sockets in a scratch directory):
//! `frontseat interface` with `[goby3]` joins it beside its Zenoh gateway, a Goby3 helm (a Goby3
//! client in this process) commands the vehicle, a Zenoh topside sees the same vehicle and the
//! Goby3 link flag, and gobyd going away and coming back is survived; and `frontseat
//! moos-gateway` reaches the interface through gobyd alone, so a scripted pHelmIvP on a MOOSDB
//! steers the simulator. Every wait has a deadline; children are killed when the test ends.

mod common;

use common::goby3::goby3_client;

use common::procs::{Kill, free_port, scratch, wait_for_tcp};
use frontseat_actors::bus::test_util::UntypedBus as _;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

use common::phelm::{ScriptedHelm, heading_near};
use frontseat_actors::bus::{Bus, Origin};
use frontseat_actors::groups;
use frontseat_actors::proto::frontseat::protobuf::InterfaceDetail;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    DesiredCourse, HelmState, HelmStateReport, NodeStatus,
};
use frontseat_actors::proto::goby::middleware::protobuf::HealthState;
use frontseat_helm_side::goby3::Goby3Handle;
use frontseat_helm_side::goby3::standin::{StandinGobyd, StandinTransport};
use frontseat_helm_side::zenoh;
use frontseat_helm_side::{client_config, key_for};
use frontseat_moos::Broker;
use prost::Message;
use tokio::time::{Instant, timeout_at};

const WARP: f64 = 10.0;
const LONG: Duration = Duration::from_secs(60);
const BIN: &str = env!("CARGO_BIN_EXE_frontseat");

fn spawn(dir: &Path, what: &str, args: &[&str]) -> Kill {
    Kill(
        Command::new(BIN)
            .args(args)
            .env("RUST_LOG", "info")
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(dir.join(format!("{what}.log"))).unwrap())
            .spawn()
            .unwrap(),
    )
}

fn log(dir: &Path, what: &str) -> String {
    std::fs::read_to_string(dir.join(format!("{what}.log"))).unwrap_or_default()
}

async fn start_sim(dir: &Path) -> (u16, Kill) {
    let port = free_port();
    let sim = spawn(dir, "sim", &["sim", "--port", &port.to_string()]);
    wait_for_tcp(port).await;
    (port, sim)
}

fn goby3_section(base: &str) -> String {
    format!(
        "[goby3]\nenabled = true\nsocket_name = \"{base}\"\nsettle_ms = 200\nreconnect_initial_ms = 20\nreconnect_max_ms = 200\nmanager_timeout_seconds = 1.0\n"
    )
}

fn interface(dir: &Path, sim_port: u16, extra: &str) -> Kill {
    let cfg = format!(
        "name = \"auv1\"\nsim_warp_factor = {WARP}\nstatus_period = 0.5\nhelm_running_timeout = 5.0\n[driver]\nname = \"basic_simulator\"\n[driver.basic_simulator]\ntcp_port = {sim_port}\n{extra}"
    );
    let path = dir.join("interface.toml");
    std::fs::write(&path, cfg).unwrap();
    spawn(
        dir,
        "interface",
        &["interface", "-c", path.to_str().unwrap()],
    )
}

/// A Goby3 helm: a Goby3 client of gobyd on its own bus, as a separate process would be.
fn goby3_helm(bus: &Bus, base: &str) -> Goby3Handle {
    goby3_client(bus, base, "goby3_course_helm", "FrontSeatTranslation")
}

async fn standin(base: &str) -> StandinGobyd {
    StandinGobyd::start(
        StandinTransport::Ipc {
            base: base.to_string(),
        },
        &[],
    )
    .await
    .unwrap()
}

fn base_in(dir: &Path) -> String {
    dir.join("goby_auv1").display().to_string()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_goby3_helm_commands_the_interface_through_gobyd_beside_a_zenoh_topside() {
    let dir: PathBuf = scratch("goby3", "helm");
    let base = base_in(&dir);
    let gobyd = standin(&base).await;
    let (sim_port, _sim) = start_sim(&dir).await;
    let zport = free_port();
    let _interface = interface(
        &dir,
        sim_port,
        &format!(
            "{}[interprocess]\nenabled = true\nlisten = [\"tcp/127.0.0.1:{zport}\"]\n",
            goby3_section(&base)
        ),
    );
    wait_for_tcp(zport).await;

    // The Zenoh topside: node_status and the interface's detail (with the Goby3 link flag).
    let session = zenoh::open(client_config(&[format!("tcp/127.0.0.1:{zport}")]).unwrap())
        .await
        .unwrap();
    let (dtx, mut details) = tokio::sync::mpsc::unbounded_channel();
    let _d = session
        .declare_subscriber(key_for("auv1", groups::FRONTSEAT_INTERFACE_DETAIL.name()))
        .callback(move |s| {
            if let Ok(d) = InterfaceDetail::decode(&*s.payload().to_bytes()) {
                let _ = dtx.send(d);
            }
        })
        .await
        .unwrap();
    let (ntx, mut zenoh_nav) = tokio::sync::mpsc::unbounded_channel();
    let _n = session
        .declare_subscriber(key_for(
            "auv1",
            groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS.name(),
        ))
        .callback(move |s| {
            if let Ok(n) = NodeStatus::decode(&*s.payload().to_bytes()) {
                let _ = ntx.send(n);
            }
        })
        .await
        .unwrap();
    until_link(&mut details, true, &dir).await;

    // The Goby3 helm: DRIVE and a course due east, every 100 ms, as pHelmIvP would.
    let bus = Bus::new();
    let helm = goby3_helm(&bus, &base);
    let (_s2, mut nav) =
        bus.subscribe_channel(&groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS, "t", 1000);
    let hb_bus = bus.clone();
    let heartbeat = tokio::spawn(async move {
        loop {
            hb_bus.publish(
                &groups::GOBY_MIDDLEWARE_FRONTSEAT_HELM_STATE,
                HelmStateReport {
                    state: HelmState::HelmDrive as i32,
                },
            );
            hb_bus.publish(
                &groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE,
                DesiredCourse {
                    heading: Some(90.0),
                    speed: Some(1.5),
                    ..Default::default()
                },
            );
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
    });

    // The helm (like goby3_course_helm) reads node_status: the vehicle turning east proves the
    // interface reached COMMAND on the helm's DRIVE and acted on its course.
    let deadline = Instant::now() + LONG;
    loop {
        match timeout_at(deadline, nav.recv()).await {
            Ok(Some(n)) if heading_near(n.msg.pose.heading(), 90.0, 5.0) => {
                assert_eq!(n.origin, Origin::Goby3);
                break;
            }
            Ok(Some(_)) => {}
            _ => panic!(
                "the vehicle never turned east\ninterface log:\n{}",
                log(&dir, "interface")
            ),
        }
    }
    // The Zenoh topside sees the same vehicle at the same time.
    timeout_at(Instant::now() + LONG, zenoh_nav.recv())
        .await
        .unwrap()
        .unwrap();

    // goby_coroner's question, through gobyd: the interface answers as the Goby3 application it
    // replaces, with the root supervisor's children.
    let coroner_bus = Bus::new();
    let coroner = goby3_client(&coroner_bus, &base, "goby_coroner", "Coroner");
    let (_s3, mut health) = coroner_bus.subscribe_channel(&groups::GOBY_HEALTH_RESPONSE, "t", 100);
    let deadline = Instant::now() + LONG;
    let answer = loop {
        // Repeated: the first requests may go out before gobyd forwarded the subscriptions.
        coroner_bus.publish(&groups::GOBY_HEALTH_REQUEST, Default::default());
        match tokio::time::timeout(Duration::from_millis(500), health.recv()).await {
            Ok(Some(h)) => break h,
            Ok(None) => panic!("coroner bus closed"),
            Err(_) => assert!(
                Instant::now() < deadline,
                "no health answer\ninterface log:\n{}",
                log(&dir, "interface")
            ),
        }
    };
    assert_eq!(answer.msg.name, "goby_frontseat_interface");
    assert_eq!(
        answer.msg.main.state(),
        HealthState::HealthOk,
        "{:?}",
        answer.msg
    );
    let children: Vec<&str> = answer
        .msg
        .main
        .child
        .iter()
        .map(|c| c.name.as_str())
        .collect();
    for want in ["ZenohGateway", "Goby3Gateway", "FrontSeatInterface"] {
        assert!(children.contains(&want), "{children:?}");
    }
    coroner.close().await;

    // gobyd goes away: the interface keeps running and says so; Zenoh keeps flowing.
    gobyd.stop().await;
    until_link(&mut details, false, &dir).await;
    while zenoh_nav.try_recv().is_ok() {}
    timeout_at(Instant::now() + LONG, zenoh_nav.recv())
        .await
        .expect("Zenoh node_status stopped while gobyd was down")
        .unwrap();

    // gobyd is back: the interface and the helm join again and node_status flows through it.
    let gobyd = standin(&base).await;
    until_link(&mut details, true, &dir).await;
    while nav.try_recv().is_ok() {}
    timeout_at(Instant::now() + LONG, nav.recv())
        .await
        .expect("no node_status through the new gobyd")
        .unwrap();
    assert!(helm.stats().connects >= 2, "{:?}", helm.stats());
    let l = log(&dir, "interface");
    assert!(l.contains("Goby3 link down"), "{l}");

    heartbeat.abort();
    helm.close().await;
    gobyd.stop().await;
    let _ = std::fs::remove_dir_all(&dir);
}

/// Waits for an InterfaceDetail whose Goby3 link flag is `want`.
async fn until_link(
    details: &mut tokio::sync::mpsc::UnboundedReceiver<InterfaceDetail>,
    want: bool,
    dir: &Path,
) {
    let deadline = Instant::now() + LONG;
    loop {
        match timeout_at(deadline, details.recv()).await {
            Ok(Some(d)) if d.goby3_link_up == Some(want) => return,
            Ok(Some(_)) => {}
            _ => panic!(
                "no detail with goby3_link_up = {want}\ninterface log:\n{}",
                log(dir, "interface")
            ),
        }
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn phelmivp_steers_through_moos_gateway_and_gobyd() {
    let dir: PathBuf = scratch("goby3", "moos");
    let base = base_in(&dir);
    let gobyd = standin(&base).await;
    let (sim_port, _sim) = start_sim(&dir).await;
    // The interface speaks only Goby3 here (no Zenoh).
    let _interface = interface(&dir, sim_port, &goby3_section(&base));

    let broker = Broker::bind("127.0.0.1:0").await.unwrap();
    let moos_port = broker.local_addr().port();
    let gw_cfg = format!(
        "name = \"auv1\"\n[moos]\nport = {moos_port}\n[interprocess]\nenabled = false\n{}",
        goby3_section(&base)
    );
    let gw_path = dir.join("gw.toml");
    std::fs::write(&gw_path, gw_cfg).unwrap();
    let _gw = spawn(
        &dir,
        "moos-gateway",
        &["moos-gateway", "-c", gw_path.to_str().unwrap()],
    );

    // A scripted pHelmIvP: IVPHELM_STATE, DESIRED_* at 4 Hz; it reads NAV_HEADING.
    let mut helm = ScriptedHelm::start(moos_port, 270.0, 1.0);
    assert!(
        helm.sees_heading(270.0, Instant::now() + LONG).await,
        "pHelmIvP never saw the vehicle head west\ninterface log:\n{}\nmoos-gateway log:\n{}",
        log(&dir, "interface"),
        log(&dir, "moos-gateway")
    );
    assert!(gobyd.forwarded() > 0);
    helm.stop().await;
    broker.shutdown().await;
    gobyd.stop().await;
    let _ = std::fs::remove_dir_all(&dir);
}
