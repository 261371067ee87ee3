//! Where a helm-side path's time goes (issue 49): with `FRONTSEAT_BENCH_HOPS=1` in its
//! environment the bench installs the hop hooks of `frontseat-moos`, `frontseat-helm-side` and
//! `frontseat-web` (each crate's `hops` module: one atomic load per hop while nothing is
//! installed), which stamp the instant a message passes each named hop. A row then matches the
//! stamps to its messages — the first stamp of each hop after the previous hop's and before the
//! message's end, so one message in flight at a time (the rows' 1–2 ms period against paths of
//! 0.1–0.5 ms) is what makes the match unambiguous — and prints the p50 and p99 of every
//! segment. Only in-process rows can be broken down (M1, M2, G1, G2, W1): Z1 and Z2's middle is
//! in the interface child.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Mutex, PoisonError};
use std::time::Instant;

use serde_json::{Value, json};

use super::report::{Hist, fmt_duration};

/// Set in the bench's environment to break the helm-side rows down by hop.
pub const HOPS_ENV: &str = "FRONTSEAT_BENCH_HOPS";

static ON: AtomicBool = AtomicBool::new(false);
/// Every stamp since the last [`clear`]: hop, instant, what passed it.
static LOG: Mutex<Vec<(&'static str, Instant, String)>> = Mutex::new(Vec::new());

fn record(name: &'static str, what: &str) {
    let now = Instant::now();
    if ON.load(Ordering::Relaxed) {
        LOG.lock()
            .unwrap_or_else(PoisonError::into_inner)
            .push((name, now, what.to_owned()));
    }
}

/// Installs the hooks when [`HOPS_ENV`] asks for it; whether the breakdown is on.
pub fn install_if_asked() -> bool {
    let asked = std::env::var(HOPS_ENV).is_ok_and(|v| !v.is_empty() && v != "0");
    if asked {
        frontseat_moos::hops::install(record);
        frontseat_helm_side::hops::install(record);
        frontseat_web::hops::install(record);
        ON.store(true, Ordering::Relaxed);
    }
    asked
}

fn on() -> bool {
    ON.load(Ordering::Relaxed)
}

/// Forgets every stamp so far (before a row's burst).
pub fn clear() {
    LOG.lock().unwrap_or_else(PoisonError::into_inner).clear();
}

/// One hop of a path: its label in the table, the hook's name, and what must pass it (None:
/// anything).
pub struct Hop {
    pub label: &'static str,
    pub name: &'static str,
    pub what: Option<&'static str>,
}

pub const fn hop(label: &'static str, name: &'static str, what: Option<&'static str>) -> Hop {
    Hop { label, name, what }
}

/// The breakdown of `count` messages (`start(i)` → `end(i)`) over `path`, from the stamps since
/// the last [`clear`]: a text for the row's detail and a JSON value for its `hops` field; None
/// when the breakdown is off. `end_label` names the last segment's end.
pub fn breakdown(
    count: usize,
    start: impl Fn(usize) -> Option<Instant>,
    end: impl Fn(usize) -> Option<Instant>,
    path: &[Hop],
    end_label: &str,
) -> Option<(String, Value)> {
    if !on() {
        return None;
    }
    let log = std::mem::take(&mut *LOG.lock().unwrap_or_else(PoisonError::into_inner));
    let times: Vec<Vec<Instant>> = path
        .iter()
        .map(|h| {
            let mut t: Vec<Instant> = log
                .iter()
                .filter(|(n, _, w)| *n == h.name && h.what.is_none_or(|x| x == w))
                .map(|(_, t, _)| *t)
                .collect();
            t.sort();
            t
        })
        .collect();
    let mut segs: Vec<Hist> = (0..=path.len()).map(|_| Hist::new()).collect();
    let (mut complete, mut incomplete) = (0usize, 0usize);
    'msg: for i in 0..count {
        let (Some(s), Some(e)) = (start(i), end(i)) else {
            continue;
        };
        let mut at = Vec::with_capacity(path.len());
        let mut prev = s;
        for t in &times {
            let k = t.partition_point(|x| *x < prev);
            match t.get(k) {
                Some(&x) if x <= e => {
                    at.push(x);
                    prev = x;
                }
                _ => {
                    incomplete += 1;
                    continue 'msg;
                }
            }
        }
        let mut prev = s;
        for (k, x) in at.iter().chain(std::iter::once(&e)).enumerate() {
            segs[k].record(x.saturating_duration_since(prev));
            prev = *x;
        }
        complete += 1;
    }
    let labels = path
        .iter()
        .map(|h| h.label)
        .chain(std::iter::once(end_label));
    let mut parts = Vec::new();
    let mut json_segs = Vec::new();
    for (label, h) in labels.zip(&segs) {
        let Some(l) = h.latency() else { continue };
        parts.push(format!(
            "→ {label} {} / {}",
            fmt_duration(l.p50),
            fmt_duration(l.p99)
        ));
        json_segs.push(json!({
            "to": label,
            "p50_us": l.p50.as_secs_f64() * 1e6,
            "p99_us": l.p99.as_secs_f64() * 1e6,
        }));
    }
    let text = format!(
        "hops (p50 / p99 of each segment; {complete} complete, {incomplete} not matched): {}",
        parts.join(", ")
    );
    Some((
        text,
        json!({ "complete": complete, "incomplete": incomplete, "segments": json_segs }),
    ))
}

/// Appends the breakdown to `row` (detail and `hops` in its JSON).
pub fn add_to(row: &mut super::report::Row, b: Option<(String, Value)>) {
    let Some((text, v)) = b else { return };
    row.detail = format!("{}; {text}", row.detail);
    if let Value::Object(m) = &mut row.extra {
        m.insert("hops".into(), v);
    }
}
