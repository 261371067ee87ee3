//! What the driver shares with the setpoint lane (ARCHITECTURE.md "The lane per vehicle family"):
//! the steering snapshot the driver publishes after every message (armed in GUIDED, the vehicle's
//! ids, for a Sub its LOCAL_POSITION_NED anchor, the course in force, or None), the MAVLink framer
//! the driver's own writes share (one lock: sequence numbers go out in the order the frames enter
//! the link), the course the lane last wrote, and the lane's [`DirectTarget`], which writes a new
//! course's GUIDED target from the publisher's thread. What the driver does with them is `lane`.

use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use crate::codec::{MavMessage, Sender};
use crate::infer;
use crate::modes::Firmware;

use frontseat_actors::driver::DirectCommand;
use frontseat_actors::drivers::kit::raw_binary;
use frontseat_actors::link::LineWriter;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{CommandRequest, Raw};

/// A course as the driver keeps it: heading (deg), speed (m/s), depth (m; a Sub's always set).
pub(super) type Triple = (f64, f64, Option<f64>);

/// Where a lane target may go, as the driver last left it.
#[derive(Clone, Copy, Debug)]
pub(super) struct Ready {
    pub(super) sys: u8,
    pub(super) comp: u8,
    /// Sub: the latest finite LOCAL_POSITION_NED (north, east, down).
    pub(super) anchor: Option<(f64, f64, f64)>,
    /// The course in force (None: no course yet, or the helm's timed out).
    pub(super) course: Option<Triple>,
    /// The driver's clock at its last message, for the target's time_boot_ms.
    pub(super) now: Duration,
}

pub(super) struct SteerState {
    /// The one MAVLink framer: the driver's frames and the lane's take their sequence here.
    pub(super) tx: Sender,
    pub(super) ready: Option<Ready>,
    /// The course the lane last wrote a target for, not yet taken by the driver.
    pub(super) written: Option<Triple>,
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
    pub(super) writer: LineWriter,
    pub(super) steer: Steer,
    pub(super) firmware: Firmware,
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
