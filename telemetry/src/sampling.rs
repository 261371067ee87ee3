//! Which traces are kept: at most so many navigation traces a second (a vehicle's NAV lines
//! would otherwise flood the collector), every other root by the ratio, or the standard
//! OTEL_TRACES_SAMPLER when the environment names one.

use opentelemetry_sdk::trace::Sampler;

use crate::settings::Resolved;

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
                tracing::warn!(target: crate::LOG_TARGET, sampler = %name, "unknown OTEL_TRACES_SAMPLER; using frontseat's")
            }
        }
    }
    match r.nav_traces_per_s {
        Some(per_s) => Sampler::ParentBased(Box::new(NavRateSampler::new(per_s, r.sampling_ratio))),
        None => Sampler::ParentBased(Box::new(Sampler::TraceIdRatioBased(r.sampling_ratio))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::settings::resolve;
    use crate::settings::tests::env;
    use frontseat_config::TelemetryConfig;

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
