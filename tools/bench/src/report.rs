//! The bench's results: one `Row` per measured path, the machine header, and the two outputs
//! (a Markdown table that can be pasted into BENCHMARKS.md / the README as is, and JSON).

use std::fmt::Write as _;
use std::time::Duration;

use hdrhistogram::Histogram;
use serde_json::{Value, json};

/// p50 / p99 / max of a set of durations.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Latency {
    pub p50: Duration,
    pub p99: Duration,
    pub max: Duration,
    pub samples: u64,
}

/// A histogram of nanoseconds from 1 ns to an hour (longer is recorded as an hour), 3
/// significant digits.
pub struct Hist(Histogram<u64>);

impl Hist {
    pub fn new() -> Self {
        // Constant, valid bounds: hdrhistogram refuses only low < 1, high < 2·low or more than
        // 5 significant figures.
        Self(
            Histogram::new_with_bounds(1, 3_600_000_000_000, 3)
                .expect("constant histogram bounds are valid"),
        )
    }

    pub fn record(&mut self, d: Duration) {
        let ns = u64::try_from(d.as_nanos()).unwrap_or(u64::MAX).max(1);
        self.0.saturating_record(ns);
    }

    pub fn latency(&self) -> Option<Latency> {
        if self.0.is_empty() {
            return None;
        }
        let ns = Duration::from_nanos;
        Some(Latency {
            p50: ns(self.0.value_at_quantile(0.50)),
            p99: ns(self.0.value_at_quantile(0.99)),
            max: ns(self.0.max()),
            samples: self.0.len(),
        })
    }
}

/// What a row shows.
#[derive(Clone, Debug)]
pub enum Figures {
    /// p50 / p99 / max, and a free-text detail.
    Latency(Latency),
    /// A rate or a footprint: the result column says it all.
    Result(String),
    /// The measurement could not be made; why.
    Failed(String),
}

#[derive(Clone, Debug)]
pub struct Row {
    pub id: &'static str,
    pub what: String,
    pub figures: Figures,
    /// How it was measured (samples, rates, what was lost).
    pub detail: String,
    /// Extra machine-readable fields for `--json`.
    pub extra: Value,
}

impl Row {
    pub fn failed(id: &'static str, what: impl Into<String>, why: impl Into<String>) -> Self {
        Self {
            id,
            what: what.into(),
            figures: Figures::Failed(why.into()),
            detail: String::new(),
            extra: Value::Null,
        }
    }

    pub fn is_failed(&self) -> bool {
        matches!(self.figures, Figures::Failed(_))
    }
}

/// The machine and build the figures come from.
#[derive(Clone, Debug)]
pub struct Machine {
    pub cpu: String,
    pub cores: usize,
    pub kernel: String,
    pub profile: &'static str,
    pub version: &'static str,
    /// 1-minute load average when the bench started: on a shared machine the figures depend on it.
    pub load: Option<f64>,
}

impl Machine {
    pub fn detect() -> Self {
        let cpu = std::fs::read_to_string("/proc/cpuinfo")
            .ok()
            .and_then(|s| {
                s.lines()
                    .find(|l| l.starts_with("model name"))
                    .and_then(|l| l.split_once(':'))
                    .map(|(_, v)| v.trim().to_string())
            })
            .unwrap_or_else(|| "unknown CPU".into());
        let cores = std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(1);
        let kernel = std::fs::read_to_string("/proc/sys/kernel/osrelease")
            .map(|s| format!("Linux {}", s.trim()))
            .unwrap_or_else(|_| std::env::consts::OS.to_string());
        Self {
            cpu,
            cores,
            kernel,
            profile: if cfg!(debug_assertions) {
                "debug"
            } else {
                "release"
            },
            version: env!("CARGO_PKG_VERSION"),
            load: std::fs::read_to_string("/proc/loadavg")
                .ok()
                .and_then(|s| s.split_whitespace().next()?.parse().ok()),
        }
    }
}

/// `41 µs`, `1.25 ms`, `2.10 s`.
pub fn fmt_duration(d: Duration) -> String {
    let us = d.as_secs_f64() * 1e6;
    if us < 10.0 {
        format!("{us:.1} µs")
    } else if us < 1000.0 {
        format!("{us:.0} µs")
    } else if us < 1e6 {
        format!("{:.2} ms", us / 1e3)
    } else {
        format!("{:.2} s", us / 1e6)
    }
}

/// `100000` → `100 000`: rates are easier to read with thousands separated.
pub fn fmt_count(n: f64) -> String {
    let s = format!("{:.0}", n.max(0.0));
    let mut out = String::new();
    for (i, c) in s.chars().enumerate() {
        if i > 0 && (s.len() - i) % 3 == 0 {
            out.push(' ');
        }
        out.push(c);
    }
    out
}

pub fn markdown(machine: &Machine, quick: bool, elapsed: Duration, rows: &[Row]) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "frontseat bench{} — frontseat {}, {} build",
        if quick {
            " --quick (rough figures)"
        } else {
            ""
        },
        machine.version,
        machine.profile
    );
    let _ = writeln!(
        s,
        "machine: {}, {} cores, {}; load average {} at start; ran {:.0} s\n",
        machine.cpu,
        machine.cores,
        machine.kernel,
        machine
            .load
            .map(|l| format!("{l:.2}"))
            .unwrap_or_else(|| "unknown".into()),
        elapsed.as_secs_f64()
    );
    let _ = writeln!(s, "| row | path | p50 | p99 | max | result / how |");
    let _ = writeln!(s, "|---|---|---:|---:|---:|---|");
    for r in rows {
        let (p50, p99, max, result) = match &r.figures {
            Figures::Latency(l) => (
                fmt_duration(l.p50),
                fmt_duration(l.p99),
                fmt_duration(l.max),
                r.detail.clone(),
            ),
            Figures::Result(text) => ("–".into(), "–".into(), "–".into(), join(text, &r.detail)),
            Figures::Failed(why) => (
                "–".into(),
                "–".into(),
                "–".into(),
                join(&format!("FAILED: {why}"), &r.detail),
            ),
        };
        let _ = writeln!(
            s,
            "| {} | {} | {p50} | {p99} | {max} | {} |",
            r.id,
            r.what,
            result.replace('|', "/")
        );
    }
    s
}

fn join(a: &str, b: &str) -> String {
    if b.is_empty() {
        a.to_string()
    } else {
        format!("{a}; {b}")
    }
}

pub fn json(machine: &Machine, quick: bool, elapsed: Duration, rows: &[Row]) -> Value {
    let us = |d: Duration| d.as_secs_f64() * 1e6;
    let rows: Vec<Value> = rows
        .iter()
        .map(|r| {
            let mut v = json!({ "id": r.id, "path": r.what, "detail": r.detail });
            match &r.figures {
                Figures::Latency(l) => {
                    v["p50_us"] = json!(us(l.p50));
                    v["p99_us"] = json!(us(l.p99));
                    v["max_us"] = json!(us(l.max));
                    v["samples"] = json!(l.samples);
                }
                Figures::Result(text) => v["result"] = json!(text),
                Figures::Failed(why) => v["failed"] = json!(why),
            }
            if let (Value::Object(extra), Value::Object(obj)) = (&r.extra, &mut v) {
                for (k, x) in extra {
                    obj.insert(k.clone(), x.clone());
                }
            }
            v
        })
        .collect();
    json!({
        "version": machine.version,
        "profile": machine.profile,
        "quick": quick,
        "machine": {
            "cpu": machine.cpu,
            "cores": machine.cores,
            "os": machine.kernel,
            "load_average_1m": machine.load,
        },
        "elapsed_s": elapsed.as_secs_f64(),
        "rows": rows,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn histogram_percentiles_and_formatting() {
        let mut h = Hist::new();
        assert!(h.latency().is_none());
        for us in 1..=100u64 {
            h.record(Duration::from_micros(us));
        }
        let l = h.latency().unwrap();
        assert_eq!(l.samples, 100);
        assert!(
            (49_900..=50_100).contains(&(l.p50.as_nanos() as i64)),
            "{l:?}"
        );
        assert!(l.max >= Duration::from_micros(100));
        h.record(Duration::from_secs(7200));
        assert!(h.latency().unwrap().max >= Duration::from_secs(3599));
        assert_eq!(fmt_duration(Duration::from_nanos(4_250)), "4.2 µs");
        assert_eq!(fmt_duration(Duration::from_micros(88)), "88 µs");
        assert_eq!(fmt_duration(Duration::from_micros(1250)), "1.25 ms");
        assert_eq!(fmt_count(100_000.0), "100 000");
        assert_eq!(fmt_count(999.0), "999");
    }
}
