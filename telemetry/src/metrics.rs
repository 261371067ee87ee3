//! The OpenTelemetry metrics of a frontseat process: the counters of every interface's detail
//! status (NAV received and refused, setpoints sent and refused, commands gated, bus drops, driver
//! restarts, the Goby3 state), the drivers' bad lines and the span exporter's own counts.
//!
//! The data path pays one relaxed atomic add per event and nothing else: the values live in
//! atomics here and the SDK reads them through observable instruments, on its periodic reader's
//! thread, only when it exports (every `[telemetry] metrics_interval_s`). With export off nobody
//! reads them. Rates (NAV/s, setpoints/s) are left to the backend, which derives them from the
//! monotonic counters as it does for any OTel counter.

use std::sync::atomic::{AtomicI32, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, Weak};

use opentelemetry::KeyValue;
use opentelemetry::metrics::Meter;

/// One interface's counters, shared between the interface actor (writer) and the exporter's
/// callbacks (reader).
#[derive(Debug, Default)]
pub struct VehicleMetrics {
    /// NodeStatus received from the driver (before the envelope check).
    pub nav_received: AtomicU64,
    /// Setpoints that passed the safety envelope on their way to the driver.
    pub setpoints_sent: AtomicU64,
    pub setpoints_refused: AtomicU64,
    pub nav_refused: AtomicU64,
    /// Navigation fields dropped as out of bounds ([limits.navigation]).
    pub nav_fields_dropped: AtomicU64,
    /// raw_send_request passed to the driver, and refused by the raw gate.
    pub raw_sent: AtomicU64,
    pub raw_refused: AtomicU64,
    pub commands_gated: AtomicU64,
    pub bus_dropped: AtomicU64,
    pub driver_restarts: AtomicU64,
    /// The InterfaceState number (Goby3's enum).
    pub state: AtomicI32,
    /// Its name: the runtime owns the enum, this crate only reports it.
    pub state_name: StateName,
}

/// Names a Goby3 InterfaceState number, as the runtime that owns the enum does.
#[derive(Clone, Copy)]
pub struct StateName(pub fn(i32) -> &'static str);

impl Default for StateName {
    fn default() -> Self {
        Self(|_| "UNKNOWN")
    }
}

impl std::fmt::Debug for StateName {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("StateName")
    }
}

impl VehicleMetrics {
    pub fn add(counter: &AtomicU64) {
        counter.fetch_add(1, Ordering::Relaxed);
    }
    pub fn set(counter: &AtomicU64, v: u64) {
        counter.store(v, Ordering::Relaxed);
    }
}

/// Every live interface of the process with its vehicle name: a process may run several (the
/// demo's fleet, the bench). Weak, so a stopped interface disappears from the export.
static VEHICLES: Mutex<Vec<(String, Weak<VehicleMetrics>)>> = Mutex::new(Vec::new());

/// Lines from a frontseat that no driver could use (bad NAV, binary frames, undecodable input),
/// for the whole process: drivers do not know which vehicle they serve.
static BAD_LINES: AtomicU64 = AtomicU64::new(0);

/// The counters of a new interface, exported with the attribute `vehicle = <name>`; its state
/// is named by `state_name`.
pub fn register(vehicle: &str, state_name: fn(i32) -> &'static str) -> Arc<VehicleMetrics> {
    let m = Arc::new(VehicleMetrics {
        state_name: StateName(state_name),
        ..Default::default()
    });
    let mut v = VEHICLES.lock().unwrap_or_else(|p| p.into_inner());
    v.retain(|(_, w)| w.strong_count() > 0);
    v.push((vehicle.to_string(), Arc::downgrade(&m)));
    m
}

/// A driver could not use a line from its frontseat.
pub fn bad_line() {
    BAD_LINES.fetch_add(1, Ordering::Relaxed);
}

pub fn bad_lines() -> u64 {
    BAD_LINES.load(Ordering::Relaxed)
}

/// Times a helm-side child of a supervisor went down (failed or stopped), for the whole process:
/// each is a period of running degraded.
static HELM_SIDE_DOWN: AtomicU64 = AtomicU64::new(0);

pub fn helm_side_down() {
    HELM_SIDE_DOWN.fetch_add(1, Ordering::Relaxed);
}

pub fn helm_side_downs() -> u64 {
    HELM_SIDE_DOWN.load(Ordering::Relaxed)
}

/// Messages the MCAP recorders of this process dropped (queue full, no writable file), and how
/// many recorders run: a recorder falling behind shows in every interface's detail status and in
/// the metrics, not only in the file's closing metadata.
static RECORDER_DROPPED: AtomicU64 = AtomicU64::new(0);
static RECORDERS: AtomicU64 = AtomicU64::new(0);

pub fn recorder_dropped(n: u64) {
    RECORDER_DROPPED.fetch_add(n, Ordering::Relaxed);
}

pub fn recorder_drops() -> u64 {
    RECORDER_DROPPED.load(Ordering::Relaxed)
}

/// A recorder started (`true`) or stopped (`false`).
pub fn recorder_running(running: bool) {
    if running {
        RECORDERS.fetch_add(1, Ordering::Relaxed);
    } else {
        let _ = RECORDERS.fetch_update(Ordering::Relaxed, Ordering::Relaxed, |n| n.checked_sub(1));
    }
}

/// The process's recorder drops, `None` when it never recorded.
pub fn recorder_drops_if_recording() -> Option<u64> {
    let d = recorder_drops();
    (RECORDERS.load(Ordering::Relaxed) > 0 || d > 0).then_some(d)
}

fn each_vehicle(mut f: impl FnMut(&[KeyValue], &VehicleMetrics)) {
    let live: Vec<(String, Arc<VehicleMetrics>)> = {
        let v = VEHICLES.lock().unwrap_or_else(|p| p.into_inner());
        v.iter()
            .filter_map(|(n, w)| w.upgrade().map(|m| (n.clone(), m)))
            .collect()
    };
    for (name, m) in live {
        f(&[KeyValue::new("vehicle", name)], &m);
    }
}

/// Names of the exported instruments (documented in README "Traces" and deploy/TRACING.md).
pub mod names {
    pub const NAV_RECEIVED: &str = "frontseat.nav.received";
    pub const NAV_REFUSED: &str = "frontseat.nav.refused";
    pub const NAV_FIELDS_DROPPED: &str = "frontseat.nav.fields_dropped";
    pub const RAW_SENT: &str = "frontseat.raw.sent";
    pub const RAW_REFUSED: &str = "frontseat.raw.refused";
    pub const SETPOINTS_SENT: &str = "frontseat.setpoints.sent";
    pub const SETPOINTS_REFUSED: &str = "frontseat.setpoints.refused";
    pub const COMMANDS_GATED: &str = "frontseat.commands.gated";
    pub const BUS_DROPPED: &str = "frontseat.bus.dropped";
    pub const DRIVER_RESTARTS: &str = "frontseat.driver.restarts";
    pub const STATE: &str = "frontseat.interface.state";
    pub const BAD_LINES: &str = "frontseat.bad_lines";
    pub const RECORD_DROPPED: &str = "frontseat.record.dropped";
    pub const HELM_SIDE_DOWN: &str = "frontseat.supervision.helm_side_down";
    pub const SPANS_EXPORTED: &str = "frontseat.spans.exported";
    pub const SPANS_DROPPED: &str = "frontseat.spans.dropped";
}

type Field = fn(&VehicleMetrics) -> &AtomicU64;

/// Registers the observable instruments on `meter`. The SDK keeps their callbacks for the
/// meter provider's life.
/// `spans` says (exported, dropped) so far: the telemetry that installs these owns the counts.
pub(crate) fn install(meter: &Meter, spans: fn() -> (u64, u64)) {
    let per_vehicle: [(&'static str, &'static str, &'static str, Field); 10] = [
        (
            names::NAV_RECEIVED,
            "{message}",
            "NodeStatus received from the frontseat",
            |m| &m.nav_received,
        ),
        (
            names::NAV_REFUSED,
            "{message}",
            "NodeStatus refused as insane",
            |m| &m.nav_refused,
        ),
        (
            names::NAV_FIELDS_DROPPED,
            "{field}",
            "NodeStatus fields dropped as out of physical bounds",
            |m| &m.nav_fields_dropped,
        ),
        (
            names::RAW_SENT,
            "{message}",
            "raw_send_request passed to the driver",
            |m| &m.raw_sent,
        ),
        (
            names::RAW_REFUSED,
            "{message}",
            "raw_send_request refused (source, terminator, size)",
            |m| &m.raw_refused,
        ),
        (
            names::SETPOINTS_SENT,
            "{message}",
            "setpoints passed to the driver",
            |m| &m.setpoints_sent,
        ),
        (
            names::SETPOINTS_REFUSED,
            "{message}",
            "setpoints refused by the safety envelope",
            |m| &m.setpoints_refused,
        ),
        (
            names::COMMANDS_GATED,
            "{message}",
            "commands refused outside COMMAND",
            |m| &m.commands_gated,
        ),
        (
            names::BUS_DROPPED,
            "{message}",
            "bus messages dropped at a full subscriber queue",
            |m| &m.bus_dropped,
        ),
        (
            names::DRIVER_RESTARTS,
            "{restart}",
            "driver restarts by the supervisor",
            |m| &m.driver_restarts,
        ),
    ];
    for (name, unit, description, field) in per_vehicle {
        meter
            .u64_observable_counter(name)
            .with_unit(unit)
            .with_description(description)
            .with_callback(move |obs| {
                each_vehicle(|attrs, m| obs.observe(field(m).load(Ordering::Relaxed), attrs))
            })
            .build();
    }
    meter
        .i64_observable_gauge(names::STATE)
        .with_description(
            "the interface's Goby3 state: the InterfaceState number, named in `state`",
        )
        .with_callback(|obs| {
            each_vehicle(|attrs, m| {
                let n = m.state.load(Ordering::Relaxed);
                let name = (m.state_name.0)(n);
                let mut a = attrs.to_vec();
                a.push(KeyValue::new("state", name));
                obs.observe(i64::from(n), &a);
            })
        })
        .build();
    meter
        .u64_observable_counter(names::BAD_LINES)
        .with_unit("{line}")
        .with_description("lines from the frontseat no driver could use")
        .with_callback(|obs| obs.observe(bad_lines(), &[]))
        .build();
    meter
        .u64_observable_counter(names::RECORD_DROPPED)
        .with_unit("{message}")
        .with_description("messages the MCAP recorder dropped (queue full, no writable file)")
        .with_callback(|obs| obs.observe(recorder_drops(), &[]))
        .build();
    meter
        .u64_observable_counter(names::HELM_SIDE_DOWN)
        .with_unit("{event}")
        .with_description(
            "helm-side actors gone down (each a degraded period; restarted without end)",
        )
        .with_callback(|obs| obs.observe(helm_side_downs(), &[]))
        .build();
    meter
        .u64_observable_counter(names::SPANS_EXPORTED)
        .with_unit("{span}")
        .with_description("spans the collector accepted")
        .with_callback(move |obs| obs.observe(spans().0, &[]))
        .build();
    meter
        .u64_observable_counter(names::SPANS_DROPPED)
        .with_unit("{span}")
        .with_description("spans lost before the collector had them (queue full, export failed)")
        .with_callback(move |obs| obs.observe(spans().1, &[]))
        .build();
}
