//! `frontseat log info`: what a recording holds, read in one pass: its span, every group with
//! its count, rate and longest silence, the recorder's own drop counts and whether the file was
//! closed or cut short.

use std::collections::{BTreeMap, HashMap};
use std::fmt::Write as _;
use std::io::Read;
use std::sync::Arc;

use crate::reader::{ReadError, Recording};
use crate::time::{iso_utc, secs};
use crate::{META_IMPORT_SKIPPED, META_RECORDER, META_RECOVERED, META_RUN};

/// A silence this many times the group's mean interval (and at least [`MIN_GAP_NS`]) is a gap.
const GAP_FACTOR: u64 = 5;
const MIN_GAP_NS: u64 = 1_000_000_000;

#[derive(Clone, Debug, Default, PartialEq)]
pub struct GroupInfo {
    pub group: String,
    pub type_name: String,
    pub count: u64,
    pub bytes: u64,
    pub first: u64,
    pub last: u64,
    /// Longest interval between two messages. Unit: ns.
    pub max_interval: u64,
    /// Intervals longer than 5× the mean (and 1 s).
    pub gaps: u64,
    /// Messages not published in the recording process (imported, replayed).
    pub not_local: u64,
}

impl GroupInfo {
    /// Messages per second over the group's own span.
    pub fn rate_hz(&self) -> f64 {
        let span = secs(self.last.saturating_sub(self.first));
        if self.count < 2 || span <= 0.0 {
            0.0
        } else {
            (self.count - 1) as f64 / span
        }
    }
}

#[derive(Clone, Debug, Default)]
pub struct Info {
    pub messages: u64,
    pub start: u64,
    pub end: u64,
    pub groups: Vec<GroupInfo>,
    pub run: BTreeMap<String, String>,
    /// Messages the recorder dropped (from its closing metadata; unknown when cut short).
    pub dropped: Option<u64>,
    /// Entries `log import` could not convert, by `<SCHEME> <group>` (DCCL, CSTR, ...).
    pub not_imported: BTreeMap<String, u64>,
    pub truncated: Option<String>,
    /// Set when the file was finished after a crash (`log recover`, the recorder at start): when,
    /// and where the original ended.
    pub recovered: Option<BTreeMap<String, String>>,
    /// Definitions the reader skipped for its limits, with the operator's line.
    pub skipped_definitions: u64,
    pub limits_note: Option<String>,
}

/// Reads the whole recording once. Work per message does not depend on the length of its
/// topic: a channel's group is looked up once per channel definition.
pub fn info<R: Read>(mut rec: Recording<R>) -> Result<Info, ReadError> {
    // Per channel: (times of the group in order, ...) kept as running values only: bounded
    // memory whatever the file's length.
    struct Acc {
        info: GroupInfo,
        prev: Option<u64>,
        intervals: Vec<u64>,
    }
    let mut by_topic: BTreeMap<String, usize> = BTreeMap::new();
    let mut accs: Vec<Acc> = Vec::new();
    // Channel id → (its topic's allocation, index in `accs`, local?).
    let mut by_channel: HashMap<u16, (Option<Arc<str>>, usize, bool)> = HashMap::new();
    let mut out = Info::default();
    while let Some(m) = rec.next_message_ref()? {
        let (channel_id, log_time, len) = (m.channel_id, m.log_time, m.data.len() as u64);
        // The cache holds the Arc, so an equal address is the same definition.
        let topic = m.channel.map(|c| Arc::as_ptr(&c.topic));
        let cached = by_channel
            .get(&channel_id)
            .filter(|(t, _, _)| t.as_ref().map(Arc::as_ptr) == topic);
        let (ix, local) = match cached {
            Some((_, ix, local)) => (*ix, *local),
            None => {
                let (name, type_name, local) = match rec.channel(channel_id) {
                    Some(c) => (
                        c.topic.to_string(),
                        rec.schema(c.schema_id)
                            .map(|s| s.name.clone())
                            .unwrap_or_default(),
                        c.metadata
                            .get(crate::CHANNEL_ORIGIN)
                            .is_none_or(|o| o == "local"),
                    ),
                    None => (
                        format!("<unknown channel {channel_id}>"),
                        String::new(),
                        true,
                    ),
                };
                let ix = *by_topic.entry(name.clone()).or_insert_with(|| {
                    accs.push(Acc {
                        info: GroupInfo {
                            group: name,
                            type_name,
                            first: log_time,
                            ..Default::default()
                        },
                        prev: None,
                        intervals: Vec::new(),
                    });
                    accs.len() - 1
                });
                let topic = rec.channel(channel_id).map(|c| c.topic.clone());
                by_channel.insert(channel_id, (topic, ix, local));
                (ix, local)
            }
        };
        out.messages += 1;
        if out.messages == 1 || log_time < out.start {
            out.start = log_time;
        }
        out.end = out.end.max(log_time);
        let a = &mut accs[ix];
        a.info.count += 1;
        a.info.bytes += len;
        a.info.last = a.info.last.max(log_time);
        if !local {
            a.info.not_local += 1;
        }
        if let Some(p) = a.prev {
            let d = log_time.saturating_sub(p);
            a.info.max_interval = a.info.max_interval.max(d);
            // Only the intervals far above the running mean are kept to judge gaps at the end.
            let mean = (log_time.saturating_sub(a.info.first)) / a.info.count.max(1);
            if d >= MIN_GAP_NS && d > mean.saturating_mul(GAP_FACTOR) && a.intervals.len() < 100_000
            {
                a.intervals.push(d);
            }
        }
        a.prev = Some(log_time);
    }
    // In group order, as before.
    let mut accs: Vec<Option<Acc>> = accs.into_iter().map(Some).collect();
    for ix in by_topic.into_values() {
        let Some(a) = accs[ix].take() else { continue };
        let mut g = a.info;
        let mean = if g.count > 1 {
            g.last.saturating_sub(g.first) / (g.count - 1)
        } else {
            0
        };
        let threshold = MIN_GAP_NS.max(mean.saturating_mul(GAP_FACTOR));
        g.gaps = a.intervals.iter().filter(|d| **d > threshold).count() as u64;
        out.groups.push(g);
    }
    for (name, m) in rec.metadata() {
        match name.as_str() {
            META_RUN => out.run = m.clone(),
            META_RECORDER => {
                let n = |k: &str| m.get(k).and_then(|v| v.parse::<u64>().ok()).unwrap_or(0);
                out.dropped = Some(n("dropped_queue") + n("dropped_unwritable"));
            }
            META_RECOVERED => out.recovered = Some(m.clone()),
            META_IMPORT_SKIPPED => {
                out.not_imported = m
                    .iter()
                    .filter_map(|(k, v)| Some((k.clone(), v.parse::<u64>().ok()?)))
                    .collect();
            }
            _ => {}
        }
    }
    out.truncated = rec.truncated().map(str::to_string);
    out.skipped_definitions = rec.skipped_definitions();
    out.limits_note = rec.limits_note();
    Ok(out)
}

impl Info {
    /// What `frontseat log info --json` prints.
    pub fn to_json(&self) -> serde_json::Value {
        let groups: Vec<_> = self
            .groups
            .iter()
            .map(|g| {
                serde_json::json!({
                    "group": g.group, "type": g.type_name, "count": g.count,
                    "bytes": g.bytes, "rate_hz": g.rate_hz(),
                    "max_gap_s": g.max_interval as f64 / 1e9, "gaps": g.gaps,
                    "not_local": g.not_local,
                })
            })
            .collect();
        serde_json::json!({
            "messages": self.messages,
            "start_ns": self.start, "end_ns": self.end,
            "duration_s": self.end.saturating_sub(self.start) as f64 / 1e9,
            "run": self.run, "dropped": self.dropped, "truncated": self.truncated,
            "recovered": self.recovered,
            "skipped_definitions": self.skipped_definitions,
            "groups": groups,
        })
    }

    /// The text `frontseat log info` prints.
    pub fn render(&self) -> String {
        let mut s = String::new();
        let dur = secs(self.end.saturating_sub(self.start));
        let _ = writeln!(s, "messages: {}", self.messages);
        if self.messages > 0 {
            let _ = writeln!(
                s,
                "span:     {} → {} ({dur:.3} s)",
                iso_utc(self.start),
                iso_utc(self.end)
            );
        }
        for k in [
            "vehicle",
            "driver",
            "datum_lat",
            "datum_lon",
            "version",
            "config_digest",
        ] {
            if let Some(v) = self.run.get(k) {
                let _ = writeln!(s, "{k}: {v}");
            }
        }
        match self.dropped {
            Some(d) => {
                let _ = writeln!(s, "dropped by the recorder: {d}");
            }
            None => {
                let _ = writeln!(
                    s,
                    "dropped by the recorder: unknown (the file was not closed)"
                );
            }
        }
        for (k, n) in &self.not_imported {
            let _ = writeln!(s, "not imported (no codec or schema here): {k}: {n}");
        }
        if let Some(n) = &self.limits_note {
            let _ = writeln!(s, "not read: {n}");
        }
        if let Some(r) = &self.recovered {
            let get = |k: &str| r.get(k).map(String::as_str).unwrap_or("?");
            let _ = writeln!(
                s,
                "recovered: {} after a crash — the original ended: {}",
                get("recovered_utc"),
                get("cut")
            );
        }
        match &self.truncated {
            Some(t) => {
                let _ = writeln!(s, "end: cut short — {t}; read up to the last whole chunk");
            }
            None => {
                let _ = writeln!(s, "end: closed properly");
            }
        }
        let _ = writeln!(
            s,
            "\n{:<52} {:>8} {:>9} {:>10} {:>5}  type",
            "group", "count", "rate Hz", "max gap s", "gaps"
        );
        for g in &self.groups {
            let _ = writeln!(
                s,
                "{:<52} {:>8} {:>9.2} {:>10.3} {:>5}  {}{}",
                g.group,
                g.count,
                g.rate_hz(),
                secs(g.max_interval),
                g.gaps,
                g.type_name,
                if g.not_local > 0 {
                    format!(" ({} not local)", g.not_local)
                } else {
                    String::new()
                }
            );
        }
        s
    }
}
