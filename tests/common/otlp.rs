//! A tiny OTLP/HTTP (protobuf) receiver for the end-to-end tests: it listens on loopback, decodes
//! `POST /v1/traces` and `POST /v1/metrics` as a real collector would, answers 200 with a valid
//! (empty) Export*ServiceResponse, and keeps what arrived for the assertions. Anything else is
//! recorded as a bad request and answered 400, so a test can insist there were none.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use opentelemetry_proto::tonic::collector::metrics::v1::{
    ExportMetricsServiceRequest, ExportMetricsServiceResponse,
};
use opentelemetry_proto::tonic::collector::trace::v1::{
    ExportTraceServiceRequest, ExportTraceServiceResponse,
};
use opentelemetry_proto::tonic::common::v1::{AnyValue, KeyValue, any_value};
use opentelemetry_proto::tonic::metrics::v1::{metric, number_data_point};
use prost::Message;
use tokio::io::{AsyncReadExt, AsyncWriteExt};

/// One span as the receiver decoded it; ids in lower-case hex as in a traceparent.
#[derive(Clone, Debug)]
pub struct RxSpan {
    pub trace_id: String,
    pub span_id: String,
    pub parent: String,
    pub name: String,
    pub attrs: HashMap<String, String>,
    pub service: String,
}

impl RxSpan {
    pub fn attr(&self, k: &str) -> &str {
        self.attrs.get(k).map(String::as_str).unwrap_or("")
    }
}

/// One data point of a sum or gauge, flattened: metric name, its attributes, the value.
#[derive(Clone, Debug)]
pub struct RxPoint {
    pub metric: String,
    pub attrs: HashMap<String, String>,
    pub value: f64,
    pub service: String,
}

/// What arrived: every span and metric point, and the headers of every accepted request.
#[derive(Default)]
pub struct Received {
    pub spans: Vec<RxSpan>,
    pub points: Vec<RxPoint>,
    /// Headers of the accepted trace export requests.
    pub requests: Vec<HashMap<String, String>>,
    pub metric_requests: usize,
    pub bad_requests: Vec<String>,
}

impl Received {
    /// The last value received for `metric` whose attributes include `with`.
    pub fn last_value(&self, metric: &str, with: &[(&str, &str)]) -> Option<f64> {
        self.points
            .iter()
            .rev()
            .find(|p| {
                p.metric == metric
                    && with
                        .iter()
                        .all(|(k, v)| p.attrs.get(*k).map(String::as_str) == Some(*v))
            })
            .map(|p| p.value)
    }
}

pub type Store = Arc<Mutex<Received>>;

fn hex(b: &[u8]) -> String {
    b.iter().map(|x| format!("{x:02x}")).collect()
}

fn value_string(v: &Option<AnyValue>) -> String {
    match v.as_ref().and_then(|v| v.value.as_ref()) {
        Some(any_value::Value::StringValue(s)) => s.clone(),
        Some(any_value::Value::IntValue(i)) => i.to_string(),
        Some(any_value::Value::DoubleValue(d)) => d.to_string(),
        Some(any_value::Value::BoolValue(b)) => b.to_string(),
        Some(other) => format!("{other:?}"),
        None => String::new(),
    }
}

fn attr_map(kvs: &[KeyValue]) -> HashMap<String, String> {
    kvs.iter()
        .map(|kv| (kv.key.clone(), value_string(&kv.value)))
        .collect()
}

fn flatten(req: ExportTraceServiceRequest) -> Vec<RxSpan> {
    let mut out = Vec::new();
    for rs in req.resource_spans {
        let res = rs
            .resource
            .map(|r| attr_map(&r.attributes))
            .unwrap_or_default();
        let service = res.get("service.name").cloned().unwrap_or_default();
        for ss in rs.scope_spans {
            for s in ss.spans {
                out.push(RxSpan {
                    trace_id: hex(&s.trace_id),
                    span_id: hex(&s.span_id),
                    parent: hex(&s.parent_span_id),
                    name: s.name,
                    attrs: attr_map(&s.attributes),
                    service: service.clone(),
                });
            }
        }
    }
    out
}

fn flatten_metrics(req: ExportMetricsServiceRequest) -> Vec<RxPoint> {
    let mut out = Vec::new();
    for rm in req.resource_metrics {
        let res = rm
            .resource
            .map(|r| attr_map(&r.attributes))
            .unwrap_or_default();
        let service = res.get("service.name").cloned().unwrap_or_default();
        for sm in rm.scope_metrics {
            for m in sm.metrics {
                let points = match m.data {
                    Some(metric::Data::Sum(s)) => s.data_points,
                    Some(metric::Data::Gauge(g)) => g.data_points,
                    _ => Vec::new(),
                };
                for p in points {
                    let value = match p.value {
                        Some(number_data_point::Value::AsInt(i)) => i as f64,
                        Some(number_data_point::Value::AsDouble(d)) => d,
                        None => f64::NAN,
                    };
                    out.push(RxPoint {
                        metric: m.name.clone(),
                        attrs: attr_map(&p.attributes),
                        value,
                        service: service.clone(),
                    });
                }
            }
        }
    }
    out
}

/// Largest export request accepted; the SDK's batches are far smaller.
const MAX_BODY: usize = 32 * 1024 * 1024;

/// Serves one keep-alive connection until the client closes it.
async fn serve(mut sock: tokio::net::TcpStream, store: Store) {
    let mut buf: Vec<u8> = Vec::new();
    loop {
        let head_end = loop {
            if let Some(i) = buf.windows(4).position(|w| w == b"\r\n\r\n") {
                break i + 4;
            }
            if buf.len() > 64 * 1024 {
                return;
            }
            let mut chunk = [0u8; 8192];
            match sock.read(&mut chunk).await {
                Ok(0) | Err(_) => return,
                Ok(n) => buf.extend_from_slice(&chunk[..n]),
            }
        };
        let head = String::from_utf8_lossy(&buf[..head_end]).to_string();
        let mut lines = head.split("\r\n");
        let request_line = lines.next().unwrap_or("").to_string();
        let headers: HashMap<String, String> = lines
            .filter_map(|l| l.split_once(':'))
            .map(|(k, v)| (k.trim().to_ascii_lowercase(), v.trim().to_string()))
            .collect();
        let len: usize = headers
            .get("content-length")
            .and_then(|v| v.parse().ok())
            .unwrap_or(usize::MAX);
        if len > MAX_BODY {
            store
                .lock()
                .unwrap()
                .bad_requests
                .push(format!("{request_line}: no usable content-length"));
            let _ = sock
                .write_all(b"HTTP/1.1 411 Length Required\r\nContent-Length: 0\r\n\r\n")
                .await;
            return;
        }
        while buf.len() < head_end + len {
            let mut chunk = [0u8; 65536];
            match sock.read(&mut chunk).await {
                Ok(0) | Err(_) => return,
                Ok(n) => buf.extend_from_slice(&chunk[..n]),
            }
        }
        let body: Vec<u8> = buf.drain(..head_end + len).skip(head_end).collect();
        let ok_type =
            headers.get("content-type").map(String::as_str) == Some("application/x-protobuf");
        let (status, resp) = {
            let mut st = store.lock().unwrap();
            if ok_type && request_line.starts_with("POST /v1/traces ") {
                match ExportTraceServiceRequest::decode(body.as_slice()) {
                    Ok(req) => {
                        st.spans.extend(flatten(req));
                        st.requests.push(headers.clone());
                        (
                            "200 OK",
                            ExportTraceServiceResponse::default().encode_to_vec(),
                        )
                    }
                    Err(e) => {
                        st.bad_requests.push(format!("{request_line}: {e}"));
                        ("400 Bad Request", Vec::new())
                    }
                }
            } else if ok_type && request_line.starts_with("POST /v1/metrics ") {
                match ExportMetricsServiceRequest::decode(body.as_slice()) {
                    Ok(req) => {
                        st.points.extend(flatten_metrics(req));
                        st.metric_requests += 1;
                        (
                            "200 OK",
                            ExportMetricsServiceResponse::default().encode_to_vec(),
                        )
                    }
                    Err(e) => {
                        st.bad_requests.push(format!("{request_line}: {e}"));
                        ("400 Bad Request", Vec::new())
                    }
                }
            } else {
                st.bad_requests.push(format!("{request_line} {headers:?}"));
                ("400 Bad Request", Vec::new())
            }
        };
        let head = format!(
            "HTTP/1.1 {status}\r\nContent-Type: application/x-protobuf\r\nContent-Length: {}\r\n\r\n",
            resp.len()
        );
        if sock.write_all(head.as_bytes()).await.is_err() || sock.write_all(&resp).await.is_err() {
            return;
        }
    }
}

/// Starts the receiver on a free loopback port; returns its base URL and what it collects.
pub async fn start_receiver() -> (String, Store) {
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let port = listener.local_addr().unwrap().port();
    let store = Store::default();
    let s = store.clone();
    tokio::spawn(async move {
        while let Ok((sock, _)) = listener.accept().await {
            tokio::spawn(serve(sock, s.clone()));
        }
    });
    (format!("http://127.0.0.1:{port}"), store)
}

/// Waits (at most `within`) until the received spans satisfy `pred`, which returns what the
/// test needs from them; panics with `log()` (the child's log) otherwise.
pub async fn spans_until<T>(
    store: &Store,
    what: &str,
    within: Duration,
    log: impl Fn() -> String,
    pred: impl Fn(&[RxSpan]) -> Option<T>,
) -> T {
    let deadline = tokio::time::Instant::now() + within;
    loop {
        let (n, bad) = {
            let st = store.lock().unwrap();
            if let Some(t) = pred(&st.spans) {
                return t;
            }
            (st.spans.len(), st.bad_requests.clone())
        };
        assert!(
            tokio::time::Instant::now() < deadline,
            "timed out waiting for {what}; {n} spans received, bad requests {bad:?}\nlog:\n{}",
            log()
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

/// The chain from `leaf` up to the furthest ancestor the receiver has, root first.
pub fn ancestry(spans: &[RxSpan], leaf: &RxSpan) -> Vec<RxSpan> {
    let by_id: HashMap<&str, &RxSpan> = spans
        .iter()
        .filter(|s| s.trace_id == leaf.trace_id)
        .map(|s| (s.span_id.as_str(), s))
        .collect();
    let mut chain = vec![leaf.clone()];
    let mut cur = leaf;
    while let Some(p) = by_id.get(cur.parent.as_str()) {
        chain.push((*p).clone());
        cur = p;
        if chain.len() > 64 {
            break;
        }
    }
    chain.reverse();
    chain
}
