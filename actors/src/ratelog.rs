//! Rate-limited logging for input we do not control: the first few occurrences in a window are
//! logged in full, the rest are counted and summarised once the window ends ("…and 97 more in
//! the last 10 s"), so a hostile or broken peer cannot flood the journal.
//!
//! Time is whatever clock the caller lives by: tokio's `Instant` ([`RateLimitedLog::decide`]) or
//! a driver's simulated time ([`RateLimitedLog::decide_at`]), so that under a warp the window
//! shrinks with every other timer. [`RateLimitedLog::summary_due`] (and `_at`) lets a periodic
//! task report what a burst suppressed even when no further bad input arrives to carry the
//! summary: the owner's tick asks, and logs [`summary`] when one is due.

use std::time::Duration;

use tokio::time::Instant;

/// One limiter per kind of bad input.
#[derive(Debug)]
pub struct RateLimitedLog {
    window: Duration,
    burst: u32,
    /// The first `Instant` seen: `decide` measures from it.
    epoch: Option<Instant>,
    window_start: Option<Duration>,
    in_window: u32,
    suppressed: u64,
}

/// What the caller should log now.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LogDecision {
    /// Log this occurrence in full. `suppressed_before` occurrences of the previous window were
    /// not logged: say so.
    Log { suppressed_before: u64 },
    /// Count it, do not log.
    Suppress,
}

impl RateLimitedLog {
    pub fn new(burst: u32, window: Duration) -> Self {
        Self {
            window,
            burst,
            epoch: None,
            window_start: None,
            in_window: 0,
            suppressed: 0,
        }
    }

    /// Default for bad input: 5 lines per 10 s.
    pub fn for_bad_input() -> Self {
        Self::new(5, Duration::from_secs(10))
    }

    pub fn window(&self) -> Duration {
        self.window
    }

    pub fn decide(&mut self, now: Instant) -> LogDecision {
        let epoch = *self.epoch.get_or_insert(now);
        self.decide_at(now.duration_since(epoch))
    }

    /// [`Self::decide`] on a clock of the caller's (e.g. simulated time since start).
    pub fn decide_at(&mut self, now: Duration) -> LogDecision {
        let expired = self
            .window_start
            .is_none_or(|s| now.saturating_sub(s) >= self.window);
        if expired {
            let suppressed_before = std::mem::take(&mut self.suppressed);
            self.window_start = Some(now);
            self.in_window = 1;
            return LogDecision::Log { suppressed_before };
        }
        if self.in_window < self.burst {
            self.in_window += 1;
            LogDecision::Log {
                suppressed_before: 0,
            }
        } else {
            self.suppressed += 1;
            LogDecision::Suppress
        }
    }

    /// [`Self::summary_due_at`] on tokio's clock, for a limiter fed by [`Self::decide`].
    pub fn summary_due(&mut self, now: Instant) -> Option<u64> {
        let epoch = self.epoch?;
        self.summary_due_at(now.saturating_duration_since(epoch))
    }

    /// Occurrences suppressed in a window that has ended, once: the caller logs the summary.
    /// None while the window runs or when nothing was suppressed.
    pub fn summary_due_at(&mut self, now: Duration) -> Option<u64> {
        let start = self.window_start?;
        if self.suppressed == 0 || now.saturating_sub(start) < self.window {
            return None;
        }
        self.window_start = None;
        self.in_window = 0;
        Some(std::mem::take(&mut self.suppressed))
    }
}

/// " (…and 97 more bad lines in the last 10 s)", or "" when nothing was suppressed.
pub fn more(suppressed: u64, what: &str, window: Duration) -> String {
    if suppressed == 0 {
        String::new()
    } else {
        format!(" ({})", summary(suppressed, what, window))
    }
}

/// "…and 97 more bad lines in the last 10 s": the line logged for a summary that is due.
pub fn summary(suppressed: u64, what: &str, window: Duration) -> String {
    format!(
        "…and {suppressed} more {what} in the last {} s",
        window.as_secs()
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test(start_paused = true)]
    async fn a_burst_then_silence_then_a_summary() {
        let mut l = RateLimitedLog::new(3, Duration::from_secs(10));
        let t0 = Instant::now();
        let decisions: Vec<_> = (0..100).map(|_| l.decide(t0)).collect();
        assert_eq!(
            decisions
                .iter()
                .filter(|d| matches!(d, LogDecision::Log { .. }))
                .count(),
            3
        );
        tokio::time::advance(Duration::from_secs(10)).await;
        assert_eq!(
            l.decide(Instant::now()),
            LogDecision::Log {
                suppressed_before: 97
            }
        );
        assert_eq!(
            l.decide(Instant::now()),
            LogDecision::Log {
                suppressed_before: 0
            }
        );
    }

    #[test]
    fn a_summary_is_due_when_the_window_ends_without_more_input() {
        let mut l = RateLimitedLog::new(5, Duration::from_secs(10));
        let t0 = Duration::from_secs(100);
        for _ in 0..100 {
            l.decide_at(t0);
        }
        assert_eq!(l.summary_due_at(t0 + Duration::from_secs(9)), None);
        assert_eq!(l.summary_due_at(t0 + Duration::from_secs(10)), Some(95));
        assert_eq!(l.summary_due_at(t0 + Duration::from_secs(30)), None, "once");
        assert_eq!(
            l.decide_at(t0 + Duration::from_secs(31)),
            LogDecision::Log {
                suppressed_before: 0
            },
            "a new window starts"
        );
        assert_eq!(
            more(95, "bad lines", l.window()),
            " (…and 95 more bad lines in the last 10 s)"
        );
    }

    #[tokio::test(start_paused = true)]
    async fn a_summary_on_tokio_time_counts_from_the_first_occurrence() {
        let mut l = RateLimitedLog::new(2, Duration::from_secs(10));
        assert_eq!(l.summary_due(Instant::now()), None, "nothing seen yet");
        tokio::time::advance(Duration::from_secs(50)).await;
        for _ in 0..7 {
            l.decide(Instant::now());
        }
        tokio::time::advance(Duration::from_secs(9)).await;
        assert_eq!(l.summary_due(Instant::now()), None, "the window still runs");
        tokio::time::advance(Duration::from_secs(1)).await;
        assert_eq!(l.summary_due(Instant::now()), Some(5));
        assert_eq!(
            summary(5, "refused setpoints", l.window()),
            "…and 5 more refused setpoints in the last 10 s"
        );
    }
}
