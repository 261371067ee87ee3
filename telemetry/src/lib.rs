//! Logs and traces for every frontseat process: console logs (tracing-subscriber with an env
//! filter, no colours off a TTY) always, and OpenTelemetry traces exported over OTLP/HTTP when the
//! config's `[telemetry]` or the standard `OTEL_*` environment variables ask for it. A crate of its
//! own, beside the runtime rather than in it: the runtime (`frontseat-actors`) reports into it
//! (trace context on the bus, counters in [`metrics`]) and the binaries set it up; it knows no
//! actor and no message type.
//!
//! The hop spans (socket read, decode, bus publish, bus delivery, handling, socket write) are at
//! TRACE level and only the OpenTelemetry layer enables them, so with telemetry off they cost one
//! disabled-callsite check. Trace context crosses the bus in the envelope as a W3C traceparent (and
//! within a process also through ractor's message span propagation), so a subscriber's span is a
//! child of the publisher's, fan-out included.
//!
//! It also owns the export pipeline's bookkeeping: every span handed to the batch processor is
//! either exported, dropped at a full queue or lost in a failed request, and those counts reach
//! the interface's detail status, the metrics (`crate::metrics`, exported over OTLP/HTTP beside
//! the traces) and a last log line at shutdown.
//!
//! Its parts: `settings` resolves config and environment, `setup` installs the subscriber
//! and the pipelines, `export` counts what becomes of each span, `sampling` decides which
//! traces are kept, `context` carries a trace across the bus; [`metrics`] names the counters.

#![forbid(unsafe_code)]

/// Log lines keep the target this crate had as one file, whatever module now writes them:
/// operators filter and grep on it.
const LOG_TARGET: &str = "frontseat_telemetry";

mod context;
mod export;
pub mod metrics;
mod sampling;
mod settings;
mod setup;

pub use context::{TraceContext, current_trace, enabled, set_parent, truncate};
pub use export::{SpanCounts, span_counts, span_counts_if_exporting};
pub use sampling::{NavRateSampler, is_nav_line, sampler_for};
pub use settings::{BatchSizes, Resolved, resolve};
pub use setup::{Telemetry, init, init_with_exporter, set_default_console_level};
