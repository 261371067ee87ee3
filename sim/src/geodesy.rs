//! The local grid, the one every part of frontseat uses (simulator, interface, MOOS translation,
//! web map): Goby3's `UTMGeodesy` and MOOS-IvP's, so NAV_X/NAV_Y and mission waypoints mean the
//! same metres as in a Goby3/MOOS system.
//!
//! x east, y north in metres = UTM(point) − UTM(datum), both projected in the datum's UTM zone
//! (Z = floor((lon0 + 180) / 6) % 60 + 1, no Norway/Svalbard exceptions, no false northing in the
//! south — the differences cancel it) on WGS-84. Grid north is therefore UTM grid north, not true
//! north: at the course datum 1 km due true north is (24.55, 999.66). The projection is PROJ's
//! (`proj4rs`, the extended transverse Mercator PROJ uses for `+proj=utm`); the golden points in
//! `sim/tests/fixtures/geodesy/` were computed with PROJ itself.

use std::fmt;
use std::sync::Arc;

use proj4rs::proj::Proj;
use proj4rs::transform::transform;

/// Points this far (m) from the datum are refused: the grid of one zone is meaningless there and
/// a vehicle that far from its datum is a configuration error, not a position.
pub const MAX_DISTANCE_M: f64 = 2_000_000.0;

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GeoError {
    #[error("latitude/longitude not finite or out of range: {0}, {1}")]
    BadLatLon(f64, f64),
    #[error("local point ({0:.1}, {1:.1}) m is not finite or too far from the datum")]
    TooFar(f64, f64),
    #[error("projection failed: {0}")]
    Projection(String),
}

/// The UTM zone Goby3 takes from a datum longitude.
pub fn utm_zone(lon: f64) -> u8 {
    // lon is validated to [-180, 180]; the modulo folds 180 onto zone 1 as Goby3's formula does.
    ((((lon + 180.0) / 6.0).floor() as i64).rem_euclid(60) + 1) as u8
}

/// True for a latitude/longitude pair a vehicle can be at.
pub fn valid_lat_lon(lat: f64, lon: f64) -> bool {
    lat.is_finite()
        && lon.is_finite()
        && (-90.0..=90.0).contains(&lat)
        && (-180.0..=180.0).contains(&lon)
}

struct Projs {
    lonlat: Proj,
    utm: Proj,
}

/// Goby3's local grid around a datum.
#[derive(Clone)]
pub struct LocalGrid {
    lat0: f64,
    lon0: f64,
    zone: u8,
    e0: f64,
    n0: f64,
    projs: Arc<Projs>,
}

impl fmt::Debug for LocalGrid {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("LocalGrid")
            .field("lat0", &self.lat0)
            .field("lon0", &self.lon0)
            .field("zone", &self.zone)
            .finish()
    }
}

impl PartialEq for LocalGrid {
    fn eq(&self, o: &Self) -> bool {
        self.lat0 == o.lat0 && self.lon0 == o.lon0
    }
}

impl LocalGrid {
    /// The grid around a datum; refuses a datum that is not finite or out of range.
    pub fn new(lat0: f64, lon0: f64) -> Result<Self, GeoError> {
        if !valid_lat_lon(lat0, lon0) {
            return Err(GeoError::BadLatLon(lat0, lon0));
        }
        let zone = utm_zone(lon0);
        let err = |e: proj4rs::errors::Error| GeoError::Projection(e.to_string());
        let lonlat = Proj::from_proj_string("+proj=longlat +ellps=WGS84").map_err(err)?;
        let utm =
            Proj::from_proj_string(&format!("+proj=utm +ellps=WGS84 +zone={zone}")).map_err(err)?;
        let projs = Arc::new(Projs { lonlat, utm });
        let (e0, n0) = forward(&projs, lat0, lon0)?;
        Ok(Self {
            lat0,
            lon0,
            zone,
            e0,
            n0,
            projs,
        })
    }

    pub fn origin(&self) -> (f64, f64) {
        (self.lat0, self.lon0)
    }

    pub fn zone(&self) -> u8 {
        self.zone
    }

    /// (lat, lon) in degrees → (x east, y north) in metres.
    pub fn to_local(&self, lat: f64, lon: f64) -> Result<(f64, f64), GeoError> {
        if !valid_lat_lon(lat, lon) {
            return Err(GeoError::BadLatLon(lat, lon));
        }
        let (e, n) = forward(&self.projs, lat, lon)?;
        let (x, y) = (e - self.e0, n - self.n0);
        if !(x.is_finite() && y.is_finite()) || x.hypot(y) > MAX_DISTANCE_M {
            return Err(GeoError::TooFar(x, y));
        }
        Ok((x, y))
    }

    /// (x east, y north) in metres → (lat, lon) in degrees, longitude in [-180, 180].
    pub fn to_global(&self, x: f64, y: f64) -> Result<(f64, f64), GeoError> {
        if !(x.is_finite() && y.is_finite()) || x.hypot(y) > MAX_DISTANCE_M {
            return Err(GeoError::TooFar(x, y));
        }
        let mut p = (self.e0 + x, self.n0 + y, 0.0);
        transform(&self.projs.utm, &self.projs.lonlat, &mut p)
            .map_err(|e| GeoError::Projection(e.to_string()))?;
        let (lat, lon) = (p.1.to_degrees(), wrap_lon(p.0.to_degrees()));
        if !valid_lat_lon(lat, lon) {
            return Err(GeoError::TooFar(x, y));
        }
        Ok((lat, lon))
    }
}

fn forward(projs: &Projs, lat: f64, lon: f64) -> Result<(f64, f64), GeoError> {
    let mut p = (lon.to_radians(), lat.to_radians(), 0.0);
    transform(&projs.lonlat, &projs.utm, &mut p)
        .map_err(|e| GeoError::Projection(e.to_string()))?;
    Ok((p.0, p.1))
}

fn wrap_lon(lon: f64) -> f64 {
    if (-180.0..=180.0).contains(&lon) {
        return lon;
    }
    let l = (lon + 180.0).rem_euclid(360.0) - 180.0;
    if l >= 180.0 { l - 360.0 } else { l }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zones_follow_goby3s_formula() {
        for (lon, zone) in [
            (-180.0, 1),
            (-179.9, 1),
            (-71.087589, 19),
            (-72.0, 19),
            (-72.0001, 18),
            (0.0, 31),
            (10.75, 32),
            (179.99, 60),
            (180.0, 1),
        ] {
            assert_eq!(utm_zone(lon), zone, "lon {lon}");
        }
    }

    #[test]
    fn origin_maps_to_zero_and_back() {
        let g = LocalGrid::new(42.358456, -71.087589).unwrap();
        let (x, y) = g.to_local(42.358456, -71.087589).unwrap();
        assert!(x.abs() < 1e-9 && y.abs() < 1e-9);
        let (lat, lon) = g.to_global(0.0, 0.0).unwrap();
        assert!((lat - 42.358456).abs() < 1e-12 && (lon + 71.087589).abs() < 1e-12);
    }

    #[test]
    fn bad_input_is_an_error_not_a_panic() {
        assert!(LocalGrid::new(95.0, 0.0).is_err());
        assert!(LocalGrid::new(f64::NAN, 0.0).is_err());
        assert!(LocalGrid::new(0.0, 181.0).is_err());
        let g = LocalGrid::new(0.0, 0.0).unwrap();
        assert!(g.to_local(f64::INFINITY, 0.0).is_err());
        assert!(g.to_local(0.0, -180.5).is_err());
        assert!(g.to_global(1e9, 0.0).is_err());
        assert!(g.to_global(f64::NAN, 0.0).is_err());
        assert!(
            g.to_local(0.0, 90.0).is_err(),
            "a quarter of the earth away"
        );
    }
}
