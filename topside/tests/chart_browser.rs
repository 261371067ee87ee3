//! The chart on the topside page in a real browser (Debian's headless Chromium over
//! chromedriver) against a real Topside serving an MBTiles file made here, hearing two real
//! vehicles (each a real interface flying in the real simulator, exporting through its real
//! gateway) and a helm on Zenoh driving one of them. Proves: the tiles are drawn where Web
//! Mercator puts them (a screenshot's pixels have each tile's own colour), each vehicle's mark
//! sits at its node_status latitude and longitude (checked against tile arithmetic done here,
//! not by the map library), the scale bar, the GeoJSON overlay, pan and zoom and "fit the
//! fleet", a stale vehicle greyed, and the selected vehicle's plots (heading, speed, depth
//! against the helm's desired_course, the interface state as a band) drawn from what the
//! topside hears. Fails, never skips, when the browser is missing.

mod chartkit;
#[path = "../../web/tests/common/mod.rs"]
mod common;

use std::time::Duration;

use chartkit::{colour_of, solid_png, tile_of, world_pixel, write_mbtiles};
use common::browser::{Browser, base64_decode, free_port};
use frontseat_actors::bus::Bus;
use frontseat_actors::groups;
use frontseat_actors::interface::InterfaceService;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    DesiredCourse, HelmState, HelmStateReport,
};
use frontseat_config::{InterfaceConfig, InterprocessConfig};
use frontseat_helm_side::{GatewayHandle, GatewayOptions, key_for, put_message, zenoh};
use frontseat_sim::{SimHandle, SimOptions, SimServer};
use frontseat_topside::{Topside, TopsideConfig};
use serde_json::json;

/// The zoom the test looks at, and the chart's zooms around it.
const Z: u8 = 16;

struct Vehicle {
    service: Option<InterfaceService>,
    gateway: Option<GatewayHandle>,
    zenoh_port: u16,
    _bus: Bus,
}

async fn vehicle(sim: &SimHandle, name: &str, index: u32) -> Vehicle {
    let mut cfg = InterfaceConfig {
        name: name.into(),
        status_period: 0.5,
        helm_running_timeout: 600.0,
        ..Default::default()
    };
    cfg.driver.basic_simulator.tcp_port = sim.local_addr().port();
    // 60 m apart, north-east of each other.
    cfg.driver.basic_simulator.start.lat = cfg.origin.lat + 0.00054 * f64::from(index);
    cfg.driver.basic_simulator.start.lon = cfg.origin.lon + 0.0005 * f64::from(index);
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
    Vehicle {
        service: Some(service),
        gateway: Some(gateway),
        zenoh_port,
        _bus: bus,
    }
}

impl Vehicle {
    async fn silence(&mut self) {
        if let Some(g) = self.gateway.take() {
            g.close().await;
        }
        if let Some(s) = self.service.take() {
            s.shutdown(Duration::from_secs(3)).await;
        }
    }
}

/// A chart of zooms Z−1..=Z+1, a 7×7 block of tiles around the origin at each, every tile its
/// own colour.
fn chart(path: &std::path::Path, lat: f64, lon: f64) {
    let mut tiles = Vec::new();
    for z in Z - 1..=Z + 1 {
        let (cx, cy) = tile_of(lat, lon, z);
        for x in cx - 3..=cx + 3 {
            for y in cy - 3..=cy + 3 {
                tiles.push((z, x, y, solid_png(colour_of(z, x, y))));
            }
        }
    }
    let (minzoom, maxzoom) = ((Z - 1).to_string(), (Z + 1).to_string());
    write_mbtiles(
        path,
        &[
            ("name", "test harbour"),
            ("format", "png"),
            ("minzoom", &minzoom),
            ("maxzoom", &maxzoom),
        ],
        &tiles,
    );
}

/// The RGB of pixel (x, y) of an RGBA or RGB PNG.
struct Screenshot {
    width: usize,
    channels: usize,
    data: Vec<u8>,
}

impl Screenshot {
    fn decode(png_bytes: &[u8]) -> Screenshot {
        let mut r = png::Decoder::new(std::io::Cursor::new(png_bytes))
            .read_info()
            .expect("the screenshot is a PNG");
        let mut data = vec![0; r.output_buffer_size().expect("size")];
        let info = r.next_frame(&mut data).expect("a frame");
        Screenshot {
            width: info.width as usize,
            channels: info.color_type.samples(),
            data,
        }
    }
    fn rgb(&self, x: usize, y: usize) -> [u8; 3] {
        let i = (y * self.width + x) * self.channels;
        [self.data[i], self.data[i + 1], self.data[i + 2]]
    }
}

fn close(a: [u8; 3], b: [u8; 3]) -> bool {
    a.iter().zip(b).all(|(p, q)| p.abs_diff(q) <= 3)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_chart_is_drawn_under_the_fleet_and_the_selected_vehicle_is_plotted() {
    let origin = InterfaceConfig::default().origin;
    let dir = tempfile::tempdir().unwrap();
    let mbtiles = dir.path().join("harbour.mbtiles");
    chart(&mbtiles, origin.lat, origin.lon);
    let area = dir.path().join("operating-area.geojson");
    let (la, lo) = (origin.lat, origin.lon);
    std::fs::write(
        &area,
        json!({"type": "Feature", "properties": {"name": "box"}, "geometry": {"type": "Polygon",
            "coordinates": [[[lo - 0.002, la - 0.002], [lo + 0.003, la - 0.002], [lo + 0.003, la + 0.003],
                             [lo - 0.002, la + 0.003], [lo - 0.002, la - 0.002]]]}})
        .to_string(),
    )
    .unwrap();

    let sim = SimServer::bind(([127, 0, 0, 1], 0).into(), SimOptions::default())
        .await
        .expect("simulator on loopback");
    let mut fleet = vec![
        vehicle(&sim, "auv1", 0).await,
        vehicle(&sim, "auv2", 1).await,
    ];
    // A helm on Zenoh for auv1: connected to auv1's gateway, listened to by the topside.
    let helm_port = free_port();
    let helm = zenoh::open(
        frontseat_helm_side::zenoh_config(
            &InterprocessConfig {
                enabled: true,
                listen: vec![format!("tcp/127.0.0.1:{helm_port}")],
                connect: vec![format!("tcp/127.0.0.1:{}", fleet[0].zenoh_port)],
                ..Default::default()
            },
            65536,
        )
        .unwrap(),
    )
    .await
    .unwrap();

    let mut cfg = TopsideConfig::default();
    cfg.web.listen = "127.0.0.1:0".into();
    cfg.stale_after_s = 2.0;
    cfg.zenoh.connect = fleet
        .iter()
        .map(|v| format!("tcp/127.0.0.1:{}", v.zenoh_port))
        .chain([format!("tcp/127.0.0.1:{helm_port}")])
        .collect();
    cfg.chart.mbtiles = Some(mbtiles);
    cfg.chart.geojson = vec![area];
    let top = Topside::start(&cfg).await.expect("topside");

    let b = Browser::start().await;
    b.go(&format!("http://{}/", top.local_addr())).await;
    for (what, expr) in [
        (
            "both vehicles on the chart, fresh",
            "topside.marks.length === 2 && topside.fleet.vehicles.every((v) => !v.stale)",
        ),
        (
            "the chart's tiles loaded",
            "document.querySelectorAll('.chart-tiles img.leaflet-tile-loaded').length > 0",
        ),
        (
            "the overlay",
            "document.querySelectorAll('path.chart-geojson').length === 1",
        ),
        (
            "the scale bar in metres",
            "/^\\d+ k?m$/.test(document.querySelector('.leaflet-control-scale-line').textContent)",
        ),
    ] {
        until(&b, what, expr).await;
    }
    // Fitted to the fleet on load: both marks inside the view.
    b.until(
        "the view fitted to the fleet",
        "topside.marks.every((m) => topside.map.getBounds().contains([m.lat, m.lon]))",
    )
    .await;

    // Look at zoom Z, one of the chart's own, and wait for its tiles.
    b.js(&format!(
        "topside.follow = false; topside.map.setView([{}, {}], {Z}, {{animate: false}}); return true",
        origin.lat, origin.lon
    ))
    .await;
    let tiles_at_z = format!(
        "[...document.querySelectorAll('.chart-tiles img')].filter((i) => i.src.includes('/tiles/{Z}/'))"
    );
    b.until(
        "the tiles of zoom Z loaded",
        &format!(
            "!topside.follow && {tiles_at_z}.length >= 4 && {tiles_at_z}.every((i) => i.complete && i.naturalWidth === 256)"
        ),
    )
    .await;
    // Where each mark and each tile is, and what the page was told of each vehicle, at once.
    let seen = b
        .js(&format!(
            "const map = document.getElementById('map').getBoundingClientRect();
             const r = (e) => {{ const b = e.getBoundingClientRect(); return [b.left, b.top, b.width, b.height]; }};
             return {{
               dpr: window.devicePixelRatio, map: [map.left, map.top, map.width, map.height],
               tiles: {tiles_at_z}.map((i) => ({{src: i.src, rect: r(i)}})),
               marks: topside.fleet.vehicles.map((v) => ({{name: v.name, lat: v.nav.lat, lon: v.nav.lon,
                 rect: r(document.querySelector('.vmark[data-vehicle=\"' + v.name + '\"]'))}})),
             }};"
        ))
        .await;
    let tiles: Vec<(u32, u32, [f64; 4])> = seen["tiles"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| {
            let src = t["src"].as_str().unwrap();
            let tail = src.split(&format!("/tiles/{Z}/")).nth(1).unwrap();
            let (x, y) = tail.split_once('/').unwrap();
            let rect: Vec<f64> = t["rect"]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_f64().unwrap())
                .collect();
            (
                x.parse().unwrap(),
                y.split('?').next().unwrap().parse().unwrap(),
                [rect[0], rect[1], rect[2], rect[3]],
            )
        })
        .collect();
    // Each mark: on the tile Web Mercator puts its latitude and longitude in, at the pixel
    // within that tile it computes (within 1.5 px).
    for m in seen["marks"].as_array().unwrap() {
        let (lat, lon) = (m["lat"].as_f64().unwrap(), m["lon"].as_f64().unwrap());
        let r: Vec<f64> = m["rect"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        let (cx, cy) = (r[0] + r[2] / 2.0, r[1] + r[3] / 2.0);
        let (tx, ty) = tile_of(lat, lon, Z);
        let (_, _, rect) = tiles
            .iter()
            .find(|(x, y, _)| (*x, *y) == (tx, ty))
            .unwrap_or_else(|| panic!("the tile {Z}/{tx}/{ty} of {m} is drawn: {tiles:?}"));
        let (wx, wy) = world_pixel(lat, lon, Z);
        let want = (
            rect[0] + wx - f64::from(tx) * 256.0,
            rect[1] + wy - f64::from(ty) * 256.0,
        );
        assert!(
            (cx - want.0).abs() < 1.5 && (cy - want.1).abs() < 1.5,
            "{}: the mark at ({cx}, {cy}), Web Mercator says {want:?}",
            m["name"]
        );
    }
    // The screenshot, with the marks, tracks and controls hidden: every tile wholly inside the
    // map shows its own colour at its centre.
    b.js("document.querySelectorAll('.leaflet-marker-pane, .leaflet-overlay-pane, .leaflet-control-container')
            .forEach((e) => e.style.visibility = 'hidden'); return true")
        .await;
    let png = b.session("GET", "/screenshot", json!({})).await;
    if let Ok(path) = std::env::var("FRONTSEAT_CHART_SCREENSHOT") {
        let _ = std::fs::write(path, base64_decode(png.as_str().unwrap_or("")));
    }
    let shot = Screenshot::decode(&base64_decode(png.as_str().expect("a screenshot")));
    let dpr = seen["dpr"].as_f64().unwrap_or(1.0);
    let map: Vec<f64> = seen["map"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    let mut checked = 0;
    for (x, y, r) in &tiles {
        let inside = r[0] >= map[0]
            && r[1] >= map[1]
            && r[0] + r[2] <= map[0] + map[2]
            && r[1] + r[3] <= map[1] + map[3];
        if !inside {
            continue;
        }
        let (px, py) = (
            ((r[0] + r[2] / 2.0) * dpr) as usize,
            ((r[1] + r[3] / 2.0) * dpr) as usize,
        );
        let got = shot.rgb(px, py);
        assert!(
            close(got, colour_of(Z, *x, *y)),
            "tile {Z}/{x}/{y} at ({px}, {py}) is {got:?}, not {:?}",
            colour_of(Z, *x, *y)
        );
        checked += 1;
    }
    assert!(
        checked >= 1,
        "no tile wholly inside the map: {tiles:?} in {map:?}"
    );
    b.js("document.querySelectorAll('.leaflet-marker-pane, .leaflet-overlay-pane, .leaflet-control-container')
            .forEach((e) => e.style.visibility = ''); return true")
        .await;

    // "Fit the fleet" follows it again; the zoom control zooms and stops following; fit again.
    b.click("#fit").await;
    b.until(
        "following the fleet",
        "topside.follow && topside.marks.every((m) => topside.map.getBounds().contains([m.lat, m.lon]))",
    )
    .await;
    let z0 = b.js("return topside.map.getZoom()").await;
    b.click(".leaflet-control-zoom-in").await;
    b.until(
        "zoomed in by the control, which stops following the fleet",
        &format!("!topside.follow && topside.map.getZoom() > {z0}"),
    )
    .await;
    b.click("#fit").await;
    b.until(
        "fitted to the fleet again",
        "topside.follow && topside.marks.every((m) => topside.map.getBounds().contains([m.lat, m.lon]))",
    )
    .await;

    // auv1's plots: the helm drives it; what it did against what it was asked.
    let put_helm = || {
        put_message(
            &helm,
            &key_for("auv1", groups::GOBY_MIDDLEWARE_FRONTSEAT_HELM_STATE.name()),
            groups::GOBY_MIDDLEWARE_FRONTSEAT_HELM_STATE.type_name(),
            &HelmStateReport {
                state: HelmState::HelmDrive as i32,
            },
            None,
        )
        .unwrap();
        put_message(
            &helm,
            &key_for(
                "auv1",
                groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE.name(),
            ),
            groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE.type_name(),
            &DesiredCourse {
                time: 1_700_000_000.0,
                heading: Some(120.0),
                speed: Some(1.2),
                depth: Some(0.0),
                ..Default::default()
            },
            None,
        )
        .unwrap();
    };
    // Selected by its mark on the chart (made once and kept, unlike the table's rows, which are
    // rebuilt each second and can go stale under a click).
    b.click(r#".vmark[data-vehicle="auv1"]"#).await;
    b.until("auv1 selected", "topside.selected === 'auv1'")
        .await;
    let plotted = "topside.plots.lastDraw && topside.plots.lastDraw.heading.actual >= 3 \
         && topside.plots.lastDraw.heading.desired >= 1 && topside.plots.lastDraw.speed.desired >= 1 \
         && topside.plots.lastDraw.speed.actual >= 3 && topside.plots.lastDraw.band.includes('INTERFACE_COMMAND')";
    let deadline = std::time::Instant::now() + Duration::from_secs(30);
    loop {
        put_helm();
        let v = b
            .js(&format!(
                "try {{ return !!({plotted}); }} catch (e) {{ return false; }}"
            ))
            .await;
        if v == json!(true) {
            break;
        }
        assert!(
            std::time::Instant::now() < deadline,
            "auv1's plots: {}",
            b.js("return JSON.stringify(topside.plots.lastDraw)").await
        );
        tokio::time::sleep(Duration::from_millis(200)).await;
    }
    // Drawn, not only counted: the canvas holds the actual and desired colours and the band's
    // (over one minute, where the few seconds in COMMAND are wider than a column).
    b.click(r#"#plot-minutes option[value="1"]"#).await;
    b.until(
        "a one-minute window",
        "topside.plots.lastDraw.minutes === 1",
    )
    .await;
    let pixels = b.js(COUNT_COLOURS).await;
    for (k, at_least) in [("actual", 20), ("desired", 10), ("command", 16 * 3)] {
        assert!(
            pixels[k].as_u64().unwrap_or(0) >= at_least,
            "{k} pixels on the plot: {pixels}"
        );
    }

    // auv2 goes silent: greyed and labelled stale on the chart, still there.
    fleet[1].silence().await;
    b.until(
        "auv2 stale on the chart",
        "document.querySelector('.vmark[data-vehicle=\"auv2\"]').classList.contains('stale') \
         && document.querySelector('.vmark[data-vehicle=\"auv2\"]').textContent.includes('(stale)') \
         && !document.querySelector('.vmark[data-vehicle=\"auv1\"]').classList.contains('stale')",
    )
    .await;

    drop(b);
    let _ = helm.close().await;
    top.shutdown().await;
    for mut v in fleet {
        v.silence().await;
    }
    sim.shutdown().await;
}

/// The map's state, when a wait fails.
const MAP_STATE: &str = "return JSON.stringify({zoom: topside.map.getZoom(), center: topside.map.getCenter(),
  size: topside.map.getSize(), follow: topside.follow, chart: topside.chart, marks: topside.marks,
  tiles: [...document.querySelectorAll('.leaflet-tile-pane img')].map((i) => [i.src, i.className, i.complete, i.naturalWidth]).slice(0, 20)})";

/// Waits (bounded) until `expr` holds; on a timeout, says what the map showed.
async fn until(b: &Browser, what: &str, expr: &str) {
    let deadline = std::time::Instant::now() + Duration::from_secs(30);
    loop {
        let v = b
            .js(&format!(
                "try {{ return !!({expr}); }} catch (e) {{ return false; }}"
            ))
            .await;
        if v == json!(true) {
            return;
        }
        assert!(
            std::time::Instant::now() < deadline,
            "timed out waiting for {what}; the map: {}",
            b.js(MAP_STATE).await
        );
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
}

/// Counts the plot canvas's pixels of the actual line's, the desired line's and the COMMAND
/// band's colours.
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
