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

#![forbid(unsafe_code)]

pub mod metrics;

use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Duration;

use frontseat_config::TelemetryConfig;
use opentelemetry::propagation::TextMapPropagator;
use opentelemetry::trace::TracerProvider as _;
use opentelemetry_sdk::error::OTelSdkResult;
use opentelemetry_sdk::metrics::SdkMeterProvider;
use opentelemetry_sdk::propagation::TraceContextPropagator;
use opentelemetry_sdk::trace::{
    BatchConfigBuilder, BatchSpanProcessor, Sampler, SdkTracerProvider, SpanData, SpanExporter,
    SpanProcessor,
};
use tracing_opentelemetry::OpenTelemetrySpanExt;
use tracing_subscriber::Layer;
use tracing_subscriber::layer::SubscriberExt;
use tracing_subscriber::util::SubscriberInitExt;

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

static ENABLED: AtomicBool = AtomicBool::new(false);

/// True when spans are exported: only then do publishers capture a trace context.
pub fn enabled() -> bool {
    ENABLED.load(Ordering::Relaxed)
}

/// Where and how traces go, after config and environment are combined.
#[derive(Clone, Debug, PartialEq)]
pub struct Resolved {
    /// None: leave the endpoint to the exporter, which reads OTEL_EXPORTER_OTLP_(TRACES_)ENDPOINT.
    pub endpoint: Option<String>,
    /// Config, else OTEL_SERVICE_NAME, else role + platform.
    pub service_name: Option<String>,
    pub sampling_ratio: f64,
    /// Navigation traces per second (None: unlimited); None too when OTEL_TRACES_SAMPLER is set.
    pub nav_traces_per_s: Option<f64>,
    /// OTEL_TRACES_SAMPLER, when set: the standard sampler wins over ours.
    pub standard_sampler: Option<String>,
    /// Export metrics at all: `[telemetry] metrics` and not OTEL_METRICS_EXPORTER=none.
    pub metrics: bool,
    /// Where metrics go; None: leave it to the exporter (OTEL_EXPORTER_OTLP_(METRICS_)ENDPOINT).
    pub metrics_endpoint: Option<String>,
    pub metrics_interval: Duration,
    pub batch: BatchSizes,
}

/// The batch span processor's sizes after config and OTEL_BSP_* are combined.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BatchSizes {
    pub max_queue_size: usize,
    pub max_export_batch_size: usize,
    pub scheduled_delay: Duration,
}

const DEFAULT_ENDPOINT: &str = "http://127.0.0.1:4318";

/// `<base>/v1/metrics`, also from a traces URL (`…/v1/traces`), so metrics follow the traces.
fn metrics_url(base: &str) -> String {
    let b = base.trim_end_matches('/');
    let b = b.strip_suffix("/v1/traces").unwrap_or(b);
    if b.ends_with("/v1/metrics") {
        b.to_string()
    } else {
        format!("{b}/v1/metrics")
    }
}

/// The config's value unless it is the default, then the environment's, then the default.
fn setting<T: PartialEq + Copy + std::str::FromStr>(
    cfg: T,
    default: T,
    env: &impl Fn(&str) -> Option<String>,
    var: &str,
) -> T {
    if cfg != default {
        return cfg;
    }
    env(var)
        .and_then(|s| s.trim().parse::<T>().ok())
        .unwrap_or(default)
}

fn batch_sizes(cfg: &TelemetryConfig, env: &impl Fn(&str) -> Option<String>) -> BatchSizes {
    use frontseat_config::{
        DEFAULT_MAX_EXPORT_BATCH_SIZE, DEFAULT_MAX_QUEUE_SIZE, DEFAULT_SCHEDULED_DELAY_MS,
    };
    let queue = setting(
        cfg.max_queue_size,
        DEFAULT_MAX_QUEUE_SIZE,
        env,
        "OTEL_BSP_MAX_QUEUE_SIZE",
    )
    .clamp(1, 1 << 24);
    let batch = setting(
        cfg.max_export_batch_size,
        DEFAULT_MAX_EXPORT_BATCH_SIZE,
        env,
        "OTEL_BSP_MAX_EXPORT_BATCH_SIZE",
    )
    .clamp(1, queue);
    let delay = setting(
        cfg.scheduled_delay_ms,
        DEFAULT_SCHEDULED_DELAY_MS,
        env,
        "OTEL_BSP_SCHEDULE_DELAY",
    );
    BatchSizes {
        max_queue_size: queue as usize,
        max_export_batch_size: batch as usize,
        scheduled_delay: Duration::from_millis(u64::from(delay.max(1))),
    }
}

fn traces_url(base: &str) -> String {
    let b = base.trim_end_matches('/');
    if b.ends_with("/v1/traces") {
        b.to_string()
    } else {
        format!("{b}/v1/traces")
    }
}

/// Combines `[telemetry]` with the standard environment variables. Config wins where both say
/// something; a config value equal to its default says nothing.
pub fn resolve(
    cfg: &TelemetryConfig,
    default_service: &str,
    env: impl Fn(&str) -> Option<String>,
) -> Option<Resolved> {
    let env_endpoint = env("OTEL_EXPORTER_OTLP_TRACES_ENDPOINT")
        .or_else(|| env("OTEL_EXPORTER_OTLP_ENDPOINT"))
        .filter(|s| !s.trim().is_empty());
    if !cfg.enabled && env_endpoint.is_none() {
        return None;
    }
    let config_says_endpoint = cfg.endpoint.trim_end_matches('/') != DEFAULT_ENDPOINT;
    let endpoint = if config_says_endpoint || env_endpoint.is_none() {
        Some(traces_url(&cfg.endpoint))
    } else {
        None
    };
    let env_metrics = env("OTEL_EXPORTER_OTLP_METRICS_ENDPOINT")
        .or_else(|| env("OTEL_EXPORTER_OTLP_ENDPOINT"))
        .filter(|s| !s.trim().is_empty());
    let metrics_endpoint = match (&endpoint, &env_metrics, &env_endpoint) {
        (Some(_), _, _) => Some(metrics_url(&cfg.endpoint)),
        (None, Some(_), _) => None,
        // Only OTEL_EXPORTER_OTLP_TRACES_ENDPOINT: the metrics go to the same collector.
        (None, None, traces) => traces.as_deref().map(metrics_url),
    };
    let default_interval = frontseat_config::DEFAULT_METRICS_INTERVAL_S;
    let metrics_interval = if cfg.metrics_interval_s != default_interval {
        Duration::from_secs_f64(cfg.metrics_interval_s.clamp(0.1, 3600.0))
    } else {
        env("OTEL_METRIC_EXPORT_INTERVAL")
            .and_then(|s| s.trim().parse::<u64>().ok())
            .filter(|ms| *ms > 0)
            .map(Duration::from_millis)
            .unwrap_or(Duration::from_secs_f64(default_interval))
    };
    // Read OTEL_SERVICE_NAME here rather than leaving it to the SDK, so that the project
    // attribute Phoenix groups by follows it too.
    let service_name = if !cfg.service_name.is_empty() {
        Some(cfg.service_name.clone())
    } else if let Some(s) = env("OTEL_SERVICE_NAME").filter(|s| !s.is_empty()) {
        Some(s)
    } else {
        Some(default_service.to_string())
    };
    let env_ratio = env("OTEL_TRACES_SAMPLER_ARG").and_then(|s| s.trim().parse::<f64>().ok());
    let sampling_ratio = if cfg.sampling_ratio != 1.0 {
        cfg.sampling_ratio
    } else {
        env_ratio.filter(|r| (0.0..=1.0).contains(r)).unwrap_or(1.0)
    };
    let standard_sampler = env("OTEL_TRACES_SAMPLER")
        .map(|s| s.trim().to_ascii_lowercase())
        .filter(|s| !s.is_empty());
    Some(Resolved {
        endpoint,
        service_name,
        sampling_ratio,
        nav_traces_per_s: standard_sampler
            .is_none()
            .then_some(cfg.nav_traces_per_s.clamp(0.0, 1000.0)),
        standard_sampler,
        metrics: cfg.metrics
            && !env("OTEL_METRICS_EXPORTER").is_some_and(|v| v.trim().eq_ignore_ascii_case("none")),
        metrics_endpoint,
        metrics_interval,
        batch: batch_sizes(cfg, &env),
    })
}

/// What became of the spans handed to the export pipeline, for the whole process.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SpanCounts {
    /// Accepted by the collector.
    pub exported: u64,
    /// Not queued: the batch queue was full (or the pipeline already shut down).
    pub queue_full: u64,
    /// In a request that failed (collector down, timeout, refused).
    pub export_failed: u64,
}

impl SpanCounts {
    pub fn dropped(&self) -> u64 {
        self.queue_full + self.export_failed
    }
}

static EXPORTED: AtomicU64 = AtomicU64::new(0);
static QUEUE_FULL: AtomicU64 = AtomicU64::new(0);
static EXPORT_FAILED: AtomicU64 = AtomicU64::new(0);
/// Spans accepted by [`CountingProcessor`] and not yet handed to the exporter: in the batch
/// processor's channel or its pending batch.
static IN_QUEUE: AtomicU64 = AtomicU64::new(0);

/// The process's span counts so far.
pub fn span_counts() -> SpanCounts {
    SpanCounts {
        exported: EXPORTED.load(Ordering::Relaxed),
        queue_full: QUEUE_FULL.load(Ordering::Relaxed),
        export_failed: EXPORT_FAILED.load(Ordering::Relaxed),
    }
}

/// The span counts for a status: None when this process does not export spans.
pub fn span_counts_if_exporting() -> Option<SpanCounts> {
    enabled().then(span_counts)
}

/// Wraps the SDK's BatchSpanProcessor, which counts the spans it drops but does not say how many
/// (it only logs the total at shutdown): this processor admits a span only while fewer than
/// `max_queue` are waiting, so the batch processor's channel (of that capacity) never refuses one,
/// and the ones refused here are counted exactly.
#[derive(Debug)]
struct CountingProcessor {
    inner: BatchSpanProcessor,
    max_queue: u64,
}

impl SpanProcessor for CountingProcessor {
    fn on_start(&self, span: &mut opentelemetry_sdk::trace::Span, cx: &opentelemetry::Context) {
        self.inner.on_start(span, cx);
    }

    fn on_end(&self, span: SpanData) {
        if IN_QUEUE.fetch_add(1, Ordering::AcqRel) >= self.max_queue {
            IN_QUEUE.fetch_sub(1, Ordering::AcqRel);
            QUEUE_FULL.fetch_add(1, Ordering::Relaxed);
            return;
        }
        self.inner.on_end(span);
    }

    fn force_flush(&self) -> OTelSdkResult {
        self.inner.force_flush()
    }

    fn shutdown_with_timeout(&self, timeout: Duration) -> OTelSdkResult {
        let r = self.inner.shutdown_with_timeout(timeout);
        // Whatever the batch still held when shutdown gave up is lost.
        QUEUE_FULL.fetch_add(IN_QUEUE.swap(0, Ordering::AcqRel), Ordering::Relaxed);
        r
    }

    fn set_resource(&mut self, resource: &opentelemetry_sdk::Resource) {
        self.inner.set_resource(resource);
    }
}

/// Wraps the OTLP exporter: spans leave the queue when handed over, and count as exported or
/// failed by the request's outcome.
#[derive(Debug)]
struct CountingExporter<E>(E);

impl<E: SpanExporter> SpanExporter for CountingExporter<E> {
    fn export(
        &self,
        batch: Vec<SpanData>,
    ) -> impl std::future::Future<Output = OTelSdkResult> + Send {
        let n = batch.len() as u64;
        IN_QUEUE.fetch_sub(n, Ordering::AcqRel);
        let fut = self.0.export(batch);
        async move {
            let r = fut.await;
            match &r {
                Ok(()) => EXPORTED.fetch_add(n, Ordering::Relaxed),
                Err(_) => EXPORT_FAILED.fetch_add(n, Ordering::Relaxed),
            };
            r
        }
    }

    fn shutdown_with_timeout(&self, timeout: Duration) -> OTelSdkResult {
        self.0.shutdown_with_timeout(timeout)
    }

    fn force_flush(&self) -> OTelSdkResult {
        self.0.force_flush()
    }

    fn set_resource(&mut self, resource: &opentelemetry_sdk::Resource) {
        self.0.set_resource(resource);
    }
}

/// Keeps the tracer and meter providers alive; `shutdown` flushes the last spans and metrics
/// (call it on SIGTERM).
#[derive(Default)]
pub struct Telemetry {
    provider: Option<SdkTracerProvider>,
    meters: Option<SdkMeterProvider>,
}

impl Telemetry {
    pub fn exporting(&self) -> bool {
        self.provider.is_some()
    }
    pub fn flush(&self) {
        if let Some(p) = &self.provider
            && let Err(e) = p.force_flush()
        {
            tracing::warn!(error = %e, "flushing spans failed");
        }
    }
    pub fn shutdown(&mut self) {
        let Some(p) = self.provider.take() else {
            return;
        };
        if let Err(e) = p.force_flush() {
            tracing::warn!(error = %e, "flushing spans failed");
        }
        let _ = p.shutdown();
        // After the spans, so the last metrics carry the final span counts.
        if let Some(m) = self.meters.take()
            && let Err(e) = m.shutdown()
        {
            tracing::warn!(error = %e, "exporting the last metrics failed");
        }
        ENABLED.store(false, Ordering::Relaxed);
        let c = span_counts();
        tracing::info!(
            spans_exported = c.exported,
            spans_dropped = c.dropped(),
            queue_full = c.queue_full,
            export_failed = c.export_failed,
            "telemetry shut down"
        );
    }
}

static DEFAULT_CONSOLE_LEVEL: std::sync::OnceLock<&'static str> = std::sync::OnceLock::new();

/// The console log level used when RUST_LOG is not set (default "info"); call before `init`.
pub fn set_default_console_level(level: &'static str) {
    let _ = DEFAULT_CONSOLE_LEVEL.set(level);
}

fn console_filter() -> tracing_subscriber::EnvFilter {
    tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| {
        tracing_subscriber::EnvFilter::new(DEFAULT_CONSOLE_LEVEL.get().copied().unwrap_or("info"))
    })
}

/// The root sampler: navigation lines from the frontseat start at most `per_s` traces a second;
/// every other root follows the ratio. Children follow their root (ParentBased around it).
#[derive(Clone, Debug)]
pub struct NavRateSampler {
    per_s: f64,
    ratio: Sampler,
    window: std::sync::Arc<std::sync::Mutex<(std::time::Instant, f64)>>,
}

/// A line that is navigation, in the protocols we drive: the basic simulator's NAV, Bluefin's
/// NVG/NVR, Iver's compass and status lines.
pub fn is_nav_line(line: &str) -> bool {
    ["NAV,", "$BFNVG", "$BFNVR", "$C", "$OSI"]
        .iter()
        .any(|p| line.starts_with(p))
}

impl NavRateSampler {
    pub fn new(per_s: f64, ratio: f64) -> Self {
        Self {
            per_s,
            ratio: Sampler::TraceIdRatioBased(ratio),
            window: std::sync::Arc::new(std::sync::Mutex::new((std::time::Instant::now(), 0.0))),
        }
    }

    fn take_nav(&self) -> bool {
        let mut w = self.window.lock().unwrap_or_else(|p| p.into_inner());
        let now = std::time::Instant::now();
        if now.duration_since(w.0) >= std::time::Duration::from_secs(1) {
            *w = (now, 0.0);
        }
        if w.1 < self.per_s {
            w.1 += 1.0;
            true
        } else {
            false
        }
    }
}

impl opentelemetry_sdk::trace::ShouldSample for NavRateSampler {
    fn should_sample(
        &self,
        parent: Option<&opentelemetry::Context>,
        trace_id: opentelemetry::trace::TraceId,
        name: &str,
        kind: &opentelemetry::trace::SpanKind,
        attributes: &[opentelemetry::KeyValue],
        links: &[opentelemetry::trace::Link],
    ) -> opentelemetry_sdk::trace::SamplingResult {
        let nav = name == "frontseat.socket_read"
            && attributes
                .iter()
                .any(|kv| kv.key.as_str() == "line" && is_nav_line(&kv.value.as_str()));
        if !nav {
            return self
                .ratio
                .should_sample(parent, trace_id, name, kind, attributes, links);
        }
        let decision = if self.take_nav() {
            opentelemetry_sdk::trace::SamplingDecision::RecordAndSample
        } else {
            opentelemetry_sdk::trace::SamplingDecision::Drop
        };
        opentelemetry_sdk::trace::SamplingResult {
            decision,
            attributes: Vec::new(),
            trace_state: Default::default(),
        }
    }
}

/// The standard OTEL_TRACES_SAMPLER values (the ratio from OTEL_TRACES_SAMPLER_ARG).
fn standard_sampler(name: &str, ratio: f64) -> Option<Sampler> {
    Some(match name {
        "always_on" => Sampler::AlwaysOn,
        "always_off" => Sampler::AlwaysOff,
        "traceidratio" => Sampler::TraceIdRatioBased(ratio),
        "parentbased_always_on" => Sampler::ParentBased(Box::new(Sampler::AlwaysOn)),
        "parentbased_always_off" => Sampler::ParentBased(Box::new(Sampler::AlwaysOff)),
        "parentbased_traceidratio" => {
            Sampler::ParentBased(Box::new(Sampler::TraceIdRatioBased(ratio)))
        }
        _ => return None,
    })
}

/// The sampler a resolved config asks for.
pub fn sampler_for(r: &Resolved) -> Sampler {
    if let Some(name) = &r.standard_sampler {
        match standard_sampler(name, r.sampling_ratio) {
            Some(s) => return s,
            None => {
                tracing::warn!(sampler = %name, "unknown OTEL_TRACES_SAMPLER; using frontseat's")
            }
        }
    }
    match r.nav_traces_per_s {
        Some(per_s) => Sampler::ParentBased(Box::new(NavRateSampler::new(per_s, r.sampling_ratio))),
        None => Sampler::ParentBased(Box::new(Sampler::TraceIdRatioBased(r.sampling_ratio))),
    }
}

fn resource_for(service_name: Option<String>) -> opentelemetry_sdk::Resource {
    let mut resource = opentelemetry_sdk::Resource::builder();
    if let Some(name) = service_name {
        resource = resource.with_service_name(name.clone()).with_attribute(
            // Phoenix ignores service.name and picks its project from this attribute.
            opentelemetry::KeyValue::new("openinference.project.name", name),
        );
    }
    resource.build()
}

fn provider_with<E: SpanExporter + 'static>(
    exporter: E,
    service_name: Option<String>,
    sampler: Sampler,
    batch: Option<BatchSizes>,
) -> SdkTracerProvider {
    let b = SdkTracerProvider::builder()
        .with_resource(resource_for(service_name))
        .with_sampler(sampler);
    match batch {
        Some(sizes) => {
            let config = BatchConfigBuilder::default()
                .with_max_queue_size(sizes.max_queue_size)
                .with_max_export_batch_size(sizes.max_export_batch_size)
                .with_scheduled_delay(sizes.scheduled_delay)
                .build();
            let inner = BatchSpanProcessor::builder(CountingExporter(exporter))
                .with_batch_config(config)
                .build();
            b.with_span_processor(CountingProcessor {
                inner,
                max_queue: sizes.max_queue_size as u64,
            })
            .build()
        }
        None => b.with_simple_exporter(exporter).build(),
    }
}

/// The metrics pipeline: an OTLP/HTTP metric exporter read every `metrics_interval`.
fn meter_provider(r: &Resolved) -> Result<SdkMeterProvider, String> {
    let mut builder = opentelemetry_otlp::MetricExporter::builder().with_http();
    if let Some(ep) = &r.metrics_endpoint {
        use opentelemetry_otlp::WithExportConfig;
        builder = builder.with_endpoint(ep.clone());
    }
    let exporter = builder.build().map_err(|e| e.to_string())?;
    let reader = opentelemetry_sdk::metrics::PeriodicReader::builder(exporter)
        .with_interval(r.metrics_interval)
        .build();
    let provider = SdkMeterProvider::builder()
        .with_resource(resource_for(r.service_name.clone()))
        .with_reader(reader)
        .build();
    use opentelemetry::metrics::MeterProvider as _;
    crate::metrics::install(&provider.meter("frontseat"), || {
        let c = span_counts();
        (c.exported, c.dropped())
    });
    Ok(provider)
}

/// Installs the global subscriber: console logs always, OTLP export when resolved. `role` is
/// the binary's role ("interface", "sim", …) and `platform` the vehicle name, for the default
/// service name.
pub fn init(cfg: &TelemetryConfig, role: &str, platform: &str) -> Telemetry {
    use std::io::IsTerminal;
    let default_service = if platform.is_empty() {
        format!("frontseat-{role}")
    } else {
        format!("frontseat-{role}-{platform}")
    };
    let fmt = tracing_subscriber::fmt::layer()
        .with_ansi(std::io::stderr().is_terminal())
        .with_writer(std::io::stderr)
        .with_filter(console_filter());
    let resolved = resolve(cfg, &default_service, |k| std::env::var(k).ok());
    let Some(r) = resolved else {
        let _ = tracing_subscriber::registry().with(fmt).try_init();
        return Telemetry::default();
    };
    let mut builder = opentelemetry_otlp::SpanExporter::builder().with_http();
    if let Some(ep) = &r.endpoint {
        use opentelemetry_otlp::WithExportConfig;
        builder = builder.with_endpoint(ep.clone());
    }
    let exporter = match builder.build() {
        Ok(e) => e,
        Err(e) => {
            let _ = tracing_subscriber::registry().with(fmt).try_init();
            tracing::error!(error = %e, "cannot build the OTLP exporter; traces are off");
            return Telemetry::default();
        }
    };
    let provider = provider_with(
        exporter,
        r.service_name.clone(),
        sampler_for(&r),
        Some(r.batch),
    );
    install(fmt, &provider);
    let meters = match r.metrics.then(|| meter_provider(&r)) {
        None => None,
        Some(Ok(m)) => Some(m),
        Some(Err(e)) => {
            tracing::error!(error = %e, "cannot build the OTLP metric exporter; metrics are off");
            None
        }
    };
    tracing::info!(
        endpoint = r
            .endpoint
            .as_deref()
            .unwrap_or("(from OTEL_EXPORTER_OTLP_*)"),
        service = r
            .service_name
            .as_deref()
            .unwrap_or("(from OTEL_SERVICE_NAME)"),
        sampling_ratio = r.sampling_ratio,
        max_queue_size = r.batch.max_queue_size,
        max_export_batch_size = r.batch.max_export_batch_size,
        scheduled_delay = ?r.batch.scheduled_delay,
        metrics_interval = ?r.metrics_interval,
        metrics = r.metrics,
        "exporting traces (and metrics, when metrics=true) over OTLP/HTTP"
    );
    Telemetry {
        provider: Some(provider),
        meters,
    }
}

/// For tests: console logs plus export to `exporter` (e.g. the SDK's in-memory exporter),
/// every span sampled, exported as it ends.
pub fn init_with_exporter<E: SpanExporter + 'static>(exporter: E, service: &str) -> Telemetry {
    let fmt = tracing_subscriber::fmt::layer()
        .with_writer(std::io::stderr)
        .with_filter(console_filter());
    let provider = provider_with(
        exporter,
        Some(service.to_string()),
        Sampler::ParentBased(Box::new(Sampler::AlwaysOn)),
        None,
    );
    install(fmt, &provider);
    Telemetry {
        provider: Some(provider),
        meters: None,
    }
}

fn install<L>(fmt: L, provider: &SdkTracerProvider)
where
    L: Layer<tracing_subscriber::Registry> + Send + Sync + 'static,
{
    let tracer = provider.tracer("frontseat");
    let otel = tracing_opentelemetry::layer()
        .with_tracer(tracer)
        .with_filter(
            tracing_subscriber::filter::Targets::new()
                .with_target("frontseat", tracing::Level::TRACE)
                .with_target("frontseat_actors", tracing::Level::TRACE)
                .with_target("frontseat_helm_side", tracing::Level::TRACE)
                .with_target("frontseat_sim", tracing::Level::INFO),
        );
    if tracing_subscriber::registry()
        .with(fmt)
        .with(otel)
        .try_init()
        .is_ok()
    {
        ENABLED.store(true, Ordering::Relaxed);
    }
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

    fn cfg() -> TelemetryConfig {
        TelemetryConfig::default()
    }

    fn env<'a>(vars: &'a [(&'a str, &'a str)]) -> impl Fn(&str) -> Option<String> + 'a {
        move |k| {
            vars.iter()
                .find(|(n, _)| *n == k)
                .map(|(_, v)| v.to_string())
        }
    }

    #[test]
    fn off_by_default() {
        assert_eq!(resolve(&cfg(), "svc", env(&[])), None);
    }

    #[test]
    fn env_endpoint_turns_export_on_and_is_left_to_the_exporter() {
        let r = resolve(
            &cfg(),
            "svc",
            env(&[("OTEL_EXPORTER_OTLP_ENDPOINT", "http://h:4318")]),
        )
        .unwrap();
        assert_eq!(r.endpoint, None);
        assert_eq!(r.service_name.as_deref(), Some("svc"));
        let r = resolve(
            &cfg(),
            "svc",
            env(&[(
                "OTEL_EXPORTER_OTLP_TRACES_ENDPOINT",
                "http://h:4318/v1/traces",
            )]),
        )
        .unwrap();
        assert_eq!(r.endpoint, None);
    }

    #[test]
    fn config_wins_where_both_say_something() {
        let mut c = cfg();
        c.enabled = true;
        c.endpoint = "http://127.0.0.1:6006".into();
        c.service_name = "mine".into();
        c.sampling_ratio = 0.5;
        let r = resolve(
            &c,
            "svc",
            env(&[
                ("OTEL_EXPORTER_OTLP_ENDPOINT", "http://other:4318"),
                ("OTEL_SERVICE_NAME", "theirs"),
                ("OTEL_TRACES_SAMPLER_ARG", "0.1"),
            ]),
        )
        .unwrap();
        assert_eq!(
            r.endpoint.as_deref(),
            Some("http://127.0.0.1:6006/v1/traces")
        );
        assert_eq!(r.service_name.as_deref(), Some("mine"));
        assert_eq!(r.sampling_ratio, 0.5);
    }

    #[test]
    fn env_fills_what_config_leaves_default() {
        let mut c = cfg();
        c.enabled = true;
        let r = resolve(
            &c,
            "svc",
            env(&[
                ("OTEL_SERVICE_NAME", "theirs"),
                ("OTEL_TRACES_SAMPLER_ARG", "0.25"),
            ]),
        )
        .unwrap();
        assert_eq!(
            r.endpoint.as_deref(),
            Some("http://127.0.0.1:4318/v1/traces")
        );
        assert_eq!(
            r.service_name.as_deref(),
            Some("theirs"),
            "from OTEL_SERVICE_NAME"
        );
        assert_eq!(r.sampling_ratio, 0.25);
        let r = resolve(&c, "svc", env(&[("OTEL_TRACES_SAMPLER_ARG", "7")])).unwrap();
        assert_eq!(r.sampling_ratio, 1.0, "out-of-range env ratio ignored");
    }

    #[test]
    fn truncates_on_a_char_boundary() {
        let long = "é".repeat(200);
        assert_eq!(truncate(&long).chars().count(), 120);
        assert_eq!(truncate("NAV,LAT:1"), "NAV,LAT:1");
    }

    #[test]
    fn navigation_is_sampled_and_everything_else_kept() {
        use opentelemetry::KeyValue;
        use opentelemetry::trace::{SpanKind, TraceId};
        use opentelemetry_sdk::trace::{SamplingDecision, ShouldSample};
        let s = NavRateSampler::new(3.0, 1.0);
        let decide = |name: &str, line: &str| {
            s.should_sample(
                None,
                TraceId::from_bytes([7; 16]),
                name,
                &SpanKind::Internal,
                &[KeyValue::new("line", line.to_string())],
                &[],
            )
            .decision
        };
        let navs: Vec<_> = (0..10)
            .map(|_| decide("frontseat.socket_read", "NAV,LAT:1,LON:2"))
            .collect();
        assert_eq!(
            navs.iter()
                .filter(|d| **d == SamplingDecision::RecordAndSample)
                .count(),
            3,
            "at most 3 NAV traces in the second"
        );
        for (name, line) in [
            ("frontseat.socket_read", "CTRL,STATE:PAYLOAD"),
            ("frontseat.socket_read", "CMD,RESULT:OK"),
            ("helm.setpoint", ""),
            ("moos.mail", ""),
        ] {
            assert_eq!(
                decide(name, line),
                SamplingDecision::RecordAndSample,
                "{name} {line}"
            );
        }
        assert!(is_nav_line("$BFNVG,1") && is_nav_line("NAV,") && !is_nav_line("CTRL,"));
    }

    #[test]
    fn metrics_follow_the_traces_endpoint() {
        let mut c = cfg();
        c.enabled = true;
        c.endpoint = "http://127.0.0.1:6006/".into();
        let r = resolve(&c, "svc", env(&[])).unwrap();
        assert_eq!(
            r.metrics_endpoint.as_deref(),
            Some("http://127.0.0.1:6006/v1/metrics")
        );
        let r = resolve(
            &cfg(),
            "svc",
            env(&[("OTEL_EXPORTER_OTLP_ENDPOINT", "http://h:4318")]),
        )
        .unwrap();
        assert_eq!(r.metrics_endpoint, None, "left to the exporter");
        let r = resolve(
            &cfg(),
            "svc",
            env(&[(
                "OTEL_EXPORTER_OTLP_TRACES_ENDPOINT",
                "http://h:4318/v1/traces",
            )]),
        )
        .unwrap();
        assert_eq!(
            r.metrics_endpoint.as_deref(),
            Some("http://h:4318/v1/metrics"),
            "only a traces URL: the metrics go to the same collector"
        );
    }

    #[test]
    fn batch_sizes_and_interval_from_config_else_environment() {
        let mut c = cfg();
        c.enabled = true;
        let r = resolve(&c, "svc", env(&[])).unwrap();
        assert_eq!(
            r.batch,
            BatchSizes {
                max_queue_size: 16_384,
                max_export_batch_size: 1_024,
                scheduled_delay: Duration::from_millis(500),
            }
        );
        assert_eq!(r.metrics_interval, Duration::from_secs(10));
        assert!(r.metrics);
        let off = resolve(&c, "svc", env(&[("OTEL_METRICS_EXPORTER", "none")])).unwrap();
        assert!(!off.metrics, "OTEL_METRICS_EXPORTER=none");
        let vars = [
            ("OTEL_BSP_MAX_QUEUE_SIZE", "100"),
            ("OTEL_BSP_MAX_EXPORT_BATCH_SIZE", "500"),
            ("OTEL_BSP_SCHEDULE_DELAY", "50"),
            ("OTEL_METRIC_EXPORT_INTERVAL", "250"),
        ];
        let r = resolve(&c, "svc", env(&vars)).unwrap();
        assert_eq!(r.batch.max_queue_size, 100);
        assert_eq!(r.batch.max_export_batch_size, 100, "never above the queue");
        assert_eq!(r.batch.scheduled_delay, Duration::from_millis(50));
        assert_eq!(r.metrics_interval, Duration::from_millis(250));
        c.max_queue_size = 4096;
        c.scheduled_delay_ms = 2000;
        c.metrics_interval_s = 1.0;
        let r = resolve(&c, "svc", env(&vars)).unwrap();
        assert_eq!(r.batch.max_queue_size, 4096, "the config wins");
        assert_eq!(r.batch.max_export_batch_size, 500);
        assert_eq!(r.batch.scheduled_delay, Duration::from_secs(2));
        assert_eq!(r.metrics_interval, Duration::from_secs(1));
    }

    /// An exporter that fails every request.
    #[derive(Debug)]
    struct Refusing;

    impl SpanExporter for Refusing {
        async fn export(&self, _batch: Vec<SpanData>) -> OTelSdkResult {
            Err(opentelemetry_sdk::error::OTelSdkError::InternalFailure(
                "collector down".into(),
            ))
        }
    }

    /// A collector that holds every request until the test opens the gate.
    #[derive(Debug, Clone, Default)]
    struct Gated {
        open: std::sync::Arc<(std::sync::Mutex<bool>, std::sync::Condvar)>,
        got: std::sync::Arc<AtomicU64>,
    }

    impl Gated {
        fn open(&self) {
            let (m, cv) = &*self.open;
            *m.lock().unwrap() = true;
            cv.notify_all();
        }
    }

    impl SpanExporter for Gated {
        async fn export(&self, batch: Vec<SpanData>) -> OTelSdkResult {
            let (m, cv) = &*self.open;
            let mut open = m.lock().unwrap();
            while !*open {
                open = cv.wait(open).unwrap();
            }
            self.got.fetch_add(batch.len() as u64, Ordering::Relaxed);
            Ok(())
        }
    }

    /// The only test touching the process-wide counters: every span ends up exported, dropped at
    /// the queue, or failed, and the totals say which.
    #[test]
    fn every_span_is_counted_as_exported_or_dropped() {
        use opentelemetry::trace::{Tracer as _, TracerProvider as _};
        let sizes = BatchSizes {
            max_queue_size: 4,
            max_export_batch_size: 4,
            scheduled_delay: Duration::from_secs(3600),
        };
        let before = span_counts();
        let gated = Gated::default();
        let p = provider_with(gated.clone(), None, Sampler::AlwaysOn, Some(sizes));
        let tracer = p.tracer("t");
        // The first full batch blocks in the exporter; 4 more fit the queue; the rest is refused.
        for i in 0..20 {
            drop(tracer.start(format!("s{i}")));
        }
        gated.open();
        p.force_flush().unwrap();
        let mid = span_counts();
        let exported = mid.exported - before.exported;
        let refused = mid.queue_full - before.queue_full;
        assert_eq!(exported + refused, 20, "{mid:?}");
        assert!(refused >= 12, "at most 8 of 20 spans fit: {mid:?}");
        assert_eq!(gated.got.load(Ordering::Relaxed), exported);
        let _ = p.shutdown();

        let p = provider_with(Refusing, None, Sampler::AlwaysOn, Some(sizes));
        let tracer = p.tracer("t");
        for i in 0..3 {
            drop(tracer.start(format!("f{i}")));
        }
        let _ = p.force_flush();
        let end = span_counts();
        assert_eq!(end.export_failed - mid.export_failed, 3);
        assert_eq!(end.exported, mid.exported);
        assert_eq!(end.dropped() - mid.dropped(), 3);
        let _ = p.shutdown();
    }

    #[test]
    fn otel_traces_sampler_wins() {
        let c = TelemetryConfig {
            enabled: true,
            ..Default::default()
        };
        let r = resolve(&c, "svc", env(&[])).unwrap();
        assert_eq!(r.nav_traces_per_s, Some(10.0));
        assert!(r.standard_sampler.is_none());
        let r = resolve(&c, "svc", env(&[("OTEL_TRACES_SAMPLER", "always_on")])).unwrap();
        assert_eq!(r.nav_traces_per_s, None);
        assert!(matches!(sampler_for(&r), Sampler::AlwaysOn));
    }
}
