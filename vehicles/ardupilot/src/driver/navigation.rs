//! Navigation: whether the vehicle's estimate may be steered by (EKF, GPS, SYS_STATUS; for a Sub
//! attitude and a horizontal position, or depth alone in ALT_HOLD), and a usable
//! GLOBAL_POSITION_INT with the latest ATTITUDE (and the Sub's LOCAL_POSITION_NED depth) as the
//! NodeStatus the driver publishes.

use std::time::Duration;

use crate::dialect::EkfStatusFlags;
use crate::infer;
use crate::modes::sub;

use super::state::ArdupilotDriver;
use frontseat_actors::clock::SimClock;
use frontseat_actors::driver::SignalSink;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    EulerAngles, InterfaceData, NodeStatus, Speed,
};
use frontseat_actors::proto::goby::middleware::protobuf::LatLonPoint;

impl ArdupilotDriver {
    /// Why navigation is not to be steered by, or Ok.
    pub(super) fn nav_ready(&self) -> Result<(), String> {
        if self.settings.require_ekf && self.ekf.is_none() {
            return Err("no EKF_STATUS_REPORT heard yet".into());
        }
        if self.settings.require_gps && self.gps_fix.is_none() {
            return Err("no GPS_RAW_INT heard yet".into());
        }
        if self.gps_unhealthy {
            return Err("SYS_STATUS: GPS present and enabled but unhealthy".into());
        }
        if self.is_sub() {
            return self.sub_nav_usable();
        }
        infer::nav_usable(self.ekf, self.gps_fix)
    }

    /// A Sub's estimate: attitude and a horizontal position, absolute (UGPS, GPS) or relative
    /// (DVL, visual odometry, from the EKF origin); in ALT_HOLD with
    /// `alt_hold_accepts_commands`, attitude and depth suffice.
    pub(super) fn sub_nav_usable(&self) -> Result<(), String> {
        let Some(f) = self.ekf else { return Ok(()) };
        if !f.contains(EkfStatusFlags::EKF_ATTITUDE)
            || f.contains(EkfStatusFlags::EKF_UNINITIALIZED)
        {
            return Err(format!("EKF has no attitude (flags {:#06x})", f.bits()));
        }
        let horizontal = f
            .intersects(EkfStatusFlags::EKF_POS_HORIZ_ABS | EkfStatusFlags::EKF_POS_HORIZ_REL)
            && !f.contains(EkfStatusFlags::EKF_CONST_POS_MODE);
        let alt_hold = self.settings.alt_hold_accepts_commands
            && self.beat.is_some_and(|b| b.mode == sub::ALT_HOLD);
        if horizontal || alt_hold {
            Ok(())
        } else {
            Err(format!(
                "EKF has no horizontal position (flags {:#06x}): GUIDED needs a DVL, underwater GPS or visual odometry",
                f.bits()
            ))
        }
    }

    pub(super) fn on_position(
        &mut self,
        pos: infer::Position,
        now: Duration,
        sig: &mut dyn SignalSink,
    ) {
        if let Err(why) = self.nav_ready() {
            if self.nav_problem.as_deref() != Some(why.as_str()) {
                tracing::warn!(target: super::LOG_TARGET, %why, "ArduPilot navigation not usable: not providing data");
            }
            self.nav_problem = Some(why);
            self.nav.lost();
            return;
        }
        if self.nav_problem.take().is_some() {
            tracing::info!(target: super::LOG_TARGET, "ArduPilot navigation usable again");
        }
        let (roll, pitch, yaw) = match self.attitude {
            Some((r, p, y)) => (Some(r), Some(p), Some(y)),
            None => (None, None, None),
        };
        // Sub: depth is LOCAL_POSITION_NED.z, unclamped (the navigation gate judges a reading
        // above the surface or beyond its bounds); relative_alt's zero moves at each arming.
        let depth = if self.settings.depth_from_local {
            let Some(l) = self.local else {
                let why = "no LOCAL_POSITION_NED (depth) heard yet".to_string();
                if self.nav_problem.as_deref() != Some(why.as_str()) {
                    tracing::warn!(target: super::LOG_TARGET, %why, "ArduSub navigation not usable: not providing data");
                }
                self.nav_problem = Some(why);
                self.nav.lost();
                return;
            };
            f64::from(l.z)
        } else {
            (-pos.relative_alt).max(0.0)
        };
        let ns = NodeStatus {
            time: SimClock::unix_now(),
            global_fix: LatLonPoint {
                lat: pos.lat,
                lon: pos.lon,
                depth: Some(depth),
                altitude: None,
            },
            pose: EulerAngles {
                heading: pos.heading.or(yaw),
                roll,
                pitch,
                ..Default::default()
            },
            speed: Speed {
                over_ground: pos.speed_over_ground,
                over_water: None,
            },
            ..Default::default()
        };
        self.counters.nav_published += 1;
        self.nav.fresh(now);
        sig.data_from_frontseat(InterfaceData {
            node_status: Some(ns),
            ..Default::default()
        });
    }
}
