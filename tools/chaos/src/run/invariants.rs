//! The invariants table the run ends with: one row per thing that must hold — recovery, the five
//! states, one answer per request, bounded resources, no escaped panic, restarts as injected, a
//! clean end, and what each kind of helm-side fault must leave alone — in the order the report
//! prints them.

use std::sync::atomic::Ordering;
use std::time::Duration;

use frontseat_actors::interface::{ServiceExit, Snapshot};

use super::tally::Tally;
use crate::monitor::Monitor;
use crate::options::ChaosOptions;
use crate::panics;
use crate::plan::FaultKind;
use crate::report::{Invariant, fmt_ms, percentile};
use crate::resources::Sample;

/// What the end of the run measured, beside what the run itself holds.
pub(super) struct End<'a> {
    /// From the last fault's clearing to COMMAND held; None past the bound.
    pub(super) final_recovery: Option<Duration>,
    /// Requests the helm sent.
    pub(super) sent: i32,
    /// The interface's last snapshot, before it was shut down.
    pub(super) snapshot: Option<Snapshot>,
    pub(super) exit: ServiceExit,
    pub(super) rss_baseline: Option<u64>,
    pub(super) rss_max: u64,
    pub(super) samples: &'a [Sample],
}

/// Every row, in the report's order; a note where a row cannot be measured.
pub(super) fn table(
    t: &Tally,
    monitor: &Monitor,
    opts: &ChaosOptions,
    end: &End<'_>,
    notes: &mut Vec<String>,
) -> Vec<Invariant> {
    let bound = opts.recovery_bound;
    let mut inv = common(t, monitor, opts, end, notes);
    inv.extend(stalls(t));
    if opts.moos {
        inv.push(moos_reconnects(t, bound));
        inv.push(translation_restarts(t, bound));
    }
    inv.push(process_restarts(t, bound));
    inv.push(vehicle_link(t));
    inv.extend(web_floods(t));
    inv.extend(gobyd_returns(t, bound));
    if opts.soak.is_some() {
        inv.push(soak_invariant(end.samples, opts.rss_growth_limit_kib));
    }
    inv
}

/// The rows every run has, the basic simulator's and a vehicle family's.
pub(super) fn common(
    t: &Tally,
    monitor: &Monitor,
    opts: &ChaosOptions,
    end: &End<'_>,
    notes: &mut Vec<String>,
) -> Vec<Invariant> {
    let bound = opts.recovery_bound;
    let mut inv = vec![
        final_recovery(monitor, bound, end),
        each_recovery(t, bound),
        five_states(monitor),
        nothing_absurd(monitor),
        one_response_each(t, monitor, end.sent),
    ];
    match end.rss_baseline {
        Some(base) => inv.push(resident_set(opts.rss_growth_limit_kib, base, end.rss_max)),
        None => notes.push("RSS not measured (no /proc/self/status)".into()),
    }
    inv.push(no_panic_escaped(t));
    inv.push(driver_restarts(t, end));
    inv.push(Invariant {
        name: "the service ran to the end and shut down cleanly",
        bound: "clean exit".into(),
        measured: format!("{:?}", end.exit),
        ok: end.exit == ServiceExit::Clean && end.snapshot.is_some(),
    });
    inv
}

fn nothing_absurd(monitor: &Monitor) -> Invariant {
    let n = monitor.absurd_nav.load(Ordering::Relaxed);
    let examples = monitor
        .absurd_examples
        .lock()
        .map(|v| v.clone())
        .unwrap_or_default();
    Invariant {
        name: "nothing absurd reaches a helm (every node_status on the globe, finite, inside [limits.navigation])",
        bound: "0 absurd node_status".into(),
        measured: format!(
            "{} node_status, {n} absurd{}",
            monitor.node_status.load(Ordering::Relaxed),
            if examples.is_empty() {
                String::new()
            } else {
                format!(" ({})", examples.join("; "))
            }
        ),
        ok: n == 0,
    }
}

fn final_recovery(monitor: &Monitor, bound: Duration, end: &End<'_>) -> Invariant {
    Invariant {
        name: "back in COMMAND after the last fault cleared (and held 300 ms)",
        bound: format!("≤ {} wall", fmt_ms(bound)),
        measured: end.final_recovery.map_or_else(
            || format!("not within bound (state {:?})", monitor.state()),
            fmt_ms,
        ),
        ok: end.final_recovery.is_some(),
    }
}

fn each_recovery(t: &Tally, bound: Duration) -> Invariant {
    let mut all_rec: Vec<Duration> = t
        .by_kind
        .values()
        .flat_map(|k| k.recoveries.iter().copied())
        .collect();
    all_rec.sort();
    let late = t
        .violations
        .iter()
        .filter(|v| v.contains("not back in COMMAND"))
        .count()
        + all_rec.iter().filter(|d| **d > bound).count();
    Invariant {
        name: "back in COMMAND after each non-burst fault",
        bound: format!("≤ {} wall", fmt_ms(bound)),
        measured: format!(
            "n {}, p50 {}, p99 {}, max {}; {} late",
            all_rec.len(),
            fmt_ms(percentile(&all_rec, 50.0)),
            fmt_ms(percentile(&all_rec, 99.0)),
            fmt_ms(all_rec.last().copied().unwrap_or_default()),
            late
        ),
        ok: late == 0,
    }
}

fn five_states(monitor: &Monitor) -> Invariant {
    let invalid = monitor.invalid_states.load(Ordering::Relaxed);
    let examples = monitor
        .invalid_examples
        .lock()
        .map(|v| v.clone())
        .unwrap_or_default();
    Invariant {
        name: "every published state is one of the five",
        bound: "0 outside STANDBY/LISTEN/COMMAND/HELM_ERROR/FS_ERROR".into(),
        measured: format!(
            "{} statuses, {} outside{}",
            monitor.statuses.load(Ordering::Relaxed),
            invalid,
            if examples.is_empty() {
                String::new()
            } else {
                format!(" (raw {examples:?})")
            }
        ),
        ok: invalid == 0,
    }
}

fn one_response_each(t: &Tally, monitor: &Monitor, sent: i32) -> Invariant {
    let r = monitor.responses.lock().unwrap_or_else(|p| p.into_inner());
    let missing_ids: Vec<i32> = (1..=sent)
        .filter(|id| !r.answered(*id) && !t.lost_to_restart.contains(id))
        .collect();
    let missing = missing_ids.len();
    let lost = (1..=sent)
        .filter(|id| !r.answered(*id) && t.lost_to_restart.contains(id))
        .count();
    // A second answer is right only after our own timeout (the driver's late answer, which
    // Goby3 forwards too); anything else answered twice is a duplicate.
    let late = r
        .answers
        .iter()
        .filter(|a| a.count == 2 && a.interface_first)
        .count();
    let dup = r.answers.iter().filter(|a| a.count > 1).count() - late;
    let beyond = r
        .answers
        .iter()
        .skip(usize::try_from(sent).unwrap_or(0))
        .filter(|a| a.count > 0)
        .count() as u64;
    let unknown = r.unknown_ids + beyond + r.without_id;
    Invariant {
        name: "one CommandResponse per request with response_requested (and the driver's late one after our timeout or driver-failed answer)",
        bound: "0 missing, 0 duplicated, 0 unknown".into(),
        measured: format!(
            "{sent} sent: {} ok, {} not in COMMAND, {} timed out, {} driver failed, {} frontseat error, {} shutting down; {late} late after a timeout; {lost} unanswered across process restarts (in flight or sent while down); {missing} missing{}, {dup} duplicated, {unknown} unknown{}",
            r.ok,
            r.not_in_command,
            r.timeout,
            r.driver_failed,
            r.frontseat_refused,
            r.shutting_down,
            if missing > 0 {
                format!(" (ids {:?})", &missing_ids[..missing.min(10)])
            } else {
                String::new()
            },
            if dup > 0 {
                format!(" (request, first code, further code: {:?})", r.dup_examples)
            } else {
                String::new()
            }
        ),
        ok: missing == 0 && dup == 0 && unknown == 0 && sent > 0,
    }
}

fn resident_set(limit: u64, base: u64, rss_max: u64) -> Invariant {
    let growth = rss_max.saturating_sub(base);
    Invariant {
        name: "resident set stays bounded",
        bound: format!("growth ≤ {} MiB over the warm baseline", limit / 1024),
        measured: format!(
            "baseline {:.1} MiB, max {:.1} MiB (+{:.1} MiB)",
            base as f64 / 1024.0,
            rss_max as f64 / 1024.0,
            growth as f64 / 1024.0
        ),
        ok: growth <= limit,
    }
}

fn no_panic_escaped(t: &Tally) -> Invariant {
    let panics::PanicCounts {
        other,
        injected_driver: seen,
        injected_other: seen_other,
        other_texts: texts,
    } = panics::counts();
    let other_injected: u64 = [
        FaultKind::TranslationPanic,
        FaultKind::VehiclePanic,
        FaultKind::ProcessRestart,
    ]
    .iter()
    .map(|k| t.by_kind.get(k).map_or(0, |s| s.injected as u64))
    .sum();
    Invariant {
        name: "no panic escaped (injected driver, translation and vehicle panics absorbed by supervision)",
        bound: "0 other panics".into(),
        measured: format!(
            "{other} other panics{}; {seen} injected driver panics and {seen_other}/{other_injected} translation/vehicle panics raised and absorbed",
            if texts.is_empty() {
                String::new()
            } else {
                format!(" ({})", texts.join("; "))
            }
        ),
        ok: other == 0 && seen == t.injected_panics && seen_other == other_injected,
    }
}

fn driver_restarts(t: &Tally, end: &End<'_>) -> Invariant {
    // The current process's restarts: the counter starts again with each process.
    let crashes = t.injected_panics + t.injected_kills - t.crash_base;
    let restarts = end.snapshot.as_ref().map(|s| u64::from(s.driver_restarts));
    let mut rw = t.restart_waits.clone();
    rw.sort();
    Invariant {
        name: "driver restarts equal injected driver crashes",
        bound: "equal".into(),
        measured: format!(
            "{} restarts, {crashes} crashes since the last process start ({} panics + {} kills in all); restart p50 {}, max {}",
            restarts.map_or("?".into(), |r| r.to_string()),
            t.injected_panics,
            t.injected_kills,
            fmt_ms(percentile(&rw, 50.0)),
            fmt_ms(rw.last().copied().unwrap_or_default())
        ),
        ok: restarts == Some(crashes),
    }
}

pub(super) fn stalls(t: &Tally) -> Option<Invariant> {
    if t.stall_deliveries.is_empty() {
        return None;
    }
    let min = t.stall_deliveries.iter().min().copied().unwrap_or(0);
    Some(Invariant {
        name: "a stalled subscriber blocks no publisher",
        bound: "node_status keeps flowing during every stall".into(),
        measured: format!(
            "{} stalls, ≥ {min} node_status delivered during each, {} messages dropped and counted",
            t.stall_deliveries.len(),
            t.stall_drops
        ),
        ok: min > 0,
    })
}

fn moos_reconnects(t: &Tally, bound: Duration) -> Invariant {
    let mut mr = t.moos_reconnects.clone();
    mr.sort();
    let restarts = [FaultKind::MoosRestart, FaultKind::MoosCrashLoop]
        .iter()
        .map(|k| t.by_kind.get(k).map_or(0, |s| s.injected) as usize)
        .sum::<usize>();
    Invariant {
        name: "MOOS bridge reconnects after every broker restart and crash loop",
        bound: format!("≤ {} wall each", fmt_ms(bound)),
        measured: format!(
            "{}/{} reconnected; p50 {}, max {}",
            mr.len(),
            restarts,
            fmt_ms(percentile(&mr, 50.0)),
            fmt_ms(mr.last().copied().unwrap_or_default())
        ),
        ok: mr.len() == restarts,
    }
}

fn translation_restarts(t: &Tally, bound: Duration) -> Invariant {
    let mut tr = t.translation_restarts.clone();
    tr.sort();
    let panics = t
        .by_kind
        .get(&FaultKind::TranslationPanic)
        .map_or(0, |k| k.injected) as usize;
    Invariant {
        name: "a panicked FrontSeatTranslation is restarted and posts NAV to MOOS again",
        bound: format!("≤ {} wall each", fmt_ms(bound)),
        measured: format!(
            "{}/{} restarted; p50 {}, max {}",
            tr.len(),
            panics,
            fmt_ms(percentile(&tr, 50.0)),
            fmt_ms(tr.last().copied().unwrap_or_default())
        ),
        ok: tr.len() == panics,
    }
}

fn process_restarts(t: &Tally, bound: Duration) -> Invariant {
    let mut pr = t.process_restarts.clone();
    pr.sort();
    let ended = t
        .by_kind
        .get(&FaultKind::ProcessRestart)
        .map_or(0, |k| k.injected) as usize;
    Invariant {
        name: "back in COMMAND after a process restart (service manager: RestartSec 100 ms)",
        bound: format!("≤ {} wall each", fmt_ms(bound)),
        measured: format!(
            "{}/{} back; p50 {}, max {}",
            pr.len(),
            ended,
            fmt_ms(percentile(&pr, 50.0)),
            fmt_ms(pr.last().copied().unwrap_or_default())
        ),
        ok: pr.len() == ended && pr.iter().all(|d| *d <= bound),
    }
}

fn vehicle_link(t: &Tally) -> Invariant {
    let touched = t
        .violations
        .iter()
        .filter(|v| v.contains("touched the vehicle link"))
        .count();
    Invariant {
        name: "the driver's connection to the frontseat is never closed by a helm-side fault",
        bound: "0 new connections at the simulator; 0 driver restarts where the interface answers its snapshot".into(),
        measured: format!(
            "{} helm-side faults checked (MOOS restarts and crash loops, translation panics, web floods, gobyd gone, stalls, PARK), {touched} touched it{}",
            t.vehicle_link_checked,
            if t.vehicle_link_unknown > 0 {
                format!(
                    "; in {} the interface answered no snapshot (restart count unknown) and the simulator saw no new connection",
                    t.vehicle_link_unknown
                )
            } else {
                String::new()
            }
        ),
        ok: touched == 0,
    }
}

fn web_floods(t: &Tally) -> Option<Invariant> {
    let k = t.by_kind.get(&FaultKind::WebFlood)?;
    let bad = t
        .violations
        .iter()
        .filter(|v| v.contains("(web flood)"))
        .count();
    Some(Invariant {
        name: "a web client flooding the commander reaches nothing bad and is answered",
        bound: "0 refused CMDs at the vehicle; answers given".into(),
        measured: format!(
            "{} floods, {} requests (hostile setpoints, no token, foreign origin, broken JSON), {bad} failed; {} left COMMAND meanwhile",
            k.injected, t.web_flood_requests, t.web_floods_left_command
        ),
        ok: bad == 0,
    })
}

fn gobyd_returns(t: &Tally, bound: Duration) -> Option<Invariant> {
    let k = t.by_kind.get(&FaultKind::GobydGone)?;
    let mut gr = t.goby_returns.clone();
    gr.sort();
    Some(Invariant {
        name: "the Goby3 link is back after gobyd returns (gobyd gone 60 s sim)",
        bound: format!("≤ {} wall each", fmt_ms(bound)),
        measured: format!(
            "{}/{} back; p50 {}, max {}; the gateway saw its link lost in {} of them",
            gr.len(),
            k.injected,
            fmt_ms(percentile(&gr, 50.0)),
            fmt_ms(gr.last().copied().unwrap_or_default()),
            t.goby_losses_seen
        ),
        ok: gr.len() == k.injected as usize,
    })
}

/// Fds, threads and tasks may move while faults come and go, but not drift: over the second
/// half of the soak none may exceed its first-half peak by more than the slack, and RSS stays
/// within the growth limit over the first sample after warm-up.
pub fn soak_invariant(samples: &[Sample], rss_limit_kib: u64) -> Invariant {
    const FD_SLACK: u64 = 32;
    const THREAD_SLACK: u64 = 4;
    const TASK_SLACK: usize = 64;
    // A stall adds one subscriber for its length; a leak adds several per crash, thousands.
    const SUB_SLACK: u64 = 16;
    let half = samples.len() / 2;
    let (first, second) = samples.split_at(half.max(1).min(samples.len()));
    let peak = |v: &[Sample], f: &dyn Fn(&Sample) -> Option<u64>| v.iter().filter_map(f).max();
    let mut problems = Vec::new();
    let fd = |x: &Sample| x.fds;
    let th = |x: &Sample| x.threads;
    let tk = |x: &Sample| Some(x.tasks as u64);
    let sb = |x: &Sample| Some(x.subscriptions as u64);
    for (name, f, slack) in [
        ("open fds", &fd as &dyn Fn(&Sample) -> Option<u64>, FD_SLACK),
        ("threads", &th, THREAD_SLACK),
        ("tasks", &tk, TASK_SLACK as u64),
        ("bus subscriptions", &sb, SUB_SLACK),
    ] {
        if let (Some(a), Some(b)) = (peak(first, f), peak(second, f))
            && b > a + slack
        {
            problems.push(format!("{name} {a} -> {b}"));
        }
    }
    let base = samples.get(1).or(samples.first()).and_then(|x| x.rss_kib);
    let rss_max = samples.iter().filter_map(|x| x.rss_kib).max();
    if let (Some(b), Some(m)) = (base, rss_max)
        && m.saturating_sub(b) > rss_limit_kib
    {
        problems.push(format!("RSS {} -> {} KiB", b, m));
    }
    let last = samples.last().map(Sample::line).unwrap_or_default();
    Invariant {
        name: "soak: RSS, open fds, threads, tasks and bus subscriptions stay flat",
        bound: format!(
            "second-half peak ≤ first-half peak + {FD_SLACK} fds / {THREAD_SLACK} threads / {TASK_SLACK} tasks / {SUB_SLACK} bus subscriptions; RSS growth ≤ {} MiB",
            rss_limit_kib / 1024
        ),
        measured: if problems.is_empty() {
            format!("{} samples; last: {last}", samples.len())
        } else {
            format!("{} samples; drift: {}", samples.len(), problems.join(", "))
        },
        ok: problems.is_empty() && samples.len() >= 2,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn soak_invariant_sees_a_drift_and_passes_a_flat_run() {
        let at = |i: u64, fds: u64, rss: u64| Sample {
            at: Duration::from_secs(i),
            faults: i as u32,
            rss_kib: Some(rss),
            fds: Some(fds),
            threads: Some(8),
            tasks: 40,
            subscriptions: 60,
        };
        let flat: Vec<Sample> = (0..10).map(|i| at(i, 30 + i % 3, 10_000)).collect();
        assert!(soak_invariant(&flat, 1024).ok);
        let leak: Vec<Sample> = (0..10).map(|i| at(i, 30 + 10 * i, 10_000)).collect();
        let inv = soak_invariant(&leak, 1024);
        assert!(
            !inv.ok && inv.measured.contains("open fds"),
            "{}",
            inv.measured
        );
        let grow: Vec<Sample> = (0..10).map(|i| at(i, 30, 10_000 + 500 * i)).collect();
        assert!(!soak_invariant(&grow, 1024).ok);
        // Subscriptions left behind by crashed actors: 7 more every sample.
        let subs: Vec<Sample> = (0..10)
            .map(|i| Sample {
                subscriptions: 60 + 7 * i as usize,
                ..at(i, 30, 10_000)
            })
            .collect();
        let inv = soak_invariant(&subs, 1024);
        assert!(
            !inv.ok && inv.measured.contains("bus subscriptions"),
            "{}",
            inv.measured
        );
    }
}
