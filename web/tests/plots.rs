//! The vehicle page's plots in a real browser (Debian's headless Chromium over chromedriver)
//! against a real interface flying in the real simulator: with a helm driving (helm_state DRIVE
//! and a desired_course on the vehicle's bus), the Vehicle tab plots heading, speed and depth
//! against the desired values and the interface state as a band, drawn on the canvas (its
//! pixels are counted); the window can be changed; and the page's rings stay bounded however
//! much arrives. Fails, never skips, when the browser is missing.

mod common;

use std::time::Duration;

use common::browser::Browser;
use frontseat_actors::bus::Bus;
use frontseat_actors::bus::test_util::UntypedBus as _;
use frontseat_actors::groups;
use frontseat_actors::interface::InterfaceService;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    DesiredCourse, HelmState, HelmStateReport,
};
use frontseat_config::{InterfaceConfig, WebConfig};
use frontseat_sim::{SimOptions, SimServer};
use frontseat_web::WebService;
use serde_json::json;

/// Counts the plot canvas's pixels of the actual line's, the desired line's and each band
/// colour's.
const COUNT_COLOURS: &str = "
  const c = document.getElementById('plots'), d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
  const hex = (h) => [1, 3, 5].map((i) => parseInt(h.slice(i, i + 2), 16));
  const want = { actual: hex(FrontseatPlots.ACTUAL), desired: hex(FrontseatPlots.DESIRED),
                 command: hex(FrontseatPlots.STATE_COLOURS.INTERFACE_COMMAND) };
  const n = { actual: 0, desired: 0, command: 0 };
  for (let i = 0; i < d.length; i += 4)
    for (const [k, w] of Object.entries(want))
      if (Math.abs(d[i] - w[0]) < 4 && Math.abs(d[i + 1] - w[1]) < 4 && Math.abs(d[i + 2] - w[2]) < 4) n[k] += 1;
  return n;";

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_vehicle_view_plots_what_the_vehicle_did_against_what_it_was_asked() {
    let sim = SimServer::bind(([127, 0, 0, 1], 0).into(), SimOptions::default())
        .await
        .expect("simulator on loopback");
    let bus = Bus::new();
    let mut cfg = InterfaceConfig {
        name: "plots-auv".into(),
        status_period: 0.5,
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

    let b = Browser::start().await;
    b.go(&format!("http://{}/", web.local_addr())).await;
    b.until("NAV in the page", "frontseat.model.navCount >= 3")
        .await;
    b.click(r#"button[data-tab="vehicle"]"#).await;
    // Before any helm: the vehicle's own values and a band, no desired line.
    b.until(
        "the actual values plotted, no desired yet",
        "frontseat.plots.lastDraw && frontseat.plots.lastDraw.heading.actual >= 3 \
         && frontseat.plots.lastDraw.speed.actual >= 3 && frontseat.plots.lastDraw.heading.desired === 0 \
         && frontseat.plots.lastDraw.band.length >= 1",
    )
    .await;
    // A helm drives: COMMAND, and a course the vehicle turns to.
    bus.publish(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_HELM_STATE,
        HelmStateReport {
            state: HelmState::HelmDrive as i32,
        },
    );
    b.until(
        "INTERFACE_COMMAND",
        "frontseat.model.groups.get('goby::middleware::frontseat::status').latest.msg.state === 'INTERFACE_COMMAND'",
    )
    .await;
    for heading in [45.0, 200.0] {
        bus.publish(
            &groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE,
            DesiredCourse {
                time: 1_700_000_000.0,
                heading: Some(heading),
                speed: Some(1.5),
                depth: Some(0.0),
                ..Default::default()
            },
        );
        tokio::time::sleep(Duration::from_millis(300)).await;
    }
    b.until(
        "the desired values and the COMMAND band plotted",
        "frontseat.plots.lastDraw.heading.desired >= 2 && frontseat.plots.lastDraw.speed.desired >= 2 \
         && frontseat.plots.lastDraw.depth.desired >= 2 \
         && frontseat.plots.lastDraw.band.includes('INTERFACE_COMMAND') \
         && frontseat.plots.desired.heading.at(frontseat.plots.desired.heading.length - 1)[1] === 200",
    )
    .await;
    // The vehicle turns toward what it was asked: its heading moves off the start.
    b.until(
        "the simulated vehicle answers the course",
        "(() => { const r = frontseat.plots.actual.heading; const h = r.at(r.length - 1)[1]; \
           return Math.abs(((h - 200 + 540) % 360) - 180) < 90; })()",
    )
    .await;
    let pixels = b.js(COUNT_COLOURS).await;
    for (k, at_least) in [("actual", 20), ("desired", 20), ("command", 50)] {
        assert!(
            pixels[k].as_u64().unwrap_or(0) >= at_least,
            "{k} pixels on the plot: {pixels}"
        );
    }
    // Another window.
    b.click(r#"#plot-minutes option[value="1"]"#).await;
    b.until(
        "a one-minute window",
        "frontseat.plots.lastDraw.minutes === 1",
    )
    .await;
    assert!(b.text("#plot-legend").await.contains("desired"));

    // Bounded: a day of NAV at 50 Hz pushed into a recorder keeps at most its capacity.
    let bound = b
        .js("const r = new FrontseatPlots.Recorder(); const t0 = Date.now() - 86400000;
             for (let i = 0; i < 86400 * 50; i += 7) r.nav(t0 + i * 20, {pose: {heading: i % 360}, speed: {over_ground: 1}});
             for (let i = 0; i < 5000; i++) r.state(t0 + i, i % 2 ? 'INTERFACE_COMMAND' : 'INTERFACE_LISTEN');
             return {n: r.actual.heading.length, cap: FrontseatPlots.CAPACITY, states: r.states.length,
                     last: r.actual.heading.at(r.actual.heading.length - 1)[1]};")
        .await;
    assert_eq!(bound["n"], bound["cap"], "{bound}");
    assert_eq!(bound["states"], json!(2000), "{bound}");
    // The newest sample is the last one pushed (the ring dropped the oldest).
    let last_i = (86400 * 50 - 1) / 7 * 7;
    assert_eq!(bound["last"], json!(last_i % 360), "{bound}");

    drop(b);
    web.shutdown(Duration::from_secs(2)).await;
    service.shutdown(Duration::from_secs(3)).await;
    sim.shutdown().await;
}
