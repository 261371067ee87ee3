//! The report a run ends with: per fault kind what was measured, the invariants table, the
//! violations and notes, and its rendering as Markdown (what `frontseat chaos` prints).

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::time::Duration;

use crate::plan::FaultKind;
use crate::resources::Sample;

/// One row of the invariants table.
#[derive(Clone, Debug, PartialEq)]
pub struct Invariant {
    pub name: &'static str,
    pub bound: String,
    pub measured: String,
    pub ok: bool,
}

/// Per fault kind: how often, how long until COMMAND again after the fault cleared, and how
/// long the interface was out of COMMAND from injection to recovery (non-burst faults only).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct KindStats {
    pub injected: u32,
    pub recoveries: Vec<Duration>,
    pub outages: Vec<Duration>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct ChaosReport {
    pub seed: u64,
    pub warp: f64,
    pub faults: u32,
    pub moos: bool,
    pub wall: Duration,
    pub by_kind: BTreeMap<FaultKind, KindStats>,
    pub invariants: Vec<Invariant>,
    /// Every violation, with the fault number and kind where it happened.
    pub violations: Vec<String>,
    pub notes: Vec<String>,
    /// Resource samples, one per `sample_every` (and one at the start and the end).
    pub samples: Vec<Sample>,
}

impl ChaosReport {
    pub fn passed(&self) -> bool {
        self.violations.is_empty() && self.invariants.iter().all(|i| i.ok)
    }

    /// The report as Markdown: run line, faults table, invariants table, violations.
    pub fn render(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "frontseat chaos: seed {}, {} faults, warp {}, MOOS {}, {:.1} s wall",
            self.seed,
            self.faults,
            self.warp,
            if self.moos { "on" } else { "off" },
            self.wall.as_secs_f64()
        );
        let _ = writeln!(s);
        let _ = writeln!(
            s,
            "| fault | injected | measured | left COMMAND | out of COMMAND p50 / max | back in COMMAND after clear p50 / max |"
        );
        let _ = writeln!(s, "|---|---:|---:|---:|---|---|");
        let pm = |v: &[Duration]| {
            let mut v = v.to_vec();
            v.sort();
            match v.last() {
                Some(max) => format!("{} / {}", fmt_ms(percentile(&v, 50.0)), fmt_ms(*max)),
                None => "—".to_string(),
            }
        };
        for (k, st) in &self.by_kind {
            let left = st.outages.iter().filter(|d| !d.is_zero()).count();
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} | {} |",
                k.name(),
                st.injected,
                st.recoveries.len(),
                left,
                pm(&st.outages),
                pm(&st.recoveries)
            );
        }
        let _ = writeln!(s);
        let _ = writeln!(s, "| invariant | bound | measured | result |");
        let _ = writeln!(s, "|---|---|---|---|");
        for i in &self.invariants {
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} |",
                i.name,
                i.bound,
                i.measured,
                if i.ok { "PASS" } else { "FAIL" }
            );
        }
        if !self.samples.is_empty() {
            let _ = writeln!(
                s,
                "\n| t (wall) | faults | RSS MiB | open fds | threads | tasks | bus subscriptions |"
            );
            let _ = writeln!(s, "|---:|---:|---:|---:|---:|---:|---:|");
            let o = |v: Option<u64>| v.map_or("?".to_string(), |v| v.to_string());
            for x in &self.samples {
                let _ = writeln!(
                    s,
                    "| {:.0} s | {} | {} | {} | {} | {} | {} |",
                    x.at.as_secs_f64(),
                    x.faults,
                    x.rss_kib
                        .map_or("?".into(), |k| format!("{:.1}", k as f64 / 1024.0)),
                    o(x.fds),
                    o(x.threads),
                    x.tasks,
                    x.subscriptions
                );
            }
        }
        for n in &self.notes {
            let _ = writeln!(s, "\nnote: {n}");
        }
        if !self.violations.is_empty() {
            let _ = writeln!(s, "\nviolations ({}):", self.violations.len());
            for v in self.violations.iter().take(50) {
                let _ = writeln!(s, "- {v}");
            }
        }
        let _ = writeln!(
            s,
            "\nresult: {}",
            if self.passed() { "PASS" } else { "FAIL" }
        );
        s
    }
}

pub(crate) fn percentile(sorted: &[Duration], p: f64) -> Duration {
    if sorted.is_empty() {
        return Duration::ZERO;
    }
    let i = ((p / 100.0) * (sorted.len() - 1) as f64).round() as usize;
    sorted[i.min(sorted.len() - 1)]
}

pub(crate) fn fmt_ms(d: Duration) -> String {
    format!("{:.0} ms", d.as_secs_f64() * 1000.0)
}
