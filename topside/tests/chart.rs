//! The chart's serving path against the real topside on loopback: an MBTiles file made here
//! (PNG tiles of known colours, TMS rows, a metadata table) is served tile by tile at
//! `/tiles/{z}/{x}/{y}` in XYZ numbering with the image's content type; a missing tile is 404,
//! a z/x/y outside the pyramid or not a number is refused and counted, and no request path
//! reaches the filesystem. GeoJSON overlays are served as given; a file that is not MBTiles or
//! not GeoJSON, or a vector-tile MBTiles, stops the topside with an error naming the file; the
//! config refuses missing files and a bad tile URL template. The token rule covers the tiles.

mod chartkit;

use std::time::Duration;

use chartkit::{colour_of, solid_png, write_mbtiles};
use frontseat_config::ServiceConfig as _;
use frontseat_topside::{Topside, TopsideConfig, TopsideError};
use serde_json::Value;
use tokio::io::{AsyncReadExt, AsyncWriteExt};

const BOUND: Duration = Duration::from_secs(15);

struct Answer {
    status: u16,
    head: String,
    body: Vec<u8>,
}

impl Answer {
    fn header(&self, name: &str) -> Option<String> {
        self.head.lines().find_map(|l| {
            let (k, v) = l.split_once(':')?;
            k.eq_ignore_ascii_case(name).then(|| v.trim().to_string())
        })
    }
    fn json(&self) -> Value {
        serde_json::from_slice(&self.body)
            .unwrap_or_else(|e| panic!("{e}: {}", String::from_utf8_lossy(&self.body)))
    }
}

async fn get(addr: std::net::SocketAddr, path: &str, headers: &str) -> Answer {
    let mut s = tokio::net::TcpStream::connect(addr).await.unwrap();
    let req = format!(
        "GET {path} HTTP/1.1\r\nHost: 127.0.0.1:{}\r\n{headers}Connection: close\r\n\r\n",
        addr.port()
    );
    s.write_all(req.as_bytes()).await.unwrap();
    let mut buf = Vec::new();
    tokio::time::timeout(BOUND, s.read_to_end(&mut buf))
        .await
        .expect("an answer in time")
        .unwrap();
    let at = buf
        .windows(4)
        .position(|w| w == b"\r\n\r\n")
        .expect("a complete head");
    let head = String::from_utf8_lossy(&buf[..at]).into_owned();
    Answer {
        status: head[9..12].parse().unwrap(),
        head,
        body: buf[at + 4..].to_vec(),
    }
}

fn config(dir: &std::path::Path) -> TopsideConfig {
    let mut cfg = TopsideConfig::default();
    // Nobody listens there: the chart needs no fleet.
    cfg.zenoh.connect = vec![format!(
        "tcp/127.0.0.1:{}",
        std::net::TcpListener::bind("127.0.0.1:0")
            .unwrap()
            .local_addr()
            .unwrap()
            .port()
    )];
    cfg.web.listen = "127.0.0.1:0".into();
    cfg.chart.mbtiles = Some(dir.join("chart.mbtiles"));
    cfg
}

/// Zoom 0 (one tile), and at zoom 2 the tiles of the top-left and bottom-right quarter, each
/// of its own colour.
fn tiles() -> Vec<(u8, u32, u32, Vec<u8>)> {
    [(0, 0, 0), (2, 0, 0), (2, 1, 0), (2, 3, 3), (2, 3, 2)]
        .into_iter()
        .map(|(z, x, y)| (z, x, y, solid_png(colour_of(z, x, y))))
        .collect()
}

/// The colour of the top-left pixel of a PNG.
fn first_pixel(png_bytes: &[u8]) -> [u8; 3] {
    let mut r = png::Decoder::new(std::io::Cursor::new(png_bytes))
        .read_info()
        .expect("a PNG");
    let mut buf = vec![0; r.output_buffer_size().expect("size")];
    r.next_frame(&mut buf).expect("a frame");
    [buf[0], buf[1], buf[2]]
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn tiles_are_served_in_xyz_order_from_the_mbtiles_rows_and_bad_requests_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    write_mbtiles(
        &dir.path().join("chart.mbtiles"),
        &[
            ("name", "test chart"),
            ("format", "png"),
            ("minzoom", "0"),
            ("maxzoom", "2"),
            ("bounds", "-180,-85,180,85"),
            ("attribution", "made in the test"),
        ],
        &tiles(),
    );
    let coast = dir.path().join("coast.geojson");
    let coast_text = r#"{"type":"FeatureCollection","features":[{"type":"Feature","properties":{},"geometry":{"type":"LineString","coordinates":[[-70.0,41.0],[-70.1,41.1]]}}]}"#;
    std::fs::write(&coast, coast_text).unwrap();
    let mut cfg = config(dir.path());
    cfg.chart.geojson = vec![coast];
    assert!(cfg.validate().is_empty(), "{:?}", cfg.validate());
    let top = Topside::start(&cfg).await.expect("topside with a chart");
    let addr = top.local_addr();

    let meta = get(addr, "/api/chart", "").await;
    assert_eq!(meta.status, 200);
    let m = meta.json();
    assert_eq!(m["mbtiles"]["name"], "test chart");
    assert_eq!(
        (
            m["mbtiles"]["minzoom"].as_u64(),
            m["mbtiles"]["maxzoom"].as_u64()
        ),
        (Some(0), Some(2))
    );
    assert_eq!(m["mbtiles"]["bounds"][0], -180.0);
    assert_eq!(m["geojson"][0]["name"], "coast");
    assert_eq!(
        m["tile_url"],
        Value::Null,
        "nothing online unless configured"
    );

    // Every stored tile at its XYZ address, with its own colour: row flipped from TMS.
    for (z, x, y, data) in tiles() {
        let a = get(addr, &format!("/tiles/{z}/{x}/{y}"), "").await;
        assert_eq!(a.status, 200, "{z}/{x}/{y}");
        assert_eq!(a.header("content-type").as_deref(), Some("image/png"));
        assert_eq!(a.body, data, "{z}/{x}/{y}");
        assert_eq!(first_pixel(&a.body), colour_of(z, x, y));
    }
    // Stored at (2, 0, 0) XYZ = TMS row 3: XYZ (2, 0, 3) is another tile, not stored.
    assert_eq!(get(addr, "/tiles/2/0/3", "").await.status, 404);
    // Past the file's zooms; outside the pyramid; not numbers; traversal.
    for (path, status) in [
        ("/tiles/3/0/0", 404),
        ("/tiles/2/4/0", 404),
        ("/tiles/2/0/4", 404),
        ("/tiles/31/0/0", 404),
        ("/tiles/255/0/0", 404),
        ("/tiles/256/0/0", 400),
        ("/tiles/1/0/0.png", 400),
        ("/tiles/1/-1/0", 400),
        ("/tiles/1/0/99999999999", 400),
        ("/tiles/a/b/c", 400),
        ("/tiles/..%2F..%2Fetc/passwd/0", 400),
        ("/tiles/../../../../etc/passwd", 404),
        ("/tiles/0/0", 404),
        ("/chart/geojson/1", 404),
        ("/chart/geojson/-1", 404),
        ("/chart/geojson/..%2Fchart.mbtiles", 404),
    ] {
        let a = get(addr, path, "").await;
        assert_eq!(
            a.status,
            status,
            "{path}: {}",
            String::from_utf8_lossy(&a.body)
        );
        assert!(!a.body.starts_with(b"SQLite format"), "{path}");
    }
    let c = get(addr, "/api/chart", "").await.json()["counters"].clone();
    assert_eq!(c["tiles_served"], 5, "{c}");
    // 2/0/3, 3/0/0 missing; 2/4/0, 2/0/4, 31/0/0, 255/0/0 outside; six not numbers.
    assert_eq!(c["tiles_missing"], 2, "{c}");
    assert_eq!(c["tiles_refused"], 4 + 6, "{c}");

    let g = get(addr, "/chart/geojson/0", "").await;
    assert_eq!(g.status, 200);
    assert_eq!(
        g.header("content-type").as_deref(),
        Some("application/geo+json")
    );
    assert_eq!(g.body, coast_text.as_bytes());
    // The map library, vendored and served by the topside itself.
    for (path, ct) in [
        ("/leaflet/leaflet.js", "text/javascript"),
        ("/leaflet/leaflet.css", "text/css"),
        ("/leaflet/images/layers.png", "image/png"),
    ] {
        let a = get(addr, path, "").await;
        assert_eq!(
            (a.status, a.header("content-type").as_deref()),
            (200, Some(ct)),
            "{path}"
        );
    }
    top.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn with_a_token_tiles_need_it_too() {
    let dir = tempfile::tempdir().unwrap();
    write_mbtiles(
        &dir.path().join("chart.mbtiles"),
        &[("format", "png")],
        &tiles(),
    );
    let mut cfg = config(dir.path());
    cfg.web.token = Some("a-topside-token-of-some-length".into());
    let top = Topside::start(&cfg).await.unwrap();
    let addr = top.local_addr();
    assert_eq!(get(addr, "/tiles/0/0/0", "").await.status, 401);
    assert_eq!(get(addr, "/api/chart", "").await.status, 401);
    // As the page's <img> asks: the token in the query.
    let a = get(
        addr,
        "/tiles/0/0/0?token=a-topside-token-of-some-length",
        "",
    )
    .await;
    assert_eq!(a.status, 200);
    let a = get(
        addr,
        "/api/chart",
        "Authorization: Bearer a-topside-token-of-some-length\r\n",
    )
    .await;
    assert_eq!(a.status, 200);
    // No metadata zooms: taken from the tiles.
    assert_eq!(
        (
            a.json()["mbtiles"]["minzoom"].as_u64(),
            a.json()["mbtiles"]["maxzoom"].as_u64()
        ),
        (Some(0), Some(2))
    );
    assert_eq!(a.json()["counters"]["unauthorized"], 2);
    top.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_tile_that_is_too_large_or_not_an_image_is_refused_not_sent() {
    let dir = tempfile::tempdir().unwrap();
    let huge = vec![0x89u8; frontseat_topside::chart::MAX_TILE_BYTES as usize + 1];
    write_mbtiles(
        &dir.path().join("chart.mbtiles"),
        &[("format", "png")],
        &[
            (1, 0, 0, huge),
            (1, 1, 0, b"<html>not a tile</html>".to_vec()),
        ],
    );
    let top = Topside::start(&config(dir.path())).await.unwrap();
    let addr = top.local_addr();
    assert_eq!(get(addr, "/tiles/1/0/0", "").await.status, 502);
    assert_eq!(get(addr, "/tiles/1/1/0", "").await.status, 502);
    assert_eq!(
        get(addr, "/api/chart", "").await.json()["counters"]["tiles_bad"],
        2
    );
    top.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn files_that_are_not_a_chart_stop_the_topside_with_an_error_naming_them() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("chart.mbtiles");
    // Not SQLite at all.
    std::fs::write(&path, b"this is not a database, it is text").unwrap();
    let e = Topside::start(&config(dir.path()))
        .await
        .err()
        .expect("refused");
    assert!(matches!(e, TopsideError::Chart(_)), "{e}");
    assert!(e.to_string().contains("chart.mbtiles"), "{e}");
    // SQLite without a tiles table.
    std::fs::remove_file(&path).unwrap();
    rusqlite::Connection::open(&path)
        .unwrap()
        .execute_batch("CREATE TABLE other (a integer);")
        .unwrap();
    let e = Topside::start(&config(dir.path()))
        .await
        .err()
        .expect("refused");
    assert!(e.to_string().contains("not an MBTiles file"), "{e}");
    // Vector tiles.
    std::fs::remove_file(&path).unwrap();
    write_mbtiles(&path, &[("format", "pbf")], &[]);
    let e = Topside::start(&config(dir.path()))
        .await
        .err()
        .expect("refused");
    assert!(e.to_string().contains("`pbf`, not raster"), "{e}");
    // GeoJSON that is not.
    std::fs::remove_file(&path).unwrap();
    write_mbtiles(&path, &[("format", "png")], &tiles());
    for (text, says) in [
        ("{\"type\": \"Feature\"", "not GeoJSON"),
        ("[1, 2, 3]", "no \"type\""),
        ("{\"type\": \"Banana\"}", "`Banana`"),
        (&"[".repeat(100_000), "not GeoJSON"),
    ] {
        let g = dir.path().join("area.geojson");
        std::fs::write(&g, text).unwrap();
        let mut cfg = config(dir.path());
        cfg.chart.geojson = vec![g];
        let e = Topside::start(&cfg).await.err().expect("refused");
        assert!(
            e.to_string().contains(says) && e.to_string().contains("area.geojson"),
            "{e}"
        );
    }
    // The opened file is never written.
    let before = std::fs::read(&path).unwrap();
    let top = Topside::start(&config(dir.path())).await.unwrap();
    assert_eq!(get(top.local_addr(), "/tiles/0/0/0", "").await.status, 200);
    top.shutdown().await;
    assert_eq!(std::fs::read(&path).unwrap(), before);
}

#[test]
fn the_config_checks_the_chart_paths_and_the_tile_url() {
    let dir = tempfile::tempdir().unwrap();
    let mut cfg = config(dir.path());
    let fields = |c: &TopsideConfig| c.validate().into_iter().map(|e| e.path).collect::<Vec<_>>();
    assert_eq!(fields(&cfg), ["chart.mbtiles"], "missing file");
    cfg.chart.mbtiles = Some(dir.path().to_path_buf());
    assert_eq!(fields(&cfg), ["chart.mbtiles"], "a directory");
    cfg.chart.mbtiles = None;
    cfg.chart.geojson = vec![dir.path().join("nope.geojson")];
    assert_eq!(fields(&cfg), ["chart.geojson[0]"]);
    cfg.chart.geojson.clear();
    for bad in [
        "ftp://tiles.example/{z}/{x}/{y}.png",
        "https://tiles.example/{z}/{x}.png",
        "https://tiles.example/{z}/{x}/{y}.png\" onerror=\"x",
        "https://tiles.example/{z}/{x}/{y} .png",
    ] {
        cfg.chart.tile_url = Some(bad.into());
        assert_eq!(fields(&cfg), ["chart.tile_url"], "{bad}");
    }
    cfg.chart.tile_url = Some("https://tile.openstreetmap.org/{z}/{x}/{y}.png".into());
    assert!(fields(&cfg).is_empty());
    // The section in TOML, as the guide shows it.
    let t: TopsideConfig = toml::from_str(
        "[chart]\nmbtiles = \"/srv/charts/harbour.mbtiles\"\ngeojson = [\"/srv/charts/area.geojson\"]\n",
    )
    .unwrap();
    assert_eq!(t.chart.geojson.len(), 1);
    assert!(
        toml::from_str::<TopsideConfig>("[chart]\nmbtile = \"x\"\n").is_err(),
        "unknown keys refused"
    );
}
