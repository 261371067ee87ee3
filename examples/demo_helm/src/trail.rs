//! The trail helm of `frontseat demo --fleet`: a follower that keeps a slot in formation behind
//! a leader, from the leader's node_status (which the caller receives, e.g. over Zenoh), through
//! the same groups any helm uses on its own vehicle. The steering law is pure ([`setpoint`]) and
//! follows the idea of pHelmIvP's BHV_Trail (a point at a range and angle from the leader, taken
//! relative to the leader's heading; inside a radius match the leader's heading and speed): it
//! steers for a point `lookahead_m` ahead of the slot along the leader's heading, and adds to the
//! leader's speed in proportion to how far the slot is ahead.

use std::time::Duration;

use frontseat_actors::bus::{Bus, Undeliverable};
use frontseat_actors::clock::SimClock;
use frontseat_actors::ports::{DemoHelmInbox, DemoHelmPorts};
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    DesiredCourse, HelmState, HelmStateReport, InterfaceState,
};
use tokio::sync::watch;

use crate::{Leg, TrackPoint};

/// Where a follower sits: `behind_m` behind the leader along its heading, `side_m` to its
/// right (negative: left).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Slot {
    pub behind_m: f64,
    pub side_m: f64,
}

impl Slot {
    /// The slot of follower `k` (1, 2, …) in a V: pairs at `behind_m` steps, right then left.
    pub fn in_v(k: usize, behind_m: f64, side_m: f64) -> Self {
        let rank = k.div_ceil(2) as f64;
        let side = if k % 2 == 1 { side_m } else { -side_m };
        Self {
            behind_m: behind_m * rank,
            side_m: side,
        }
    }

    /// The slot's position in the local grid (x east, y north) for a leader at `(x, y)` heading
    /// `heading_deg` (compass: 0 north, 90 east).
    pub fn position(&self, x: f64, y: f64, heading_deg: f64) -> (f64, f64) {
        let h = heading_deg.to_radians();
        let (fx, fy) = (h.sin(), h.cos());
        let (rx, ry) = (h.cos(), -h.sin());
        (
            x - self.behind_m * fx + self.side_m * rx,
            y - self.behind_m * fy + self.side_m * ry,
        )
    }
}

/// The leader as the follower last heard it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeaderFix {
    pub x: f64,
    pub y: f64,
    pub heading: f64,
    pub speed: f64,
}

impl LeaderFix {
    /// A fix usable for steering: finite, a heading within a turn, a speed a boat can do.
    pub fn plausible(&self) -> bool {
        [self.x, self.y, self.heading, self.speed]
            .iter()
            .all(|v| v.is_finite())
            && self.x.abs() < 1e7
            && self.y.abs() < 1e7
            && (-360.0..=720.0).contains(&self.heading)
            && (0.0..=50.0).contains(&self.speed)
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrailParams {
    pub slot: Slot,
    /// The point steered for is this far ahead of the slot. Unit: m.
    pub lookahead_m: f64,
    /// Speed added per metre the slot is ahead (removed per metre behind). Unit: 1/s.
    pub gain: f64,
    /// Highest speed asked for. Unit: m/s.
    pub max_speed: f64,
}

impl TrailParams {
    pub fn new(slot: Slot) -> Self {
        Self {
            slot,
            lookahead_m: 15.0,
            gain: 0.15,
            max_speed: 3.0,
        }
    }
}

/// Heading (degrees, [0, 360)) and speed (m/s) to keep the slot, from the follower at `(x, y)`.
pub fn setpoint(p: &TrailParams, leader: &LeaderFix, x: f64, y: f64) -> (f64, f64) {
    let (sx, sy) = p.slot.position(leader.x, leader.y, leader.heading);
    let h = leader.heading.to_radians();
    let (fx, fy) = (h.sin(), h.cos());
    let (ax, ay) = (sx + p.lookahead_m * fx, sy + p.lookahead_m * fy);
    let heading = (ax - x).atan2(ay - y).to_degrees().rem_euclid(360.0);
    // How far the slot is ahead of us along the leader's heading.
    let along = (sx - x) * fx + (sy - y) * fy;
    let speed = (leader.speed + p.gain * along).clamp(0.0, p.max_speed);
    (heading, speed)
}

/// Runs a follower on `bus` (its own vehicle's groups) until `done` turns true: helm_state DRIVE
/// every second, and from the moment its interface is in COMMAND and the leader has been heard,
/// a desired_course every half second. Stops the vehicle before returning its track.
pub async fn run(
    bus: &Bus,
    clock: SimClock,
    params: TrailParams,
    leader: watch::Receiver<Option<LeaderFix>>,
    mut done: watch::Receiver<bool>,
) -> Vec<TrackPoint> {
    let ports = DemoHelmPorts::new(bus);
    let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel();
    let subs = DemoHelmInbox::subscribe_all(bus, "TrailHelm", 1024, move |m| {
        tx.send(m).map_err(|_| Undeliverable)
    });
    let mut track = Vec::new();
    let mut in_command = false;
    let (mut x, mut y, mut heading) = (0.0, 0.0, 0.0);
    let mut heard_self = false;
    let mut tick = tokio::time::interval(clock.wall(Duration::from_millis(500)));
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
    let mut n = 0u64;
    loop {
        tokio::select! {
            _ = tick.tick() => {
                if n.is_multiple_of(2) {
                    ports.publish_helm_state(HelmStateReport { state: HelmState::HelmDrive as i32 });
                }
                n += 1;
                let fix = *leader.borrow();
                if let (true, true, Some(l)) = (in_command, heard_self, fix.filter(LeaderFix::plausible)) {
                    let (h, s) = setpoint(&params, &l, x, y);
                    ports.publish_desired_course(DesiredCourse {
                        time: SimClock::unix_now(),
                        heading: Some(h),
                        speed: Some(s),
                        depth: Some(0.0),
                        ..Default::default()
                    });
                }
            }
            changed = done.changed() => {
                if changed.is_err() || *done.borrow() {
                    break;
                }
            }
            Some(m) = rx.recv() => match m {
                DemoHelmInbox::NodeStatus(env) => {
                    if let Some(l) = &env.msg.local_fix {
                        x = l.x;
                        y = l.y;
                        heard_self = true;
                    }
                    heading = env.msg.pose.heading();
                    track.push(TrackPoint {
                        t: clock.now().as_secs_f64(),
                        x,
                        y,
                        heading,
                        speed: env.msg.speed.over_ground,
                        leg: if in_command { Leg::Trail } else { Leg::WaitingForCommand },
                        depth: env.msg.global_fix.depth.unwrap_or(0.0),
                    });
                }
                DemoHelmInbox::Status(env) => {
                    in_command = env.msg.state == Some(InterfaceState::InterfaceCommand as i32);
                }
            },
        }
    }
    ports.publish_desired_course(DesiredCourse {
        time: SimClock::unix_now(),
        heading: Some(heading),
        speed: Some(0.0),
        depth: Some(0.0),
        ..Default::default()
    });
    for s in subs {
        s.cancel();
    }
    track
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-9
    }

    #[test]
    fn slot_is_behind_and_to_the_right_of_the_leaders_heading() {
        let s = Slot {
            behind_m: 20.0,
            side_m: 10.0,
        };
        // Heading east: behind is west, right is south.
        let (x, y) = s.position(100.0, 50.0, 90.0);
        assert!(close(x, 80.0) && close(y, 40.0), "{x} {y}");
        // Heading north: behind is south, right is east.
        let (x, y) = s.position(0.0, 0.0, 0.0);
        assert!(close(x, 10.0) && close(y, -20.0), "{x} {y}");
    }

    #[test]
    fn v_formation_alternates_sides_and_steps_back_per_pair() {
        assert_eq!(
            Slot::in_v(1, 20.0, 15.0),
            Slot {
                behind_m: 20.0,
                side_m: 15.0
            }
        );
        assert_eq!(
            Slot::in_v(2, 20.0, 15.0),
            Slot {
                behind_m: 20.0,
                side_m: -15.0
            }
        );
        assert_eq!(
            Slot::in_v(3, 20.0, 15.0),
            Slot {
                behind_m: 40.0,
                side_m: 15.0
            }
        );
    }

    #[test]
    fn in_the_slot_it_matches_the_leader() {
        let p = TrailParams::new(Slot::in_v(1, 20.0, 15.0));
        let l = LeaderFix {
            x: 0.0,
            y: 0.0,
            heading: 90.0,
            speed: 1.5,
        };
        let (sx, sy) = p.slot.position(l.x, l.y, l.heading);
        let (h, s) = setpoint(&p, &l, sx, sy);
        assert!((h - 90.0).abs() < 1e-6 && (s - 1.5).abs() < 1e-9, "{h} {s}");
    }

    #[test]
    fn behind_the_slot_it_speeds_up_ahead_of_it_slows_down_within_bounds() {
        let p = TrailParams::new(Slot::in_v(1, 20.0, 0.0));
        let l = LeaderFix {
            x: 0.0,
            y: 0.0,
            heading: 0.0,
            speed: 1.5,
        };
        let (_, fast) = setpoint(&p, &l, 0.0, -40.0);
        let (_, slow) = setpoint(&p, &l, 0.0, -10.0);
        let (_, capped) = setpoint(&p, &l, 0.0, -500.0);
        let (_, stopped) = setpoint(&p, &l, 0.0, 200.0);
        assert!(fast > 1.5 && slow < 1.5, "{fast} {slow}");
        assert_eq!(capped, p.max_speed);
        assert_eq!(stopped, 0.0);
    }

    #[test]
    fn off_to_the_side_it_steers_back_towards_the_slot() {
        let p = TrailParams::new(Slot::in_v(1, 20.0, 0.0));
        let l = LeaderFix {
            x: 0.0,
            y: 0.0,
            heading: 0.0,
            speed: 1.5,
        };
        // 10 m west of the slot, heading north: turn right (east of north).
        let (h, _) = setpoint(&p, &l, -10.0, -20.0);
        assert!(h > 0.0 && h < 90.0, "{h}");
        let (h, _) = setpoint(&p, &l, 10.0, -20.0);
        assert!(h > 270.0 && h < 360.0, "{h}");
    }

    #[test]
    fn an_impossible_leader_fix_is_not_steered_by() {
        let ok = LeaderFix {
            x: 1.0,
            y: 2.0,
            heading: 90.0,
            speed: 1.5,
        };
        assert!(ok.plausible());
        for bad in [
            LeaderFix { x: f64::NAN, ..ok },
            LeaderFix { speed: 1e308, ..ok },
            LeaderFix {
                heading: f64::INFINITY,
                ..ok
            },
            LeaderFix { y: 1e9, ..ok },
        ] {
            assert!(!bad.plausible(), "{bad:?}");
        }
    }
}
