//! The setpoint lane: a helm's desired_course goes to the vehicle's connection from the thread
//! that published it — through the state gate and the safety envelope, as every setpoint — with
//! no actor hop, the way Goby3's interface calls its driver in the handler that received the
//! course (frontseat_interface.cpp). It owns what that needs and nothing else: whether the
//! interface is in command, the envelope's limits and context (last commanded and current
//! heading), the driver's way to write a command at once (a [`DirectCommand`], while it has a
//! connection that offers one), and the fence that keeps setpoints in order.
//!
//! The FrontSeatInterface and the DriverActor keep everything else, and every setpoint the lane
//! does not take goes their way as before: a course the envelope refuses (the interface counts,
//! logs and answers it), one outside command (refused there), a driver without a
//! [`DirectCommand`] (every built-in driver has one but the SV2's, whose C&C pulls its commands:
//! ARCHITECTURE.md "The lane per vehicle family"), and every
//! command_request, vehicle extension and raw send. While any of those is still on its way
//! through the actors (its delivery, or the interface's re-publication of it, not yet dropped:
//! see [`crate::bus::Held`]) the lane takes no course either, so no course overtakes one
//! published before it.
//!
//! Why it cannot delay the vehicle side: the publisher's thread does bounded work (a lock held
//! for a pure check and one non-blocking `write(2)`); when the link has anything queued the
//! course goes the actors' way. A helm that never publishes costs the lane nothing.

use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};

use crate::bus::{Envelope, Held};
use crate::command_gate::{GateContext, Limits, check_course};
use crate::ports::DriverActorPorts;
use crate::proto::goby::middleware::frontseat::protobuf::{CommandRequest, DesiredCourse, Raw};

/// A driver's way to write a command to its vehicle at once, from any thread.
pub trait DirectCommand: Send + Sync {
    /// Hands `req` (a course that passed the envelope) to the connection now, without waiting:
    /// the raw bytes written (for raw_out), or None when it cannot (not connected, something
    /// queued before it, a command it does not write this way) — the course then goes through the
    /// DriverActor.
    fn send_now(&self, req: &CommandRequest) -> Option<Raw>;
}

/// The driver's [`DirectCommand`] as installed by its DriverActor (`start`: which start of the
/// driver, so a dead one's leftovers never remove its successor's).
struct Installed {
    start: u32,
    cmd: Arc<dyn DirectCommand>,
    ports: DriverActorPorts,
}

struct LaneState {
    /// The interface is in command and not shutting down (the interface sets it after every
    /// message it handles).
    open: bool,
    limits: Limits,
    gate: GateContext,
    direct: Option<Installed>,
}

/// Counts setpoints still on their way through the actors; each [`Fence`] is one.
struct FenceToken(Arc<AtomicUsize>);

impl Drop for FenceToken {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::AcqRel);
    }
}

/// Shared by the interface (its bus subscription and its actor), the DriverActor, and whoever
/// publishes a desired_course (through that subscription). Cheap to clone.
#[derive(Clone)]
pub struct SetpointLane {
    state: Arc<Mutex<LaneState>>,
    in_actors: Arc<AtomicUsize>,
    direct_sent: Arc<AtomicU64>,
    metrics: Arc<frontseat_telemetry::metrics::VehicleMetrics>,
}

impl SetpointLane {
    pub fn new(limits: Limits, metrics: Arc<frontseat_telemetry::metrics::VehicleMetrics>) -> Self {
        Self {
            state: Arc::new(Mutex::new(LaneState {
                open: false,
                limits,
                gate: GateContext::default(),
                direct: None,
            })),
            in_actors: Arc::new(AtomicUsize::new(0)),
            direct_sent: Arc::new(AtomicU64::new(0)),
            metrics,
        }
    }

    fn lock(&self) -> MutexGuard<'_, LaneState> {
        self.state.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Takes `env` to the vehicle now when it can; otherwise gives it back, fenced, for the
    /// interface's mailbox.
    pub fn offer(&self, env: Envelope<DesiredCourse>) -> Result<(), Envelope<DesiredCourse>> {
        let mut st = self.lock();
        if !st.open || self.in_actors.load(Ordering::Acquire) > 0 {
            return Err(self.fenced(env));
        }
        let Some(direct) = st.direct.as_ref() else {
            return Err(self.fenced(env));
        };
        // A refused course goes to the interface, which refuses it again, counts, logs and
        // answers: one place says why a setpoint was refused.
        let Ok(safe) = check_course(&env.msg, &st.limits, &st.gate) else {
            return Err(self.fenced(env));
        };
        let req = CommandRequest {
            desired_course: Some(safe),
            ..Default::default()
        };
        let span = tracing::trace_span!(
            target: "frontseat_actors",
            "setpoint.direct",
            group = env.group,
        );
        let Some(raw) = span.in_scope(|| direct.cmd.send_now(&req)) else {
            return Err(self.fenced(env));
        };
        let ports = direct.ports.clone();
        st.gate.last_commanded_heading = safe.heading;
        drop(st);
        self.direct_sent.fetch_add(1, Ordering::Relaxed);
        frontseat_telemetry::metrics::VehicleMetrics::add(&self.metrics.setpoints_sent);
        span.in_scope(|| ports.publish_raw_to_frontseat_with(Arc::new(raw), env.meta()));
        Ok(())
    }

    /// `env` holding a fence: no course takes the lane until it (and what the interface
    /// re-publishes from it with [`crate::bus::Bus::publish_held`]) is dropped.
    pub fn fenced<T>(&self, env: Envelope<T>) -> Envelope<T> {
        self.in_actors.fetch_add(1, Ordering::AcqRel);
        env.holding(Held::new(FenceToken(self.in_actors.clone())))
    }

    /// Set by the interface after each message: whether a course may go to the vehicle.
    pub fn set_open(&self, open: bool) {
        self.lock().open = open;
    }

    /// The envelope's context, for the interface's own checks.
    pub fn gate(&self) -> GateContext {
        self.lock().gate
    }

    /// A course passed the envelope on the interface's path.
    pub fn commanded(&self, heading: Option<f64>) {
        self.lock().gate.last_commanded_heading = heading;
    }

    /// The newest navigation's heading.
    pub fn navigated(&self, heading: f64) {
        self.lock().gate.current_heading = Some(heading);
    }

    /// The DriverActor of start `start` installs its driver's [`DirectCommand`] (None: it has
    /// none now), publishing raw_out on `ports`.
    pub fn install(
        &self,
        start: u32,
        cmd: Option<Arc<dyn DirectCommand>>,
        ports: &DriverActorPorts,
    ) {
        let mut st = self.lock();
        st.direct = cmd.map(|cmd| Installed {
            start,
            cmd,
            ports: ports.clone(),
        });
    }

    /// The DriverActor of start `start` ends: its [`DirectCommand`] goes with it (a newer
    /// driver's stays).
    pub fn uninstall(&self, start: u32) {
        let mut st = self.lock();
        if st.direct.as_ref().is_some_and(|d| d.start == start) {
            st.direct = None;
        }
    }

    /// The interface ends: nothing more goes to the vehicle this way.
    pub fn close(&self) {
        let mut st = self.lock();
        st.open = false;
        st.direct = None;
    }

    /// Courses the lane wrote (for the snapshot and the tests).
    pub fn direct_sent(&self) -> u64 {
        self.direct_sent.load(Ordering::Relaxed)
    }

    /// Setpoints and other vehicle-bound messages on their way through the actors now.
    pub fn in_actors(&self) -> usize {
        self.in_actors.load(Ordering::Acquire)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bus::tests::Ping;
    use crate::bus::{Bus, Layer, PublishMeta};
    use crate::command_gate::Limits;

    const IN: crate::bus::Group<Ping> =
        crate::bus::Group::new("test::in", "test.Ping", Layer::Interthread);
    const OUT: crate::bus::Group<Ping> =
        crate::bus::Group::new("test::out", "test.Ping", Layer::Interthread);

    fn lane() -> SetpointLane {
        SetpointLane::new(
            Limits::default(),
            Arc::new(frontseat_telemetry::metrics::VehicleMetrics::default()),
        )
    }

    /// The fence holds while the delivery lives, and on through what is re-published from it
    /// with its `held`; it lifts when the last of them is dropped, and a delivery the bus could
    /// not queue holds nothing.
    #[tokio::test]
    async fn the_fence_follows_a_message_through_a_republication() {
        let lane = lane();
        let bus = Bus::new();
        let (_i, mut rin) = bus.subscribe_channel(&IN, "interface", 4);
        let (_o, mut rout) = bus.subscribe_channel(&OUT, "driver", 1);
        bus.publish(&IN, Ping { n: 1 });
        let env = lane.fenced(rin.recv().await.unwrap());
        assert_eq!(lane.in_actors(), 1);
        // The interface re-publishes it to the driver and is done with its own delivery.
        let held = env.held();
        bus.publish_held(&OUT, env.msg.clone(), PublishMeta::default(), held.clone());
        drop(env);
        drop(held);
        assert_eq!(lane.in_actors(), 1, "the driver's delivery holds it");
        // A second re-publication finds the driver's queue full: nothing of it is kept.
        let again = lane.fenced(bus_envelope(&bus, &mut rin).await);
        assert_eq!(lane.in_actors(), 2);
        let report = bus.publish_held(
            &OUT,
            again.msg.clone(),
            PublishMeta::default(),
            again.held(),
        );
        assert_eq!(report.dropped, 1);
        drop(again);
        assert_eq!(lane.in_actors(), 1);
        drop(rout.recv().await.unwrap());
        assert_eq!(
            lane.in_actors(),
            0,
            "the driver handled it: the lane is free"
        );
    }

    async fn bus_envelope(
        bus: &Bus,
        rx: &mut tokio::sync::mpsc::UnboundedReceiver<crate::bus::Envelope<Ping>>,
    ) -> crate::bus::Envelope<Ping> {
        bus.publish(&IN, Ping { n: 2 });
        rx.recv().await.unwrap()
    }

    /// Closed (not in command), or with no driver way in, the lane gives every course back,
    /// fenced: it goes the actors' way.
    #[tokio::test]
    async fn a_closed_lane_gives_the_course_back() {
        let lane = lane();
        let bus = Bus::new();
        let group = crate::groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE;
        let (_s, mut rx) = bus.subscribe_channel(&group, "interface", 4);
        bus.publish(&group, DesiredCourse::default());
        let env = rx.recv().await.unwrap();
        let back = lane.offer(env).expect_err("closed: given back");
        assert_eq!(lane.in_actors(), 1);
        lane.set_open(true);
        drop(back);
        bus.publish(&group, DesiredCourse::default());
        let env = rx.recv().await.unwrap();
        let back = lane.offer(env).expect_err("no DirectCommand: given back");
        assert_eq!(lane.in_actors(), 1);
        drop(back);
        assert_eq!(lane.in_actors(), 0);
        assert_eq!(lane.direct_sent(), 0);
    }
}
