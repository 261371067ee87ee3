//! Rows G1 and G2: the Goby3 path. The real interface runs in this process with its Goby3
//! gateway; a second Goby3 gateway on a bus of its own plays the helm's process (as
//! `frontseat moos-gateway` or a Goby3 helm would), and the two meet through the stand-in gobyd
//! (`frontseat_helm_side::goby3::standin`: gobyd's manager handshake and XPUB/XSUB proxy) over
//! loopback TCP. Every hop a deployed Goby3 system has is here — our ZeroMQ sockets, the length
//! guards in front of them, gobyd's proxy — in one process, so one clock stamps both ends.

use std::time::{Duration, Instant};

use frontseat_actors::bus::Bus;
use frontseat_actors::interface::InterfaceService;
use frontseat_config::{Goby3Config, Goby3Transport, InterfaceConfig};
use frontseat_helm_side::GatewayOptions;
use frontseat_helm_side::goby3::standin::{StandinGobyd, StandinTransport};
use frontseat_helm_side::goby3::{self, Goby3Handle, Goby3Settings};

use super::frontseat::{ScriptedFrontseat, Stamps};
use super::hops::{self, Hop, hop};
use super::inproc::{
    course_row, helm_drive, nav_burst_row, reached_command, stamp_node_status, status_channel,
};
use super::report::Row;

/// How much each row measures.
#[derive(Clone, Copy, Debug)]
pub struct Plan {
    pub g1_count: usize,
    pub g1_rate_hz: f64,
    pub g2_count: usize,
    pub g2_rate_hz: f64,
}

const G1: &str =
    "NAV line written by the frontseat → node_status at a Goby3 subscriber (through gobyd)";
const G2: &str = "desired_course published by a Goby3 client → CMD line read at the frontseat";

/// Runs G1 then G2 on one interface; returns their rows in that order.
pub async fn run(plan: Plan) -> Vec<Row> {
    match run_inner(plan).await {
        Ok(rows) => rows,
        Err(why) => vec![
            Row::failed("G1", G1, why.clone()),
            Row::failed("G2", G2, why),
        ],
    }
}

/// A Goby3 gateway on `bus` hosting `actor`'s groups, joining the stand-in gobyd's TCP manager
/// on `manager_port`.
fn gateway(bus: &Bus, manager_port: u16, actor: &str) -> Result<Goby3Handle, String> {
    let cfg = Goby3Config {
        enabled: true,
        transport: Goby3Transport::Tcp,
        tcp_port: manager_port,
        settle_ms: 100,
        manager_timeout_seconds: 2.0,
        ..Goby3Config::default()
    };
    let settings = Goby3Settings::from_config(&cfg, "bench-auv")
        .map_err(|e| format!("goby3 settings: {e}"))?;
    goby3::start(bus, settings, &[actor], GatewayOptions::default())
        .map_err(|e| format!("{actor}'s Goby3 gateway: {e}"))
}

async fn until_up(h: &Goby3Handle, within: Duration) -> Result<(), String> {
    let deadline = tokio::time::Instant::now() + within;
    while !h.stats().link_up {
        if tokio::time::Instant::now() >= deadline {
            return Err(format!("the Goby3 link did not come up within {within:?}"));
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    Ok(())
}

async fn run_inner(plan: Plan) -> Result<Vec<Row>, String> {
    let base = Instant::now();
    let nav_written = Stamps::new(base, plan.g1_count);
    let node_status_at = Stamps::new(base, plan.g1_count);
    let cmd_sent = Stamps::new(base, plan.g2_count);
    let cmd_read = Stamps::new(base, plan.g2_count);
    let fs = ScriptedFrontseat::start(nav_written.clone(), cmd_read.clone())
        .map_err(|e| format!("scripted frontseat: {e}"))?;
    let gobyd = StandinGobyd::start(StandinTransport::Tcp { manager_port: 0 }, &[])
        .await
        .map_err(|e| format!("stand-in gobyd: {e}"))?;
    let port = gobyd
        .manager_port()
        .ok_or("the stand-in gobyd has no TCP manager port")?;

    let mut cfg = InterfaceConfig {
        name: "bench-auv".into(),
        ..InterfaceConfig::default()
    };
    cfg.driver.basic_simulator.tcp_port = fs.port();
    // G2 carries its sequence number in DEPTH, as P2 does.
    cfg.limits.max_depth = 1e9;
    // G1's NAV lines step their DEPTH 1 m a line: past the navigation gate's depth-rate bound.
    cfg.limits.navigation.max_abs_depth_rate = 1e9;
    let capacity = cfg.bus.queue_capacity;

    let bus_if = Bus::new();
    let bus_helm = Bus::new();
    let mut tasks = Vec::new();
    let (_ns_sub, ns_task) = stamp_node_status(&bus_helm, &node_status_at, capacity);
    tasks.push(ns_task);
    let (_st_sub, mut st_rx) = status_channel(&bus_if, capacity);
    // The helm's DRIVE goes through gobyd, as a Goby3 helm's would.
    tasks.push(helm_drive(&bus_helm));

    let service = InterfaceService::start(&cfg, &bus_if, frontseat_drivers::BUILT_IN)
        .await
        .map_err(|e| format!("interface: {e}"))?;
    let gw_if = gateway(&bus_if, port, "FrontSeatInterface")?;
    let gw_helm = gateway(&bus_helm, port, "FrontSeatTranslation")?;

    let result = async {
        until_up(&gw_if, Duration::from_secs(10)).await?;
        until_up(&gw_helm, Duration::from_secs(10)).await?;
        if !reached_command(&mut st_rx).await {
            return Err(
                "the interface did not reach running:command (helm DRIVE through gobyd) within 10 s"
                    .to_string(),
            );
        }
        let g1 = g1(&plan, &fs, &nav_written, &node_status_at).await;
        let g2 = g2(&plan, &bus_helm, &fs, &cmd_sent, &cmd_read).await;
        Ok(vec![g1, g2])
    }
    .await;

    gw_helm.close().await;
    gw_if.close().await;
    let _ = service.shutdown(Duration::from_secs(2)).await;
    for t in tasks {
        t.abort();
    }
    gobyd.stop().await;
    fs.stop();
    result
}

const NODE_STATUS: Option<&str> = Some("goby::middleware::frontseat::node_status");
const DESIRED_COURSE: Option<&str> = Some("goby::middleware::frontseat::desired_course");

/// G1's hops: the interface's bus delivers node_status to its gateway (on the publisher's
/// thread), the gateway's link task sends it to its PUB socket, gobyd's proxy forwards it, the
/// helm side's length guard reads it from gobyd, its SUB socket hands it to the link task, which
/// publishes it on the helm side's bus.
const G1_HOPS: [Hop; 6] = [
    hop("the interface's gateway", "export.delivered", NODE_STATUS),
    hop("its link task sends", "goby3.send", NODE_STATUS),
    hop("gobyd's proxy forwards", "goby3.standin", None),
    hop("the helm's guard reads", "goby3.guard.in", None),
    hop("the helm's link task receives", "goby3.recv", None),
    hop("published on the helm's bus", "goby3.import", NODE_STATUS),
];
/// G2's hops, the other way; the last segment is the interface's own (P2's path).
const G2_HOPS: [Hop; 6] = [
    hop("the helm's gateway", "export.delivered", DESIRED_COURSE),
    hop("its link task sends", "goby3.send", DESIRED_COURSE),
    hop("gobyd's proxy forwards", "goby3.standin", None),
    hop("the interface's guard reads", "goby3.guard.in", None),
    hop("the interface's link task receives", "goby3.recv", None),
    hop(
        "published on the interface's bus",
        "goby3.import",
        DESIRED_COURSE,
    ),
];

async fn g1(plan: &Plan, fs: &ScriptedFrontseat, written: &Stamps, got: &Stamps) -> Row {
    let how = "; interface + Goby3 gateway → stand-in gobyd (TCP, loopback) → a second Goby3 gateway's bus";
    hops::clear();
    let mut row = nav_burst_row(
        "G1",
        G1,
        fs,
        written,
        got,
        plan.g1_count,
        plan.g1_rate_hz,
        how,
    )
    .await;
    let b = hops::breakdown(
        plan.g1_count,
        |i| written.get(i),
        |i| got.get(i),
        &G1_HOPS,
        "the bench's subscriber (end)",
    );
    hops::add_to(&mut row, b);
    row
}

async fn g2(plan: &Plan, bus: &Bus, fs: &ScriptedFrontseat, sent: &Stamps, read: &Stamps) -> Row {
    let how = ", published on the helm side's bus → its Goby3 gateway → gobyd → the interface";
    hops::clear();
    let mut row = course_row(
        "G2",
        G2,
        bus,
        fs,
        sent,
        read,
        plan.g2_count,
        plan.g2_rate_hz,
        how,
    )
    .await;
    let b = hops::breakdown(
        plan.g2_count,
        |i| sent.get(i),
        |i| read.get(i),
        &G2_HOPS,
        "CMD read at the frontseat (end)",
    );
    hops::add_to(&mut row, b);
    row
}
