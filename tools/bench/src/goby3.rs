//! Rows G1 and G2: the Goby3 path. The real interface runs in this process with its Goby3
//! gateway; a second Goby3 gateway on a bus of its own plays the helm's process (as
//! `frontseat moos-gateway` or a Goby3 helm would), and the two meet through the stand-in gobyd
//! (`frontseat_gateway::goby3::standin`: gobyd's manager handshake and XPUB/XSUB proxy) over
//! loopback TCP. Every hop a deployed Goby3 system has is here — our ZeroMQ sockets, the length
//! guards in front of them, gobyd's proxy — in one process, so one clock stamps both ends.

use std::time::{Duration, Instant};

use frontseat_actors::bus::Bus;
use frontseat_actors::groups;
use frontseat_actors::interface::InterfaceService;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    DesiredCourse, HelmState, HelmStateReport, InterfaceState,
};
use frontseat_config::{Goby3Config, Goby3Transport, InterfaceConfig};
use frontseat_gateway::GatewayOptions;
use frontseat_gateway::goby3::standin::{StandinGobyd, StandinTransport};
use frontseat_gateway::goby3::{self, Goby3Handle, Goby3Settings};

use super::frontseat::{ScriptedFrontseat, Stamps};
use super::inproc::{GRACE, latency_row, match_up};
use super::report::{Row, fmt_count};

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

fn settings(manager_port: u16, name: &str) -> Result<Goby3Settings, String> {
    let cfg = Goby3Config {
        enabled: true,
        transport: Goby3Transport::Tcp,
        tcp_port: manager_port,
        settle_ms: 100,
        manager_timeout_seconds: 2.0,
        ..Goby3Config::default()
    };
    Goby3Settings::from_config(&cfg, name).map_err(|e| format!("goby3 settings: {e}"))
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
    let capacity = cfg.bus.queue_capacity;

    let bus_if = Bus::new();
    let bus_helm = Bus::new();
    let mut tasks = Vec::new();
    let (_ns_sub, mut ns_rx) = bus_helm.subscribe_channel(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS,
        "bench",
        capacity,
    );
    let at = node_status_at.clone();
    tasks.push(tokio::spawn(async move {
        while let Some(env) = ns_rx.recv().await {
            let now = Instant::now();
            let depth = env.msg.global_fix.depth();
            if depth >= 1.0 && depth.fract() == 0.0 {
                at.set(depth as usize - 1, now);
            }
        }
    }));
    let (_st_sub, mut st_rx) =
        bus_if.subscribe_channel(&groups::GOBY_MIDDLEWARE_FRONTSEAT_STATUS, "bench", capacity);
    let helm_bus = bus_helm.clone();
    tasks.push(tokio::spawn(async move {
        loop {
            helm_bus.publish(
                &groups::GOBY_MIDDLEWARE_FRONTSEAT_HELM_STATE,
                HelmStateReport {
                    state: HelmState::HelmDrive as i32,
                },
            );
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
    }));

    let service = InterfaceService::start(&cfg, &bus_if)
        .await
        .map_err(|e| format!("interface: {e}"))?;
    let gw_if = goby3::start(
        &bus_if,
        settings(port, "bench-auv")?,
        &["FrontSeatInterface"],
        GatewayOptions::default(),
    )
    .map_err(|e| format!("interface's Goby3 gateway: {e}"))?;
    let gw_helm = goby3::start(
        &bus_helm,
        settings(port, "bench-auv")?,
        &["FrontSeatTranslation"],
        GatewayOptions::default(),
    )
    .map_err(|e| format!("helm's Goby3 gateway: {e}"))?;

    let result = async {
        until_up(&gw_if, Duration::from_secs(10)).await?;
        until_up(&gw_helm, Duration::from_secs(10)).await?;
        let reached = tokio::time::timeout(Duration::from_secs(10), async {
            while let Some(env) = st_rx.recv().await {
                if env.msg.state() == InterfaceState::InterfaceCommand {
                    return true;
                }
            }
            false
        })
        .await;
        if !matches!(reached, Ok(true)) {
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

async fn g1(plan: &Plan, fs: &ScriptedFrontseat, written: &Stamps, got: &Stamps) -> Row {
    let report = match fs.burst(0, plan.g1_count, plan.g1_rate_hz, false).await {
        Ok(r) => r,
        Err(_) => return Row::failed("G1", G1, "the scripted frontseat stopped"),
    };
    tokio::time::sleep(GRACE).await;
    let (h, n, lost) = match_up(written, got, 0..plan.g1_count);
    let detail = format!(
        "{} NAV lines at {} Hz; interface + Goby3 gateway → stand-in gobyd (TCP, loopback) → a second Goby3 gateway's bus; lost {lost}",
        fmt_count(n as f64),
        plan.g1_rate_hz
    );
    latency_row("G1", G1, &h, detail, report.written, lost)
}

async fn g2(plan: &Plan, bus: &Bus, fs: &ScriptedFrontseat, sent: &Stamps, read: &Stamps) -> Row {
    let start = tokio::time::Instant::now();
    let period = Duration::from_secs_f64(1.0 / plan.g2_rate_hz);
    let before = fs.cmds_read();
    for i in 0..plan.g2_count {
        tokio::time::sleep_until(start + period.mul_f64(i as f64)).await;
        let course = DesiredCourse {
            time: 0.0,
            heading: Some(90.0),
            speed: Some(1.5),
            depth: Some((i + 1) as f64),
            ..Default::default()
        };
        sent.set(i, Instant::now());
        bus.publish(&groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE, course);
    }
    let deadline = tokio::time::Instant::now() + GRACE;
    while fs.cmds_read() < before + plan.g2_count as u64 && tokio::time::Instant::now() < deadline {
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    let (h, n, lost) = match_up(sent, read, 0..plan.g2_count);
    let detail = format!(
        "{} desired_course at {} Hz (sequence in DEPTH), published on the helm side's bus → its Goby3 gateway → gobyd → the interface; lost {lost}",
        fmt_count(n as f64),
        plan.g2_rate_hz
    );
    latency_row("G2", G2, &h, detail, n, lost)
}
