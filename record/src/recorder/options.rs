//! What the recorder is told: where files go ([`Target`]), which groups, rotation, budget and
//! queue ([`RecorderOptions`], resolved from `[record]`), what each file says of the run
//! ([`RecordMeta`], [`config_digest`]), and what can go wrong starting it ([`RecorderError`]).

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::time::Duration;

use frontseat_config::{RecordCompression, RecordConfig};
use regex::Regex;

#[derive(Debug, thiserror::Error)]
pub enum RecorderError {
    #[error("record.{field}: {reason}")]
    Config { field: String, reason: String },
    #[error("cannot create {path}: {source}")]
    Create {
        path: String,
        source: std::io::Error,
    },
    #[error("cannot start the MCAP file {path}: {reason}")]
    Mcap { path: String, reason: String },
    #[error("the compiled protobuf descriptors do not decode (a build defect)")]
    NoDescriptors,
    #[error("cannot start the recorder thread: {0}")]
    Thread(std::io::Error),
}

/// Where files go. Every file is created new (`O_EXCL`, never through a symlink): the recorder
/// never truncates nor replaces a file, its own included.
#[derive(Clone, Debug)]
pub enum Target {
    /// This file: never rotated nor removed. If the name is taken (the recording of a run that
    /// crashed, restarted with the same config), that file is kept and this run records to
    /// `<stem>.1.<ext>` (then `.2`, ...), logging both names.
    File(PathBuf),
    /// `<dir>/<prefix>_<UTC>_<seq>.mcap`, rotated, trimmed to the budget.
    Dir { dir: PathBuf, prefix: String },
}

/// The recorder's settings, resolved from `[record]` (or made for `demo --record FILE`).
#[derive(Clone, Debug)]
pub struct RecorderOptions {
    pub target: Target,
    pub include: Vec<Regex>,
    pub exclude: Vec<Regex>,
    /// 0 = never by size.
    pub rotate_bytes: u64,
    pub rotate_after: Option<Duration>,
    /// 0 = no budget.
    pub budget_bytes: u64,
    pub min_free_bytes: u64,
    pub flush: Duration,
    pub compression: RecordCompression,
    pub queue: usize,
    /// [`Target::File`] only (`demo --record FILE --force`): record under a temporary name
    /// beside the file and rename it onto the file when closed, replacing what was there.
    pub replace: bool,
}

impl RecorderOptions {
    /// One file, everything recorded, the defaults of `[record]` otherwise.
    pub fn file(path: impl Into<PathBuf>) -> Self {
        let d = RecordConfig::default();
        Self {
            target: Target::File(path.into()),
            include: Vec::new(),
            exclude: Vec::new(),
            rotate_bytes: 0,
            rotate_after: None,
            budget_bytes: 0,
            min_free_bytes: d.min_free_mb << 20,
            flush: Duration::from_secs_f64(d.flush_s),
            compression: d.compression,
            queue: d.queue,
            replace: false,
        }
    }

    /// From a validated `[record]`; `vehicle` names the files (`frontseat` when empty).
    pub fn from_config(cfg: &RecordConfig, vehicle: &str) -> Result<Self, RecorderError> {
        let compile = |field: &str, list: &[String]| -> Result<Vec<Regex>, RecorderError> {
            list.iter()
                .map(|r| {
                    Regex::new(r).map_err(|e| RecorderError::Config {
                        field: field.into(),
                        reason: format!("{r:?}: {e}"),
                    })
                })
                .collect()
        };
        if !(cfg.flush_s.is_finite() && (0.05..=60.0).contains(&cfg.flush_s)) {
            return Err(RecorderError::Config {
                field: "flush_s".into(),
                reason: format!("{} outside [0.05, 60]", cfg.flush_s),
            });
        }
        let prefix: String = match vehicle {
            "" => "frontseat".into(),
            v => v
                .chars()
                .map(|c| {
                    if c.is_ascii_alphanumeric() || c == '-' {
                        c
                    } else {
                        '-'
                    }
                })
                .collect(),
        };
        let target = match &cfg.path {
            Some(p) => Target::File(PathBuf::from(p)),
            None => Target::Dir {
                dir: PathBuf::from(&cfg.dir),
                prefix,
            },
        };
        let single = matches!(target, Target::File(_));
        Ok(Self {
            target,
            include: compile("include", &cfg.include)?,
            exclude: compile("exclude", &cfg.exclude)?,
            rotate_bytes: if single { 0 } else { cfg.rotate_mb << 20 },
            rotate_after: (!single && cfg.rotate_s > 0).then(|| Duration::from_secs(cfg.rotate_s)),
            budget_bytes: if single { 0 } else { cfg.budget_mb << 20 },
            min_free_bytes: cfg.min_free_mb << 20,
            flush: Duration::from_secs_f64(cfg.flush_s),
            compression: cfg.compression,
            queue: cfg.queue.clamp(16, 1 << 20),
            replace: false,
        })
    }

    /// Whether `group` is recorded.
    pub fn wants(&self, group: &str) -> bool {
        (self.include.is_empty() || self.include.iter().any(|r| r.is_match(group)))
            && !self.exclude.iter().any(|r| r.is_match(group))
    }
}

/// What the run was, written as the `frontseat.run` metadata record of every file.
#[derive(Clone, Debug, Default)]
pub struct RecordMeta {
    pub vehicle: String,
    pub datum_lat: f64,
    pub datum_lon: f64,
    /// Hex digest of the config the process runs (see [`config_digest`]).
    pub config_digest: String,
    pub version: String,
    pub driver: String,
    /// Anything else worth keeping (the command line, the application).
    pub extra: BTreeMap<String, String>,
}

impl RecordMeta {
    pub(super) fn to_map(&self) -> BTreeMap<String, String> {
        let mut m = self.extra.clone();
        m.insert("vehicle".into(), self.vehicle.clone());
        m.insert("datum_lat".into(), format!("{}", self.datum_lat));
        m.insert("datum_lon".into(), format!("{}", self.datum_lon));
        m.insert("config_digest".into(), self.config_digest.clone());
        m.insert("version".into(), self.version.clone());
        m.insert("driver".into(), self.driver.clone());
        m
    }
}

/// A stable digest of a config's text (FNV-1a, 64 bit, hex): enough to tell two runs' configs
/// apart or equal; not a security hash.
pub fn config_digest(text: &str) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in text.bytes() {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    format!("fnv1a64:{h:016x}")
}
