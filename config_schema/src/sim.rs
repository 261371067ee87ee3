//! Configuration of `frontseat sim`, the basic frontseat simulator: where it listens, its input
//! limits, the water current, and faults scheduled relative to each vehicle's START.

use std::net::IpAddr;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::check::{Checker, at};
use crate::sections::TelemetryConfig;
use crate::{FieldError, ServiceConfig};

/// Configuration of the basic frontseat simulator (`frontseat sim -c FILE`). `--port` and
/// `--bind` on the command line override the file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct SimConfig {
    /// IP address to listen on (an address, not a host name). Loopback by default.
    pub bind: String,
    /// TCP port to listen on; 0 is refused here (tests pick ephemeral ports in code).
    #[schemars(range(min = 1))]
    pub port: u16,
    /// Longest accepted line from a client, without its line ending; longer lines are discarded
    /// and counted. Unit: bytes, 16 to 1048576.
    #[schemars(range(min = 16, max = 1048576))]
    pub max_line_bytes: usize,
    /// Most vehicles simulated at once (connections that have sent START); more are told why
    /// and closed. Unit: vehicles.
    #[schemars(range(min = 1))]
    pub max_vehicles: usize,
    /// A connection that sends no valid START within this long after it was accepted is closed,
    /// so silent clients cannot hold the simulator's slots. 0 = wait for ever (Goby3's
    /// simulator). Unit: s (wall time), 0 to 3600.
    #[schemars(range(min = 0.0, max = 3600.0))]
    pub start_timeout_s: f64,
    /// Most connections waiting for their first START at once; a new connection past it closes
    /// the oldest waiting one, so a vehicle that connects and sends START always gets in.
    /// Unit: connections, at least 1.
    #[schemars(range(min = 1))]
    pub max_pending: usize,
    /// A vehicle whose client disconnected is kept this long: a client that reconnects within it
    /// and repeats the same START gets the same vehicle back (position, heading, speed), so a
    /// network blip does not teleport the vehicle to its start point. 0 = every START makes a new
    /// vehicle (Goby3's simulator). Unit: s (wall time), 0 to 3600.
    #[schemars(range(min = 0.0, max = 3600.0))]
    pub resume_grace_s: f64,
    /// Constant water current that drifts every vehicle.
    pub current: CurrentConfig,
    /// Faults injected into every vehicle's connection, at times after its START. Empty by default.
    #[schemars(example = example_faults())]
    pub faults: Vec<ScheduledFaultConfig>,
    /// OpenTelemetry trace export.
    pub telemetry: TelemetryConfig,
    /// The simulator server under the root supervisor: restarted (rebinding its port) if its
    /// accept task fails. Each vehicle connection is isolated inside it: a panic closes only
    /// that connection.
    pub supervision: crate::RestartConfig,
}

/// Upper bound of [`SimConfig::max_line_bytes`].
pub const MAX_LINE_BYTES_LIMIT: usize = 1 << 20;

impl Default for SimConfig {
    fn default() -> Self {
        Self {
            bind: "127.0.0.1".into(),
            port: 54321,
            max_line_bytes: 1024,
            max_vehicles: 1000,
            start_timeout_s: 10.0,
            max_pending: 64,
            resume_grace_s: 10.0,
            current: CurrentConfig::default(),
            faults: Vec::new(),
            telemetry: TelemetryConfig::default(),
            supervision: crate::RestartConfig::default(),
        }
    }
}

fn example_faults() -> Vec<ScheduledFaultConfig> {
    vec![
        ScheduledFaultConfig {
            at: 30.0,
            kind: FaultKind::StopNav,
            seconds: Some(15.0),
            lines: None,
        },
        ScheduledFaultConfig {
            at: 60.0,
            kind: FaultKind::Garbage,
            seconds: None,
            lines: Some(3),
        },
        ScheduledFaultConfig {
            at: 90.0,
            kind: FaultKind::DropConnection,
            seconds: None,
            lines: None,
        },
    ]
}

impl ServiceConfig for SimConfig {
    const SERVICE: &'static str = "sim";

    fn validate(&self) -> Vec<FieldError> {
        let mut c = Checker::default();
        if self.bind.parse::<IpAddr>().is_err() {
            c.push(FieldError::new(
                "bind",
                format!("{:?}", self.bind),
                "not an IP address (e.g. \"127.0.0.1\" or \"::1\")",
            ));
        }
        c.port("port", self.port);
        c.count(
            "max_line_bytes",
            self.max_line_bytes as u64,
            16,
            MAX_LINE_BYTES_LIMIT as u64,
        );
        c.at_least("max_vehicles", self.max_vehicles as u64, 1);
        c.at_least("max_pending", self.max_pending as u64, 1);
        c.within("start_timeout_s", self.start_timeout_s, 0.0, 3600.0);
        c.within("resume_grace_s", self.resume_grace_s, 0.0, 3600.0);
        c.finite("current.east", self.current.east);
        c.finite("current.north", self.current.north);
        self.supervision.check_at("supervision", &mut c);
        for (i, f) in self.faults.iter().enumerate() {
            f.check(&format!("faults[{i}]"), &mut c);
        }
        self.telemetry.check("telemetry", &mut c);
        c.errors
    }
}

/// Water current, the same for every vehicle.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct CurrentConfig {
    /// Eastward component of the current. Unit: m/s.
    pub east: f64,
    /// Northward component of the current. Unit: m/s.
    pub north: f64,
}

/// What a scheduled fault does to the vehicle's connection.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum FaultKind {
    /// Close the TCP connection.
    DropConnection,
    /// Stop sending NAV for `seconds`.
    StopNav,
    /// Send `lines` lines of garbage.
    Garbage,
    /// Send one line longer than the driver accepts.
    OversizedLine,
    /// Send CTRL,STATE:PAYLOAD.
    CtrlPayload,
    /// Send CTRL,STATE:AUV.
    CtrlAuv,
    /// Send CTRL,STATE:IDLE.
    CtrlIdle,
}

/// One fault at a fixed time after START.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ScheduledFaultConfig {
    /// When to inject, after the vehicle's START (simulation time). Unit: s.
    #[schemars(range(min = 0.0))]
    pub at: f64,
    /// What to inject.
    pub kind: FaultKind,
    /// For stop_nav (required there): how long NAV stays off. Unit: s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seconds: Option<f64>,
    /// For garbage: how many garbage lines (default 1). Unit: lines, 1 to 10000.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(range(min = 1, max = 10000))]
    pub lines: Option<u32>,
}

impl ScheduledFaultConfig {
    fn check(&self, prefix: &str, c: &mut Checker) {
        c.non_negative(&at(prefix, "at"), self.at);
        match (self.kind, self.seconds) {
            (FaultKind::StopNav, Some(s)) => c.positive(&at(prefix, "seconds"), s),
            (FaultKind::StopNav, None) => c.push(FieldError::new(
                at(prefix, "seconds"),
                "(unset)",
                "required for kind stop_nav",
            )),
            (_, Some(s)) => c.push(FieldError::new(
                at(prefix, "seconds"),
                s,
                "only meaningful for kind stop_nav",
            )),
            (_, None) => {}
        }
        match (self.kind, self.lines) {
            (FaultKind::Garbage, Some(n)) => c.count(&at(prefix, "lines"), n.into(), 1, 10_000),
            (_, None) => {}
            (_, Some(n)) => c.push(FieldError::new(
                at(prefix, "lines"),
                n,
                "only meaningful for kind garbage",
            )),
        }
    }
}
