//! The local grid against the 280 golden points PROJ computed the way Goby3's UTMGeodesy defines
//! it (fixtures/geodesy/README.md): forward and inverse within 1 mm, for every datum, including the
//! southern hemisphere, the antimeridian, a zone edge and high latitude.

use frontseat_sim::geodesy::{LocalGrid, utm_zone};
use serde_json::Value;

const TOLERANCE_M: f64 = 0.001;

fn golden() -> Value {
    let text = include_str!("fixtures/geodesy/utm_local_grid_golden.json");
    serde_json::from_str(text).expect("fixture is valid JSON")
}

fn f(v: &Value, k: &str) -> f64 {
    v[k].as_f64().unwrap_or_else(|| panic!("field {k} in {v}"))
}

#[test]
fn every_golden_point_within_a_millimetre() {
    let g = golden();
    let datums = g["datums"].as_array().expect("datums");
    assert_eq!(datums.len(), 8);
    let mut checked = 0;
    for d in datums {
        let (lat0, lon0) = (f(d, "lat0"), f(d, "lon0"));
        let grid = LocalGrid::new(lat0, lon0).expect("datum");
        assert_eq!(
            grid.zone() as u64,
            d["zone"].as_u64().expect("zone"),
            "{}",
            d["note"]
        );
        for p in d["forward"].as_array().expect("forward") {
            let (x, y) = grid.to_local(f(p, "lat"), f(p, "lon")).expect("forward");
            assert!(
                (x - f(p, "x")).abs() < TOLERANCE_M && (y - f(p, "y")).abs() < TOLERANCE_M,
                "{}: forward {p} gave ({x}, {y})",
                d["note"]
            );
            checked += 1;
        }
        for p in d["inverse"].as_array().expect("inverse") {
            let (lat, lon) = grid.to_global(f(p, "x"), f(p, "y")).expect("inverse");
            // Compare on the ground: the error in metres along each axis.
            let dn = (lat - f(p, "lat")).to_radians() * 6_378_137.0;
            let de = (lon - f(p, "lon")).to_radians() * 6_378_137.0 * lat.to_radians().cos();
            assert!(
                dn.abs() < TOLERANCE_M && de.abs() < TOLERANCE_M,
                "{}: inverse {p} gave ({lat}, {lon})",
                d["note"]
            );
            checked += 1;
        }
    }
    assert_eq!(checked, 280);
}

#[test]
fn one_km_due_true_north_is_not_grid_north() {
    // Every datum's "1 km due true north" as the notes give it: the meridian arc of 1 km, from the
    // radius of curvature in the meridian at the mid latitude (exact to well under a millimetre
    // over 1 km).
    let g = golden();
    for d in g["datums"].as_array().expect("datums") {
        let grid = LocalGrid::new(f(d, "lat0"), f(d, "lon0")).expect("datum");
        let (lat0, lon0) = grid.origin();
        let a = 6_378_137.0_f64;
        let e2 = 0.006_694_379_990_141_317_f64;
        let mut dlat = 1000.0 / 111_000.0_f64;
        for _ in 0..5 {
            let phi = (lat0 + dlat / 2.0).to_radians();
            let m = a * (1.0 - e2) / (1.0 - e2 * phi.sin().powi(2)).powf(1.5);
            dlat = (1000.0 / m).to_degrees();
        }
        let (x, y) = grid.to_local(lat0 + dlat, lon0).expect("forward");
        let n = &d["one_km_true_north_in_grid"];
        assert!(
            (x - f(n, "x")).abs() < 0.001 && (y - f(n, "y")).abs() < 0.001,
            "{}: ({x}, {y}) vs {n}",
            d["note"]
        );
    }
    assert_eq!(utm_zone(-71.087589), 19);
}
