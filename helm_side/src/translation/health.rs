//! The translation's own health: the MOOSDB link, whether the helm is heard and in DRIVE, and
//! how fresh DESIRED_* are, turned into the TranslationStatus it publishes; and which changes
//! of that status are worth publishing at once.

use std::time::Duration;

use tokio::time::Instant;

use frontseat_actors::proto::frontseat::protobuf::TranslationStatus;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::HelmState;

/// The translation's view of its health, turned into a TranslationStatus on demand.
#[derive(Clone, Debug)]
pub struct Health {
    pub connected: bool,
    pub helm_state: HelmState,
    pub last_helm_state: Option<Instant>,
    pub last_desired: Option<Instant>,
    pub started: Instant,
    pub reconnects: u64,
    /// 0 = never report staleness.
    pub desired_timeout: Duration,
}

impl Health {
    pub fn new(now: Instant, desired_timeout_s: f64) -> Self {
        let desired_timeout = if desired_timeout_s.is_finite() && desired_timeout_s > 0.0 {
            Duration::from_secs_f64(desired_timeout_s)
        } else {
            Duration::ZERO
        };
        Self {
            connected: false,
            helm_state: HelmState::HelmNotRunning,
            last_helm_state: None,
            last_desired: None,
            started: now,
            reconnects: 0,
            desired_timeout,
        }
    }

    /// The status at `now`. The helm counts as NOT_RUNNING when the DB link is down or when
    /// IVPHELM_STATE (a 4 Hz heartbeat of pHelmIvP) has not been heard for `desired_timeout`;
    /// DESIRED_* are stale when none arrived for `desired_timeout` (counting from start when
    /// none ever did).
    pub fn status(&self, now: Instant) -> TranslationStatus {
        let timeout = self.desired_timeout;
        let silent = |last: Option<Instant>| {
            !timeout.is_zero() && now.duration_since(last.unwrap_or(self.started)) > timeout
        };
        let helm_heard = self.last_helm_state.is_some() && !silent(self.last_helm_state);
        let helm_state = if !self.connected || !helm_heard {
            HelmState::HelmNotRunning
        } else {
            self.helm_state
        };
        TranslationStatus {
            moos_connected: Some(self.connected),
            helm_state: Some(helm_state as i32),
            helm_driving: Some(helm_state == HelmState::HelmDrive),
            seconds_since_desired: self
                .last_desired
                .map(|t| now.duration_since(t).as_secs_f64()),
            desired_stale: Some(silent(self.last_desired)),
            reconnects: Some(self.reconnects),
        }
    }
}

/// Whether two statuses differ in what a user acts on (not in the ticking age).
pub(super) fn status_changed(a: &TranslationStatus, b: &TranslationStatus) -> bool {
    a.moos_connected != b.moos_connected
        || a.helm_state != b.helm_state
        || a.helm_driving != b.helm_driving
        || a.desired_stale != b.desired_stale
        || a.reconnects != b.reconnects
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn health_reports_link_helm_and_desired_staleness() {
        let t0 = Instant::now();
        let mut h = Health::new(t0, 2.0);
        let s = h.status(t0);
        assert_eq!(s.moos_connected, Some(false));
        assert_eq!(s.helm_state(), HelmState::HelmNotRunning);
        assert_eq!(s.helm_driving, Some(false));
        assert_eq!(s.desired_stale, Some(false), "not stale before the timeout");
        assert_eq!(s.seconds_since_desired, None);
        assert_eq!(
            h.status(t0 + Duration::from_secs(3)).desired_stale,
            Some(true)
        );

        h.connected = true;
        h.helm_state = HelmState::HelmDrive;
        let t1 = t0 + Duration::from_secs(4);
        h.last_helm_state = Some(t1);
        h.last_desired = Some(t1);
        let s = h.status(t1 + Duration::from_millis(500));
        assert_eq!(s.helm_state(), HelmState::HelmDrive);
        assert_eq!(s.helm_driving, Some(true));
        assert_eq!(s.desired_stale, Some(false));
        assert_eq!(s.seconds_since_desired, Some(0.5));

        // The helm went quiet: neither driving nor fresh.
        let s = h.status(t1 + Duration::from_secs(3));
        assert_eq!(s.helm_state(), HelmState::HelmNotRunning);
        assert_eq!(s.helm_driving, Some(false));
        assert_eq!(s.desired_stale, Some(true));

        // PARK is not driving; a lost link is not driving either.
        h.helm_state = HelmState::HelmPark;
        assert_eq!(h.status(t1).helm_driving, Some(false));
        h.helm_state = HelmState::HelmDrive;
        h.connected = false;
        assert_eq!(h.status(t1).helm_driving, Some(false));

        // Timeout 0 = never stale.
        let never = Health::new(t0, 0.0);
        assert_eq!(
            never.status(t0 + Duration::from_secs(1000)).desired_stale,
            Some(false)
        );
    }

    #[test]
    fn status_change_ignores_the_ticking_age() {
        let t0 = Instant::now();
        let mut h = Health::new(t0, 2.0);
        h.last_desired = Some(t0);
        let a = h.status(t0);
        let b = h.status(t0 + Duration::from_millis(100));
        assert!(!status_changed(&a, &b));
        h.connected = true;
        assert!(status_changed(&a, &h.status(t0)));
    }
}
