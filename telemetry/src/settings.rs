//! Where and how telemetry goes: `[telemetry]` combined with the standard `OTEL_*` environment
//! variables (endpoints for traces and metrics, service name, sampling, batch sizes, metrics
//! interval). Pure: the environment comes in as a function, so the tests give their own.

use std::time::Duration;

use frontseat_config::TelemetryConfig;

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

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    fn cfg() -> TelemetryConfig {
        TelemetryConfig::default()
    }

    pub(crate) fn env<'a>(vars: &'a [(&'a str, &'a str)]) -> impl Fn(&str) -> Option<String> + 'a {
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
}
