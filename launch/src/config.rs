//! The launch file: what `frontseat launch FILE` starts, in which order, how it knows each
//! process is ready and how each one is restarted. Shape (serde), schema (schemars) and rules
//! ([`ServiceConfig::validate`]) live here; turning it into processes is [`crate::plan`].

use std::collections::BTreeMap;

use frontseat_config::{FieldError, RestartConfig, RestartPolicy, ServiceConfig};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// Longest process name: it prefixes every log line of the process.
pub const MAX_NAME_CHARS: usize = 32;
/// Most processes one launch file may start (vehicles' interfaces and per-vehicle processes
/// included): a fleet of a few dozen vehicles, each with a helm, fits.
pub const MAX_PROCESSES: usize = 512;

/// A fleet in one file (`frontseat launch FILE`): simulators, one `frontseat interface` per
/// `[[vehicle]]`, helms, a topside, any command. Started in order — the `before_vehicles`
/// processes, then per vehicle its interface and its `per_vehicle` processes, then the
/// `after_vehicles` ones — each waited for until ready; stopped in the reverse order on Ctrl-C
/// or SIGTERM. A command whose first word is `frontseat` runs this very binary.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct LaunchConfig {
    /// Where the per-vehicle interface configs and the readiness sockets are written. Empty = a
    /// fresh directory under the system temp dir, removed at the end. A relative path is relative
    /// to the launch file.
    pub run_dir: String,
    /// How long a process may take to end after SIGTERM before it gets SIGKILL. Unit: s, 0.1 to
    /// 60.
    #[schemars(range(min = 0.1, max = 60.0))]
    pub stop_timeout_s: f64,
    /// What every vehicle's interface shares: the template config and how it is supervised.
    pub vehicles: VehiclesConfig,
    /// One `frontseat interface` per entry, named after the vehicle (`interface-<name>`).
    #[schemars(example = example_vehicles())]
    pub vehicle: Vec<VehicleEntry>,
    /// Any other process: simulators, helms, a MOOS community, a topside.
    #[schemars(example = example_processes())]
    pub process: Vec<ProcessEntry>,
    /// Record every vehicle: with `enabled = true` this `[record]` goes into each templated
    /// vehicle's interface config, its files apart per vehicle — `dir` gets `/<vehicle>` added
    /// (or `{vehicle}` in it is replaced), `path` gets `-<vehicle>` before its extension (or
    /// `{vehicle}` replaced); budget and rotation apply per vehicle. A vehicle whose template or
    /// `set` has its own `[record]` keeps it (a warning says so), as does a vehicle with its own
    /// `config`. `foxglove` is refused here (every vehicle would bind the same address): set it
    /// per vehicle. A topside process records by its own config. Relative paths are relative to
    /// the launch file.
    pub record: frontseat_config::RecordConfig,
}

impl Default for LaunchConfig {
    fn default() -> Self {
        Self {
            run_dir: String::new(),
            stop_timeout_s: 5.0,
            vehicles: VehiclesConfig::default(),
            vehicle: Vec::new(),
            process: Vec::new(),
            record: frontseat_config::RecordConfig::default(),
        }
    }
}

/// The interfaces of the `[[vehicle]]` entries.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct VehiclesConfig {
    /// An interface config (TOML) every vehicle without its own `config` starts from; the
    /// vehicle's values (name, ports, datum, start, `set`) are written over it. Empty = the
    /// interface's defaults with `[interprocess] enabled = true`. Relative to the launch file.
    pub template: String,
    /// How the launcher knows an interface is up: `notify` (its sd_notify READY=1) by default.
    pub ready: ReadyConfig,
    /// How an interface that ends is restarted.
    pub restart: RestartConfig,
}

impl Default for VehiclesConfig {
    fn default() -> Self {
        Self {
            template: String::new(),
            ready: ReadyConfig {
                kind: ReadyKind::Notify,
                ..Default::default()
            },
            restart: RestartConfig::default(),
        }
    }
}

/// One vehicle: its interface, from its own config or from the template with these values.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct VehicleEntry {
    /// The vehicle name: the interface's `name` and so its Zenoh platform.
    pub name: String,
    /// Its own interface config (TOML) instead of the template; the other values below are
    /// then not allowed. Relative to the launch file.
    pub config: String,
    /// The local grid's datum (`[origin]`).
    pub datum: Option<LatLon>,
    /// Where the simulator starts the vehicle (`[driver.basic_simulator.start]`).
    pub start: Option<LatLon>,
    /// The simulator's TCP port (`driver.basic_simulator.tcp_port`).
    pub sim_port: Option<u16>,
    /// Zenoh endpoints the interface listens on (`interprocess.listen`), e.g.
    /// "tcp/127.0.0.1:7448".
    pub zenoh_listen: Vec<String>,
    /// Zenoh endpoints the interface connects to (`interprocess.connect`).
    pub zenoh_connect: Vec<String>,
    /// Serve the vehicle's web scope on this address (`[web] enabled`, `listen`).
    pub web_listen: Option<String>,
    /// Any other setting, as dotted paths of the interface config, e.g.
    /// `{ "sim_warp_factor" = 10, "limits.max_speed" = 3.0 }`.
    pub set: BTreeMap<String, serde_json::Value>,
}

/// A position. Unit: decimal degrees (WGS-84).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct LatLon {
    /// Latitude, -90 to 90.
    pub lat: f64,
    /// Longitude, -180 to 180.
    pub lon: f64,
}

/// When a process starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Stage {
    /// Before the vehicles' interfaces (simulators, a MOOSDB).
    #[default]
    BeforeVehicles,
    /// Once per vehicle, right after its interface (its helm); `{vehicle}` and `{index}` in the
    /// command, env and cwd are replaced by the vehicle's name and its position (0, 1, …).
    PerVehicle,
    /// After every vehicle (a topside).
    AfterVehicles,
}

/// Any process.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct ProcessEntry {
    /// Its name, the prefix of its log lines (`per_vehicle`: `<name>-<vehicle>`). Letters,
    /// digits, `-`, `_`, `.`; at most 32 characters.
    pub name: String,
    /// The program and its arguments. `frontseat` as the program runs this binary.
    pub command: Vec<String>,
    /// Extra environment variables.
    pub env: BTreeMap<String, String>,
    /// Working directory; empty = the launch file's directory.
    pub cwd: String,
    /// When it starts: `before_vehicles`, `per_vehicle` or `after_vehicles`.
    pub stage: Stage,
    /// Start it only when every one of these programs is on PATH (e.g. ["MOOSDB", "pHelmIvP"]);
    /// otherwise it is skipped with a log line saying so.
    pub when_on_path: Vec<String>,
    /// How the launcher knows it is up before starting the next one.
    pub ready: ReadyConfig,
    /// How it is restarted when it ends. With `never` (or `on-failure` after exit 0) a process
    /// that ends is left down; a failure past the policy stops everything.
    pub restart: RestartConfig,
}

/// How a process shows it is ready.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum ReadyKind {
    /// Ready as soon as it is started.
    #[default]
    None,
    /// Ready when it sends READY=1 on the NOTIFY_SOCKET the launcher gives it (every frontseat
    /// service does, as under systemd).
    Notify,
    /// Ready when `address` (host:port) accepts a TCP connection.
    Tcp,
    /// Ready when a line of its stdout or stderr contains `line`.
    Line,
}

/// Readiness of one process.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct ReadyConfig {
    /// `none`, `notify`, `tcp` or `line`.
    pub kind: ReadyKind,
    /// With `tcp`: the address to try, e.g. "127.0.0.1:54321".
    pub address: String,
    /// With `line`: text a ready line contains.
    pub line: String,
    /// Not ready within this long counts as a failed start. Unit: s, greater than 0, at most
    /// 600.
    #[schemars(range(min = 0.001, max = 600.0))]
    pub timeout_s: f64,
}

impl Default for ReadyConfig {
    fn default() -> Self {
        Self {
            kind: ReadyKind::None,
            address: String::new(),
            line: String::new(),
            timeout_s: 30.0,
        }
    }
}

fn example_vehicles() -> Vec<VehicleEntry> {
    vec![VehicleEntry {
        name: "auv1".into(),
        sim_port: Some(54321),
        zenoh_listen: vec!["tcp/127.0.0.1:7448".into()],
        start: Some(LatLon {
            lat: 42.358,
            lon: -70.877,
        }),
        ..Default::default()
    }]
}

fn example_processes() -> Vec<ProcessEntry> {
    vec![ProcessEntry {
        name: "sim".into(),
        command: vec![
            "frontseat".into(),
            "sim".into(),
            "--port".into(),
            "54321".into(),
        ],
        ready: ReadyConfig {
            kind: ReadyKind::Notify,
            ..Default::default()
        },
        ..Default::default()
    }]
}

/// A process name is a log prefix and a file name: the names rule every name follows
/// (`frontseat_config::names`: no `.`/`..`, separators or control characters), then short and
/// plain characters only.
pub fn check_name(name: &str) -> Result<(), String> {
    frontseat_config::names::check_name(name).map_err(|e| e.to_string())?;
    if name.chars().count() > MAX_NAME_CHARS {
        return Err(format!("longer than {MAX_NAME_CHARS} characters"));
    }
    if !name
        .chars()
        .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'))
    {
        return Err("only letters, digits, '-', '_' and '.'".into());
    }
    Ok(())
}

fn check_restart(path: &str, r: &RestartConfig, errors: &mut Vec<FieldError>) {
    if r.backoff_initial_ms < 1 {
        errors.push(FieldError::new(
            format!("{path}.backoff_initial_ms"),
            r.backoff_initial_ms,
            "at least 1",
        ));
    }
    if r.backoff_max_ms < r.backoff_initial_ms {
        errors.push(FieldError::new(
            format!("{path}.backoff_max_ms"),
            r.backoff_max_ms,
            "below backoff_initial_ms",
        ));
    }
    if !(r.restart_window_s.is_finite() && r.restart_window_s > 0.0) {
        errors.push(FieldError::new(
            format!("{path}.restart_window_s"),
            r.restart_window_s,
            "must be a positive number",
        ));
    }
    if r.policy != RestartPolicy::Never && r.max_restarts == 0 {
        errors.push(FieldError::new(
            format!("{path}.max_restarts"),
            0,
            "0 restarts with a restarting policy: use policy = \"never\"",
        ));
    }
}

fn check_ready(path: &str, r: &ReadyConfig, errors: &mut Vec<FieldError>) {
    if !(r.timeout_s.is_finite() && r.timeout_s > 0.0 && r.timeout_s <= 600.0) {
        errors.push(FieldError::new(
            format!("{path}.timeout_s"),
            r.timeout_s,
            "outside (0, 600]",
        ));
    }
    match r.kind {
        ReadyKind::Tcp if r.address.parse::<std::net::SocketAddr>().is_err() => {
            errors.push(FieldError::new(
                format!("{path}.address"),
                format!("{:?}", r.address),
                "kind = \"tcp\" needs an IP address and port, e.g. \"127.0.0.1:54321\"",
            ));
        }
        ReadyKind::Line if r.line.is_empty() => errors.push(FieldError::new(
            format!("{path}.line"),
            "\"\"",
            "kind = \"line\" needs the text of the ready line",
        )),
        _ => {}
    }
}

fn check_latlon(path: &str, p: &Option<LatLon>, errors: &mut Vec<FieldError>) {
    if let Some(p) = p {
        if !(p.lat.is_finite() && (-90.0..=90.0).contains(&p.lat)) {
            errors.push(FieldError::new(
                format!("{path}.lat"),
                p.lat,
                "outside [-90, 90]",
            ));
        }
        if !(p.lon.is_finite() && (-180.0..=180.0).contains(&p.lon)) {
            errors.push(FieldError::new(
                format!("{path}.lon"),
                p.lon,
                "outside [-180, 180]",
            ));
        }
    }
}

impl ServiceConfig for LaunchConfig {
    const SERVICE: &'static str = "launch";

    fn validate(&self) -> Vec<FieldError> {
        let mut e = Vec::new();
        if !(self.stop_timeout_s.is_finite() && (0.1..=60.0).contains(&self.stop_timeout_s)) {
            e.push(FieldError::new(
                "stop_timeout_s",
                self.stop_timeout_s,
                "outside [0.1, 60]",
            ));
        }
        e.extend(self.record.errors_at("record"));
        if self.record.foxglove.enabled {
            e.push(FieldError::new(
                "record.foxglove.enabled",
                true,
                "every vehicle would serve on the same address: enable it per vehicle (set = { \"record.foxglove.enabled\" = true, \"record.foxglove.bind\" = ... })",
            ));
        }
        check_ready("vehicles.ready", &self.vehicles.ready, &mut e);
        check_restart("vehicles.restart", &self.vehicles.restart, &mut e);
        let mut names = std::collections::BTreeSet::new();
        for (i, v) in self.vehicle.iter().enumerate() {
            let p = format!("vehicle[{i}]");
            if let Err(why) = check_name(&v.name) {
                e.push(FieldError::new(
                    format!("{p}.name"),
                    format!("{:?}", v.name),
                    why,
                ));
            } else if !names.insert(format!("interface-{}", v.name)) {
                e.push(FieldError::new(
                    format!("{p}.name"),
                    format!("{:?}", v.name),
                    "a second vehicle of that name",
                ));
            }
            let templated = v.datum.is_some()
                || v.start.is_some()
                || v.sim_port.is_some()
                || !v.zenoh_listen.is_empty()
                || !v.zenoh_connect.is_empty()
                || v.web_listen.is_some()
                || !v.set.is_empty();
            if !v.config.is_empty() && templated {
                e.push(FieldError::new(
                    format!("{p}.config"),
                    format!("{:?}", v.config),
                    "a vehicle with its own config takes no template values (datum, start, ports, set): put them in its config",
                ));
            }
            check_latlon(&format!("{p}.datum"), &v.datum, &mut e);
            check_latlon(&format!("{p}.start"), &v.start, &mut e);
            if v.sim_port == Some(0) {
                e.push(FieldError::new(format!("{p}.sim_port"), 0, "not a port"));
            }
        }
        for (i, pr) in self.process.iter().enumerate() {
            let p = format!("process[{i}]");
            if let Err(why) = check_name(&pr.name) {
                e.push(FieldError::new(
                    format!("{p}.name"),
                    format!("{:?}", pr.name),
                    why,
                ));
            } else if pr.stage != Stage::PerVehicle && !names.insert(pr.name.clone()) {
                e.push(FieldError::new(
                    format!("{p}.name"),
                    format!("{:?}", pr.name),
                    "a second process of that name",
                ));
            }
            if pr.command.first().is_none_or(|c| c.is_empty()) {
                e.push(FieldError::new(
                    format!("{p}.command"),
                    format!("{:?}", pr.command),
                    "needs at least the program",
                ));
            }
            if pr.stage == Stage::PerVehicle && self.vehicle.is_empty() {
                e.push(FieldError::new(
                    format!("{p}.stage"),
                    "\"per_vehicle\"",
                    "there is no [[vehicle]]",
                ));
            }
            check_ready(&format!("{p}.ready"), &pr.ready, &mut e);
            check_restart(&format!("{p}.restart"), &pr.restart, &mut e);
        }
        let per_vehicle = self
            .process
            .iter()
            .filter(|p| p.stage == Stage::PerVehicle)
            .count();
        let total = self.vehicle.len() * (1 + per_vehicle) + self.process.len() - per_vehicle;
        if total > MAX_PROCESSES {
            e.push(FieldError::new(
                "process",
                total,
                format!("more than {MAX_PROCESSES} processes"),
            ));
        }
        e
    }

    fn warnings(&self) -> Vec<String> {
        let mut w = Vec::new();
        if self.vehicle.is_empty() && self.process.is_empty() {
            w.push("nothing to launch: no [[vehicle]] and no [[process]]".into());
        }
        w
    }
}
