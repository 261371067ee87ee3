//! The page in a real browser (Debian's headless Chromium, driven over WebDriver by
//! chromedriver) against a real interface and simulator: NAV arrives in the page's model, a
//! message expands field by field, the filter and pause work, the commander flags a bad field,
//! and a command sent from the commander is refused (no helm) and then accepted (after a
//! helm_state DRIVE sent from the commander too). Fails, never skips, when the browser is
//! missing: `.ci/run` installs it (`apt-get install chromium chromium-driver`).

mod common;

use std::time::Duration;

use common::browser::{Browser, base64_decode};
use frontseat_actors::bus::Bus;
use frontseat_actors::interface::InterfaceService;
use frontseat_config::{InterfaceConfig, WebConfig};
use frontseat_sim::{SimOptions, SimServer};
use frontseat_web::WebService;
use serde_json::json;

async fn fill_command(b: &Browser, request_id: u32) {
    b.click(r#"#cmd-group option[value="goby::middleware::frontseat::command_request"]"#)
        .await;
    b.until(
        "the command_request form",
        r#"document.querySelector('[name="desired_course.time"]')"#,
    )
    .await;
    b.type_into(r#"[name="desired_course.time"]"#, "1700000000")
        .await;
    b.type_into(r#"[name="desired_course.heading"]"#, "90")
        .await;
    b.type_into(r#"[name="desired_course.speed"]"#, "1.5").await;
    b.click(r#"[name="response_requested"] option[value="true"]"#)
        .await;
    b.type_into(r#"[name="request_id"]"#, &request_id.to_string())
        .await;
}

fn response_of(request_id: u32) -> String {
    format!("frontseat.model.sent.find((s) => s.request_id === {request_id} && s.response)")
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_page_shows_nav_expands_messages_and_commands_through_the_interface() {
    let sim = SimServer::bind(([127, 0, 0, 1], 0).into(), SimOptions::default())
        .await
        .expect("simulator on loopback");
    let bus = Bus::new();
    let mut cfg = InterfaceConfig {
        name: "browser-auv".into(),
        status_period: 1.0,
        helm_running_timeout: 600.0,
        ..Default::default()
    };
    cfg.driver.basic_simulator.tcp_port = sim.local_addr().port();
    cfg.driver.basic_simulator.start.lat = cfg.origin.lat;
    cfg.driver.basic_simulator.start.lon = cfg.origin.lon;
    let web_cfg = WebConfig {
        enabled: true,
        listen: "127.0.0.1:0".into(),
        ..Default::default()
    };
    let web = WebService::start_with(&web_cfg, &cfg.limits, None, &bus, &cfg.name)
        .await
        .expect("web");
    let service = InterfaceService::start(&cfg, &bus, frontseat_drivers::BUILT_IN)
        .await
        .expect("interface");
    let url = format!("http://{}/", web.local_addr());

    let b = Browser::start().await;
    b.go(&url).await;
    // NAV from the simulator, through the driver and the interface, into the page's model.
    b.until(
        "three NAV in the page's model",
        "frontseat.model.navCount >= 3",
    )
    .await;
    b.until(
        "the vehicle name",
        "document.getElementById('vehicle-name').textContent === 'browser-auv'",
    )
    .await;
    // Pause, then expand node_status field by field.
    b.click("#pause").await;
    b.click(r#"tr.group-row[data-group="goby::middleware::frontseat::node_status"]"#)
        .await;
    let fields = b
        .text(r#"tr[data-fields-of="goby::middleware::frontseat::node_status"] li[data-field="local_fix"]"#)
        .await;
    assert!(fields.contains("x:") && fields.contains("y:"), "{fields}");
    let heading = b
        .text(r#"tr[data-fields-of="goby::middleware::frontseat::node_status"] li[data-field="pose"]"#)
        .await;
    assert!(heading.contains("heading"), "{heading}");
    // While paused the table does not move, although the model does.
    let shown = b
        .text(r#"tr.group-row[data-group="goby::middleware::frontseat::node_status"] td.count"#)
        .await;
    let nav_then = b.js("return frontseat.model.navCount").await;
    b.until(
        "more NAV while paused",
        &format!("frontseat.model.navCount > {nav_then}"),
    )
    .await;
    let still = b
        .text(r#"tr.group-row[data-group="goby::middleware::frontseat::node_status"] td.count"#)
        .await;
    assert_eq!(shown, still, "paused table moved");
    b.click("#pause").await;
    // The regex filter.
    b.type_into("#filter", "node_status$").await;
    b.until(
        "the filter leaves one group",
        "[...document.querySelectorAll('#groups tr.group-row')].filter((r) => !r.hidden).length === 1",
    )
    .await;
    // History of one group.
    b.click(r#"tr.group-row[data-group="goby::middleware::frontseat::node_status"] button.hist"#)
        .await;
    b.until(
        "history rows",
        "document.querySelectorAll('#history-rows tr').length >= 3",
    )
    .await;

    // Commander: a bad value is flagged and blocks the send.
    b.click(r#"button[data-tab="commander"]"#).await;
    b.until(
        "the commander's groups",
        "document.querySelectorAll('#cmd-group option').length === 6",
    )
    .await;
    fill_command(&b, 7).await;
    b.type_into(r#"[name="desired_course.heading"]"#, "ninety")
        .await;
    b.until(
        "the bad field flagged",
        r#"document.querySelector('[name="desired_course.heading"]').classList.contains('bad') && document.getElementById('cmd-send').disabled"#,
    )
    .await;
    b.type_into(r#"[name="desired_course.heading"]"#, "90")
        .await;
    b.until(
        "send enabled",
        "!document.getElementById('cmd-send').disabled",
    )
    .await;
    // Beyond the command gate's envelope ([limits] max_speed 5 m/s): flagged, as the gate would.
    b.type_into(r#"[name="desired_course.speed"]"#, "50").await;
    b.until(
        "the out-of-range speed flagged",
        r#"document.querySelector('[name="desired_course.speed"]').classList.contains('bad') && document.getElementById('cmd-send').disabled"#,
    )
    .await;
    b.type_into(r#"[name="desired_course.speed"]"#, "1.5").await;
    b.until(
        "send enabled again",
        "!document.getElementById('cmd-send').disabled",
    )
    .await;
    // No helm yet: the interface is not in command and refuses, answering on command_response.
    b.click("#cmd-send").await;
    b.until("the answer to request 7", &response_of(7)).await;
    let r7 = b.js(&format!("return {}.response", response_of(7))).await;
    assert_eq!(r7["request_successful"], json!(false), "{r7}");
    assert!(
        r7["error_string"]
            .as_str()
            .unwrap_or("")
            .contains("not in command"),
        "{r7}"
    );
    b.until(
        "the log shows the refusal",
        "document.querySelector('#cmd-log td.response').textContent.includes('refused')",
    )
    .await;
    // The helm (this commander) drives: the interface reaches command.
    b.click(r#"#cmd-group option[value="goby::middleware::frontseat::helm_state"]"#)
        .await;
    b.click(r#"[name="state"] option[value="HELM_DRIVE"]"#)
        .await;
    b.click("#cmd-send").await;
    b.until(
        "INTERFACE_COMMAND in the vehicle view",
        "frontseat.model.groups.get('goby::middleware::frontseat::status').latest.msg.state === 'INTERFACE_COMMAND'",
    )
    .await;
    fill_command(&b, 8).await;
    b.click("#cmd-send").await;
    b.until("the answer to request 8", &response_of(8)).await;
    let r8 = b.js(&format!("return {}.response", response_of(8))).await;
    assert_eq!(r8["request_successful"], json!(true), "{r8}");
    // The server-side gate is what counts: a send that skips the form's checks is refused by
    // the interface's command gate, and the answer reaches the page.
    let status = b
        .js(r#"return fetch('/api/send', {method: 'POST', headers: {'Content-Type': 'application/json'},
            body: JSON.stringify({group: 'goby::middleware::frontseat::command_request', message: {
              desired_course: {time: 1700000000, heading: 90, speed: 50},
              response_requested: true, request_id: 9}})}).then((r) => r.status)"#)
        .await;
    assert_eq!(status, json!(200));
    let r9 = "frontseat.model.responses.find((r) => r.msg.request_id === 9)";
    b.until("the gate's answer to request 9", r9).await;
    let r9 = b.js(&format!("return {r9}.msg")).await;
    assert_eq!(r9["request_successful"], json!(false), "{r9}");
    assert!(
        r9["error_string"].as_str().unwrap_or("").contains("speed"),
        "{r9}"
    );

    // The vehicle view: states, the timeline of transitions, the map legend.
    b.click(r#"button[data-tab="vehicle"]"#).await;
    b.until(
        "the vehicle view",
        "document.getElementById('st-interface').textContent === 'INTERFACE_COMMAND' && document.querySelectorAll('#timeline tbody tr').length >= 1 && document.getElementById('map-legend').textContent.includes('heading')",
    )
    .await;
    if let Ok(path) = std::env::var("FRONTSEAT_WEB_SCREENSHOT") {
        let png = b.session("GET", "/screenshot", json!({})).await;
        if let Some(data) = png.as_str() {
            let _ = std::fs::write(path, base64_decode(data));
        }
    }
    drop(b);
    web.shutdown(Duration::from_secs(2)).await;
    service.shutdown(Duration::from_secs(3)).await;
    sim.shutdown().await;
}
