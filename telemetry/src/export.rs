//! The span export pipeline and its bookkeeping: the tracer provider around the OTLP exporter,
//! whose batch processor and exporter are wrapped so that every span handed to them counts as
//! exported, dropped at a full queue or lost in a failed request; the process-wide counts.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use opentelemetry_sdk::error::OTelSdkResult;
use opentelemetry_sdk::trace::{
    BatchConfigBuilder, BatchSpanProcessor, Sampler, SdkTracerProvider, SpanData, SpanExporter,
    SpanProcessor,
};

use crate::context::enabled;
use crate::settings::BatchSizes;

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

pub(crate) fn resource_for(service_name: Option<String>) -> opentelemetry_sdk::Resource {
    let mut resource = opentelemetry_sdk::Resource::builder();
    if let Some(name) = service_name {
        resource = resource.with_service_name(name.clone()).with_attribute(
            // Phoenix ignores service.name and picks its project from this attribute.
            opentelemetry::KeyValue::new("openinference.project.name", name),
        );
    }
    resource.build()
}

pub(crate) fn provider_with<E: SpanExporter + 'static>(
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

#[cfg(test)]
mod tests {
    use super::*;

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
}
