//! The tick schedule of one vehicle: pure deadline arithmetic and the catch-up policy, no clock.
//!
//! Tick n is due at `start + n / (FREQ·WARP)` wall seconds, computed from n every time, so no
//! error accumulates at any WARP. When a vehicle gets to its ticks late, every due tick is still
//! integrated (simulated time never falls behind), but only ticks that are not stale are
//! reported: a tick is stale when a later tick is also due and its own deadline is more than
//! [`STALE_AFTER`] in the past. The newest due tick is always reported.

use std::time::Duration;

/// A due tick older than this, with a newer one also due, is integrated but not reported.
/// 20 ms: at 10 Hz and WARP 1 any catch-up reports only the newest tick, while at 1 ms periods
/// (WARP 100) ordinary scheduling jitter on a loaded 2-core machine is absorbed, not dropped.
pub const STALE_AFTER: Duration = Duration::from_millis(20);
/// A reported tick later than this after its deadline counts as late (tokio's timer has 1 ms
/// granularity, so lateness below that is normal).
pub const LATE_AFTER: Duration = Duration::from_millis(2);
/// Most ticks integrated in one catch-up; beyond it (the process was suspended) the schedule is
/// re-anchored so a single wake-up never computes for long.
pub const MAX_CATCH_UP: u64 = 100_000;

/// Deadlines of one run, as offsets from the run's start.
#[derive(Debug, Clone, PartialEq)]
pub struct Schedule {
    /// Wall ticks per second (FREQ·WARP).
    rate: f64,
    /// Offset of tick 0 from the run's start; grows only when re-anchored.
    shift: Duration,
    /// Next tick not yet processed.
    next: u64,
}

/// What to do at a wake-up.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Due {
    /// Ticks to process, in order: `first..=last`.
    pub first: u64,
    pub last: u64,
    /// Ticks from `first` before this are integrated but not reported.
    pub report_from: u64,
    /// Ticks skipped by re-anchoring (not integrated at all).
    pub dropped: u64,
}

impl Due {
    pub fn skipped(&self) -> u64 {
        self.report_from - self.first
    }
}

impl Schedule {
    /// `rate` is wall ticks per second and must be positive and finite (START validation).
    pub fn new(rate: f64) -> Self {
        Self {
            rate,
            shift: Duration::ZERO,
            next: 0,
        }
    }

    /// Deadline of tick `n`, as an offset from the run's start.
    pub fn deadline(&self, n: u64) -> Duration {
        self.shift + Duration::from_secs_f64(n as f64 / self.rate)
    }

    /// The next tick's deadline.
    pub fn next_deadline(&self) -> Duration {
        self.deadline(self.next)
    }

    pub fn next_tick(&self) -> u64 {
        self.next
    }

    /// Ticks due at `now` (offset from the run's start), or `None` before the next deadline.
    /// Marks them processed.
    pub fn due(&mut self, now: Duration) -> Option<Due> {
        if now < self.next_deadline() {
            return None;
        }
        let since_shift = now.saturating_sub(self.shift).as_secs_f64();
        // Newest n with deadline(n) <= now; guard the float edge both ways.
        let mut last = ((since_shift * self.rate).floor() as u64).max(self.next);
        while last > self.next && self.deadline(last) > now {
            last -= 1;
        }
        while self.deadline(last + 1) <= now {
            last += 1;
        }
        let first = self.next;
        let mut dropped = 0;
        if last + 1 - first > MAX_CATCH_UP {
            dropped = last + 1 - first - MAX_CATCH_UP;
            // Tick numbers stay simulated time; the deadlines of the dropped ticks are given up.
            self.shift += Duration::from_secs_f64(dropped as f64 / self.rate);
            last = first + MAX_CATCH_UP - 1;
        }
        let mut report_from = last;
        while report_from > first
            && now.saturating_sub(self.deadline(report_from - 1)) <= STALE_AFTER
        {
            report_from -= 1;
        }
        self.next = last + 1;
        Some(Due {
            first,
            last,
            report_from,
            dropped,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ms(v: f64) -> Duration {
        Duration::from_secs_f64(v / 1000.0)
    }

    #[test]
    fn deadlines_do_not_drift() {
        // FREQ 10 WARP 100 → 1 ms; FREQ 3 WARP 1 → 333.33 ms; FREQ 7 WARP 10000 → 14.29 µs.
        for (rate, n, want) in [
            (1000.0, 3_600_000u64, 3600.0),
            (3.0, 30_000, 10_000.0),
            (70_000.0, 7_000_000, 100.0),
        ] {
            let s = Schedule::new(rate);
            let got = s.deadline(n).as_secs_f64();
            assert!((got - want).abs() < 1e-6, "{rate}: {got} != {want}");
        }
    }

    #[test]
    fn on_time_wakeups_report_every_tick() {
        let mut s = Schedule::new(1000.0);
        for n in 0..10_000u64 {
            let now = s.next_deadline() + ms(0.3);
            let d = s.due(now).unwrap();
            assert_eq!((d.first, d.last, d.report_from, d.dropped), (n, n, n, 0));
        }
        assert_eq!(s.due(s.next_deadline() - ms(0.1)), None);
    }

    #[test]
    fn policy_table() {
        // (rate, wake at ms after start with a fresh schedule, first, last, report_from)
        let rows = [
            (10.0, 0.0, 0, 0, 0),
            // 2 s stall at 10 Hz: 21 ticks due, only the newest reported.
            (10.0, 2000.0, 0, 20, 20),
            // 1 ms ticks, woken 3.5 ms late: all within 20 ms, all reported.
            (1000.0, 3.5, 0, 3, 0),
            // 1 ms ticks, woken 29.5 ms late: ticks 0..=9 are over 20 ms old, stale.
            (1000.0, 29.5, 0, 29, 10),
            // Just short of tick 1.
            (10.0, 99.9, 0, 0, 0),
        ];
        for (rate, at, first, last, from) in rows {
            let mut s = Schedule::new(rate);
            let d = s.due(ms(at)).unwrap();
            assert_eq!(
                (d.first, d.last, d.report_from),
                (first, last, from),
                "{rate} {at}"
            );
            assert_eq!(s.next_tick(), last + 1);
        }
    }

    #[test]
    fn suspension_reanchors_and_bounds_work() {
        let mut s = Schedule::new(10_000.0);
        // 1 hour suspended: 36 M ticks due.
        let d = s.due(Duration::from_secs(3600)).unwrap();
        assert_eq!(d.last - d.first + 1, MAX_CATCH_UP);
        assert_eq!(d.dropped, 36_000_001 - MAX_CATCH_UP);
        // Only the ticks of the last STALE_AFTER (20 ms = 200 ticks) are reported.
        assert_eq!(d.last - d.report_from, 200);
        // After re-anchoring the next tick is due just after now, not in the past.
        let next = s.next_deadline();
        assert!(next > Duration::from_secs(3600) && next <= Duration::from_secs(3600) + ms(0.2));
    }
}
