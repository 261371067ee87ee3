//! Rate-limited logging for input we do not control: the first few occurrences in a window are
//! logged in full, the rest are counted and summarised once the window ends ("…and 97 more in
//! the last 10 s"), so a hostile or broken peer cannot flood the journal.

use std::time::Duration;

use tokio::time::Instant;

/// One limiter per kind of bad input.
#[derive(Debug)]
pub struct RateLimitedLog {
    window: Duration,
    burst: u32,
    window_start: Option<Instant>,
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
        let expired = self
            .window_start
            .is_none_or(|s| now.duration_since(s) >= self.window);
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
}
