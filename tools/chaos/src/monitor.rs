//! What the bus tells the harness: every status (the interface's state and when it changed),
//! node_status and CommandResponse, counted on the publisher's thread as it passes, and the
//! waits the run makes on the state (out of COMMAND, back in it, held there).

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use frontseat_actors::bus::{Bus, Subscription};
use frontseat_actors::interface::error_code;
use frontseat_actors::ports::ChaosMonitorInbox;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{InterfaceState, NodeStatus};
use frontseat_config::NavLimitsConfig;
use tokio::sync::watch;
use tokio::time::Instant;

const FIVE: [InterfaceState; 5] = [
    InterfaceState::InterfaceStandby,
    InterfaceState::InterfaceListen,
    InterfaceState::InterfaceCommand,
    InterfaceState::InterfaceHelmError,
    InterfaceState::InterfaceFsError,
];

/// What one request got: answers seen, the code of the first (0: success) and whether that
/// first one was the interface's own (timeout, driver failed), after which the driver's late
/// answer is still right. Four bytes per request, so a soak's bookkeeping stays small.
#[derive(Clone, Copy, Default)]
pub(crate) struct Answer {
    pub(crate) count: u8,
    first: i16,
    pub(crate) interface_first: bool,
}

/// Request ids from here up are the harness's pilot's (arming an ArduPilot and selecting
/// GUIDED, as the person at the ground station does): not the helm's, not counted.
pub(crate) const PILOT_IDS: i32 = 1 << 30;

/// Our helm's request ids run 1, 2, 3…: an id this far past the highest seen is not ours.
const FAR_ID: usize = 1 << 16;

#[derive(Default)]
pub(crate) struct Responses {
    /// Indexed by request_id − 1.
    pub(crate) answers: Vec<Answer>,
    /// (request_id, first code, further code) of the first few requests answered again.
    pub(crate) dup_examples: Vec<(i32, i32, i32)>,
    /// Answers with an id that cannot be one of ours (< 1, or far past every id seen).
    pub(crate) unknown_ids: u64,
    pub(crate) without_id: u64,
    pub(crate) ok: u64,
    pub(crate) not_in_command: u64,
    pub(crate) timeout: u64,
    pub(crate) driver_failed: u64,
    pub(crate) shutting_down: u64,
    pub(crate) frontseat_refused: u64,
}

impl Responses {
    fn get(&self, id: i32) -> Answer {
        usize::try_from(id)
            .ok()
            .and_then(|i| i.checked_sub(1))
            .and_then(|i| self.answers.get(i).copied())
            .unwrap_or_default()
    }

    pub(crate) fn answered(&self, id: i32) -> bool {
        self.get(id).count > 0
    }

    fn record(&mut self, id: i32, code: i32) {
        let Some(i) = usize::try_from(id).ok().and_then(|i| i.checked_sub(1)) else {
            self.unknown_ids += 1;
            return;
        };
        if i >= self.answers.len() {
            if i >= self.answers.len() + FAR_ID {
                self.unknown_ids += 1;
                return;
            }
            self.answers.resize(i + 1, Answer::default());
        }
        let a = &mut self.answers[i];
        a.count = a.count.saturating_add(1);
        if a.count == 1 {
            a.first = i16::try_from(code).unwrap_or(i16::MAX);
            a.interface_first = code == error_code::TIMEOUT || code == error_code::DRIVER_FAILED;
        } else if self.dup_examples.len() < 10 {
            let first = i32::from(a.first);
            self.dup_examples.push((id, first, code));
        }
    }
}

/// State changes kept for measuring outages: the windows measured are seconds long, so the
/// older half is dropped past this many (a soak's bookkeeping stays bounded).
const MAX_CHANGES: usize = 8192;

fn push_change(v: &mut Vec<(Instant, InterfaceState)>, c: (Instant, InterfaceState)) {
    if v.len() >= MAX_CHANGES {
        v.drain(..MAX_CHANGES / 2);
    }
    v.push(c);
}

/// Counters fed by bus subscriptions whose delivery functions run on the publisher's thread:
/// nothing is queued, so the monitor itself can never drop a message.
pub(crate) struct Monitor {
    pub(crate) statuses: AtomicU64,
    pub(crate) invalid_states: AtomicU64,
    pub(crate) invalid_examples: Mutex<Vec<i32>>,
    pub(crate) node_status: AtomicU64,
    pub(crate) responses: Mutex<Responses>,
    state: watch::Sender<InterfaceState>,
    /// Every change of state with its wall time, to measure how long each fault kept the
    /// interface out of COMMAND.
    pub(crate) changes: Mutex<Vec<(Instant, InterfaceState)>>,
    /// Bumped at every change of state, with the moment of the last one: a reading taken with
    /// the same count before and after it saw one unbroken stretch of a state.
    change_count: AtomicU64,
    last_change: Mutex<Instant>,
    pub(crate) rss_max_kib: AtomicU64,
    /// What a helm must never be handed: the interface's own navigation bounds.
    limits: NavLimitsConfig,
    /// node_status outside those bounds (or not finite), with the first few.
    pub(crate) absurd_nav: AtomicU64,
    pub(crate) absurd_examples: Mutex<Vec<String>>,
}

/// Why `n` is absurd for a helm under `l`, or None: position off the globe, a value not finite,
/// a speed or depth past the interface's own navigation bounds, a heading not wrapped.
pub(crate) fn absurd(n: &NodeStatus, l: &NavLimitsConfig) -> Option<String> {
    let g = &n.global_fix;
    let bad = |v: Option<f64>, lo: f64, hi: f64| {
        v.is_some_and(|x| !(x.is_finite() && (lo..=hi).contains(&x)))
    };
    if !n.time.is_finite() {
        return Some(format!("time {}", n.time));
    }
    if bad(Some(g.lat), -90.0, 90.0) || bad(Some(g.lon), -180.0, 180.0) {
        return Some(format!("position {:?}, {:?}", g.lat, g.lon));
    }
    if bad(g.depth, l.min_depth, l.max_depth) {
        return Some(format!("depth {:?}", g.depth));
    }
    if bad(n.pose.heading, 0.0, 360.0) || bad(n.pose.course_over_ground, 0.0, 360.0) {
        return Some(format!(
            "heading {:?}, course {:?}",
            n.pose.heading, n.pose.course_over_ground
        ));
    }
    let s = l.max_abs_speed;
    if bad(Some(n.speed.over_ground), -s, s) || bad(n.speed.over_water, -s, s) {
        return Some(format!(
            "speed {} / {:?}",
            n.speed.over_ground, n.speed.over_water
        ));
    }
    if let Some(c) = &n.local_fix
        && [Some(c.x), Some(c.y), c.z]
            .iter()
            .any(|v| v.is_some_and(|x| !x.is_finite()))
    {
        return Some(format!("local fix {c:?}"));
    }
    None
}

impl Monitor {
    pub(crate) fn new(limits: NavLimitsConfig) -> Arc<Self> {
        let (state, _) = watch::channel(InterfaceState::InterfaceStandby);
        Arc::new(Self {
            statuses: AtomicU64::new(0),
            invalid_states: AtomicU64::new(0),
            invalid_examples: Mutex::new(Vec::new()),
            node_status: AtomicU64::new(0),
            responses: Mutex::new(Responses::default()),
            state,
            changes: Mutex::new(Vec::new()),
            change_count: AtomicU64::new(0),
            last_change: Mutex::new(Instant::now()),
            rss_max_kib: AtomicU64::new(0),
            limits,
            absurd_nav: AtomicU64::new(0),
            absurd_examples: Mutex::new(Vec::new()),
        })
    }

    pub(crate) fn subscribe(self: &Arc<Self>, bus: &Bus) -> Vec<Subscription> {
        let m = self.clone();
        ChaosMonitorInbox::subscribe_all(bus, "chaos-monitor", 1 << 20, move |msg| {
            match msg {
                ChaosMonitorInbox::Status(env) => {
                    m.statuses.fetch_add(1, Ordering::Relaxed);
                    let raw = env.msg.state.unwrap_or(0);
                    match InterfaceState::try_from(raw) {
                        Ok(s) if FIVE.contains(&s) => {
                            let changed = m.state.send_if_modified(|cur| {
                                let c = *cur != s;
                                *cur = s;
                                c
                            });
                            if changed {
                                m.changed(s);
                            }
                        }
                        _ => {
                            m.invalid_states.fetch_add(1, Ordering::Relaxed);
                            if let Ok(mut v) = m.invalid_examples.lock()
                                && v.len() < 10
                            {
                                v.push(raw);
                            }
                        }
                    }
                }
                ChaosMonitorInbox::NodeStatus(env) => {
                    m.node_status.fetch_add(1, Ordering::Relaxed);
                    if let Some(why) = absurd(&env.msg, &m.limits) {
                        m.absurd_nav.fetch_add(1, Ordering::Relaxed);
                        if let Ok(mut v) = m.absurd_examples.lock()
                            && v.len() < 5
                        {
                            v.push(why);
                        }
                    }
                }
                ChaosMonitorInbox::CommandResponse(env) => {
                    if env.msg.request_id.is_some_and(|id| id >= PILOT_IDS) {
                        return Ok(());
                    }
                    let mut r = m.responses.lock().unwrap_or_else(|p| p.into_inner());
                    match env.msg.request_id {
                        Some(id) => r.record(id, env.msg.error_code.unwrap_or(0)),
                        None => r.without_id += 1,
                    }
                    if env.msg.request_successful() {
                        r.ok += 1;
                    } else {
                        match env.msg.error_code {
                            Some(error_code::NOT_IN_COMMAND) => r.not_in_command += 1,
                            Some(error_code::TIMEOUT) => r.timeout += 1,
                            Some(error_code::DRIVER_FAILED) => r.driver_failed += 1,
                            Some(error_code::SHUTTING_DOWN) => r.shutting_down += 1,
                            _ => r.frontseat_refused += 1,
                        }
                    }
                }
            }
            Ok(())
        })
    }

    pub(crate) fn state(&self) -> InterfaceState {
        *self.state.borrow()
    }

    fn changed(&self, s: InterfaceState) {
        let now = Instant::now();
        *self.last_change.lock().unwrap_or_else(|p| p.into_inner()) = now;
        self.change_count.fetch_add(1, Ordering::SeqCst);
        if let Ok(mut v) = self.changes.lock() {
            push_change(&mut v, (now, s));
        }
    }

    /// The state, how many changes there have been and when the last was.
    pub(crate) fn stretch(&self) -> (InterfaceState, u64, Instant) {
        let count = self.change_count.load(Ordering::SeqCst);
        let at = *self.last_change.lock().unwrap_or_else(|p| p.into_inner());
        (self.state(), count, at)
    }

    pub(crate) fn change_count(&self) -> u64 {
        self.change_count.load(Ordering::SeqCst)
    }

    /// The process ended: no state until the new one publishes (it starts in STANDBY).
    pub(crate) fn process_gone(&self) {
        let s = InterfaceState::InterfaceStandby;
        if self.state.send_if_modified(|cur| {
            let c = *cur != s;
            *cur = s;
            c
        }) {
            self.changed(s);
        }
    }

    /// Time spent outside COMMAND between `from` and `to`.
    pub(crate) fn outage(&self, from: Instant, to: Instant) -> Duration {
        let v = self.changes.lock().unwrap_or_else(|p| p.into_inner());
        // The state at `from`: the last change before it.
        let start = v.partition_point(|(t, _)| *t <= from);
        let mut state = if start == 0 {
            InterfaceState::InterfaceStandby
        } else {
            v[start - 1].1
        };
        let mut since = from;
        let mut out = Duration::ZERO;
        for (t, s) in v[start..].iter().take_while(|(t, _)| *t <= to) {
            if state != InterfaceState::InterfaceCommand {
                out += t.saturating_duration_since(since);
            }
            state = *s;
            since = *t;
        }
        if state != InterfaceState::InterfaceCommand {
            out += to.saturating_duration_since(since);
        }
        out
    }

    /// Waits up to `within` for the interface to leave COMMAND (a fault that takes effect).
    pub(crate) async fn until_left_command(&self, within: Duration) {
        let mut rx = self.state.subscribe();
        let _ = tokio::time::timeout(
            within,
            rx.wait_for(|s| *s != InterfaceState::InterfaceCommand),
        )
        .await;
    }

    /// Waits until the interface is in COMMAND; the time it took, or None past `within`.
    pub(crate) async fn until_command(&self, within: Duration) -> Option<Duration> {
        let start = Instant::now();
        let mut rx = self.state.subscribe();
        let r = tokio::time::timeout(
            within,
            rx.wait_for(|s| *s == InterfaceState::InterfaceCommand),
        )
        .await;
        matches!(r, Ok(Ok(_))).then(|| start.elapsed())
    }

    /// Waits until COMMAND has held for `stable`; the time from the call to the start of that
    /// stable stretch, or None past `within`.
    pub(crate) async fn until_stable_command(
        &self,
        within: Duration,
        stable: Duration,
    ) -> Option<Duration> {
        let start = Instant::now();
        let deadline = start + within;
        let mut rx = self.state.subscribe();
        loop {
            let left = deadline.checked_duration_since(Instant::now())?;
            let reached_command = matches!(
                tokio::time::timeout(
                    left,
                    rx.wait_for(|s| *s == InterfaceState::InterfaceCommand),
                )
                .await,
                Ok(Ok(_))
            );
            if !reached_command {
                return None;
            }
            let reached = start.elapsed();
            let left_command = tokio::time::timeout(
                stable,
                rx.wait_for(|s| *s != InterfaceState::InterfaceCommand),
            )
            .await;
            match left_command {
                Err(_) => return Some(reached),
                Ok(Err(_)) => return None,
                Ok(Ok(_)) => continue,
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use frontseat_actors::proto::goby::middleware::protobuf::LatLonPoint;

    #[test]
    fn absurd_node_status_is_told_from_a_sane_one() {
        let l = NavLimitsConfig::default();
        let sane = NodeStatus {
            time: 1.0,
            global_fix: LatLonPoint {
                lat: 41.0,
                lon: -8.7,
                depth: Some(3.0),
                ..Default::default()
            },
            ..Default::default()
        };
        assert_eq!(absurd(&sane, &l), None);
        let mut n = sane.clone();
        n.global_fix.lat = f64::NAN;
        assert!(absurd(&n, &l).is_some());
        let mut n = sane.clone();
        n.global_fix.depth = Some(l.max_depth + 1.0);
        assert!(absurd(&n, &l).is_some());
        let mut n = sane.clone();
        n.speed.over_ground = 1e308;
        assert!(absurd(&n, &l).is_some());
        let mut n = sane;
        n.pose.heading = Some(720.0);
        assert!(absurd(&n, &l).is_some());
    }
}
