//! The `[record]` section: the MCAP recorder of every group the process sees (crate
//! `frontseat-record`): where files go, which groups, rotation, the disk budget and how much a
//! crash may lose. Checked here so a bad regex or an impossible budget fails `--check`.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::FieldError;
use crate::check::{Checker, at};

/// Chunk compression of the recorded MCAP files.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema, Default)]
#[serde(rename_all = "snake_case")]
pub enum RecordCompression {
    /// zstd: the smallest files, the MCAP default; read by every MCAP tool.
    #[default]
    Zstd,
    /// lz4: less CPU per message, larger files.
    Lz4,
    /// No compression.
    None,
}

/// Recording every message of the bus to MCAP files.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct RecordConfig {
    /// Record this process's bus (both layers) to MCAP.
    pub enabled: bool,
    /// Directory of the rotated files `<vehicle>_<UTC start>_<seq>.mcap`; created if missing.
    pub dir: String,
    /// One file instead of rotated files in `dir` (no rotation, no budget): e.g. a bench run.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[schemars(example = &"/tmp/run.mcap")]
    pub path: Option<String>,
    /// Record only groups whose name matches one of these regexes; empty = every group.
    pub include: Vec<String>,
    /// Never record groups whose name matches one of these regexes (wins over include).
    pub exclude: Vec<String>,
    /// Start a new file past this size; 0 = no size limit. Unit: MiB.
    pub rotate_mb: u64,
    /// Start a new file after this long; 0 = no time limit. Unit: s.
    pub rotate_s: u64,
    /// Total size of the files in `dir` kept: the oldest are removed past it; 0 = no budget
    /// (not advised on a vehicle). Unit: MiB.
    pub budget_mb: u64,
    /// Warn (rate-limited, counted) when the disk holding `dir` has less free than this, and
    /// stop writing below half of it, so a full disk degrades the recorder, never the vehicle.
    /// Unit: MiB.
    pub min_free_mb: u64,
    /// The most a crash or power loss may lose: the open chunk is closed, written and synced at
    /// least this often. Unit: s, 0.05 to 60.
    #[schemars(range(min = 0.05, max = 60.0))]
    pub flush_s: f64,
    /// Chunk compression.
    pub compression: RecordCompression,
    /// Messages waiting for the writer; past it new ones are dropped and counted, so a slow disk
    /// never slows a publisher. Unit: messages, 16 to 1048576.
    pub queue: usize,
    /// The same groups served live over the Foxglove WebSocket protocol (Foxglove, Lichtblick).
    pub foxglove: FoxgloveConfig,
}

/// Environment variable that gives the Foxglove live server's token (it wins over
/// `record.foxglove.token`).
pub const FOXGLOVE_TOKEN_ENV: &str = "FRONTSEAT_FOXGLOVE_TOKEN";

/// The live view in Foxglove/Lichtblick: `ws://<bind>/` with the `foxglove.websocket.v1`
/// subprotocol. Read-only: nothing a client sends reaches the bus or a vehicle. Works with or
/// without `record.enabled` (live only, no files).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct FoxgloveConfig {
    /// Serve the groups `include`/`exclude` select, live.
    pub enabled: bool,
    /// Address and port to listen on. Loopback by default; any other address requires a token.
    pub bind: String,
    /// Shared secret every client must give (`ws://host:port/?token=...`, or
    /// `Authorization: Bearer`); FRONTSEAT_FOXGLOVE_TOKEN in the environment wins over this.
    /// At least 16 characters.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[schemars(example = &"change-me-to-a-long-random-string")]
    pub token: Option<String>,
    /// Clients served at once; more are refused (503) and counted.
    #[schemars(range(min = 1, max = 256))]
    pub max_clients: usize,
    /// Messages queued per client; a slower client misses messages (counted), never slowing a
    /// publisher. Unit: messages, 16 to 65536.
    #[schemars(range(min = 16, max = 65536))]
    pub client_queue: usize,
    /// Longest a connection may take to send a complete upgrade request head; then it is
    /// closed. Besides, when every connection slot (`max_clients` + 8) is held, a new
    /// connection closes the oldest one not yet upgraded; connected clients are never closed
    /// for it. Unit: s, 1 to 300.
    #[schemars(range(min = 1, max = 300))]
    pub header_timeout_s: u64,
    /// Web pages (origins as the browser sends them, `scheme://host[:port]`) besides the
    /// server's own that may connect, e.g. `["https://app.foxglove.dev"]` for Foxglove in a
    /// browser. An upgrade with any other `Origin` is refused (403, logged with the origin), as
    /// is, on loopback, one whose `Host` is not a loopback name (DNS rebinding). Clients that
    /// send no `Origin` (scripts, native programs) are not affected; a desktop app whose page
    /// sends `file://` or `null` needs that value listed. At most 32.
    pub allowed_origins: Vec<String>,
}

impl Default for FoxgloveConfig {
    fn default() -> Self {
        Self {
            enabled: false,
            bind: "127.0.0.1:8765".into(),
            token: None,
            max_clients: 8,
            client_queue: 1024,
            header_timeout_s: 5,
            allowed_origins: Vec::new(),
        }
    }
}

impl FoxgloveConfig {
    /// The token in force: the environment's, else the config's.
    pub fn effective_token(&self) -> Option<String> {
        std::env::var(FOXGLOVE_TOKEN_ENV)
            .ok()
            .filter(|t| !t.is_empty())
            .or_else(|| self.token.clone())
    }

    /// The errors of this section at `prefix` (e.g. "foxglove"), for services whose config
    /// lives outside this crate (the topside's `[foxglove]`).
    pub fn errors_at(&self, prefix: &str) -> Vec<FieldError> {
        let mut c = Checker::default();
        self.check(prefix, &mut c);
        c.errors
    }

    pub(crate) fn check(&self, prefix: &str, c: &mut Checker) {
        match self.bind.parse::<std::net::SocketAddr>() {
            Err(_) => c.push(FieldError::new(
                at(prefix, "bind"),
                format!("{:?}", self.bind),
                "not an address and port like \"127.0.0.1:8765\"",
            )),
            Ok(a) if self.enabled && !a.ip().is_loopback() && self.effective_token().is_none() => c
                .push(FieldError::new(
                    at(prefix, "bind"),
                    format!("{:?}", self.bind),
                    format!("not a loopback address: set a token (token or {FOXGLOVE_TOKEN_ENV})"),
                )),
            Ok(_) => {}
        }
        if let Some(t) = &self.token
            && t.chars().count() < crate::web::MIN_TOKEN_CHARS
        {
            c.push(FieldError::new(
                at(prefix, "token"),
                "\"…\"",
                format!("shorter than {} characters", crate::web::MIN_TOKEN_CHARS),
            ));
        }
        c.count(&at(prefix, "max_clients"), self.max_clients as u64, 1, 256);
        c.count(
            &at(prefix, "client_queue"),
            self.client_queue as u64,
            16,
            65536,
        );
        c.count(
            &at(prefix, "header_timeout_s"),
            self.header_timeout_s,
            1,
            300,
        );
        c.count(
            &at(prefix, "allowed_origins"),
            self.allowed_origins.len() as u64,
            0,
            32,
        );
        for (i, o) in self.allowed_origins.iter().enumerate() {
            // An origin as a browser sends it: `https://app.foxglove.dev`, or what a desktop
            // app's page sends (`file://`, `null`); one token of visible ASCII.
            if o.is_empty() || o.len() > 256 || !o.chars().all(|c| c.is_ascii_graphic()) {
                c.push(FieldError::new(
                    format!("{}[{i}]", at(prefix, "allowed_origins")),
                    format!("{:?}", o.chars().take(64).collect::<String>()),
                    "not an origin like \"https://app.foxglove.dev\" (1 to 256 visible ASCII characters)",
                ));
            }
        }
    }
}

impl Default for RecordConfig {
    fn default() -> Self {
        Self {
            enabled: false,
            dir: "/var/log/frontseat".into(),
            path: None,
            include: Vec::new(),
            exclude: Vec::new(),
            rotate_mb: 256,
            rotate_s: 3600,
            budget_mb: 8192,
            min_free_mb: 512,
            flush_s: 1.0,
            compression: RecordCompression::Zstd,
            queue: 65536,
            foxglove: FoxgloveConfig::default(),
        }
    }
}

impl RecordConfig {
    /// The errors of this section at `prefix` (e.g. "record"), for services whose config lives
    /// outside this crate (the topside, the launcher).
    pub fn errors_at(&self, prefix: &str) -> Vec<FieldError> {
        let mut c = Checker::default();
        self.check(prefix, &mut c);
        c.errors
    }

    pub(crate) fn check(&self, prefix: &str, c: &mut Checker) {
        for (name, list) in [("include", &self.include), ("exclude", &self.exclude)] {
            for (i, r) in list.iter().enumerate() {
                if let Err(e) = regex::Regex::new(r) {
                    c.push(FieldError::new(
                        format!("{}[{i}]", at(prefix, name)),
                        format!("{r:?}"),
                        format!("not a regex: {e}"),
                    ));
                }
            }
        }
        c.within(&at(prefix, "flush_s"), self.flush_s, 0.05, 60.0);
        c.count(&at(prefix, "queue"), self.queue as u64, 16, 1 << 20);
        self.foxglove.check(&at(prefix, "foxglove"), c);
        if self.path.is_none() && self.dir.trim().is_empty() {
            c.push(FieldError::new(
                at(prefix, "dir"),
                "\"\"",
                "empty: give a directory (or `path` for one file)",
            ));
        }
        if self.path.as_deref().is_some_and(|p| p.trim().is_empty()) {
            c.push(FieldError::new(
                at(prefix, "path"),
                "\"\"",
                "empty: leave it out to rotate files in `dir`",
            ));
        }
        // A budget smaller than two files would remove the file before the one being written,
        // leaving at most one file: almost certainly not what was meant.
        if self.path.is_none()
            && self.budget_mb > 0
            && self.rotate_mb > 0
            && self.budget_mb < self.rotate_mb.saturating_mul(2)
        {
            c.push(FieldError::new(
                at(prefix, "budget_mb"),
                self.budget_mb,
                format!("smaller than two files of rotate_mb = {}", self.rotate_mb),
            ));
        }
        if self.path.is_none() && self.budget_mb > 0 && self.rotate_mb == 0 && self.rotate_s == 0 {
            c.push(FieldError::new(
                at(prefix, "budget_mb"),
                self.budget_mb,
                "a budget needs rotation (rotate_mb or rotate_s): one endless file cannot be trimmed",
            ));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn errors(r: &RecordConfig) -> Vec<String> {
        let mut c = Checker::default();
        r.check("record", &mut c);
        c.errors.iter().map(|e| e.to_string()).collect()
    }

    #[test]
    fn defaults_are_valid() {
        assert!(errors(&RecordConfig::default()).is_empty());
    }

    #[test]
    fn bad_regex_flush_and_budget_are_refused_with_their_path() {
        let r = RecordConfig {
            include: vec!["(".into()],
            flush_s: 0.0,
            budget_mb: 10,
            rotate_mb: 8,
            ..Default::default()
        };
        let e = errors(&r).join("\n");
        assert!(e.contains("record.include[0]"), "{e}");
        assert!(e.contains("record.flush_s"), "{e}");
        assert!(e.contains("record.budget_mb"), "{e}");
        let endless = RecordConfig {
            rotate_mb: 0,
            rotate_s: 0,
            ..Default::default()
        };
        assert!(errors(&endless).join("\n").contains("needs rotation"));
    }

    /// How much a crash may lose is a bounded setting: the schema says the bounds the check
    /// enforces.
    #[test]
    fn flush_s_is_bounded_in_the_schema_and_the_check() {
        let schema = serde_json::to_value(schemars::schema_for!(RecordConfig)).unwrap();
        let f = &schema["properties"]["flush_s"];
        assert_eq!(f["minimum"], 0.05, "{f}");
        assert_eq!(f["maximum"], 60.0, "{f}");
        for bad in [0.01, 60.5, f64::NAN] {
            let r = RecordConfig {
                flush_s: bad,
                ..Default::default()
            };
            assert!(errors(&r).join("\n").contains("record.flush_s"), "{bad}");
        }
        assert_eq!(RecordConfig::default().flush_s, 1.0);
    }

    #[test]
    fn foxglove_off_loopback_needs_a_token() {
        let mut r = RecordConfig::default();
        r.foxglove.enabled = true;
        r.foxglove.bind = "0.0.0.0:8765".into();
        if std::env::var_os(FOXGLOVE_TOKEN_ENV).is_none() {
            assert!(errors(&r).join("\n").contains("record.foxglove.bind"));
        }
        r.foxglove.token = Some("short".into());
        assert!(errors(&r).join("\n").contains("record.foxglove.token"));
        r.foxglove.token = Some("a-long-enough-random-token".into());
        assert!(errors(&r).is_empty(), "{:?}", errors(&r));
    }
}
