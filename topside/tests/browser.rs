//! The topside page in a real browser (Debian's headless Chromium over chromedriver, the web
//! scope's own driver) against a real Topside whose Zenoh session hears three real vehicles:
//! each a real interface flying in the real simulator, exporting through its real gateway, with
//! its own web commander that requires its token. Every vehicle is on the map with its name;
//! selecting one shows its scope (its groups, node_status field by field, a rate); a command
//! from the page's commander without the vehicle's token is refused and with it reaches that
//! vehicle's commander and bus (and no other's); a vehicle whose interface stops is shown stale,
//! not removed. Fails, never skips, when the browser is missing.

#[path = "../../web/tests/common/mod.rs"]
mod common;

use std::time::Duration;

use common::browser::{Browser, free_port};
use frontseat_actors::bus::Bus;
use frontseat_actors::bus::test_util::UntypedBus as _;
use frontseat_actors::groups;
use frontseat_actors::interface::InterfaceService;
use frontseat_config::{InterfaceConfig, InterprocessConfig, WebConfig};
use frontseat_helm_side::{GatewayHandle, GatewayOptions};
use frontseat_sim::{SimHandle, SimOptions, SimServer};
use frontseat_topside::config::VehicleLink;
use frontseat_topside::{Topside, TopsideConfig};
use frontseat_web::WebService;

const BOUND: Duration = Duration::from_secs(20);
const NODE_STATUS: &str = "goby::middleware::frontseat::node_status";

/// One vehicle: interface on the shared simulator, its gateway on its own Zenoh port, its page.
struct Vehicle {
    name: String,
    bus: Bus,
    service: Option<InterfaceService>,
    gateway: Option<GatewayHandle>,
    page: WebService,
    zenoh_port: u16,
}

fn token_of(name: &str) -> String {
    format!("{name}-vehicle-token-0123456789")
}

async fn vehicle(sim: &SimHandle, name: &str, index: u32) -> Vehicle {
    let mut cfg = InterfaceConfig {
        name: name.into(),
        status_period: 0.5,
        helm_running_timeout: 600.0,
        ..Default::default()
    };
    cfg.driver.basic_simulator.tcp_port = sim.local_addr().port();
    // Apart on the map: 30 m north of each other.
    cfg.driver.basic_simulator.start.lat = cfg.origin.lat + 0.00027 * f64::from(index);
    cfg.driver.basic_simulator.start.lon = cfg.origin.lon;
    let bus = Bus::new();
    let service = InterfaceService::start(&cfg, &bus, frontseat_drivers::BUILT_IN)
        .await
        .expect("interface");
    let zenoh_port = free_port();
    let ip = InterprocessConfig {
        enabled: true,
        listen: vec![format!("tcp/127.0.0.1:{zenoh_port}")],
        ..Default::default()
    };
    let gateway = frontseat_helm_side::start(
        &bus,
        &ip,
        name,
        &["FrontSeatInterface"],
        GatewayOptions::default(),
    )
    .await
    .expect("gateway");
    let web = WebConfig {
        enabled: true,
        listen: "127.0.0.1:0".into(),
        ..Default::default()
    };
    let page = WebService::start_with(&web, &cfg.limits, Some(token_of(name)), &bus, name)
        .await
        .expect("the vehicle's page");
    Vehicle {
        name: name.into(),
        bus,
        service: Some(service),
        gateway: Some(gateway),
        page,
        zenoh_port,
    }
}

impl Vehicle {
    /// The vehicle goes silent: its interface and its gateway stop (its page stays).
    async fn silence(&mut self) {
        if let Some(g) = self.gateway.take() {
            g.close().await;
        }
        if let Some(s) = self.service.take() {
            s.shutdown(Duration::from_secs(3)).await;
        }
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_topside_page_shows_the_fleet_a_vehicles_scope_and_commands_it_with_its_token() {
    let sim = SimServer::bind(([127, 0, 0, 1], 0).into(), SimOptions::default())
        .await
        .expect("simulator on loopback");
    let mut fleet = Vec::new();
    for (i, name) in ["auv1", "auv2", "auv3"].into_iter().enumerate() {
        fleet.push(vehicle(&sim, name, i as u32).await);
    }
    let mut cfg = TopsideConfig::default();
    cfg.web.listen = "127.0.0.1:0".into();
    cfg.stale_after_s = 2.0;
    cfg.zenoh.connect = fleet
        .iter()
        .map(|v| format!("tcp/127.0.0.1:{}", v.zenoh_port))
        .collect();
    cfg.vehicle = fleet
        .iter()
        .map(|v| VehicleLink {
            name: v.name.clone(),
            page: format!("http://{}/", v.page.local_addr()),
        })
        .collect();
    let top = Topside::start(&cfg).await.expect("topside");
    let (_sub2, mut courses2) = fleet[1].bus.subscribe_channel(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE,
        "test",
        16,
    );
    let (_sub1, mut courses1) = fleet[0].bus.subscribe_channel(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE,
        "test",
        16,
    );

    let b = Browser::start().await;
    b.go(&format!("http://{}/", top.local_addr())).await;
    // Every vehicle on the map with its name, and in the table, all fresh.
    b.until(
        "three vehicles drawn on the map and in the table",
        "JSON.stringify(topside.marks.map((m) => m.name).sort()) === '[\"auv1\",\"auv2\",\"auv3\"]' \
         && document.querySelectorAll('#rows tr').length === 3 \
         && topside.fleet.vehicles.every((v) => !v.stale && v.status)",
    )
    .await;

    // Selecting auv2 (its row) shows its scope: what the topside hears under auv2, decoded.
    b.click(r#"#rows tr[data-vehicle="auv2"]"#).await;
    b.until(
        "auv2's scope with node_status and status at a rate",
        &format!(
            "topside.scope && topside.scope.vehicle === 'auv2' \
             && topside.scope.groups.some((g) => g.group === 'goby::middleware::frontseat::status') \
             && topside.scope.groups.some((g) => g.group === '{NODE_STATUS}' && g.count >= 3 && g.rate_hz > 0)"
        ),
    )
    .await;
    assert_eq!(b.text("#sel-name").await, "auv2");
    b.click(&format!(
        r#"#scope tr.group-row[data-group="{NODE_STATUS}"]"#
    ))
    .await;
    b.until(
        "node_status field by field",
        &format!(
            r#"document.querySelector('tr[data-fields-of="{NODE_STATUS}"] li[data-field="local_fix"]')"#
        ),
    )
    .await;
    let fix = b
        .text(&format!(
            r#"tr[data-fields-of="{NODE_STATUS}"] li[data-field="local_fix"]"#
        ))
        .await;
    assert!(fix.contains("x:") && fix.contains("y:"), "{fix}");
    let name = b
        .text(&format!(
            r#"tr[data-fields-of="{NODE_STATUS}"] li[data-field="name"]"#
        ))
        .await;
    assert!(name.contains("auv2"), "auv2's own node_status: {name}");

    // The commander: the vehicle page's form (the same six groups).
    b.until(
        "the commander's groups",
        "document.querySelectorAll('#cmd-group option').length === 6",
    )
    .await;
    b.click(r#"#cmd-group option[value="goby::middleware::frontseat::desired_course"]"#)
        .await;
    b.until(
        "the desired_course form",
        r#"document.querySelector('#cmd-form [name="heading"]')"#,
    )
    .await;
    b.type_into(r#"#cmd-form [name="time"]"#, "1700000000")
        .await;
    b.type_into(r#"#cmd-form [name="heading"]"#, "77").await;
    b.type_into(r#"#cmd-form [name="speed"]"#, "1.5").await;
    // Without the vehicle's token: refused, saying why; nothing reaches the vehicle.
    b.click("#cmd-send").await;
    b.until(
        "the refusal without a token",
        "document.getElementById('cmd-result').textContent.includes('refused (401)') \
         && document.getElementById('cmd-result').textContent.includes('token')",
    )
    .await;
    // A wrong token: the vehicle's own page refuses it.
    b.type_into("#cmd-token", "not-the-token-of-auv2-at-all")
        .await;
    b.click("#cmd-send").await;
    b.until(
        "the vehicle's refusal of a wrong token",
        "topside.sent.length === 2 && topside.sent[1].result.startsWith('refused (401)')",
    )
    .await;
    let auv2_sends = || {
        fleet[1]
            .page
            .server_counters
            .sends
            .load(std::sync::atomic::Ordering::Relaxed)
    };
    assert!(courses2.try_recv().is_err(), "no course reached auv2");
    assert_eq!(auv2_sends(), 0);
    // With auv2's token: auv2's commander publishes it on auv2's bus, and only there.
    b.type_into("#cmd-token", &token_of("auv2")).await;
    b.click("#cmd-send").await;
    b.until(
        "the send accepted",
        "document.getElementById('cmd-result').textContent.startsWith('auv2: published')",
    )
    .await;
    let env = tokio::time::timeout(BOUND, courses2.recv())
        .await
        .expect("the course reaches auv2 in time")
        .expect("auv2's bus");
    assert_eq!((env.msg.heading, env.msg.speed), (Some(77.0), Some(1.5)));
    assert_eq!(auv2_sends(), 1);
    assert!(courses1.try_recv().is_err(), "auv1 got nothing");

    // auv3 goes silent: shown stale (greyed, labelled), never removed.
    fleet[2].silence().await;
    b.until(
        "auv3 stale and still shown",
        "topside.fleet.vehicles.length === 3 \
         && topside.fleet.vehicles.find((v) => v.name === 'auv3').stale \
         && !topside.fleet.vehicles.find((v) => v.name === 'auv1').stale \
         && document.querySelector('#rows tr[data-vehicle=\"auv3\"]').classList.contains('stale') \
         && document.querySelector('#rows tr[data-vehicle=\"auv3\"]').textContent.includes('(stale)') \
         && topside.marks.some((m) => m.name === 'auv3')",
    )
    .await;

    drop(b);
    top.shutdown().await;
    for mut v in fleet {
        v.silence().await;
        v.page.shutdown(Duration::from_secs(2)).await;
    }
    sim.shutdown().await;
}
