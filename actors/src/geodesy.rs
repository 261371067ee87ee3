//! Local metric frame around a datum (origin), as Goby3's compute_missing uses it: x east, y north,
//! metres. Transverse Mercator from the `utm` crate with the central meridian moved to the datum's
//! longitude (the longitude is shifted onto zone 31's meridian), which keeps scale error negligible
//! at any longitude. Errors only for points too far from the datum for the projection (> ~400 km).

const ZONE: u8 = 31;
const ZONE_MERIDIAN: f64 = 3.0;
const FALSE_NORTHING_SOUTH: f64 = 10_000_000.0;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocalFrame {
    lat0: f64,
    lon0: f64,
    e0: f64,
    n0: f64,
}

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GeoError {
    #[error("latitude/longitude not finite or out of range: {0}, {1}")]
    BadLatLon(f64, f64),
    #[error("local point ({0:.1}, {1:.1}) m is too far from the datum for the projection")]
    TooFar(f64, f64),
}

fn project(lat: f64, lon_shifted: f64) -> (f64, f64) {
    let (n, e, _) = utm::to_utm_wgs84(lat, lon_shifted, ZONE);
    let n = if lat > 0.0 {
        n
    } else {
        n - FALSE_NORTHING_SOUTH
    };
    (e, n)
}

fn wrap_lon(lon: f64) -> f64 {
    let mut l = (lon + 180.0).rem_euclid(360.0) - 180.0;
    if l == -180.0 && lon > 0.0 {
        l = 180.0;
    }
    l
}

impl LocalFrame {
    pub fn new(lat0: f64, lon0: f64) -> Result<Self, GeoError> {
        if !(lat0.is_finite() && lon0.is_finite() && lat0.abs() <= 90.0 && lon0.abs() <= 180.0) {
            return Err(GeoError::BadLatLon(lat0, lon0));
        }
        let (e0, n0) = project(lat0, ZONE_MERIDIAN);
        Ok(Self { lat0, lon0, e0, n0 })
    }

    pub fn origin(&self) -> (f64, f64) {
        (self.lat0, self.lon0)
    }

    /// (lat, lon) → (x east, y north) in metres.
    pub fn to_local(&self, lat: f64, lon: f64) -> Result<(f64, f64), GeoError> {
        if !(lat.is_finite() && lon.is_finite() && lat.abs() <= 90.0) {
            return Err(GeoError::BadLatLon(lat, lon));
        }
        let dlon = wrap_lon(lon - self.lon0);
        let (e, n) = project(lat, ZONE_MERIDIAN + dlon);
        Ok((e - self.e0, n - self.n0))
    }

    /// (x east, y north) in metres → (lat, lon).
    pub fn to_global(&self, x: f64, y: f64) -> Result<(f64, f64), GeoError> {
        if !(x.is_finite() && y.is_finite()) {
            return Err(GeoError::TooFar(x, y));
        }
        let e = self.e0 + x;
        let n = self.n0 + y;
        let (n, letter) = if n >= 0.0 {
            (n, 'N')
        } else {
            (n + FALSE_NORTHING_SOUTH, 'M')
        };
        let (lat, lon) =
            utm::wsg84_utm_to_lat_lon(e, n, ZONE, letter).map_err(|_| GeoError::TooFar(x, y))?;
        Ok((lat, wrap_lon(lon - ZONE_MERIDIAN + self.lon0)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn origin_maps_to_zero() {
        let f = LocalFrame::new(42.358456, -71.087589).unwrap();
        let (x, y) = f.to_local(42.358456, -71.087589).unwrap();
        assert!(x.abs() < 1e-6 && y.abs() < 1e-6);
    }

    #[test]
    fn one_km_north_and_east_round_trip() {
        for (lat0, lon0) in [
            (42.358456, -71.087589),
            (-33.9, 18.4),
            (0.0, 179.9),
            (60.0, 5.0),
        ] {
            let f = LocalFrame::new(lat0, lon0).unwrap();
            for (x, y) in [
                (1000.0, 0.0),
                (0.0, 1000.0),
                (-2500.0, -1200.0),
                (30_000.0, 40_000.0),
            ] {
                let (lat, lon) = f.to_global(x, y).unwrap();
                let (x2, y2) = f.to_local(lat, lon).unwrap();
                assert!(
                    (x - x2).abs() < 1e-3 && (y - y2).abs() < 1e-3,
                    "{lat0},{lon0}: {x},{y} -> {x2},{y2}"
                );
            }
        }
    }

    #[test]
    fn a_degree_of_latitude_is_about_111_km() {
        let f = LocalFrame::new(42.0, -71.0).unwrap();
        let (x, y) = f.to_local(43.0, -71.0).unwrap();
        assert!(x.abs() < 1e-6);
        assert!((y - 111_080.0).abs() < 100.0, "{y}");
    }

    #[test]
    fn bad_input_is_an_error() {
        assert!(LocalFrame::new(95.0, 0.0).is_err());
        assert!(LocalFrame::new(f64::NAN, 0.0).is_err());
        let f = LocalFrame::new(0.0, 0.0).unwrap();
        assert!(f.to_local(f64::INFINITY, 0.0).is_err());
        assert!(f.to_global(1e9, 0.0).is_err());
    }
}
