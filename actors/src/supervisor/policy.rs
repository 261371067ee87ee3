//! The restart decision, pure and table-tested: a child's [`Policy`] (which [`Side`] it is on,
//! never / on-failure / always, backoff and limit), the [`Decider`] that keeps one child's restart
//! bookkeeping with the clock passed in, the [`ChildFailure`] a child fails with and the
//! [`ServiceExit`] it may ask for. No actor and no I/O here: the supervisor actor asks, this answers.

use std::collections::VecDeque;
use std::time::Duration;

use frontseat_config::{RestartConfig, RestartPolicy};
use tokio::time::Instant;

/// Why the service ended.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ServiceExit {
    /// Orderly shutdown.
    Clean,
    /// exit_on_error and an error state was entered. Its code is Goby3's (0, frontseat_interface.cpp
    /// 176-184); `frontseat interface` exits with the configured `exit_on_error_code` instead.
    ErrorState(String),
    /// A vehicle-side child (the driver, the interface) failed more often than its limit allows.
    RestartLimit(String),
    /// The interface actor itself failed.
    Failed(String),
}

impl ServiceExit {
    pub fn code(&self) -> i32 {
        match self {
            ServiceExit::Clean => 0,
            ServiceExit::ErrorState(_) => 0,
            ServiceExit::RestartLimit(_) => 3,
            ServiceExit::Failed(_) => 4,
        }
    }
}

/// Which side of the frontseat link a child is on, and so what repeated failures of it do.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Side {
    /// The vehicle side, or any child whose repeated failure must end its supervisor: at most
    /// `max_restarts` within the window, then give up (the process ends for systemd).
    #[default]
    Vehicle,
    /// The helm side: restarted without end (capped, jittered backoff); never ends the process.
    Helm,
}

impl Side {
    pub fn name(self) -> &'static str {
        match self {
            Side::Vehicle => "vehicle",
            Side::Helm => "helm",
        }
    }
}

/// Remembered restart times per child at most (the helm side has no limit to count towards).
const MAX_REMEMBERED_RESTARTS: usize = 1024;

/// What a supervisor knows about how to restart one child.
#[derive(Clone, Debug, PartialEq)]
pub struct Policy {
    pub side: Side,
    pub restart: RestartPolicy,
    pub max_restarts: u32,
    pub window: Duration,
    pub backoff_initial: Duration,
    pub backoff_max: Duration,
}

impl Policy {
    /// The same policy on the helm side.
    pub fn helm_side(self) -> Self {
        Self {
            side: Side::Helm,
            ..self
        }
    }
}

impl From<&RestartConfig> for Policy {
    fn from(c: &RestartConfig) -> Self {
        Self {
            side: Side::Vehicle,
            restart: c.policy,
            max_restarts: c.max_restarts,
            window: Duration::from_secs_f64(c.restart_window_s.max(0.0)),
            backoff_initial: Duration::from_millis(c.backoff_initial_ms),
            backoff_max: Duration::from_millis(c.backoff_max_ms.max(c.backoff_initial_ms)),
        }
    }
}

/// How a child ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ending {
    Failed,
    Stopped,
}

/// What to do about it.
#[derive(Clone, Debug, PartialEq)]
pub enum Decision {
    /// Restart after this delay (the n-th restart in the window).
    Restart { after: Duration, nth: u32 },
    /// Leave it down (an orderly end under on-failure or never).
    LeaveDown,
    /// Give up: the process should end non-zero.
    GiveUp(String),
}

/// A child's failure as it reaches its supervisor (the error a supervised actor fails with).
/// `exit` is the process exit the child asks for should its supervisor give up on it; an exit of
/// [`ServiceExit::RestartLimit`] means the child already exhausted a restart limit of its own
/// (the DriverActor's under the FrontSeatInterface), so its supervisor escalates at once instead
/// of multiplying that limit by its own; likewise an error state under exit_on_error.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ChildFailure {
    pub why: String,
    pub exit: Option<ServiceExit>,
}

impl ChildFailure {
    pub fn new(why: impl Into<String>) -> Self {
        Self {
            why: why.into(),
            exit: None,
        }
    }

    /// The text of a panic caught by a JoinHandle.
    pub fn from_join(what: &str, e: tokio::task::JoinError) -> Self {
        if e.is_panic() {
            let p = e.into_panic();
            let text = p
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| p.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "panic".into());
            Self::new(format!("{what} panicked: {text}"))
        } else {
            Self::new(format!("{what}: {e}"))
        }
    }

    /// The child decided the process should end (an error state under exit_on_error, or an
    /// exhausted restart limit of its own): restarting it would overrule that decision.
    pub(super) fn escalates(&self) -> bool {
        matches!(
            self.exit,
            Some(ServiceExit::RestartLimit(_) | ServiceExit::ErrorState(_))
        )
    }
}

impl std::fmt::Display for ChildFailure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.why)
    }
}

impl std::error::Error for ChildFailure {}

/// The restart bookkeeping of one child: pure, clock passed in (and the jitter's seed).
#[derive(Clone, Debug)]
pub struct Decider {
    policy: Policy,
    recent: VecDeque<Instant>,
    pub restarts: u32,
    /// xorshift state for the helm side's jitter: children failing together (one cause) must
    /// not come back in lockstep.
    jitter: u64,
}

impl Decider {
    pub fn new(policy: Policy) -> Self {
        let seed = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0x9e37_79b9, |d| d.as_nanos() as u64);
        Self::with_seed(policy, seed)
    }

    pub fn with_seed(policy: Policy, seed: u64) -> Self {
        Self {
            policy,
            recent: VecDeque::new(),
            restarts: 0,
            jitter: seed | 1,
        }
    }

    /// A factor in [0.5, 1): "equal jitter", so the delay stays within half of its cap.
    fn jitter_factor(&mut self) -> f64 {
        let mut x = self.jitter;
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        self.jitter = x;
        0.5 + (x >> 11) as f64 / (1u64 << 53) as f64 / 2.0
    }

    pub fn decide(&mut self, name: &str, ending: Ending, now: Instant) -> Decision {
        if self.policy.side == Side::Helm {
            return self.decide_helm(ending, now);
        }
        let wanted = match (self.policy.restart, ending) {
            (RestartPolicy::Always, _) | (RestartPolicy::OnFailure, Ending::Failed) => true,
            (RestartPolicy::Never, Ending::Failed) => {
                return Decision::GiveUp(format!(
                    "{name} failed and its restart policy is `never`"
                ));
            }
            _ => false,
        };
        if !wanted {
            return Decision::LeaveDown;
        }
        while let Some(t) = self.recent.front() {
            if now.saturating_duration_since(*t) > self.policy.window {
                self.recent.pop_front();
            } else {
                break;
            }
        }
        if self.recent.len() as u32 >= self.policy.max_restarts {
            return Decision::GiveUp(format!(
                "{name} ended {} times within {:?} (max_restarts {}); giving up so the service manager restarts the process",
                self.recent.len() + 1,
                self.policy.window,
                self.policy.max_restarts
            ));
        }
        let n = self.recent.len() as u32;
        let after = self
            .policy
            .backoff_initial
            .saturating_mul(2u32.saturating_pow(n))
            .min(self.policy.backoff_max);
        self.recent.push_back(now);
        self.restarts += 1;
        Decision::Restart {
            after,
            nth: self.restarts,
        }
    }

    /// The helm side never gives up: restarted by its policy (a `never` child is left down,
    /// degraded), after a delay doubling with the restarts in the window up to the cap, jittered.
    fn decide_helm(&mut self, ending: Ending, now: Instant) -> Decision {
        let wanted = match (self.policy.restart, ending) {
            (RestartPolicy::Always, _) | (RestartPolicy::OnFailure, Ending::Failed) => true,
            (RestartPolicy::OnFailure | RestartPolicy::Never, _) => false,
        };
        if !wanted {
            return Decision::LeaveDown;
        }
        while let Some(t) = self.recent.front() {
            if now.saturating_duration_since(*t) > self.policy.window
                || self.recent.len() >= MAX_REMEMBERED_RESTARTS
            {
                self.recent.pop_front();
            } else {
                break;
            }
        }
        let n = u32::try_from(self.recent.len()).unwrap_or(u32::MAX);
        let cap = self
            .policy
            .backoff_initial
            .saturating_mul(2u32.saturating_pow(n))
            .min(self.policy.backoff_max);
        let after = cap.mul_f64(self.jitter_factor());
        self.recent.push_back(now);
        self.restarts = self.restarts.saturating_add(1);
        Decision::Restart {
            after,
            nth: self.restarts,
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    pub(crate) fn policy(restart: RestartPolicy, max: u32) -> Policy {
        Policy {
            side: Side::Vehicle,
            restart,
            max_restarts: max,
            window: Duration::from_secs(60),
            backoff_initial: Duration::from_millis(100),
            backoff_max: Duration::from_millis(1000),
        }
    }

    #[tokio::test(start_paused = true)]
    async fn policy_table() {
        let now = Instant::now();
        let rows: [(&str, RestartPolicy, Ending, bool); 6] = [
            (
                "on-failure restarts a failure",
                RestartPolicy::OnFailure,
                Ending::Failed,
                true,
            ),
            (
                "on-failure leaves a stop down",
                RestartPolicy::OnFailure,
                Ending::Stopped,
                false,
            ),
            (
                "always restarts a failure",
                RestartPolicy::Always,
                Ending::Failed,
                true,
            ),
            (
                "always restarts a stop",
                RestartPolicy::Always,
                Ending::Stopped,
                true,
            ),
            (
                "never leaves a stop down",
                RestartPolicy::Never,
                Ending::Stopped,
                false,
            ),
            (
                "never gives up on a failure",
                RestartPolicy::Never,
                Ending::Failed,
                false,
            ),
        ];
        for (name, p, ending, restarts) in rows {
            let d = Decider::new(policy(p, 5)).decide("child", ending, now);
            assert_eq!(
                matches!(d, Decision::Restart { .. }),
                restarts,
                "{name}: {d:?}"
            );
            if p == RestartPolicy::Never && ending == Ending::Failed {
                assert!(matches!(d, Decision::GiveUp(_)), "{name}");
            }
        }
    }

    #[tokio::test(start_paused = true)]
    async fn backoff_doubles_to_the_cap_and_the_window_forgives() {
        let mut d = Decider::new(policy(RestartPolicy::OnFailure, 5));
        let mut delays = Vec::new();
        for _ in 0..5 {
            match d.decide("c", Ending::Failed, Instant::now()) {
                Decision::Restart { after, .. } => delays.push(after.as_millis()),
                other => panic!("{other:?}"),
            }
        }
        assert_eq!(delays, vec![100, 200, 400, 800, 1000]);
        assert!(matches!(
            d.decide("c", Ending::Failed, Instant::now()),
            Decision::GiveUp(_)
        ));
        tokio::time::advance(Duration::from_secs(61)).await;
        assert_eq!(
            d.decide("c", Ending::Failed, Instant::now()),
            Decision::Restart {
                after: Duration::from_millis(100),
                nth: 6
            }
        );
    }

    #[tokio::test(start_paused = true)]
    async fn the_helm_side_never_gives_up_and_its_backoff_is_capped_and_jittered() {
        let mut d = Decider::with_seed(policy(RestartPolicy::OnFailure, 2).helm_side(), 42);
        let mut delays = Vec::new();
        for _ in 0..2000 {
            match d.decide("c", Ending::Failed, Instant::now()) {
                Decision::Restart { after, .. } => delays.push(after),
                other => panic!("the helm side gave up: {other:?}"),
            }
        }
        // Doubling from 100 ms, capped at 1000 ms, each in [cap / 2, cap).
        let caps = [100u64, 200, 400, 800, 1000];
        for (n, a) in delays.iter().enumerate() {
            let cap = Duration::from_millis(caps[n.min(caps.len() - 1)]);
            assert!(
                *a >= cap / 2 && *a < cap,
                "restart {n}: {a:?} for cap {cap:?}"
            );
        }
        let distinct: std::collections::BTreeSet<_> = delays[10..].iter().collect();
        assert!(distinct.len() > 100, "jittered, not in lockstep");
        assert_eq!(d.restarts, 2000);
        // Its bookkeeping stays bounded however often it fails.
        assert!(d.recent.len() <= MAX_REMEMBERED_RESTARTS);
    }

    #[tokio::test(start_paused = true)]
    async fn the_helm_side_honours_never_and_on_failure_without_giving_up() {
        let now = Instant::now();
        let never = policy(RestartPolicy::Never, 5).helm_side();
        assert_eq!(
            Decider::new(never).decide("c", Ending::Failed, now),
            Decision::LeaveDown
        );
        let on_failure = policy(RestartPolicy::OnFailure, 5).helm_side();
        assert_eq!(
            Decider::new(on_failure).decide("c", Ending::Stopped, now),
            Decision::LeaveDown
        );
        let always = policy(RestartPolicy::Always, 0).helm_side();
        assert!(matches!(
            Decider::new(always).decide("c", Ending::Stopped, now),
            Decision::Restart { .. }
        ));
    }
}
