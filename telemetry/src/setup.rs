//! Setting a process up: the global subscriber (console logs always, OTLP export of traces and
//! metrics when the resolved settings ask for it), the test variant with a given exporter, and
//! the handle whose shutdown flushes what is left and logs the final span counts.

use std::sync::atomic::Ordering;

use frontseat_config::TelemetryConfig;
use opentelemetry::trace::TracerProvider as _;
use opentelemetry_sdk::metrics::SdkMeterProvider;
use opentelemetry_sdk::trace::{Sampler, SdkTracerProvider, SpanExporter};
use tracing_subscriber::Layer;
use tracing_subscriber::layer::SubscriberExt;
use tracing_subscriber::util::SubscriberInitExt;

use crate::context::ENABLED;
use crate::export::{provider_with, resource_for, span_counts};
use crate::sampling::sampler_for;
use crate::settings::{Resolved, resolve};

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
            tracing::warn!(target: crate::LOG_TARGET, error = %e, "flushing spans failed");
        }
    }
    pub fn shutdown(&mut self) {
        let Some(p) = self.provider.take() else {
            return;
        };
        if let Err(e) = p.force_flush() {
            tracing::warn!(target: crate::LOG_TARGET, error = %e, "flushing spans failed");
        }
        let _ = p.shutdown();
        // After the spans, so the last metrics carry the final span counts.
        if let Some(m) = self.meters.take()
            && let Err(e) = m.shutdown()
        {
            tracing::warn!(target: crate::LOG_TARGET, error = %e, "exporting the last metrics failed");
        }
        ENABLED.store(false, Ordering::Relaxed);
        let c = span_counts();
        tracing::info!(
            target: crate::LOG_TARGET,
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
            tracing::error!(target: crate::LOG_TARGET, error = %e, "cannot build the OTLP exporter; traces are off");
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
            tracing::error!(target: crate::LOG_TARGET, error = %e, "cannot build the OTLP metric exporter; metrics are off");
            None
        }
    };
    tracing::info!(
        target: crate::LOG_TARGET,
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
