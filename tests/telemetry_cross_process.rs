//! Traces across processes: the real `frontseat interface` (a child, Zenoh gateway on, OTLP/HTTP
//! export on) and this test process (a Zenoh helm with its own tracer) must put their spans in
//! one trace. A tiny OTLP/HTTP receiver (tests/common/otlp.rs) runs in the test on loopback and
//! decodes what the child exports, so the assertions are about the bytes a real viewer would get.
//!
//! Every wait has a deadline; children are killed when the test ends, pass or fail.

mod common;

use common::otlp::{RxSpan, ancestry, spans_until, start_receiver};
use common::procs::{Kill, free_port, frontseat_sim, scratch, wait_for_tcp};

use std::collections::HashMap;
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::Duration;

use frontseat_actors::groups;
use frontseat_actors::proto::frontseat::protobuf::InterfaceDetail;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    DesiredCourse, HelmState, HelmStateReport, InterfaceState, InterfaceStatus, NodeStatus,
};
use frontseat_helm_side::zenoh;
use frontseat_helm_side::{client_config, key_for, put_message};
use opentelemetry::propagation::TextMapPropagator;
use opentelemetry::trace::{Span as _, TraceContextExt, Tracer, TracerProvider as _};
use opentelemetry_sdk::propagation::TraceContextPropagator;
use opentelemetry_sdk::trace::{InMemorySpanExporter, SdkTracerProvider};
use prost::Message;

const BIN: &str = env!("CARGO_BIN_EXE_frontseat");
const LONG: Duration = Duration::from_secs(60);
const PROJECT: &str = "frontseat-xp";
const SERVICE: &str = "xp-interface";

// ---------------------------------------------------------------------------------------------
// The processes

struct Stack {
    zenoh: u16,
    dir: PathBuf,
    _sim: Kill,
    interface: Kill,
}

impl Stack {
    fn log(&self) -> String {
        std::fs::read_to_string(self.dir.join("interface.log")).unwrap_or_default()
    }
}

/// sim + interface; the interface exports to `endpoint` with the batch settings in `bsp`.
async fn start_stack(name: &str, platform: &str, endpoint: &str, bsp: &[(&str, &str)]) -> Stack {
    let dir = scratch("otel", name);
    let (sim, sim_port) = frontseat_sim(std::fs::File::create(dir.join("sim.log")).unwrap()).await;
    let zport = free_port();
    let cfg = format!(
        r#"name = "{platform}"
sim_warp_factor = 10.0
status_period = 0.5
helm_running_timeout = 5.0
[driver]
name = "basic_simulator"
[driver.basic_simulator]
tcp_port = {sim_port}
[interprocess]
enabled = true
listen = ["tcp/127.0.0.1:{zport}"]
[telemetry]
enabled = true
endpoint = "{endpoint}"
service_name = "{SERVICE}"
"#
    );
    let cfg_path = dir.join("interface.toml");
    std::fs::write(&cfg_path, cfg).unwrap();
    let mut cmd = Command::new(BIN);
    cmd.arg("interface")
        .arg("-c")
        .arg(&cfg_path)
        .env("RUST_LOG", "info")
        // The project header as a user would set it for Phoenix: proves the env is honoured.
        .env(
            "OTEL_EXPORTER_OTLP_HEADERS",
            format!("x-project-name={PROJECT}"),
        )
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(dir.join("interface.log")).unwrap());
    for k in [
        "OTEL_EXPORTER_OTLP_ENDPOINT",
        "OTEL_EXPORTER_OTLP_TRACES_ENDPOINT",
        "OTEL_EXPORTER_OTLP_TRACES_HEADERS",
        "OTEL_SERVICE_NAME",
        "OTEL_TRACES_SAMPLER_ARG",
        "OTEL_SDK_DISABLED",
    ] {
        cmd.env_remove(k);
    }
    for (k, v) in bsp {
        cmd.env(k, v);
    }
    let interface = Kill(cmd.spawn().unwrap());
    wait_for_tcp(zport).await;
    Stack {
        zenoh: zport,
        dir,
        _sim: sim,
        interface,
    }
}

/// A Zenoh helm in this process: status and node_status (with attachments) in, DRIVE out.
struct Helm {
    session: zenoh::Session,
    status: tokio::sync::mpsc::UnboundedReceiver<InterfaceStatus>,
    nav: tokio::sync::mpsc::UnboundedReceiver<(NodeStatus, Option<Vec<u8>>)>,
    heartbeat: tokio::task::JoinHandle<()>,
    _subs: Vec<zenoh::pubsub::Subscriber<()>>,
}

impl Helm {
    async fn connect(stack: &Stack, platform: &str) -> Helm {
        let session =
            zenoh::open(client_config(&[format!("tcp/127.0.0.1:{}", stack.zenoh)]).unwrap())
                .await
                .unwrap();
        let key = |g: &str| key_for(platform, g);
        let (stx, status) = tokio::sync::mpsc::unbounded_channel();
        let s = session
            .declare_subscriber(key(groups::GOBY_MIDDLEWARE_FRONTSEAT_STATUS.name()))
            .callback(move |s| {
                if let Ok(st) = InterfaceStatus::decode(&*s.payload().to_bytes()) {
                    let _ = stx.send(st);
                }
            })
            .await
            .unwrap();
        let (ntx, nav) = tokio::sync::mpsc::unbounded_channel();
        let n = session
            .declare_subscriber(key(groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS.name()))
            .callback(move |s| {
                if let Ok(ns) = NodeStatus::decode(&*s.payload().to_bytes()) {
                    let att = s.attachment().map(|a| a.to_bytes().to_vec());
                    let _ = ntx.send((ns, att));
                }
            })
            .await
            .unwrap();
        let helm_key = key(groups::GOBY_MIDDLEWARE_FRONTSEAT_HELM_STATE.name());
        let hb = session.clone();
        let heartbeat = tokio::spawn(async move {
            loop {
                let drive = HelmStateReport {
                    state: HelmState::HelmDrive as i32,
                };
                let _ = put_message(
                    &hb,
                    &helm_key,
                    groups::GOBY_MIDDLEWARE_FRONTSEAT_HELM_STATE.type_name(),
                    &drive,
                    None,
                );
                tokio::time::sleep(Duration::from_millis(100)).await;
            }
        });
        Helm {
            session,
            status,
            nav,
            heartbeat,
            _subs: vec![s, n],
        }
    }

    async fn until_command(&mut self, stack: &Stack) {
        let deadline = tokio::time::Instant::now() + LONG;
        loop {
            match tokio::time::timeout_at(deadline, self.status.recv()).await {
                Ok(Some(s)) if s.state() == InterfaceState::InterfaceCommand => return,
                Ok(Some(_)) => {}
                _ => panic!("no COMMAND over Zenoh\ninterface log:\n{}", stack.log()),
            }
        }
    }

    /// The next node_status whose attachment is a sampled traceparent: (trace id, span id).
    async fn traced_node_status(&mut self, stack: &Stack) -> (NodeStatus, String, String) {
        let deadline = tokio::time::Instant::now() + LONG;
        loop {
            let (ns, att) = match tokio::time::timeout_at(deadline, self.nav.recv()).await {
                Ok(Some(v)) => v,
                _ => panic!(
                    "no node_status with a traceparent attachment\ninterface log:\n{}",
                    stack.log()
                ),
            };
            let Some(att) = att else { continue };
            let tp = String::from_utf8(att).unwrap();
            let parts: Vec<&str> = tp.split('-').collect();
            assert_eq!(parts.len(), 4, "attachment {tp:?} is not a traceparent");
            assert_eq!(parts[0], "00");
            // NAV is sampled (`nav_traces_per_s`): an unsampled trace still propagates its
            // context, flagged 00, and exports nothing to look for.
            assert!(parts[3] == "01" || parts[3] == "00", "flags of {tp:?}");
            if parts[3] == "01" {
                return (ns, parts[1].to_string(), parts[2].to_string());
            }
        }
    }

    async fn close(self) {
        self.heartbeat.abort();
        let _ = tokio::time::timeout(Duration::from_secs(10), self.session.close()).await;
    }
}

/// The test process's own tracer, as a helm written against the OpenTelemetry SDK would have.
fn helm_tracer() -> (SdkTracerProvider, InMemorySpanExporter) {
    let exporter = InMemorySpanExporter::default();
    let provider = SdkTracerProvider::builder()
        .with_simple_exporter(exporter.clone())
        .build();
    (provider, exporter)
}

fn names(chain: &[RxSpan]) -> Vec<&str> {
    chain.iter().map(|s| s.name.as_str()).collect()
}

// ---------------------------------------------------------------------------------------------

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn one_trace_spans_the_helm_process_and_the_interface_process_both_ways() {
    let (endpoint, store) = start_receiver().await;
    let stack = start_stack(
        "both",
        "otauv",
        &endpoint,
        &[("OTEL_BSP_SCHEDULE_DELAY", "200")],
    )
    .await;
    let log = || stack.log();
    let mut helm = Helm::connect(&stack, "otauv").await;
    helm.until_command(&stack).await;
    let (provider, helm_spans) = helm_tracer();
    let tracer = provider.tracer("test-helm");
    let propagator = TraceContextPropagator::new();

    // Helm → interface: a desired_course whose traceparent is the helm's own span.
    let span = tracer.start("helm.desired_course");
    let cx = opentelemetry::Context::new().with_span(span);
    let mut carrier = HashMap::new();
    propagator.inject_context(&cx, &mut carrier);
    let traceparent = carrier
        .remove("traceparent")
        .expect("a sampled span injects");
    let helm_trace = cx.span().span_context().trace_id().to_string();
    let helm_span = cx.span().span_context().span_id().to_string();
    let course = DesiredCourse {
        heading: Some(135.0),
        speed: Some(1.25),
        depth: Some(0.0),
        ..Default::default()
    };
    put_message(
        &helm.session,
        &key_for(
            "otauv",
            groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE.name(),
        ),
        groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE.type_name(),
        &course,
        Some(&traceparent),
    )
    .unwrap();
    cx.span().end();

    // The interface's CMD line to the frontseat is in the helm's trace, and its parent chain
    // climbs back to the helm's span through the import, the bus, and both actors.
    let chain = spans_until(
        &store,
        "the CMD write in the helm's trace",
        LONG,
        log,
        |spans| {
            spans
                .iter()
                .filter(|s| s.trace_id == helm_trace && s.name == "frontseat.socket_write")
                .map(|w| ancestry(spans, w))
                .find(|c| c[0].parent == helm_span)
        },
    )
    .await;
    println!("helm → interface: {:?}", names(&chain));
    let write = chain.last().unwrap();
    assert!(
        write.attr("line").starts_with("CMD,"),
        "socket write {:?}",
        write.attrs
    );
    assert!(
        write.attr("line").contains("HEADING:135"),
        "{:?}",
        write.attrs
    );
    assert_eq!(
        chain[0].name,
        "bus.publish",
        "the import's publish is the interface's first span: {:?}",
        names(&chain)
    );
    assert_eq!(
        chain[0].attr("group"),
        groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE.name()
    );
    // In command, with nothing ahead of it, the course takes the interface's setpoint lane: the
    // CMD line is written in the span that delivered the course to the interface. On a loaded
    // machine it may go through both actors instead (tests/telemetry_e2e.rs insists on the lane).
    let handlers: Vec<&str> = chain
        .iter()
        .filter(|s| s.name == "actor.handle")
        .map(|s| s.attr("actor"))
        .collect();
    if handlers.is_empty() {
        let tail: Vec<&str> = chain[chain.len() - 3..]
            .iter()
            .map(|s| s.name.as_str())
            .collect();
        assert_eq!(
            tail,
            ["bus.deliver", "setpoint.direct", "frontseat.socket_write"],
            "chain {:?}",
            names(&chain)
        );
        assert_eq!(
            chain[chain.len() - 3].attr("subscriber"),
            "FrontSeatInterface"
        );
    } else {
        assert_eq!(
            handlers,
            ["FrontSeatInterface", "DriverActor"],
            "chain {:?}",
            names(&chain)
        );
    }
    assert!(chain.iter().all(|s| s.service == SERVICE));

    // Interface → helm: a node_status's attachment names a span the interface exported, in a
    // trace rooted at the NAV line read from the frontseat socket.
    let (ns, nav_trace, nav_span) = helm.traced_node_status(&stack).await;
    assert_eq!(ns.name.as_deref(), Some("otauv"));
    let chain = spans_until(&store, "the node_status's span", LONG, log, |spans| {
        spans
            .iter()
            .find(|s| s.trace_id == nav_trace && s.span_id == nav_span)
            .map(|s| ancestry(spans, s))
            .filter(|c| c[0].parent.is_empty())
    })
    .await;
    println!("interface → helm: {:?}", names(&chain));
    let last = chain.last().unwrap();
    assert_eq!(last.name, "bus.deliver", "{:?}", names(&chain));
    assert_eq!(last.attr("subscriber"), "zenoh-gateway");
    assert_eq!(
        last.attr("group"),
        groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS.name()
    );
    assert_eq!(
        chain[0].name,
        "frontseat.socket_read",
        "{:?}",
        names(&chain)
    );
    assert!(
        chain[0].attr("line").starts_with("NAV,"),
        "{:?}",
        chain[0].attrs
    );

    // The helm continues that trace in its own process.
    let mut carrier = HashMap::new();
    carrier.insert(
        "traceparent".to_string(),
        format!("00-{nav_trace}-{nav_span}-01"),
    );
    let parent = propagator.extract(&carrier);
    tracer
        .start_with_context("helm.on_node_status", &parent)
        .end();
    let mine = helm_spans.get_finished_spans().unwrap();
    let on_nav = mine
        .iter()
        .find(|s| s.name == "helm.on_node_status")
        .unwrap();
    assert_eq!(on_nav.span_context.trace_id().to_string(), nav_trace);
    assert_eq!(on_nav.parent_span_id.to_string(), nav_span);
    let sent = mine
        .iter()
        .find(|s| s.name == "helm.desired_course")
        .unwrap();
    assert_eq!(sent.span_context.trace_id().to_string(), helm_trace);

    // The detail status says how many spans went out and that none was lost.
    let (dtx, mut details) = tokio::sync::mpsc::unbounded_channel();
    let _detail_sub = helm
        .session
        .declare_subscriber(key_for("otauv", groups::FRONTSEAT_INTERFACE_DETAIL.name()))
        .callback(move |s| {
            if let Ok(d) = InterfaceDetail::decode(&*s.payload().to_bytes()) {
                let _ = dtx.send(d);
            }
        })
        .await
        .unwrap();
    let deadline = tokio::time::Instant::now() + LONG;
    let detail = loop {
        match tokio::time::timeout_at(deadline, details.recv()).await {
            Ok(Some(d)) if d.spans_exported() > 0 => break d,
            Ok(Some(_)) => {}
            _ => panic!(
                "no detail status with spans_exported > 0\ninterface log:\n{}",
                stack.log()
            ),
        }
    };
    assert_eq!(detail.spans_dropped, Some(0), "{detail:?}");

    // Exported as a viewer expects: protobuf, the configured service, the project header.
    {
        let st = store.lock().unwrap();
        assert!(st.bad_requests.is_empty(), "{:?}", st.bad_requests);
        assert!(
            st.requests
                .iter()
                .all(|h| h.get("x-project-name").map(String::as_str) == Some(PROJECT)),
            "OTEL_EXPORTER_OTLP_HEADERS not honoured: {:?}",
            st.requests.first()
        );
    }
    helm.close().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn sigterm_flushes_spans_the_batch_still_held() {
    let (endpoint, store) = start_receiver().await;
    // A batch that neither the timer nor its size would send during the test.
    let mut stack = start_stack(
        "flush",
        "flauv",
        &endpoint,
        &[
            ("OTEL_BSP_SCHEDULE_DELAY", "600000"),
            ("OTEL_BSP_MAX_QUEUE_SIZE", "1000000"),
            ("OTEL_BSP_MAX_EXPORT_BATCH_SIZE", "1000000"),
        ],
    )
    .await;
    let mut helm = Helm::connect(&stack, "flauv").await;
    let (_, nav_trace, nav_span) = helm.traced_node_status(&stack).await;
    helm.close().await;
    assert!(
        store.lock().unwrap().requests.is_empty(),
        "the batch was exported before SIGTERM: the test would prove nothing"
    );

    let pid = stack.interface.0.id().to_string();
    let st = Command::new("kill").args(["-TERM", &pid]).status().unwrap();
    assert!(st.success());
    let deadline = std::time::Instant::now() + Duration::from_secs(20);
    let exit = loop {
        if let Some(s) = stack.interface.0.try_wait().unwrap() {
            break s;
        }
        assert!(
            std::time::Instant::now() < deadline,
            "interface did not exit on SIGTERM\n{}",
            stack.log()
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    };
    assert!(exit.success(), "exit {exit}\n{}", stack.log());
    let st = store.lock().unwrap();
    assert!(st.bad_requests.is_empty(), "{:?}", st.bad_requests);
    assert!(
        st.spans
            .iter()
            .any(|s| s.trace_id == nav_trace && s.span_id == nav_span),
        "the node_status's span was lost on SIGTERM ({} spans flushed)\n{}",
        st.spans.len(),
        stack.log()
    );
}
