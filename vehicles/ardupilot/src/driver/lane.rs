//! The setpoint lane's way to an ArduPilot vehicle (ARCHITECTURE.md "The lane per vehicle
//! family"): a new course's GUIDED target written from the publisher's thread. It owns the
//! steering snapshot the driver publishes after every message (armed in GUIDED, the vehicle's
//! ids, for a Sub its LOCAL_POSITION_NED anchor and held depth, the course in force, or None),
//! the MAVLink framer the driver's own writes share (one lock: sequence numbers go out in the
//! order the frames enter the link), and the course the lane last wrote, which the driver takes
//! into its own at its next message. The mode state, re-sends, the helm timeout and every other
//! frame stay the driver's.

use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use crate::codec::{MavMessage, Sender};
use crate::infer;
use crate::modes::Firmware;

use super::state::{ArdupilotDriver, Course};
use frontseat_actors::driver::DirectCommand;
use frontseat_actors::drivers::kit::raw_binary;
use frontseat_actors::link::LineWriter;
use frontseat_actors::link::byte::Transport;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CommandRequest, FrontSeatState, Raw,
};

/// A course as the driver keeps it: heading (deg), speed (m/s), depth (m; a Sub's always set).
pub(super) type Triple = (f64, f64, Option<f64>);

/// Where a lane target may go, as the driver last left it.
#[derive(Clone, Copy, Debug)]
pub(super) struct Ready {
    sys: u8,
    comp: u8,
    /// Sub: the latest finite LOCAL_POSITION_NED (north, east, down).
    anchor: Option<(f64, f64, f64)>,
    /// The course in force (None: no course yet, or the helm's timed out).
    course: Option<Triple>,
    /// The driver's clock at its last message, for the target's time_boot_ms.
    now: Duration,
}

pub(super) struct SteerState {
    /// The one MAVLink framer: the driver's frames and the lane's take their sequence here.
    pub(super) tx: Sender,
    pub(super) ready: Option<Ready>,
    /// The course the lane last wrote a target for, not yet taken by the driver.
    written: Option<Triple>,
}

/// Shared by the driver and its [`DirectTarget`].
#[derive(Clone)]
pub(super) struct Steer(Arc<Mutex<SteerState>>);

impl Steer {
    pub(super) fn new(tx: Sender) -> Self {
        Self(Arc::new(Mutex::new(SteerState {
            tx,
            ready: None,
            written: None,
        })))
    }

    pub(super) fn lock(&self) -> MutexGuard<'_, SteerState> {
        self.0.lock().unwrap_or_else(|p| p.into_inner())
    }
}

/// The lane's [`DirectCommand`] while a MAVLink link is open (not UDP: its peer may change or
/// be unknown, so its writes stay on the actors' path).
pub(super) struct DirectTarget {
    writer: LineWriter,
    steer: Steer,
    firmware: Firmware,
}

impl DirectCommand for DirectTarget {
    fn send_now(&self, req: &CommandRequest) -> Option<Raw> {
        let c = req.desired_course.as_ref()?;
        let (heading, speed) = (c.heading(), c.speed());
        // What the driver's own path would refuse goes there to be refused.
        if !(heading.is_finite() && speed.is_finite() && speed >= 0.0) {
            return None;
        }
        let sub = self.firmware == Firmware::Sub;
        if sub && c.depth.is_some_and(|d| !(d.is_finite() && d >= 0.0)) {
            return None;
        }
        let mut st = self.steer.lock();
        let ready = st.ready?;
        let in_force = st.written.or(ready.course);
        let mut depth = c.depth.filter(|d| d.is_finite());
        if sub && depth.is_none() {
            // The driver's rule: hold the depth the course finds.
            depth = in_force
                .and_then(|c| c.2)
                .or(ready.anchor.map(|(_, _, z)| z));
        }
        // Unchanged: the driver's path renews it without a write.
        if in_force == Some((heading, speed, depth)) {
            return None;
        }
        let boot_ms = ready.now.as_millis().min(u128::from(u32::MAX)) as u32;
        let msg = if sub {
            let (north, east, _) = ready.anchor?;
            MavMessage::SET_POSITION_TARGET_LOCAL_NED(infer::sub_guided_target(
                heading, speed, depth?, north, east, ready.sys, ready.comp, boot_ms,
            ))
        } else {
            MavMessage::SET_POSITION_TARGET_GLOBAL_INT(infer::course_target(
                self.firmware,
                heading,
                speed,
                depth,
                ready.sys,
                ready.comp,
                boot_ms,
            ))
        };
        // Framed and handed to the link under the lock the driver's writes take: the sequence
        // numbers reach the vehicle in order. A full queue or a closed link: None, and the course
        // goes the actors' way (the sequence number it took is a gap the vehicle counts as lost).
        let frame = st.tx.frame(&msg);
        self.writer.write_bytes(frame.clone()).ok()?;
        st.written = Some((heading, speed, depth));
        Some(raw_binary(frame))
    }
}

impl ArdupilotDriver {
    /// The link opened on `w`: the lane's way to it, unless it is UDP.
    pub(super) fn open_lane(&mut self, w: &LineWriter) {
        let udp = matches!(
            self.settings.link.as_ref().map(|l| &l.transport),
            Some(Transport::UdpIn { .. } | Transport::UdpOut { .. })
        );
        self.direct = (!udp).then(|| {
            Arc::new(DirectTarget {
                writer: w.clone(),
                steer: self.steer.clone(),
                firmware: self.settings.firmware,
            })
        });
    }

    /// At the start of every message: the course the lane wrote a target for becomes the
    /// driver's, renewed and sent now, so re-sends and the helm timeout go on from it.
    pub(super) fn absorb(&mut self, now: Duration) {
        let written = self.steer.lock().written.take();
        if let Some((heading, speed, depth)) = written {
            self.course = Some(Course {
                heading,
                speed,
                depth,
                renewed: now,
                sent: Some(now),
            });
            self.counters.targets_sent += 1;
        }
    }

    /// At the end of every message: where a lane target may go now, if anywhere — armed in
    /// GUIDED (not the Sub's ALT_HOLD, whose course is three messages), the vehicle known, the
    /// link open, and for a Sub a finite LOCAL_POSITION_NED to anchor on. A mode change or a
    /// disarm the driver has just handled closes it here, before the lane can use it again.
    pub(super) fn publish_steer(&mut self, now: Duration) {
        let guided = self
            .beat
            .is_some_and(|b| b.armed && b.mode == self.settings.firmware.guided());
        let anchor = self
            .local
            .map(|l| (f64::from(l.x), f64::from(l.y), f64::from(l.z)))
            .filter(|(x, y, z)| x.is_finite() && y.is_finite() && z.is_finite());
        let ready = match (self.vehicle, self.writer.is_some()) {
            (Some((sys, comp)), true)
                if guided
                    && self.state == FrontSeatState::FrontseatAcceptingCommands
                    && (!self.is_sub() || anchor.is_some()) =>
            {
                Some(Ready {
                    sys,
                    comp,
                    anchor,
                    course: self.course.map(|c| (c.heading, c.speed, c.depth)),
                    now,
                })
            }
            _ => None,
        };
        self.steer.lock().ready = ready;
    }

    /// The link is gone or the driver stops: nothing goes the lane's way.
    pub(super) fn close_lane(&mut self) {
        self.direct = None;
        self.steer.lock().ready = None;
    }

    pub(super) fn direct(&self) -> Option<Arc<dyn DirectCommand>> {
        self.direct.clone().map(|d| d as Arc<dyn DirectCommand>)
    }
}
