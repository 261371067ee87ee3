//! The process's resources — RSS, open fds, threads, tokio tasks and bus subscriptions — read
//! from `/proc/self` and the runtime, one sample at a time.

use std::time::Duration;

use frontseat_actors::bus::Bus;

/// The process's resources at one moment of the run.
#[derive(Clone, Debug, PartialEq)]
pub struct Sample {
    pub at: Duration,
    pub faults: u32,
    pub rss_kib: Option<u64>,
    pub fds: Option<u64>,
    pub threads: Option<u64>,
    pub tasks: usize,
    /// Subscriptions on the bus: a crashed actor whose subscriptions stayed made this grow
    /// (and RSS with it) before issue 31's fix; counted, so a drift is seen without RSS noise.
    pub subscriptions: usize,
}

impl Sample {
    pub fn take(at: Duration, faults: u32, bus: &Bus) -> Self {
        Self {
            at,
            faults,
            subscriptions: bus.stats().len(),
            rss_kib: rss_kib(),
            fds: open_fds(),
            threads: threads(),
            tasks: tokio::runtime::Handle::try_current()
                .map_or(0, |h| h.metrics().num_alive_tasks()),
        }
    }

    pub fn line(&self) -> String {
        let o = |v: Option<u64>| v.map_or("?".to_string(), |v| v.to_string());
        format!(
            "t {:>6.0} s, {:>6} faults: RSS {} MiB, fds {}, threads {}, tasks {}, bus subscriptions {}",
            self.at.as_secs_f64(),
            self.faults,
            self.rss_kib
                .map_or("?".into(), |k| format!("{:.1}", k as f64 / 1024.0)),
            o(self.fds),
            o(self.threads),
            self.tasks,
            self.subscriptions
        )
    }
}

/// Open file descriptors of this process (Linux); None elsewhere.
pub fn open_fds() -> Option<u64> {
    Some(std::fs::read_dir("/proc/self/fd").ok()?.count() as u64)
}

/// Threads of this process (Linux); None elsewhere.
pub fn threads() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = text.lines().find(|l| l.starts_with("Threads:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

/// Resident set size of this process in KiB (Linux); None elsewhere.
pub fn rss_kib() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = text.lines().find(|l| l.starts_with("VmRSS:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}
