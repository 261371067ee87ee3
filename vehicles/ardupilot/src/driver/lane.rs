//! The driver's side of the setpoint lane (ARCHITECTURE.md "The lane per vehicle family"): the
//! lane's way opened with the link (not UDP) and closed with it, the course the lane wrote taken
//! into the driver's own at the start of every message (so re-sends and the helm timeout go on
//! from it), and the steering snapshot published at the end of every message. The shared state
//! and the lane's writer are `steer`.

use std::sync::Arc;
use std::time::Duration;

use super::state::{ArdupilotDriver, Course};
use super::steer::{DirectTarget, Ready};
use frontseat_actors::driver::DirectCommand;
use frontseat_actors::link::LineWriter;
use frontseat_actors::link::byte::Transport;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::FrontSeatState;

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
