//! Trace context across the bus: whether this process exports spans at all, the publisher's
//! context as a W3C traceparent, a subscriber's span made its child, and a raw line cut to a
//! span attribute's size. What the runtime calls on every hop.

use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, Ordering};

use opentelemetry::propagation::TextMapPropagator;
use opentelemetry_sdk::propagation::TraceContextPropagator;
use tracing_opentelemetry::OpenTelemetrySpanExt;

/// The publisher's trace context in W3C `traceparent` form; empty when tracing is off.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct TraceContext {
    pub traceparent: String,
}

impl TraceContext {
    /// The trace id part of the traceparent (`00-<trace id>-<span id>-<flags>`), or "".
    pub fn trace_id(&self) -> &str {
        self.traceparent.split('-').nth(1).unwrap_or("")
    }
}

pub(crate) static ENABLED: AtomicBool = AtomicBool::new(false);

/// True when spans are exported: only then do publishers capture a trace context.
pub fn enabled() -> bool {
    ENABLED.load(Ordering::Relaxed)
}

/// The current span's context as a W3C traceparent, when exporting.
pub fn current_trace() -> Option<TraceContext> {
    if !enabled() {
        return None;
    }
    let cx = tracing::Span::current().context();
    let mut carrier: HashMap<String, String> = HashMap::new();
    TraceContextPropagator::new().inject_context(&cx, &mut carrier);
    carrier
        .remove("traceparent")
        .map(|traceparent| TraceContext { traceparent })
}

/// Makes `span` a child of the publisher whose context `trace` carries.
pub fn set_parent(span: &tracing::Span, trace: Option<&TraceContext>) {
    let Some(t) = trace else { return };
    if !enabled() {
        return;
    }
    let mut carrier = HashMap::new();
    carrier.insert("traceparent".to_string(), t.traceparent.clone());
    let cx = TraceContextPropagator::new().extract(&carrier);
    let _ = span.set_parent(cx);
}

/// A raw line as a span attribute: at most 120 characters.
pub fn truncate(line: &str) -> &str {
    match line.char_indices().nth(120) {
        Some((i, _)) => &line[..i],
        None => line,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn truncates_on_a_char_boundary() {
        let long = "é".repeat(200);
        assert_eq!(truncate(&long).chars().count(), 120);
        assert_eq!(truncate("NAV,LAT:1"), "NAV,LAT:1");
    }
}
