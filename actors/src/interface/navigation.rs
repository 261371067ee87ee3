//! Navigation from the vehicle toward the helms: the navigation gate (`nav_gate`) with its
//! counters and logs, Goby3's compute_missing (name, type, time, the local or global fix on the
//! datum's grid), and the node_status / data_from_frontseat publications.

use std::sync::Arc;

use crate::bus::Envelope;
use crate::clock::SimClock;
use crate::nav_gate::{NavViolation, OnViolation, check_navigation};
use crate::proto::goby::middleware::frontseat::protobuf::{
    CartesianCoordinate, InterfaceData, NodeStatus, VehicleType,
};
use crate::proto::goby::middleware::protobuf::LatLonPoint;
use crate::ratelog::{LogDecision, RateLimitedLog, more};
use frontseat_sim::geodesy::LocalGrid;

use super::state::FsiState;

impl FsiState {
    pub(super) fn compute_missing(&self, ns: &mut NodeStatus) {
        compute_missing(ns, &self.s.name, self.s.vehicle_type, self.frame.as_ref());
    }

    /// The navigation gate (nav_gate) with its counters and logs: `ns` fit for the helm, or
    /// false when it must not be published at all. `count` is false for a second copy of
    /// navigation already counted (the Iver3 driver's extended $OSI).
    pub(super) fn nav_fit_for_helm(&mut self, ns: &mut NodeStatus, count: bool) -> bool {
        let (refused, dropped) = match check_navigation(ns, &self.s.nav_limits) {
            Ok(dropped) if count => match self.depth_continuity.check(
                ns,
                self.clock.now().as_secs_f64(),
                &self.s.nav_limits,
            ) {
                Ok(()) => (None, dropped),
                Err(r) => (Some(r), Vec::new()),
            },
            Ok(dropped) => (None, dropped),
            Err(r) => (Some(r), Vec::new()),
        };
        if !count {
            return refused.is_none();
        }
        for v in refused.iter().chain(dropped.iter()) {
            self.counters.nav_field_violations[v.field.index()] += 1;
        }
        self.counters.nav_fields_dropped += dropped.len() as u64;
        if let Some(v) = dropped.first()
            && let LogDecision::Log { suppressed_before } = self.nav_drop_log.decide_at(self.now())
        {
            tracing::warn!(
                target: super::LOG_TARGET,
                field = v.field.name(),
                value = v.value,
                fields = dropped.len(),
                "navigation field from the frontseat dropped: {}{}",
                list(&dropped),
                more(
                    suppressed_before,
                    "navigation messages with fields dropped",
                    self.nav_drop_log.window()
                )
            );
        }
        let Some(r) = refused else { return true };
        debug_assert_eq!(r.field.on_violation(), OnViolation::RefuseMessage);
        // Impossible navigation is a frontseat fault: the helm must not steer by it.
        self.counters.nav_refused += 1;
        if let LogDecision::Log { suppressed_before } = self.nav_log.decide_at(self.now()) {
            tracing::warn!(
                target: super::LOG_TARGET,
                field = r.field.name(),
                value = r.value,
                "navigation from the frontseat refused: {r}{}",
                more(
                    suppressed_before,
                    "refused navigation messages",
                    self.nav_log.window()
                )
            );
        }
        false
    }

    pub(super) fn handle_data_from_frontseat(&mut self, env: Envelope<InterfaceData>) {
        let mut data = (*env.msg).clone();
        if data.node_status.is_some() {
            frontseat_telemetry::metrics::VehicleMetrics::add(&self.metrics.nav_received);
        }
        if let Some(ns) = data.node_status.as_mut()
            && !self.nav_fit_for_helm(ns, true)
        {
            data.node_status = None;
            if data == InterfaceData::default() {
                return;
            }
        }
        if let Some(ns) = data.node_status.as_mut() {
            self.compute_missing(ns);
            if let Some(h) = ns.pose.heading {
                self.lane.navigated(h);
            }
            self.ports
                .publish_node_status_with(Arc::new(ns.clone()), env.meta());
        }
        self.ports
            .publish_data_from_frontseat_with(Arc::new(data), env.meta());
    }
}

/// "pose.pitch = NaN (not a finite number), …" for a log line.
fn list(violations: &[NavViolation]) -> String {
    violations
        .iter()
        .map(|v| v.to_string())
        .collect::<Vec<_>>()
        .join(", ")
}

/// Goby3's compute_missing: name, type and time when absent, and the local fix (x east, y north,
/// z = −depth) from the global one around the datum — or the global from the local.
pub fn compute_missing(
    ns: &mut NodeStatus,
    name: &str,
    vehicle_type: VehicleType,
    frame: Option<&LocalGrid>,
) {
    if ns.name.is_none() && !name.is_empty() {
        ns.name = Some(name.to_string());
    }
    if ns.r#type.is_none() {
        ns.set_type(vehicle_type);
    }
    if ns.time == 0.0 {
        ns.time = SimClock::unix_now();
    }
    let Some(frame) = frame else { return };
    // global_fix is `required`, so prost always holds one: a zero fix with a local fix present
    // is taken as "global missing", as a C++ message would report !has_global_fix().
    let g = ns.global_fix;
    let global_missing = g.lat == 0.0 && g.lon == 0.0 && ns.local_fix.is_some();
    if global_missing {
        let Some(l) = ns.local_fix else { return };
        match frame.to_global(l.x, l.y) {
            Ok((lat, lon)) => {
                ns.global_fix = LatLonPoint {
                    lat,
                    lon,
                    depth: Some(-l.z()),
                    altitude: None,
                }
            }
            Err(e) => warn_fix("global_fix", &e),
        }
    } else if ns.local_fix.is_none() {
        match frame.to_local(g.lat, g.lon) {
            Ok((x, y)) => {
                ns.local_fix = Some(CartesianCoordinate {
                    x,
                    y,
                    z: Some(-g.depth()),
                })
            }
            Err(e) => warn_fix("local_fix", &e),
        }
    }
}

/// A fix that cannot be converted came from the vehicle (or a helm): one rate-limited WARN, so a
/// vehicle sending positions far off the datum cannot flood the journal (a hostile vehicle made
/// this line hundreds of times a second).
fn warn_fix(what: &str, e: &dyn std::fmt::Display) {
    static LOG: std::sync::LazyLock<std::sync::Mutex<RateLimitedLog>> =
        std::sync::LazyLock::new(|| std::sync::Mutex::new(RateLimitedLog::for_bad_input()));
    let mut log = LOG.lock().unwrap_or_else(|p| p.into_inner());
    if let LogDecision::Log { suppressed_before } = log.decide(tokio::time::Instant::now()) {
        tracing::warn!(
            target: super::LOG_TARGET,
            error = %e,
            "cannot compute {what}{}",
            more(suppressed_before, "fixes not converted", log.window())
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame() -> LocalGrid {
        LocalGrid::new(42.358456, -71.087589).unwrap()
    }

    #[test]
    fn fills_name_type_time_and_local_fix_from_global() {
        let f = frame();
        let (lat, lon) = f.to_global(100.0, -50.0).unwrap();
        let mut ns = NodeStatus {
            global_fix: LatLonPoint {
                lat,
                lon,
                depth: Some(12.5),
                altitude: None,
            },
            ..Default::default()
        };
        compute_missing(&mut ns, "auv1", VehicleType::Auv, Some(&f));
        assert_eq!(ns.name.as_deref(), Some("auv1"));
        assert_eq!(ns.r#type(), VehicleType::Auv);
        assert!(ns.time > 1.0e9, "unix time filled");
        let l = ns.local_fix.unwrap();
        assert!(
            (l.x - 100.0).abs() < 1e-3 && (l.y + 50.0).abs() < 1e-3,
            "{l:?}"
        );
        assert_eq!(l.z(), -12.5);
    }

    #[test]
    fn fills_global_fix_from_local_and_keeps_what_is_given() {
        let f = frame();
        let mut ns = NodeStatus {
            name: Some("given".into()),
            local_fix: Some(CartesianCoordinate {
                x: 0.0,
                y: 1000.0,
                z: Some(-3.0),
            }),
            ..Default::default()
        };
        ns.set_type(VehicleType::Glider);
        compute_missing(&mut ns, "auv1", VehicleType::Auv, Some(&f));
        assert_eq!(ns.name.as_deref(), Some("given"));
        assert_eq!(ns.r#type(), VehicleType::Glider);
        let g = ns.global_fix;
        assert!((g.lat - 42.367459).abs() < 1e-4, "{g:?}");
        // Goby3's grid: grid north leans west of true north at this datum.
        assert!(g.lon < -71.087589 - 1e-4, "{g:?}");
        let (x, y) = f.to_local(g.lat, g.lon).unwrap();
        assert!(x.abs() < 1e-6 && (y - 1000.0).abs() < 1e-6);
        assert_eq!(g.depth(), 3.0);
    }

    #[test]
    fn a_moved_datum_moves_the_local_fix() {
        let f = frame();
        let (lat, lon) = f.to_global(0.0, 0.0).unwrap();
        let moved = LocalGrid::new(lat - 0.001, lon).unwrap();
        let mut ns = NodeStatus {
            global_fix: LatLonPoint {
                lat,
                lon,
                depth: Some(0.0),
                altitude: None,
            },
            ..Default::default()
        };
        compute_missing(&mut ns, "", VehicleType::Auv, Some(&moved));
        let l = ns.local_fix.unwrap();
        assert!(
            (l.y - 111.07).abs() < 0.5,
            "0.001° north of the new datum: {l:?}"
        );
    }
}
