//! Sections shared by several services: geographic origin, MOOS connection, inter-process
//! (Zenoh) transport and OpenTelemetry export.
//!
//! Each section validates itself under a path prefix so its errors carry the full dotted path
//! wherever it is embedded.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::check::{Checker, at};
use crate::zenoh_security::{ZenohAccessConfig, ZenohSecurity, ZenohTlsConfig};

/// Latitude of the default origin: the example origin Goby3's course uses (MIT, Boston).
pub const DEFAULT_ORIGIN_LAT: f64 = 42.358456;
/// Longitude of the default origin (see [`DEFAULT_ORIGIN_LAT`]).
pub const DEFAULT_ORIGIN_LON: f64 = -71.087589;

/// A geographic point: the datum of the local x/y grid.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct LatLonConfig {
    /// Latitude of the origin. Unit: decimal degrees (WGS-84), -90 to 90. Goby3 requires it; our
    /// default is the example origin so that a fresh example config loads.
    #[schemars(range(min = -90.0, max = 90.0))]
    pub lat: f64,
    /// Longitude of the origin. Unit: decimal degrees (WGS-84), -180 to 180.
    #[schemars(range(min = -180.0, max = 180.0))]
    pub lon: f64,
    /// Depth of the origin below the surface. Unit: m.
    pub depth: f64,
    /// Altitude of the origin above the sea floor; unset means unknown (Goby3: nan). Unit: m.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[schemars(example = 0.0)]
    pub altitude: Option<f64>,
}

impl Default for LatLonConfig {
    fn default() -> Self {
        Self {
            lat: DEFAULT_ORIGIN_LAT,
            lon: DEFAULT_ORIGIN_LON,
            depth: 0.0,
            altitude: None,
        }
    }
}

impl LatLonConfig {
    pub(crate) fn check(&self, prefix: &str, c: &mut Checker) {
        c.latitude(&at(prefix, "lat"), self.lat);
        c.longitude(&at(prefix, "lon"), self.lon);
        c.finite(&at(prefix, "depth"), self.depth);
        if let Some(a) = self.altitude {
            c.finite(&at(prefix, "altitude"), a);
        }
    }
}

/// Connection to a MOOSDB, for the FrontSeatTranslation bridge to pHelmIvP.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct MoosConfig {
    /// Host name or IP address of the MOOSDB.
    pub server: String,
    /// TCP port of the MOOSDB (MOOS default 9000).
    #[schemars(range(min = 1))]
    pub port: u16,
    /// MOOS community name the DB is expected to announce; empty = accept any.
    pub community: String,
    /// Name this client registers under at the MOOSDB (Goby3's is iFrontSeat).
    pub app_name: String,
    /// MOOSTimeWarp of the community: every MOOS timestamp is Unix time times this; it must
    /// match the MOOSDB's. 0 = the service's own warp (the interface's sim_warp_factor; 1 for the
    /// gateway), as Goby3 runs both sides from one app.simulation.time.warp_factor; any other
    /// value must equal sim_warp_factor in an interface config. Unit: factor, 0 or (0, 10000].
    #[schemars(range(min = 0.0, max = 10000.0))]
    pub time_warp: f64,
    /// Report the helm as stale on our status group when no DESIRED_* has arrived for this long;
    /// 0 = never report. Unit: s.
    #[schemars(range(min = 0.0))]
    pub desired_timeout_s: f64,
}

impl Default for MoosConfig {
    fn default() -> Self {
        Self {
            server: "127.0.0.1".into(),
            port: 9000,
            community: String::new(),
            app_name: "iFrontSeat".into(),
            time_warp: 0.0,
            desired_timeout_s: 5.0,
        }
    }
}

impl MoosConfig {
    /// This section with `time_warp = 0` resolved to the service's warp (`service_warp`).
    pub fn with_warp(&self, service_warp: f64) -> Self {
        let mut m = self.clone();
        if m.time_warp == 0.0 {
            m.time_warp = service_warp;
        }
        m
    }

    pub(crate) fn check(&self, prefix: &str, c: &mut Checker) {
        c.non_empty(&at(prefix, "server"), &self.server);
        c.port(&at(prefix, "port"), self.port);
        c.non_empty(&at(prefix, "app_name"), &self.app_name);
        if self.time_warp != 0.0 {
            c.positive_up_to(&at(prefix, "time_warp"), self.time_warp, crate::MAX_WARP);
        }
        c.non_negative(&at(prefix, "desired_timeout_s"), self.desired_timeout_s);
    }
}

/// How the Zenoh session joins the network.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum InterprocessMode {
    /// Peer to peer: talks directly to other peers; no router needed on one host.
    #[default]
    Peer,
    /// Client of a Zenoh router given in `connect`.
    Client,
}

/// Inter-process and multi-host publish/subscribe over Zenoh.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct InterprocessConfig {
    /// Export and import the interface's interprocess groups over Zenoh.
    pub enabled: bool,
    /// Zenoh session mode.
    pub mode: InterprocessMode,
    /// Zenoh endpoints to listen on, e.g. "tcp/127.0.0.1:7447". The default touches only loopback;
    /// beyond it use "tls/<address>:<port>" with the `tls` section.
    pub listen: Vec<String>,
    /// Zenoh endpoints to connect to (a router, or other peers), e.g. "tcp/10.0.0.2:7447".
    pub connect: Vec<String>,
    /// Platform name, the first element of every key expression
    /// (`<platform>/goby/middleware/frontseat/node_status`); empty = use the top-level `name`.
    pub platform: String,
    /// TLS for `tls/…` endpoints: what a session across hosts needs to be encrypted and, with
    /// `mutual`, authenticated. Absent = no `tls/` endpoint may be used.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tls: Option<ZenohTlsConfig>,
    /// Who may do what, by certificate common name: a vehicle publishes only under its own
    /// platform, only commanders steer this vehicle, everyone else is denied. Absent = every
    /// peer that joins the session may do everything.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub access: Option<ZenohAccessConfig>,
}

impl Default for InterprocessConfig {
    fn default() -> Self {
        Self {
            enabled: false,
            mode: InterprocessMode::Peer,
            listen: vec!["tcp/127.0.0.1:7447".into()],
            connect: Vec::new(),
            platform: String::new(),
            tls: None,
            access: None,
        }
    }
}

impl InterprocessConfig {
    /// The endpoints and security sections, for the checks shared with the topside.
    pub fn security(&self) -> ZenohSecurity<'_> {
        let listen: &[String] = match self.mode {
            InterprocessMode::Peer => &self.listen,
            // A client listens nowhere (see the gateway's session config).
            InterprocessMode::Client => &[],
        };
        ZenohSecurity {
            listen,
            connect: &self.connect,
            tls: self.tls.as_ref(),
            access: self.access.as_ref(),
            in_use: self.enabled,
        }
    }

    /// Advice about a valid section (`--check` prints it).
    pub fn warnings(&self, prefix: &str) -> Vec<String> {
        self.security().warnings(prefix)
    }

    pub(crate) fn check(&self, prefix: &str, c: &mut Checker) {
        for (field, list) in [("listen", &self.listen), ("connect", &self.connect)] {
            for (i, ep) in list.iter().enumerate() {
                // Zenoh locators are `<protocol>/<address>`; catching a bare "host:port" here
                // gives a better message than Zenoh's at start-up.
                let ok = ep
                    .split_once('/')
                    .is_some_and(|(proto, addr)| !proto.is_empty() && !addr.is_empty());
                if !ok {
                    c.push(crate::FieldError::new(
                        format!("{}[{i}]", at(prefix, field)),
                        format!("{ep:?}"),
                        "not a Zenoh endpoint like \"tcp/127.0.0.1:7447\"",
                    ));
                }
            }
        }
        if self.enabled && self.mode == InterprocessMode::Client && self.connect.is_empty() {
            c.push(crate::FieldError::new(
                at(prefix, "connect"),
                "[]",
                "mode \"client\" needs at least one router endpoint to connect to",
            ));
        }
        if self.platform.contains(['/', '*', '$', '?', '#']) {
            c.push(crate::FieldError::new(
                at(prefix, "platform"),
                format!("{:?}", self.platform),
                "must not contain '/', '*', '$', '?' or '#' (it becomes a key expression chunk)",
            ));
        } else {
            crate::names::check_optional(&at(prefix, "platform"), &self.platform, c);
        }
        c.errors.extend(self.security().check(prefix));
    }
}

/// OpenTelemetry trace export over OTLP/HTTP (protobuf).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct TelemetryConfig {
    /// Export traces (and metrics: see `metrics`). The standard OTEL_EXPORTER_OTLP_ENDPOINT
    /// variable also turns export on.
    pub enabled: bool,
    /// OTLP/HTTP collector base URL; traces go to `<endpoint>/v1/traces`.
    pub endpoint: String,
    /// service.name resource attribute; empty = the service role plus the platform name.
    pub service_name: String,
    /// Fraction of traces sampled. Unit: ratio, 0 to 1.
    #[schemars(range(min = 0.0, max = 1.0))]
    pub sampling_ratio: f64,
    /// Navigation is sampled, everything else kept: at most this many traces per second start at
    /// a navigation line from the frontseat; setpoints, state changes, restarts, faults and refused
    /// commands are always traced. OTEL_TRACES_SAMPLER, when set, wins. Unit: traces/s, 0 to 1000
    /// (0 = no navigation traces).
    #[schemars(range(min = 0.0, max = 1000.0))]
    pub nav_traces_per_s: f64,
    /// Spans waiting for export, at most; more are dropped and counted (`spans_dropped` in the
    /// interface's detail status). Sized so that `frontseat demo --warp 20` drops none.
    /// OTEL_BSP_MAX_QUEUE_SIZE applies when this is left at its default. Unit: spans, 64 to
    /// 1048576.
    #[schemars(range(min = 64, max = 1_048_576))]
    pub max_queue_size: u32,
    /// Spans per export request, at most; a full batch is sent at once, before the delay.
    /// OTEL_BSP_MAX_EXPORT_BATCH_SIZE applies when this is left at its default. Unit: spans, 1 to
    /// max_queue_size.
    #[schemars(range(min = 1, max = 1_048_576))]
    pub max_export_batch_size: u32,
    /// How long spans may wait before a partial batch is sent. OTEL_BSP_SCHEDULE_DELAY applies
    /// when this is left at its default. Unit: ms, 10 to 60000.
    #[schemars(range(min = 10, max = 60_000))]
    pub scheduled_delay_ms: u32,
    /// Also export the detail status's counters as OpenTelemetry metrics (to
    /// `<endpoint>/v1/metrics`). OTEL_METRICS_EXPORTER=none turns them off too; Arize Phoenix
    /// takes traces only and answers metrics with 405.
    pub metrics: bool,
    /// Metrics (the detail status's counters) are exported this often, to the same collector
    /// (`<endpoint>/v1/metrics`). OTEL_METRIC_EXPORT_INTERVAL applies when this is left at its
    /// default. Unit: s, 0.1 to 3600.
    #[schemars(range(min = 0.1, max = 3600.0))]
    pub metrics_interval_s: f64,
}

/// Defaults of the batch span exporter (see `TelemetryConfig`): the demo's busiest load (warp 20,
/// ≈900 spans/s with NAV sampled at 10/s) fills the queue in no less than ≈18 s, far longer than a
/// collector pause worth riding out; a batch is one loopback request of a few ms.
pub const DEFAULT_MAX_QUEUE_SIZE: u32 = 16_384;
pub const DEFAULT_MAX_EXPORT_BATCH_SIZE: u32 = 1_024;
pub const DEFAULT_SCHEDULED_DELAY_MS: u32 = 500;
pub const DEFAULT_METRICS_INTERVAL_S: f64 = 10.0;

impl Default for TelemetryConfig {
    fn default() -> Self {
        Self {
            enabled: false,
            endpoint: "http://127.0.0.1:4318".into(),
            service_name: String::new(),
            sampling_ratio: 1.0,
            nav_traces_per_s: 10.0,
            metrics: true,
            max_queue_size: DEFAULT_MAX_QUEUE_SIZE,
            max_export_batch_size: DEFAULT_MAX_EXPORT_BATCH_SIZE,
            scheduled_delay_ms: DEFAULT_SCHEDULED_DELAY_MS,
            metrics_interval_s: DEFAULT_METRICS_INTERVAL_S,
        }
    }
}

impl TelemetryConfig {
    pub(crate) fn check(&self, prefix: &str, c: &mut Checker) {
        if !(self.endpoint.starts_with("http://") || self.endpoint.starts_with("https://")) {
            c.push(crate::FieldError::new(
                at(prefix, "endpoint"),
                format!("{:?}", self.endpoint),
                "must be an http:// or https:// URL",
            ));
        }
        c.within(&at(prefix, "sampling_ratio"), self.sampling_ratio, 0.0, 1.0);
        c.within(
            &at(prefix, "nav_traces_per_s"),
            self.nav_traces_per_s,
            0.0,
            1000.0,
        );
        c.within(
            &at(prefix, "max_queue_size"),
            f64::from(self.max_queue_size),
            64.0,
            1_048_576.0,
        );
        c.within(
            &at(prefix, "max_export_batch_size"),
            f64::from(self.max_export_batch_size),
            1.0,
            f64::from(self.max_queue_size.max(1)),
        );
        c.within(
            &at(prefix, "scheduled_delay_ms"),
            f64::from(self.scheduled_delay_ms),
            10.0,
            60_000.0,
        );
        c.within(
            &at(prefix, "metrics_interval_s"),
            self.metrics_interval_s,
            0.1,
            3600.0,
        );
    }
}
