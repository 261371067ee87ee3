//! Traces end to end with the SDK's in-memory exporter: the real simulator over loopback, the
//! real interface, a helm on the bus. One NAV line must form one trace from the socket read to
//! the node_status subscriber; one setpoint one trace from the helm to the socket write (a course
//! through the interface's setpoint lane, a command_request through both actors).

mod common;

use frontseat_actors::bus::test_util::UntypedBus as _;
use std::collections::HashMap;
use std::time::Duration;

use common::*;
use frontseat_actors::bus::Bus;
use frontseat_actors::groups;
use frontseat_actors::interface::InterfaceService;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CommandRequest, DesiredCourse, HelmState, InterfaceState,
};
use opentelemetry::trace::{SpanId, TraceId};
use opentelemetry_sdk::trace::{InMemorySpanExporter, SpanData};

fn attr(s: &SpanData, key: &str) -> Option<String> {
    s.attributes
        .iter()
        .find(|kv| kv.key.as_str() == key)
        .map(|kv| kv.value.as_str().to_string())
}

/// The chain of span names from `leaf` up to the root of its trace.
fn ancestry(spans: &[SpanData], leaf: &SpanData) -> Vec<SpanData> {
    let by_id: HashMap<SpanId, &SpanData> = spans
        .iter()
        .filter(|s| s.span_context.trace_id() == leaf.span_context.trace_id())
        .map(|s| (s.span_context.span_id(), s))
        .collect();
    let mut chain = vec![leaf.clone()];
    let mut cur = leaf;
    while cur.parent_span_id != SpanId::INVALID {
        match by_id.get(&cur.parent_span_id) {
            Some(p) => {
                chain.push((*p).clone());
                cur = p;
            }
            None => break,
        }
    }
    chain.reverse();
    chain
}

fn trace_id_of(traceparent: &str) -> TraceId {
    let hex = traceparent
        .split('-')
        .nth(1)
        .expect("traceparent has a trace id");
    TraceId::from_hex(hex).expect("valid trace id")
}

async fn spans_until(
    exporter: &InMemorySpanExporter,
    what: &str,
    pred: impl Fn(&[SpanData]) -> bool,
) -> Vec<SpanData> {
    let deadline = tokio::time::Instant::now() + Duration::from_secs(10);
    loop {
        let spans = exporter.get_finished_spans().unwrap_or_default();
        if pred(&spans) {
            return spans;
        }
        assert!(
            tokio::time::Instant::now() < deadline,
            "timed out waiting for {what}; have {} spans",
            spans.len()
        );
        // Spans are exported as they end, on other tasks: poll the exporter briefly.
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

/// Each `(index, key, value)`: the span at `index` in `chain` has that attribute.
fn has_attrs(chain: &[SpanData], want: &[(usize, &str, &str)]) {
    for (i, k, v) in want {
        assert_eq!(
            attr(&chain[*i], k).as_deref(),
            Some(*v),
            "span {i}, attribute {k}"
        );
    }
}

/// Runs `publish` inside a root span, as a traced helm publishes.
fn in_helm_span(publish: impl FnOnce()) {
    tracing::trace_span!(target: "frontseat", "helm.setpoint").in_scope(publish);
}

fn course(heading: f64) -> DesiredCourse {
    DesiredCourse {
        time: 0.0,
        heading: Some(heading),
        speed: Some(1.0),
        ..Default::default()
    }
}

/// The ancestry of the socket write of the CMD line that starts with `prefix`, once exported.
async fn setpoint_chain(exporter: &InMemorySpanExporter, prefix: &str) -> Vec<SpanData> {
    let is_cmd_write = |s: &SpanData| {
        s.name == "frontseat.socket_write" && attr(s, "line").is_some_and(|l| l.starts_with(prefix))
    };
    // Wait for the whole chain: spans are exported as they end, the root last.
    let spans = spans_until(exporter, "the setpoint's trace", |spans| {
        spans.iter().find(|s| is_cmd_write(s)).is_some_and(|leaf| {
            ancestry(spans, leaf).first().map(|r| r.name.as_ref()) == Some("helm.setpoint")
        })
    })
    .await;
    let leaf = spans.iter().find(|s| is_cmd_write(s)).unwrap();
    ancestry(&spans, leaf)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn one_nav_line_and_one_setpoint_each_form_one_trace() {
    let exporter = InMemorySpanExporter::default();
    let mut telemetry = frontseat_telemetry::init_with_exporter(exporter.clone(), "frontseat-test");
    assert!(frontseat_telemetry::enabled());

    let sim = start_sim().await;
    let bus = Bus::new();
    let mut status = StatusWatch::new(&bus);
    let (_s, mut nav) = bus.subscribe_channel(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS,
        "test-helm",
        1000,
    );
    let helm = helm_heartbeat(&bus, HelmState::HelmDrive);
    let service =
        InterfaceService::start(&config_for(&sim, WARP), &bus, frontseat_drivers::BUILT_IN)
            .await
            .unwrap();
    status
        .until_state(InterfaceState::InterfaceCommand, Duration::from_secs(20))
        .await;

    // --- one NAV line: socket read → driver → interface → node_status subscriber
    let env = tokio::time::timeout(Duration::from_secs(10), nav.recv())
        .await
        .unwrap()
        .unwrap();
    let tp = env
        .trace
        .clone()
        .expect("the envelope carries the publisher's trace context");
    let nav_trace = trace_id_of(&tp.traceparent);
    // Wait for the whole chain: the read span ends (and is exported) after its children.
    let spans = spans_until(&exporter, "the NAV trace", |spans| {
        spans
            .iter()
            .find(|s| {
                s.span_context.trace_id() == nav_trace
                    && s.name == "bus.deliver"
                    && attr(s, "subscriber").as_deref() == Some("test-helm")
            })
            .is_some_and(|leaf| {
                ancestry(spans, leaf).first().map(|r| r.name.as_ref())
                    == Some("frontseat.socket_read")
            })
    })
    .await;
    let leaf = spans
        .iter()
        .find(|s| {
            s.span_context.trace_id() == nav_trace
                && s.name == "bus.deliver"
                && attr(s, "subscriber").as_deref() == Some("test-helm")
        })
        .unwrap();
    let chain = ancestry(&spans, leaf);
    let names: Vec<&str> = chain.iter().map(|s| s.name.as_ref()).collect();
    assert_eq!(
        names,
        vec![
            "frontseat.socket_read",
            "actor.handle",
            "frontseat.decode",
            "bus.publish",
            "bus.deliver",
            "actor.handle",
            "bus.publish",
            "bus.deliver",
        ],
        "NAV span tree"
    );
    assert!(
        attr(&chain[0], "line").unwrap().starts_with("NAV,"),
        "raw line on the read span"
    );
    has_attrs(
        &chain,
        &[
            (1, "actor", "DriverActor"),
            (3, "group", "frontseat::driver::data_from_frontseat"),
            (4, "subscriber", "FrontSeatInterface"),
            (5, "actor", "FrontSeatInterface"),
            (6, "group", "goby::middleware::frontseat::node_status"),
            (
                6,
                "message_type",
                "goby.middleware.frontseat.protobuf.NodeStatus",
            ),
        ],
    );

    // --- one course: helm → the interface's setpoint lane → socket write, on the helm's thread.
    // A course takes the lane only while nothing bound for the vehicle is on its way through the
    // actors and the link has no backlog; on a loaded machine one may find it so and go through
    // both actors (a whole trace of its own, checked too). Up to five courses: one must take it.
    let lane = [
        "helm.setpoint",
        "bus.publish",
        "bus.deliver",
        "setpoint.direct",
        "frontseat.socket_write",
    ];
    let actors = [
        "helm.setpoint",
        "bus.publish",
        "bus.deliver",
        "actor.handle",
        "bus.publish",
        "bus.deliver",
        "actor.handle",
        "frontseat.socket_write",
    ];
    let mut took_lane = None;
    for heading in 121..126 {
        in_helm_span(|| {
            bus.publish(
                &groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE,
                course(f64::from(heading)),
            );
        });
        let chain = setpoint_chain(&exporter, &format!("CMD,HEADING:{heading},")).await;
        let names: Vec<&str> = chain.iter().map(|s| s.name.as_ref()).collect();
        if names == lane {
            took_lane = Some(chain);
            break;
        }
        assert_eq!(names, actors, "course span tree (through the actors)");
    }
    let chain = took_lane.expect("no course of five took the setpoint lane");
    has_attrs(
        &chain,
        &[
            (1, "group", "goby::middleware::frontseat::desired_course"),
            (2, "subscriber", "FrontSeatInterface"),
        ],
    );

    // --- one command_request: helm → interface → driver → socket write, through both actors
    in_helm_span(|| {
        bus.publish(
            &groups::GOBY_MIDDLEWARE_FRONTSEAT_COMMAND_REQUEST,
            CommandRequest {
                desired_course: Some(course(130.0)),
                ..Default::default()
            },
        );
    });
    let chain = setpoint_chain(&exporter, "CMD,HEADING:130,").await;
    let names: Vec<&str> = chain.iter().map(|s| s.name.as_ref()).collect();
    assert_eq!(
        names,
        vec![
            "helm.setpoint",
            "bus.publish",
            "bus.deliver",
            "actor.handle",
            "bus.publish",
            "bus.deliver",
            "actor.handle",
            "frontseat.socket_write",
        ],
        "command_request span tree"
    );
    has_attrs(
        &chain,
        &[
            (1, "group", "goby::middleware::frontseat::command_request"),
            (4, "group", "frontseat::driver::command_request"),
            (6, "actor", "DriverActor"),
        ],
    );

    helm.abort();
    service.shutdown(Duration::from_secs(3)).await;
    sim.shutdown().await;
    telemetry.shutdown();
}
