//! The operator's chart under the topside map, from files the operator carries to sea: an
//! MBTiles raster tile set (SQLite; `/tiles/{z}/{x}/{y}`) and GeoJSON overlays (a coastline, an
//! operating area; `/chart/geojson/{i}`), plus the vendored map library (Leaflet) the page
//! draws them with. This module owns opening and checking those files, answering tile and
//! overlay requests with bounded work, and the chart's counters (`/api/chart`).
//!
//! Nothing from a request reaches the filesystem: the files are the config's, opened once; a
//! request names a tile by three integers, checked against the tile pyramid, and an overlay by
//! its index in the config's list. The MBTiles file is opened read-only and queried with one
//! prepared statement; a tile larger than [`MAX_TILE_BYTES`] is never read into memory.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

use axum::Router;
use axum::extract::{Path as UrlPath, Query, State};
use axum::http::header::{CACHE_CONTROL, CONTENT_TYPE};
use axum::http::{HeaderMap, HeaderValue, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use frontseat_web::auth::Access;
use rusqlite::{Connection, OpenFlags, OptionalExtension};
use serde::Deserialize;
use serde_json::json;

pub use crate::config::{ChartConfig, MAX_GEOJSON_BYTES, MAX_GEOJSON_FILES};

/// Largest tile served; a larger one is answered 502 and counted (a raster tile is a few tens
/// of kilobytes).
pub const MAX_TILE_BYTES: i64 = 4 * 1024 * 1024;
/// Deepest zoom level served (2^z tiles a side must fit a u32 and an SQLite integer).
pub const MAX_ZOOM: u8 = 30;

// Leaflet 1.9.4 (BSD-2-Clause, © Volodymyr Agafonkin, CloudMade), `npm pack leaflet@1.9.4`,
// dist/ copied as is: see assets/leaflet/LICENSE.
const LEAFLET_JS: &str = include_str!("../assets/leaflet/leaflet.js");
const LEAFLET_CSS: &str = include_str!("../assets/leaflet/leaflet.css");
const LAYERS_PNG: &[u8] = include_bytes!("../assets/leaflet/images/layers.png");
const LAYERS_2X_PNG: &[u8] = include_bytes!("../assets/leaflet/images/layers-2x.png");

#[derive(Debug, thiserror::Error)]
pub enum ChartError {
    #[error("chart.mbtiles {path}: cannot open it read-only as SQLite: {source}")]
    Open {
        path: PathBuf,
        source: rusqlite::Error,
    },
    #[error("chart.mbtiles {path}: not an MBTiles file ({why})")]
    NotMbtiles { path: PathBuf, why: String },
    #[error(
        "chart.mbtiles {path}: its tiles are `{format}`, not raster images (png, jpg, webp); vector tiles are not drawn"
    )]
    NotRaster { path: PathBuf, format: String },
    #[error("chart.geojson {path}: {source}")]
    GeoJsonIo {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("chart.geojson {path}: larger than {MAX_GEOJSON_BYTES} bytes")]
    GeoJsonTooLarge { path: PathBuf },
    #[error("chart.geojson {path}: not GeoJSON ({why})")]
    GeoJsonInvalid { path: PathBuf, why: String },
    #[error("chart.geojson: more than {MAX_GEOJSON_FILES} files")]
    TooManyGeoJson,
}

/// What the chart served and refused; on `/api/chart`.
#[derive(Debug, Default)]
pub struct ChartCounters {
    pub tiles_served: AtomicU64,
    pub tiles_missing: AtomicU64,
    /// A z/x/y that is not a tile of the pyramid, or not numbers.
    pub tiles_refused: AtomicU64,
    /// In the file but larger than [`MAX_TILE_BYTES`], or not a PNG, JPEG or WebP image.
    pub tiles_bad: AtomicU64,
    /// SQLite failed to answer (a corrupt or vanished file).
    pub tile_read_errors: AtomicU64,
    pub unauthorized: AtomicU64,
}

impl ChartCounters {
    fn json(&self) -> serde_json::Value {
        let g = |c: &AtomicU64| c.load(Ordering::Relaxed);
        json!({
            "tiles_served": g(&self.tiles_served),
            "tiles_missing": g(&self.tiles_missing),
            "tiles_refused": g(&self.tiles_refused),
            "tiles_bad": g(&self.tiles_bad),
            "tile_read_errors": g(&self.tile_read_errors),
            "unauthorized": g(&self.unauthorized),
        })
    }
}

/// What the MBTiles file says of itself (its `metadata` table; zooms from the tiles when absent).
#[derive(Debug, Clone, PartialEq)]
pub struct TileMeta {
    pub name: String,
    /// `png`, `jpg` or `webp` as the metadata says; empty when it says nothing.
    pub format: String,
    pub minzoom: u8,
    pub maxzoom: u8,
    /// west, south, east, north in degrees.
    pub bounds: Option<[f64; 4]>,
    pub attribution: String,
}

struct MbTiles {
    /// One read-only connection; SQLite calls run on the blocking pool, one at a time.
    conn: Mutex<Connection>,
    meta: TileMeta,
}

struct Overlay {
    name: String,
    body: axum::body::Bytes,
}

/// The chart the page draws: what `[chart]` names, opened and checked.
pub struct Chart {
    mbtiles: Option<MbTiles>,
    overlays: Vec<Overlay>,
    tile_url: Option<String>,
    pub counters: ChartCounters,
}

/// The answer to one tile request.
#[derive(Debug, PartialEq)]
pub enum Tile {
    Found {
        content_type: &'static str,
        data: Vec<u8>,
    },
    /// A tile of the pyramid the file does not hold.
    Missing,
    /// Not a tile: z past [`MAX_ZOOM`], or x or y past 2^z − 1.
    OutOfRange,
    /// Held but too large, or not an image.
    Bad,
    /// SQLite failed.
    ReadError,
}

/// The image type from the tile's first bytes (what the browser is told it gets).
fn sniff(data: &[u8]) -> Option<&'static str> {
    if data.starts_with(b"\x89PNG\r\n\x1a\n") {
        Some("image/png")
    } else if data.starts_with(&[0xFF, 0xD8, 0xFF]) {
        Some("image/jpeg")
    } else if data.len() >= 12 && &data[..4] == b"RIFF" && &data[8..12] == b"WEBP" {
        Some("image/webp")
    } else {
        None
    }
}

fn not_mbtiles(path: &Path, why: impl std::fmt::Display) -> ChartError {
    ChartError::NotMbtiles {
        path: path.to_path_buf(),
        why: why.to_string(),
    }
}

impl MbTiles {
    fn open(path: &Path) -> Result<Self, ChartError> {
        let open = |source| ChartError::Open {
            path: path.to_path_buf(),
            source,
        };
        // Read-only, no URI names, no shared cache: the file is the operator's, never written.
        let conn = Connection::open_with_flags(
            path,
            OpenFlags::SQLITE_OPEN_READ_ONLY | OpenFlags::SQLITE_OPEN_NO_MUTEX,
        )
        .map_err(open)?;
        // A file from elsewhere: its schema's views and triggers may not call functions with
        // side effects, and nothing may write.
        conn.execute_batch("PRAGMA trusted_schema = OFF; PRAGMA query_only = ON;")
            .map_err(open)?;
        conn.busy_timeout(std::time::Duration::from_millis(200))
            .map_err(open)?;
        // The tiles table (or view) with its three columns, or this is not MBTiles.
        conn.prepare_cached(TILE_SQL)
            .map_err(|e| not_mbtiles(path, e))?;
        let meta_value = |key: &str| -> Option<String> {
            conn.query_row("SELECT value FROM metadata WHERE name = ?1", [key], |r| {
                r.get::<_, String>(0)
            })
            .optional()
            .ok()
            .flatten()
            .map(|v| v.chars().take(512).collect())
        };
        let format = meta_value("format")
            .unwrap_or_default()
            .to_ascii_lowercase();
        if !matches!(format.as_str(), "" | "png" | "jpg" | "jpeg" | "webp") {
            return Err(ChartError::NotRaster {
                path: path.to_path_buf(),
                format,
            });
        }
        let zoom = |key: &str| meta_value(key).and_then(|v| v.trim().parse::<u8>().ok());
        let (minzoom, maxzoom) = match (zoom("minzoom"), zoom("maxzoom")) {
            (Some(a), Some(b)) => (a, b),
            _ => conn
                .query_row(
                    "SELECT min(zoom_level), max(zoom_level) FROM tiles",
                    [],
                    |r| Ok((r.get::<_, Option<i64>>(0)?, r.get::<_, Option<i64>>(1)?)),
                )
                .map_err(|e| not_mbtiles(path, e))
                .map(|(a, b)| {
                    let z = |v: Option<i64>, d| {
                        v.and_then(|v| u8::try_from(v).ok())
                            .map_or(d, |v| v.min(MAX_ZOOM))
                    };
                    (z(a, 0), z(b, 0))
                })?,
        };
        let (minzoom, maxzoom) = (minzoom.min(MAX_ZOOM), maxzoom.min(MAX_ZOOM));
        if minzoom > maxzoom {
            return Err(not_mbtiles(
                path,
                format!("minzoom {minzoom} > maxzoom {maxzoom}"),
            ));
        }
        let bounds = meta_value("bounds").and_then(|b| {
            let v: Vec<f64> = b
                .split(',')
                .filter_map(|p| p.trim().parse::<f64>().ok())
                .collect();
            let [w, s, e, n] = v[..] else {
                return None;
            };
            let ok = [w, e].iter().all(|x| (-180.0..=180.0).contains(x))
                && [s, n].iter().all(|y| (-90.0..=90.0).contains(y))
                && w < e
                && s < n;
            ok.then_some([w, s, e, n])
        });
        let meta = TileMeta {
            name: meta_value("name").unwrap_or_default(),
            format,
            minzoom,
            maxzoom,
            bounds,
            attribution: meta_value("attribution").unwrap_or_default(),
        };
        Ok(Self {
            conn: Mutex::new(conn),
            meta,
        })
    }
}

/// The tile's data when it is at most the bound, and its length either way.
const TILE_SQL: &str = "SELECT CASE WHEN length(tile_data) <= ?4 THEN tile_data END, \
     length(tile_data) FROM tiles WHERE zoom_level = ?1 AND tile_column = ?2 AND tile_row = ?3";

/// Reads one GeoJSON overlay, bounded as it reads, and checks it is a GeoJSON object.
fn read_geojson(path: &Path) -> Result<Overlay, ChartError> {
    use std::io::Read;
    let io = |source| ChartError::GeoJsonIo {
        path: path.to_path_buf(),
        source,
    };
    let f = std::fs::File::open(path).map_err(io)?;
    let mut bytes = Vec::new();
    f.take(MAX_GEOJSON_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(io)?;
    if bytes.len() as u64 > MAX_GEOJSON_BYTES {
        return Err(ChartError::GeoJsonTooLarge {
            path: path.to_path_buf(),
        });
    }
    let invalid = |why: String| ChartError::GeoJsonInvalid {
        path: path.to_path_buf(),
        why,
    };
    let text = String::from_utf8(bytes).map_err(|e| invalid(e.to_string()))?;
    let v: serde_json::Value = serde_json::from_str(&text).map_err(|e| invalid(e.to_string()))?;
    const TYPES: [&str; 9] = [
        "FeatureCollection",
        "Feature",
        "Point",
        "MultiPoint",
        "LineString",
        "MultiLineString",
        "Polygon",
        "MultiPolygon",
        "GeometryCollection",
    ];
    match v.get("type").and_then(|t| t.as_str()) {
        Some(t) if TYPES.contains(&t) => {}
        Some(t) => {
            return Err(invalid(format!(
                "type `{}` is not a GeoJSON type",
                t.chars().take(40).collect::<String>()
            )));
        }
        None => return Err(invalid("no \"type\" member at the top".into())),
    }
    let name = path
        .file_stem()
        .map(|s| s.to_string_lossy().chars().take(64).collect())
        .unwrap_or_default();
    Ok(Overlay {
        name,
        body: axum::body::Bytes::from(text),
    })
}

impl Chart {
    /// Opens and checks every file `[chart]` names (blocking: call off the async threads).
    pub fn open(cfg: &ChartConfig) -> Result<Self, ChartError> {
        if cfg.geojson.len() > MAX_GEOJSON_FILES {
            return Err(ChartError::TooManyGeoJson);
        }
        let mbtiles = cfg.mbtiles.as_deref().map(MbTiles::open).transpose()?;
        let overlays = cfg
            .geojson
            .iter()
            .map(|p| read_geojson(p))
            .collect::<Result<_, _>>()?;
        Ok(Self {
            mbtiles,
            overlays,
            tile_url: cfg.tile_url.clone(),
            counters: ChartCounters::default(),
        })
    }

    pub fn meta(&self) -> Option<&TileMeta> {
        self.mbtiles.as_ref().map(|m| &m.meta)
    }

    /// The tile at `z/x/y` in the page's (XYZ, y down from the north) numbering; MBTiles rows
    /// count up from the south (TMS), so the row asked of the file is 2^z − 1 − y. Blocking.
    pub fn tile(&self, z: u8, x: u32, y: u32) -> Tile {
        let Some(m) = &self.mbtiles else {
            return Tile::Missing;
        };
        if z > MAX_ZOOM {
            return Tile::OutOfRange;
        }
        let side = 1u64 << z;
        if u64::from(x) >= side || u64::from(y) >= side {
            return Tile::OutOfRange;
        }
        if z < m.meta.minzoom || z > m.meta.maxzoom {
            return Tile::Missing;
        }
        let row = side - 1 - u64::from(y);
        let conn = m.conn.lock().unwrap_or_else(|p| p.into_inner());
        let found = conn.prepare_cached(TILE_SQL).and_then(|mut s| {
            s.query_row(
                rusqlite::params![i64::from(z), i64::from(x), row as i64, MAX_TILE_BYTES],
                |r| Ok((r.get::<_, Option<Vec<u8>>>(0)?, r.get::<_, Option<i64>>(1)?)),
            )
            .optional()
        });
        match found {
            Ok(None) | Ok(Some((None, None))) => Tile::Missing,
            Ok(Some((Some(data), _))) => match sniff(&data) {
                Some(content_type) => Tile::Found { content_type, data },
                None => Tile::Bad,
            },
            Ok(Some((None, Some(_)))) => Tile::Bad,
            Err(_) => Tile::ReadError,
        }
    }

    /// What the page needs to draw the chart.
    pub fn json(&self) -> serde_json::Value {
        json!({
            "mbtiles": self.meta().map(|m| json!({
                "name": m.name,
                "format": m.format,
                "minzoom": m.minzoom,
                "maxzoom": m.maxzoom,
                "bounds": m.bounds,
                "attribution": m.attribution,
            })),
            "geojson": self.overlays.iter().enumerate().map(|(i, o)| json!({
                "name": o.name,
                "url": format!("chart/geojson/{i}"),
            })).collect::<Vec<_>>(),
            "tile_url": self.tile_url,
            "counters": self.counters.json(),
        })
    }
}

/// What the chart's routes need.
#[derive(Clone)]
pub struct ChartState {
    pub chart: Arc<Chart>,
    pub access: Access,
}

#[derive(Deserialize)]
struct TokenQuery {
    token: Option<String>,
}

/// The chart's routes and the map library's files.
pub fn router(st: ChartState) -> Router {
    Router::new()
        .route("/tiles/{z}/{x}/{y}", get(tile))
        .route("/api/chart", get(chart_json))
        .route("/chart/geojson/{i}", get(geojson))
        .route(
            "/leaflet/leaflet.js",
            get(|| async { frontseat_web::server::asset("text/javascript", LEAFLET_JS) }),
        )
        .route(
            "/leaflet/leaflet.css",
            get(|| async { frontseat_web::server::asset("text/css", LEAFLET_CSS) }),
        )
        .route(
            "/leaflet/images/layers.png",
            get(|| async { png(LAYERS_PNG) }),
        )
        .route(
            "/leaflet/images/layers-2x.png",
            get(|| async { png(LAYERS_2X_PNG) }),
        )
        .with_state(st)
}

fn png(body: &'static [u8]) -> Response {
    (
        [
            (CONTENT_TYPE, HeaderValue::from_static("image/png")),
            (CACHE_CONTROL, HeaderValue::from_static("no-cache")),
        ],
        body,
    )
        .into_response()
}

fn refused(status: StatusCode, text: &str) -> Response {
    (
        status,
        axum::Json(json!({"ok": false, "error": text.to_string()})),
    )
        .into_response()
}

impl ChartState {
    /// The refusal to send when the request may not read the chart.
    fn refusal(&self, headers: &HeaderMap, token: Option<&str>) -> Option<Response> {
        let r = self.access.check_read(headers, token).err()?;
        self.chart
            .counters
            .unauthorized
            .fetch_add(1, Ordering::Relaxed);
        Some(refused(r.status(), r.text()))
    }
}

/// A z/x/y path segment: decimal digits only, at most ten (no sign, no `..`, no extension).
fn number(s: &str) -> Option<u32> {
    (!s.is_empty() && s.len() <= 10 && s.bytes().all(|b| b.is_ascii_digit()))
        .then(|| s.parse().ok())
        .flatten()
}

async fn tile(
    State(st): State<ChartState>,
    UrlPath((z, x, y)): UrlPath<(String, String, String)>,
    headers: HeaderMap,
    Query(q): Query<TokenQuery>,
) -> Response {
    if let Some(r) = st.refusal(&headers, q.token.as_deref()) {
        return r;
    }
    let c = &st.chart.counters;
    let (Some(z), Some(x), Some(y)) = (
        number(&z).and_then(|z| u8::try_from(z).ok()),
        number(&x),
        number(&y),
    ) else {
        c.tiles_refused.fetch_add(1, Ordering::Relaxed);
        return refused(
            StatusCode::BAD_REQUEST,
            "a tile is /tiles/{z}/{x}/{y} in decimal",
        );
    };
    let chart = st.chart.clone();
    let answer = tokio::task::spawn_blocking(move || chart.tile(z, x, y))
        .await
        .unwrap_or(Tile::ReadError);
    match answer {
        Tile::Found { content_type, data } => {
            c.tiles_served.fetch_add(1, Ordering::Relaxed);
            (
                [
                    (CONTENT_TYPE, HeaderValue::from_static(content_type)),
                    // The file does not change while the topside runs.
                    (
                        CACHE_CONTROL,
                        HeaderValue::from_static("private, max-age=3600"),
                    ),
                ],
                data,
            )
                .into_response()
        }
        Tile::Missing => {
            c.tiles_missing.fetch_add(1, Ordering::Relaxed);
            refused(StatusCode::NOT_FOUND, "no such tile in the chart")
        }
        Tile::OutOfRange => {
            c.tiles_refused.fetch_add(1, Ordering::Relaxed);
            refused(StatusCode::NOT_FOUND, "not a tile of the pyramid")
        }
        Tile::Bad => {
            let n = c.tiles_bad.fetch_add(1, Ordering::Relaxed);
            // The first and then every 1000th: a page scrolling over bad tiles asks for many.
            if n % 1000 == 0 {
                tracing::warn!(z, x, y, bad = n + 1, "chart tile too large or not an image");
            }
            refused(
                StatusCode::BAD_GATEWAY,
                "the chart's tile is too large or not an image",
            )
        }
        Tile::ReadError => {
            let n = c.tile_read_errors.fetch_add(1, Ordering::Relaxed);
            // The first and then every 1000th: a corrupt file fails every tile.
            if n % 1000 == 0 {
                tracing::error!(
                    z,
                    x,
                    y,
                    errors = n + 1,
                    "cannot read the chart's MBTiles file"
                );
            }
            refused(StatusCode::BAD_GATEWAY, "the chart file cannot be read")
        }
    }
}

async fn chart_json(
    State(st): State<ChartState>,
    headers: HeaderMap,
    Query(q): Query<TokenQuery>,
) -> Response {
    if let Some(r) = st.refusal(&headers, q.token.as_deref()) {
        return r;
    }
    let mut r = axum::Json(st.chart.json()).into_response();
    r.headers_mut()
        .insert(CACHE_CONTROL, HeaderValue::from_static("no-store"));
    r
}

async fn geojson(
    State(st): State<ChartState>,
    UrlPath(i): UrlPath<String>,
    headers: HeaderMap,
    Query(q): Query<TokenQuery>,
) -> Response {
    if let Some(r) = st.refusal(&headers, q.token.as_deref()) {
        return r;
    }
    let Some(o) = number(&i).and_then(|i| st.chart.overlays.get(i as usize)) else {
        return refused(StatusCode::NOT_FOUND, "no such overlay");
    };
    (
        [
            (
                CONTENT_TYPE,
                HeaderValue::from_static("application/geo+json"),
            ),
            (CACHE_CONTROL, HeaderValue::from_static("no-cache")),
        ],
        o.body.clone(),
    )
        .into_response()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segments_are_plain_decimal_numbers() {
        assert_eq!(number("0"), Some(0));
        assert_eq!(number("4294967295"), Some(u32::MAX));
        for bad in [
            "",
            "-1",
            "+1",
            "1.png",
            "..",
            "4294967296",
            "99999999999",
            " 1",
            "0x1",
        ] {
            assert_eq!(number(bad), None, "{bad}");
        }
    }

    #[test]
    fn images_are_told_apart_by_their_first_bytes() {
        assert_eq!(sniff(b"\x89PNG\r\n\x1a\n...."), Some("image/png"));
        assert_eq!(sniff(&[0xFF, 0xD8, 0xFF, 0xE0]), Some("image/jpeg"));
        assert_eq!(sniff(b"RIFF\0\0\0\0WEBPVP8 "), Some("image/webp"));
        assert_eq!(sniff(b"\x1f\x8b\x08"), None, "gzip (a vector tile)");
        assert_eq!(sniff(b""), None);
    }
}
