//! The export pipeline under the demo's load: the real `frontseat demo --warp 20` (a child)
//! exports to an OTLP/HTTP receiver in this test (tests/common/otlp.rs, loopback). The test
//! checks what a viewer would get against what the process says it sent:
//!
//! * the SDK dropped no span (the process's last log line says so),
//! * the receiver got exactly as many spans as the process says were exported,
//! * every setpoint trace that ends in a CMD line written to the frontseat is complete: every
//!   span's parent is in the trace, up to a root with no parent,
//! * the metrics arrived, under the names README "Traces" documents.
//!
//! Every wait has a deadline and the child is killed when the test ends, pass or fail.

mod common;

use common::otlp::{RxSpan, ancestry, start_receiver};
use common::procs::{Kill, scratch};

use std::collections::{HashMap, HashSet};
use std::process::{Command, Stdio};
use std::time::Duration;

use frontseat_actors::groups;
use frontseat_telemetry::metrics::names;

const BIN: &str = env!("CARGO_BIN_EXE_frontseat");
/// The demo's path at warp 20 takes ≈10 s of wall time; the bound is for a loaded machine.
const DEMO_BOUND: Duration = Duration::from_secs(180);

/// `key=<number>` in a log line.
fn field(line: &str, key: &str) -> Option<u64> {
    line.split_whitespace()
        .find_map(|w| w.strip_prefix(&format!("{key}=")))
        .and_then(|v| v.parse().ok())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_demo_at_warp_20_exports_every_span_and_its_metrics() {
    let (endpoint, store) = start_receiver().await;
    let dir = scratch("otlp", "demo");
    let log_path = dir.join("demo.log");
    let mut cmd = Command::new(BIN);
    cmd.args(["demo", "--warp", "20", "--lines", "--out"])
        .arg(dir.join("out"))
        .env("OTEL_EXPORTER_OTLP_ENDPOINT", &endpoint)
        // Several metric exports during the run, not only the last one at shutdown.
        .env("OTEL_METRIC_EXPORT_INTERVAL", "500")
        .env("RUST_LOG", "info")
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(&log_path).unwrap());
    // The test's own environment must not resize or resample the pipeline under test.
    for k in [
        "OTEL_EXPORTER_OTLP_TRACES_ENDPOINT",
        "OTEL_EXPORTER_OTLP_METRICS_ENDPOINT",
        "OTEL_EXPORTER_OTLP_HEADERS",
        "OTEL_SERVICE_NAME",
        "OTEL_TRACES_SAMPLER",
        "OTEL_TRACES_SAMPLER_ARG",
        "OTEL_BSP_SCHEDULE_DELAY",
        "OTEL_BSP_MAX_QUEUE_SIZE",
        "OTEL_BSP_MAX_EXPORT_BATCH_SIZE",
        "OTEL_SDK_DISABLED",
    ] {
        cmd.env_remove(k);
    }
    let mut child = Kill(cmd.spawn().unwrap());
    let log = || std::fs::read_to_string(&log_path).unwrap_or_default();
    let deadline = tokio::time::Instant::now() + DEMO_BOUND;
    let exit = loop {
        if let Some(s) = child.0.try_wait().unwrap() {
            break s;
        }
        assert!(
            tokio::time::Instant::now() < deadline,
            "the demo did not finish within {DEMO_BOUND:?}\n{}",
            log()
        );
        tokio::time::sleep(Duration::from_millis(100)).await;
    };
    let text = log();
    assert!(exit.success(), "demo exit {exit}\n{text}");

    // What the process says: its last telemetry line.
    let last = text
        .lines()
        .rfind(|l| l.contains("telemetry shut down"))
        .unwrap_or_else(|| panic!("no `telemetry shut down` line\n{text}"));
    let exported = field(last, "spans_exported").expect("spans_exported in the last line");
    let dropped = field(last, "spans_dropped").expect("spans_dropped in the last line");
    println!("{last}");
    assert_eq!(dropped, 0, "the SDK dropped spans: {last}");
    assert!(exported > 100, "hardly any spans exported: {last}");

    // The shutdown line is written after the last export request was answered: everything the
    // receiver will ever get is in the store now.
    let st = store.lock().unwrap();
    assert!(st.bad_requests.is_empty(), "{:?}", st.bad_requests);
    assert_eq!(
        st.spans.len() as u64,
        exported,
        "the receiver got {} spans, the process says it exported {exported}",
        st.spans.len()
    );
    let unique: HashSet<&str> = st.spans.iter().map(|s| s.span_id.as_str()).collect();
    assert_eq!(unique.len(), st.spans.len(), "a span arrived twice");

    // Every setpoint trace that reached the frontseat is whole.
    let mut by_trace: HashMap<&str, Vec<&RxSpan>> = HashMap::new();
    for s in &st.spans {
        by_trace.entry(s.trace_id.as_str()).or_default().push(s);
    }
    let writes: Vec<&RxSpan> = st
        .spans
        .iter()
        .filter(|s| s.name == "frontseat.socket_write" && s.attr("line").starts_with("CMD,"))
        .collect();
    assert!(
        writes.len() >= 20,
        "only {} CMD writes exported: the demo flies ≈150 s of setpoints",
        writes.len()
    );
    for w in &writes {
        let trace = &by_trace[w.trace_id.as_str()];
        let ids: HashSet<&str> = trace.iter().map(|s| s.span_id.as_str()).collect();
        let orphans: Vec<&str> = trace
            .iter()
            .filter(|s| !s.parent.is_empty() && !ids.contains(s.parent.as_str()))
            .map(|s| s.name.as_str())
            .collect();
        assert!(
            orphans.is_empty(),
            "trace {} has spans whose parent never arrived: {orphans:?}",
            w.trace_id
        );
        let chain = ancestry(&st.spans, w);
        let root = &chain[0];
        assert!(root.parent.is_empty(), "chain does not reach a root");
        let names: Vec<&str> = chain.iter().map(|s| s.name.as_str()).collect();
        assert_eq!(root.name, "bus.publish", "{names:?}");
        assert_eq!(
            root.attr("group"),
            groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE.name(),
            "the setpoint trace starts at the helm's desired_course: {names:?}"
        );
        let handlers: Vec<&str> = chain
            .iter()
            .filter(|s| s.name == "actor.handle")
            .map(|s| s.attr("actor"))
            .collect();
        // A course takes the interface's setpoint lane (written in the span that delivered it
        // to the interface), or both actors when something bound for the vehicle was ahead of it.
        let lane = names.ends_with(&["bus.deliver", "setpoint.direct", "frontseat.socket_write"]);
        if lane {
            assert!(handlers.is_empty(), "{names:?}");
        } else {
            assert_eq!(handlers, ["FrontSeatInterface", "DriverActor"], "{names:?}");
        }
    }
    // Not only the setpoints: no exported span anywhere lost its parent.
    let orphans = st
        .spans
        .iter()
        .filter(|s| {
            !s.parent.is_empty()
                && !by_trace[s.trace_id.as_str()]
                    .iter()
                    .any(|p| p.span_id == s.parent)
        })
        .count();
    assert_eq!(orphans, 0, "spans whose parent was not exported");

    // The metrics, under their documented names.
    assert!(
        st.metric_requests >= 2,
        "{} metric exports",
        st.metric_requests
    );
    let vehicle = [("vehicle", "demo-auv")];
    for name in [
        names::NAV_RECEIVED,
        names::SETPOINTS_SENT,
        names::SETPOINTS_REFUSED,
        names::NAV_REFUSED,
        names::COMMANDS_GATED,
        names::BUS_DROPPED,
        names::DRIVER_RESTARTS,
        names::STATE,
    ] {
        assert!(
            st.last_value(name, &vehicle).is_some(),
            "no {name} for demo-auv; metrics: {:?}",
            st.points.iter().map(|p| &p.metric).collect::<HashSet<_>>()
        );
    }
    assert!(st.last_value(names::NAV_RECEIVED, &vehicle).unwrap() > 0.0);
    assert!(st.last_value(names::SETPOINTS_SENT, &vehicle).unwrap() > 0.0);
    assert_eq!(st.last_value(names::SETPOINTS_REFUSED, &vehicle), Some(0.0));
    assert!(
        st.last_value(
            names::STATE,
            &[("vehicle", "demo-auv"), ("state", "INTERFACE_COMMAND")]
        )
        .is_some(),
        "the state gauge never said COMMAND"
    );
    assert_eq!(st.last_value(names::BAD_LINES, &[]), Some(0.0));
    assert_eq!(st.last_value(names::SPANS_DROPPED, &[]), Some(0.0));
    let last_exported = st.last_value(names::SPANS_EXPORTED, &[]).unwrap_or(0.0);
    assert!(
        last_exported > 0.0 && last_exported <= exported as f64,
        "spans.exported metric {last_exported}, log {exported}"
    );
    assert!(
        st.points.iter().all(|p| p.service == "frontseat-demo"),
        "metrics carry the service name"
    );
}
