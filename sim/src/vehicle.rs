//! The vehicle model: a pure function of its state, setpoint, limits and dt — no I/O, no clocks.
//!
//! Owns the per-tick dynamics of the issue (depth, heading the short way, speed ramp, then
//! position along the heading plus an optional ocean current). Position is kept in Goby3's local
//! grid around the START point (`crate::geodesy`, UTM zone of the datum), as Goby3's simulator
//! does, so x/y are the NAV_X/NAV_Y a helm sees.

use crate::geodesy::LocalGrid;

/// Wrap an angle in degrees into [0, 360). `rem_euclid` alone can return 360.0 for tiny negative
/// inputs, which the protocol forbids.
pub fn wrap_heading(h: f64) -> f64 {
    let w = h.rem_euclid(360.0);
    if w >= 360.0 { 0.0 } else { w }
}

/// The signed turn from `from` to `to` in degrees, the short way, in (-180, 180]. Exactly opposite
/// headings turn clockwise (positive), as Goby3's simulator does.
pub fn short_turn(from: f64, to: f64) -> f64 {
    let d = (to - from).rem_euclid(360.0);
    if d > 180.0 { d - 360.0 } else { d }
}

fn approach(current: f64, target: f64, max_step: f64) -> f64 {
    let diff = target - current;
    if diff.abs() <= max_step {
        target
    } else {
        current + max_step.copysign(diff)
    }
}

/// Rate limits, from START.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limits {
    /// m/s².
    pub accel: f64,
    /// deg/s.
    pub hdg_rate: f64,
    /// m/s.
    pub z_rate: f64,
}

/// The commanded course, from CMD.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Setpoint {
    /// Degrees, any finite value (wrapped into [0, 360)).
    pub heading: f64,
    /// m/s through the water.
    pub speed: f64,
    /// Metres, positive down.
    pub depth: f64,
}

/// One vehicle's state.
#[derive(Debug, Clone, PartialEq)]
pub struct Vehicle {
    /// None only for a START the caller failed to validate; the vehicle then stays at START.
    grid: Option<LocalGrid>,
    origin: (f64, f64),
    limits: Limits,
    /// Ocean current, east and north, m/s; moves the vehicle over ground, not through the water.
    current: (f64, f64),
    setpoint: Setpoint,
    /// Metres east of the START point.
    pub x: f64,
    /// Metres north of the START point.
    pub y: f64,
    pub depth: f64,
    /// Degrees in [0, 360), 0 = north, 90 = east.
    pub heading: f64,
    /// m/s through the water.
    pub speed: f64,
    /// Last position the projection could express; kept when the vehicle leaves its reach.
    lat_lon: (f64, f64),
}

impl Vehicle {
    /// A vehicle at rest at the START point, heading north, at the surface, with a setpoint equal
    /// to its state (so it stays put until commanded).
    pub fn new(lat: f64, lon: f64, limits: Limits, current: (f64, f64)) -> Self {
        Self {
            grid: LocalGrid::new(lat, lon).ok(),
            origin: (lat, lon),
            limits,
            current,
            setpoint: Setpoint::default(),
            x: 0.0,
            y: 0.0,
            depth: 0.0,
            heading: 0.0,
            speed: 0.0,
            lat_lon: (lat, lon),
        }
    }

    pub fn set_setpoint(&mut self, sp: Setpoint) {
        self.setpoint = Setpoint {
            heading: wrap_heading(sp.heading),
            ..sp
        };
    }

    pub fn setpoint(&self) -> Setpoint {
        self.setpoint
    }

    /// Advance by `dt` seconds: depth, heading and speed move toward the setpoint within their
    /// rate limits, then the vehicle moves `speed·dt` along the new heading, plus current·dt.
    pub fn step(&mut self, dt: f64) {
        self.depth = approach(self.depth, self.setpoint.depth, self.limits.z_rate * dt);
        let turn = short_turn(self.heading, self.setpoint.heading);
        let max_turn = self.limits.hdg_rate * dt;
        self.heading = wrap_heading(self.heading + turn.clamp(-max_turn, max_turn));
        self.speed = approach(self.speed, self.setpoint.speed, self.limits.accel * dt);
        let h = self.heading.to_radians();
        self.x += self.speed * dt * h.sin() + self.current.0 * dt;
        self.y += self.speed * dt * h.cos() + self.current.1 * dt;
    }

    /// Latitude and longitude now, in degrees. Outside the projection's reach the last position it
    /// could express is kept, so the output is always finite.
    pub fn lat_lon(&mut self) -> (f64, f64) {
        if self.x == 0.0 && self.y == 0.0 {
            return self.origin;
        }
        if let Some(ll) = self
            .grid
            .as_ref()
            .and_then(|g| g.to_global(self.x, self.y).ok())
        {
            self.lat_lon = ll;
        }
        self.lat_lon
    }

    pub fn origin(&self) -> (f64, f64) {
        self.origin
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const L: Limits = Limits {
        accel: 0.5,
        hdg_rate: 45.0,
        z_rate: 2.0,
    };

    fn v() -> Vehicle {
        Vehicle::new(42.358456, -71.087589, L, (0.0, 0.0))
    }

    fn haversine(a: (f64, f64), b: (f64, f64)) -> f64 {
        let r = 6_371_008.8;
        let (p1, p2) = (a.0.to_radians(), b.0.to_radians());
        let dp = p2 - p1;
        let dl = (b.1 - a.1).to_radians();
        let h = (dp / 2.0).sin().powi(2) + p1.cos() * p2.cos() * (dl / 2.0).sin().powi(2);
        2.0 * r * h.sqrt().asin()
    }

    #[test]
    fn short_way_turns() {
        // (from, to, expected signed turn)
        let rows = [
            (350.0, 10.0, 20.0),
            (10.0, 350.0, -20.0),
            (0.0, 270.0, -90.0),
            (270.0, 0.0, 90.0),
            (90.0, 270.0, 180.0),
            (270.0, 90.0, 180.0),
            (359.0, 0.0, 1.0),
            (0.0, 0.0, 0.0),
            (180.0, 181.0, 1.0),
        ];
        for (from, to, want) in rows {
            let got = short_turn(from, to);
            assert!((got - want).abs() < 1e-9, "{from}->{to}: {got} != {want}");
        }
    }

    #[test]
    fn heading_steps_across_north_stay_in_range() {
        // (start heading, commanded, dt, ticks, expected heading)
        let rows = [
            (350.0, 10.0, 0.1, 1, 354.5),
            (350.0, 10.0, 0.1, 3, 3.5),
            (350.0, 10.0, 0.1, 10, 10.0),
            (5.0, 340.0, 0.1, 1, 0.5),
            (5.0, 340.0, 0.1, 2, 356.0),
            (5.0, 340.0, 0.1, 20, 340.0),
            (0.0, -10.0, 0.1, 5, 350.0),
            (0.0, 720.0, 0.1, 1, 0.0),
        ];
        for (h0, cmd, dt, n, want) in rows {
            let mut veh = v();
            veh.heading = h0;
            veh.set_setpoint(Setpoint {
                heading: cmd,
                speed: 0.0,
                depth: 0.0,
            });
            for _ in 0..n {
                veh.step(dt);
                assert!((0.0..360.0).contains(&veh.heading), "{}", veh.heading);
            }
            assert!(
                (veh.heading - want).abs() < 1e-9,
                "{h0}->{cmd} after {n}: {} != {want}",
                veh.heading
            );
        }
    }

    #[test]
    fn speed_and_depth_ramp_limits() {
        // (limits, setpoint speed, setpoint depth, dt, ticks, want speed, want depth)
        let rows = [
            (L, 1.5, 10.0, 0.1, 1, 0.05, 0.2),
            (L, 1.5, 10.0, 0.1, 10, 0.5, 2.0),
            (L, 1.5, 10.0, 0.1, 30, 1.5, 6.0),
            (L, 1.5, 10.0, 0.1, 100, 1.5, 10.0),
            (
                Limits {
                    accel: 1.0,
                    hdg_rate: 90.0,
                    z_rate: 0.5,
                },
                2.0,
                5.0,
                0.05,
                1,
                0.05,
                0.025,
            ),
            (
                Limits {
                    accel: 0.0,
                    hdg_rate: 0.0,
                    z_rate: 0.0,
                },
                2.0,
                5.0,
                0.1,
                50,
                0.0,
                0.0,
            ),
        ];
        for (lim, s, d, dt, n, ws, wd) in rows {
            let mut veh = Vehicle::new(0.0, 0.0, lim, (0.0, 0.0));
            veh.set_setpoint(Setpoint {
                heading: 0.0,
                speed: s,
                depth: d,
            });
            let mut last = (0.0, 0.0);
            for _ in 0..n {
                veh.step(dt);
                assert!(veh.speed - last.0 <= lim.accel * dt + 1e-12);
                assert!(veh.depth - last.1 <= lim.z_rate * dt + 1e-12);
                last = (veh.speed, veh.depth);
            }
            assert!((veh.speed - ws).abs() < 1e-9, "{} != {ws}", veh.speed);
            assert!((veh.depth - wd).abs() < 1e-9, "{} != {wd}", veh.depth);
        }
    }

    #[test]
    fn ascends_and_slows_down_too() {
        let mut veh = v();
        veh.speed = 2.0;
        veh.depth = 3.0;
        veh.set_setpoint(Setpoint {
            heading: 0.0,
            speed: 0.0,
            depth: 0.0,
        });
        veh.step(0.1);
        assert!((veh.speed - 1.95).abs() < 1e-12);
        assert!((veh.depth - 2.8).abs() < 1e-12);
    }

    #[test]
    fn distance_after_n_ticks_at_constant_speed() {
        // (lat, lon, heading, speed, dt, ticks): distance must be speed·dt·ticks
        let rows = [
            (42.358456, -71.087589, 90.0, 1.5, 0.1, 1000),
            (42.358456, -71.087589, 0.0, 2.0, 0.1, 500),
            (-33.9, 18.4, 225.0, 1.0, 0.05, 2000),
            (0.0, 179.999, 90.0, 3.0, 0.1, 1000),
            (70.0, -150.0, 300.0, 2.5, 0.2, 500),
        ];
        for (lat, lon, hdg, speed, dt, n) in rows {
            let mut veh = Vehicle::new(lat, lon, L, (0.0, 0.0));
            veh.heading = hdg;
            veh.speed = speed;
            veh.set_setpoint(Setpoint {
                heading: hdg,
                speed,
                depth: 0.0,
            });
            for _ in 0..n {
                veh.step(dt);
            }
            let want = speed * dt * n as f64;
            let planar = veh.x.hypot(veh.y);
            assert!((planar - want).abs() < 1e-6, "{planar} != {want}");
            let ll = veh.lat_lon();
            let d = haversine((lat, lon), ll);
            // A sphere vs WGS84 over a few hundred metres: agree to a fraction of a percent.
            assert!(
                (d - want).abs() < want * 0.005,
                "{d} != {want} at {lat},{lon}"
            );
            assert!((-180.0..180.0).contains(&ll.1));
        }
    }

    #[test]
    fn north_and_east_are_grid_directions_of_goby3s_grid() {
        // Goby3's simulator moves in the local UTM grid: 1 km grid north at the course datum is
        // not due true north (the grid converges on the zone's central meridian, 69°W).
        let mut veh = Vehicle::new(42.358456, -71.087589, L, (0.0, 0.0));
        veh.y = 1000.0;
        let (lat_n, lon_n) = veh.lat_lon();
        assert!(lat_n > 42.358456);
        assert!(
            lon_n < -71.087589 - 1e-4,
            "grid north leans west of true north here: {lon_n}"
        );
        veh.y = 0.0;
        veh.x = 100.0;
        let (lat_e, lon_e) = veh.lat_lon();
        assert!(lon_e > -71.087589 && (lat_e - 42.358456).abs() < 1e-4);
    }

    #[test]
    fn origin_maps_exactly_and_reaches_both_hemispheres() {
        for (lat, lon) in [(42.1234, -72.0), (-45.0, 170.0), (0.0, 0.0), (89.9, 10.0)] {
            let mut veh = Vehicle::new(lat, lon, L, (0.0, 0.0));
            assert_eq!(veh.lat_lon(), (lat, lon));
            veh.y = -10.0;
            let (la, _) = veh.lat_lon();
            assert!(la < lat, "{la} !< {lat}");
        }
        let mut veh = Vehicle::new(0.0, 0.0, L, (0.0, 0.0));
        veh.y = -1000.0;
        let (la, lo) = veh.lat_lon();
        assert!(la < 0.0 && lo.abs() < 1e-6, "{lo}");
    }

    #[test]
    fn output_stays_finite_at_the_poles_and_beyond_reach() {
        for lat in [90.0, -90.0] {
            let mut veh = Vehicle::new(lat, 0.0, L, (0.0, 0.0));
            veh.heading = 45.0;
            veh.speed = 5.0;
            veh.set_setpoint(Setpoint {
                heading: 45.0,
                speed: 5.0,
                depth: 0.0,
            });
            for _ in 0..100 {
                veh.step(0.1);
                let (la, lo) = veh.lat_lon();
                assert!((-90.0..=90.0).contains(&la) && (-180.0..180.0).contains(&lo));
            }
        }
        let mut veh = v();
        veh.x = 5_000_000.0;
        let ll = veh.lat_lon();
        assert!(ll.0.is_finite() && ll.1.is_finite());
    }

    #[test]
    fn current_moves_a_vehicle_at_rest() {
        let mut veh = Vehicle::new(10.0, 10.0, L, (0.3, -0.2));
        for _ in 0..100 {
            veh.step(0.1);
        }
        assert!((veh.x - 3.0).abs() < 1e-9 && (veh.y + 2.0).abs() < 1e-9);
        assert_eq!(veh.speed, 0.0);
    }
}
