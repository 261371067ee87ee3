//! Logs and traces for every frontseat process: console logs (tracing-subscriber with an env
//! filter, no colours off a TTY) always, and OpenTelemetry traces exported over OTLP/HTTP when the
//! config's `[telemetry]` or the standard `OTEL_*` environment variables ask for it.
//!
//! The hop spans (socket read, decode, bus publish, bus delivery, handling, socket write) are at
//! TRACE level and only the OpenTelemetry layer enables them, so with telemetry off they cost one
//! disabled-callsite check. Trace context crosses the bus in the envelope as a W3C traceparent (and
//! within a process also through ractor's message span propagation), so a subscriber's span is a
//! child of the publisher's, fan-out included.

use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, Ordering};

use frontseat_config::TelemetryConfig;
use opentelemetry::propagation::TextMapPropagator;
use opentelemetry::trace::TracerProvider as _;
use opentelemetry_sdk::propagation::TraceContextPropagator;
use opentelemetry_sdk::trace::{Sampler, SdkTracerProvider, SpanExporter};
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
}

const DEFAULT_ENDPOINT: &str = "http://127.0.0.1:4318";

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
    })
}

/// Keeps the tracer provider alive; `shutdown` flushes the last spans (call it on SIGTERM).
#[derive(Default)]
pub struct Telemetry {
    provider: Option<SdkTracerProvider>,
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
        if let Some(p) = self.provider.take() {
            if let Err(e) = p.force_flush() {
                tracing::warn!(error = %e, "flushing spans failed");
            }
            let _ = p.shutdown();
        }
        ENABLED.store(false, Ordering::Relaxed);
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

fn provider_with<E: SpanExporter + 'static>(
    exporter: E,
    service_name: Option<String>,
    sampler: Sampler,
    batch: bool,
) -> SdkTracerProvider {
    let mut resource = opentelemetry_sdk::Resource::builder();
    if let Some(name) = service_name {
        resource = resource.with_service_name(name.clone()).with_attribute(
            // Phoenix ignores service.name and picks its project from this attribute.
            opentelemetry::KeyValue::new("openinference.project.name", name),
        );
    }
    let b = SdkTracerProvider::builder()
        .with_resource(resource.build())
        .with_sampler(sampler);
    if batch {
        b.with_batch_exporter(exporter).build()
    } else {
        b.with_simple_exporter(exporter).build()
    }
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
    let provider = provider_with(exporter, r.service_name.clone(), sampler_for(&r), true);
    install(fmt, &provider);
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
        "exporting traces over OTLP/HTTP"
    );
    Telemetry {
        provider: Some(provider),
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
        false,
    );
    install(fmt, &provider);
    Telemetry {
        provider: Some(provider),
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
                .with_target("frontseat_gateway", tracing::Level::TRACE)
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
