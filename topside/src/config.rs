//! The topside's configuration (`frontseat topside -c FILE`): how it reaches the fleet over
//! Zenoh, where its page is served and who may read it, when a silent vehicle counts as stale,
//! and the bounds on what it keeps.

use frontseat_config::{
    FieldError, ServiceConfig, ZenohAccessConfig, ZenohSecurity, ZenohTlsConfig,
};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// The topside: every vehicle of the fleet on one page, from what their interfaces publish over
/// Zenoh (`*/goby/middleware/frontseat/node_status`, `status`, and the helms' `desired_course`).
/// It publishes nothing itself: a command for a vehicle is relayed to that vehicle's own page
/// (`[[vehicle]] page`), which checks that vehicle's token.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct TopsideConfig {
    /// How the topside reaches the fleet.
    pub zenoh: ZenohConfig,
    /// The page.
    pub web: TopsideWebConfig,
    /// A vehicle not heard from for this long is shown stale (it is never removed). Unit: s,
    /// greater than 0, at most 3600.
    #[schemars(range(min = 0.001, max = 3600.0))]
    pub stale_after_s: f64,
    /// Most vehicles tracked; publications of further platforms are refused and counted.
    #[schemars(range(min = 1, max = 10000))]
    pub max_vehicles: usize,
    /// Track points kept per vehicle (one per metre moved at most); older ones are dropped.
    #[schemars(range(min = 2, max = 100000))]
    pub track_points: usize,
    /// Each vehicle's own page: linked from the topside page, and where commands from the
    /// topside's commander for that vehicle are relayed (its page checks its token).
    #[schemars(example = example_links())]
    pub vehicle: Vec<VehicleLink>,
    /// Recording what the topside hears (every vehicle's node_status, status and desired_course)
    /// to MCAP files named `topside_<UTC>_<seq>.mcap`, one channel per vehicle and group (topic
    /// `<platform>/<group>`). Its live server is `[foxglove]`, not `record.foxglove`.
    pub record: frontseat_config::RecordConfig,
    /// What the topside hears served live to Foxglove or Lichtblick over the Foxglove WebSocket
    /// protocol, read-only: one channel per vehicle and group (topic `<platform>/<group>`, as in
    /// the recording), advertised when the vehicle is first heard. Loopback by default; any
    /// other address needs a token (`token` or FRONTSEAT_FOXGLOVE_TOKEN).
    pub foxglove: frontseat_config::FoxgloveConfig,
    /// The chart under the map: offline files the topside serves to its page.
    pub chart: ChartConfig,
    /// Every vehicle heard reported to OpenCPN (or any chart plotter) as an AIS class B target,
    /// with its MMSI from `[[ais.vehicle]]`; a vehicle whose node_status is stale is no longer
    /// reported. See the guide's "OpenCPN" page.
    pub ais: frontseat_config::AisConfig,
}

impl Default for TopsideConfig {
    fn default() -> Self {
        Self {
            zenoh: ZenohConfig::default(),
            web: TopsideWebConfig::default(),
            stale_after_s: 5.0,
            max_vehicles: 200,
            track_points: 5000,
            vehicle: Vec::new(),
            record: frontseat_config::RecordConfig::default(),
            foxglove: frontseat_config::FoxgloveConfig::default(),
            chart: ChartConfig::default(),
            ais: frontseat_config::AisConfig::default(),
        }
    }
}

/// The Zenoh session of the topside (a peer that listens nowhere by default).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct ZenohConfig {
    /// Endpoints to connect to: each vehicle's interface (`[interprocess] listen`) or a router,
    /// e.g. "tcp/127.0.0.1:7447".
    pub connect: Vec<String>,
    /// Endpoints to listen on, for vehicles that connect to the topside. Empty by default.
    pub listen: Vec<String>,
    /// TLS for `tls/…` endpoints (the same section as a vehicle's `[interprocess.tls]`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tls: Option<ZenohTlsConfig>,
    /// Access by certificate common name (the same section as a vehicle's
    /// `[interprocess.access]`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub access: Option<ZenohAccessConfig>,
}

impl Default for ZenohConfig {
    fn default() -> Self {
        Self {
            connect: vec!["tcp/127.0.0.1:7447".into()],
            listen: Vec::new(),
            tls: None,
            access: None,
        }
    }
}

impl ZenohConfig {
    /// The endpoints and security sections, checked by the rules every Zenoh session shares.
    pub fn security(&self) -> ZenohSecurity<'_> {
        ZenohSecurity {
            listen: &self.listen,
            connect: &self.connect,
            tls: self.tls.as_ref(),
            access: self.access.as_ref(),
            in_use: true,
        }
    }
}

/// The topside page.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct TopsideWebConfig {
    /// Address and port to serve on. Loopback by default.
    pub listen: String,
    /// Token every request needs (as `Authorization: Bearer …` or `#token=` in the page's URL);
    /// at least 16 characters. FRONTSEAT_TOPSIDE_TOKEN in the environment wins.
    pub token: Option<String>,
    /// Most open HTTP connections.
    #[schemars(range(min = 1))]
    pub max_connections: usize,
    /// Longest a connection may take to send a complete request head, from its start (or the
    /// end of its previous answer); then it is closed. Besides, when every one of
    /// `max_connections` is held, a new connection closes the oldest one that is not being
    /// answered. Unit: s, 1 to 300.
    #[schemars(range(min = 1, max = 300))]
    pub header_timeout_s: u64,
    /// A connection that neither sends nor receives for this long is closed (the page polls
    /// every second, so only an idle or stalled socket is); a request not answered within this
    /// long of its first byte (trickled) is closed too. Unit: s, 1 to 3600.
    #[schemars(range(min = 1, max = 3600))]
    pub idle_timeout_s: u64,
}

impl Default for TopsideWebConfig {
    fn default() -> Self {
        Self {
            listen: "127.0.0.1:50080".into(),
            token: None,
            max_connections: 64,
            header_timeout_s: 5,
            idle_timeout_s: 30,
        }
    }
}

/// Largest GeoJSON overlay read; it is held in memory and sent whole to the page.
pub const MAX_GEOJSON_BYTES: u64 = 16 * 1024 * 1024;
/// Most GeoJSON overlays.
pub const MAX_GEOJSON_FILES: usize = 16;

/// The chart under the topside map, from files carried to sea: nothing is fetched from the
/// internet unless `tile_url` is set. See the guide's "The chart and the plots".
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct ChartConfig {
    /// An MBTiles file of raster tiles (PNG, JPEG or WebP), opened read-only and served as
    /// `/tiles/{z}/{x}/{y}`. None: no basemap (the fleet on a blank Web Mercator map).
    #[serde(skip_serializing_if = "Option::is_none")]
    #[schemars(example = &"/srv/charts/harbour.mbtiles")]
    pub mbtiles: Option<std::path::PathBuf>,
    /// GeoJSON files drawn over the basemap (a coastline, an operating area): each read once at
    /// start, at most 16 MiB, at most 16 files.
    #[schemars(example = vec!["/srv/charts/operating-area.geojson".to_string()])]
    pub geojson: Vec<std::path::PathBuf>,
    /// For an operator with a connection: a tile URL template the page's browser fetches
    /// itself, e.g. "https://tile.openstreetmap.org/{z}/{x}/{y}.png" (mind the server's usage
    /// policy). None by default: the page fetches nothing beyond the topside.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[schemars(example = &"https://tile.openstreetmap.org/{z}/{x}/{y}.png")]
    pub tile_url: Option<String>,
}

impl ChartConfig {
    fn errors(&self) -> Vec<FieldError> {
        let mut e = Vec::new();
        let regular = |p: &std::path::Path| std::fs::metadata(p).map(|m| m.is_file());
        if let Some(p) = &self.mbtiles {
            match regular(p) {
                Ok(true) => {}
                Ok(false) => e.push(FieldError::new(
                    "chart.mbtiles",
                    p.display(),
                    "not a regular file",
                )),
                Err(err) => e.push(FieldError::new(
                    "chart.mbtiles",
                    p.display(),
                    err.to_string(),
                )),
            }
        }
        if self.geojson.len() > MAX_GEOJSON_FILES {
            e.push(FieldError::new(
                "chart.geojson",
                self.geojson.len(),
                format!("more than {} files", MAX_GEOJSON_FILES),
            ));
        }
        for (i, p) in self.geojson.iter().enumerate() {
            let at = format!("chart.geojson[{i}]");
            match std::fs::metadata(p) {
                Ok(m) if !m.is_file() => {
                    e.push(FieldError::new(at, p.display(), "not a regular file"))
                }
                Ok(m) if m.len() > MAX_GEOJSON_BYTES => e.push(FieldError::new(
                    at,
                    p.display(),
                    format!("larger than {} bytes", MAX_GEOJSON_BYTES),
                )),
                Ok(_) => {}
                Err(err) => e.push(FieldError::new(at, p.display(), err.to_string())),
            }
        }
        if let Some(t) = &self.tile_url {
            let scheme = t.starts_with("https://") || t.starts_with("http://");
            let holes = ["{z}", "{x}", "{y}"].iter().all(|h| t.contains(h));
            let plain = t.len() <= 512
                && t.chars()
                    .all(|c| c.is_ascii_graphic() && !matches!(c, '"' | '\'' | '<' | '>' | '\\'));
            if !(scheme && holes && plain) {
                e.push(FieldError::new(
                    "chart.tile_url",
                    format!("{:?}", t.chars().take(80).collect::<String>()),
                    "not an http(s) URL template with {z}, {x} and {y} (at most 512 plain characters)",
                ));
            }
        }
        e
    }
}

/// A link to one vehicle's own page.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct VehicleLink {
    /// The vehicle's platform name.
    pub name: String,
    /// Its page, e.g. "http://127.0.0.1:50001/".
    pub page: String,
}

fn example_links() -> Vec<VehicleLink> {
    vec![VehicleLink {
        name: "auv1".into(),
        page: "http://127.0.0.1:50001/".into(),
    }]
}

/// The environment variable whose value replaces `web.token`.
pub const TOKEN_ENV: &str = "FRONTSEAT_TOPSIDE_TOKEN";

impl ServiceConfig for TopsideConfig {
    const SERVICE: &'static str = "topside";

    fn validate(&self) -> Vec<FieldError> {
        let mut e = Vec::new();
        if self.web.listen.parse::<std::net::SocketAddr>().is_err() {
            e.push(FieldError::new(
                "web.listen",
                format!("{:?}", self.web.listen),
                "not an IP address and port",
            ));
        }
        if let Some(t) = &self.web.token
            && t.chars().count() < frontseat_config::MIN_TOKEN_CHARS
        {
            e.push(FieldError::new(
                "web.token",
                "(hidden)",
                format!(
                    "shorter than {} characters",
                    frontseat_config::MIN_TOKEN_CHARS
                ),
            ));
        }
        if self.web.max_connections == 0 {
            e.push(FieldError::new("web.max_connections", 0, "at least 1"));
        }
        if !(1..=300).contains(&self.web.header_timeout_s) {
            e.push(FieldError::new(
                "web.header_timeout_s",
                self.web.header_timeout_s,
                "outside [1, 300]",
            ));
        }
        if !(1..=3600).contains(&self.web.idle_timeout_s) {
            e.push(FieldError::new(
                "web.idle_timeout_s",
                self.web.idle_timeout_s,
                "outside [1, 3600]",
            ));
        }
        if !(self.stale_after_s.is_finite()
            && self.stale_after_s > 0.0
            && self.stale_after_s <= 3600.0)
        {
            e.push(FieldError::new(
                "stale_after_s",
                self.stale_after_s,
                "outside (0, 3600]",
            ));
        }
        if !(1..=10_000).contains(&self.max_vehicles) {
            e.push(FieldError::new(
                "max_vehicles",
                self.max_vehicles,
                "outside [1, 10000]",
            ));
        }
        if !(2..=100_000).contains(&self.track_points) {
            e.push(FieldError::new(
                "track_points",
                self.track_points,
                "outside [2, 100000]",
            ));
        }
        if self.zenoh.connect.is_empty() && self.zenoh.listen.is_empty() {
            e.push(FieldError::new(
                "zenoh.connect",
                "[]",
                "with no listen endpoint either, the topside would hear nobody",
            ));
        }
        e.extend(self.zenoh.security().check("zenoh"));
        e.extend(self.record.errors_at("record"));
        if self.record.foxglove.enabled {
            e.push(FieldError::new(
                "record.foxglove.enabled",
                true,
                "the topside's live server is its own [foxglove] section",
            ));
        }
        e.extend(self.foxglove.errors_at("foxglove"));
        e.extend(self.ais.errors_at("ais"));
        e.extend(self.chart.errors());
        for (i, v) in self.vehicle.iter().enumerate() {
            if frontseat_helm_side::plan::check_platform(&v.name).is_err() {
                e.push(FieldError::new(
                    format!("vehicle[{i}].name"),
                    format!("{:?}", v.name),
                    "not a platform name",
                ));
            }
            if !(v.page.starts_with("http://") || v.page.starts_with("https://")) {
                e.push(FieldError::new(
                    format!("vehicle[{i}].page"),
                    format!("{:?}", v.page),
                    "not an http(s) URL",
                ));
            }
        }
        e
    }

    fn warnings(&self) -> Vec<String> {
        let mut w = Vec::new();
        if let Ok(a) = self.web.listen.parse::<std::net::SocketAddr>()
            && !a.ip().is_loopback()
            && self.web.token.is_none()
        {
            w.push(format!(
                "web.listen {a} is beyond loopback without a token: anyone who reaches it sees the fleet (set web.token or {TOKEN_ENV})"
            ));
        }
        w.extend(self.zenoh.security().warnings("zenoh"));
        w.extend(self.ais.warnings("ais"));
        w
    }
}
