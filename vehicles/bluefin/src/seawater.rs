//! The seawater properties Goby3's `compute_missing(CTDSample)` derives from a CTD's raw
//! conductivity, temperature and pressure: practical salinity (PSS-78, UNESCO technical paper 44,
//! Perkin and Lewis 1980), depth from pressure (UNESCO 44), sound speed (Mackenzie 1981, nine
//! terms) and density (EOS-80, UNESCO technical paper 38, Millero and Poisson 1981). Pure
//! functions in the papers' units (conductivity ratio, °C IPTS-68, decibars); [`fill_ctd`] maps a
//! CTDSample's SI fields onto them as Goby3 does. Checked against the papers' check values.

use frontseat_actors::proto::goby::middleware::frontseat::protobuf::CtdSample;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::ctd_sample::{
    DensityAlgorithm, SalinityAlgorithm, SoundSpeedAlgorithm,
};

/// Conductivity of standard seawater, C(35, 15 °C, 0 dbar). Unit: S/m (42.914 mS/cm).
pub const STANDARD_CONDUCTIVITY_S_PER_M: f64 = 4.2914;

/// Pascals per decibar.
const PA_PER_DBAR: f64 = 1.0e4;

/// Practical salinity from the conductivity ratio R = C / C(35,15,0), temperature (°C) and
/// pressure (dbar). A ratio at or below 5e-4 is fresh water: 0, as the paper's trap.
pub fn salinity_pss78(ratio: f64, t: f64, p_dbar: f64) -> f64 {
    if ratio <= 5e-4 {
        return 0.0;
    }
    // rt35: C(35,t,0)/C(35,15,0); the pressure (c) and temperature (a, b) corrections of Lewis.
    let rt35 = (((1.0031e-9 * t - 6.9698e-7) * t + 1.104259e-4) * t + 2.00564e-2) * t + 0.6766097;
    let c = ((3.989e-15 * p_dbar - 6.370e-10) * p_dbar + 2.070e-5) * p_dbar;
    let b = (4.464e-4 * t + 3.426e-2) * t + 1.0;
    let a = -3.107e-3 * t + 0.4215;
    let rt = (ratio / (rt35 * (1.0 + c / (b + a * ratio)))).abs().sqrt();
    let dt = t - 15.0;
    let s0 = ((((2.7081 * rt - 7.0261) * rt + 14.0941) * rt + 25.3851) * rt - 0.1692) * rt + 0.0080;
    let ds = ((((-0.0144 * rt + 0.0636) * rt - 0.0375) * rt - 0.0066) * rt - 0.0056) * rt + 0.0005;
    s0 + dt / (1.0 + 0.0162 * dt) * ds
}

/// Depth (m) from pressure (dbar) at a latitude (degrees), UNESCO 44.
pub fn depth_unesco(p_dbar: f64, lat_deg: f64) -> f64 {
    let x = (lat_deg / 57.29578).sin().powi(2);
    let gravity = 9.780318 * (1.0 + (5.2788e-3 + 2.36e-5 * x) * x) + 1.092e-6 * p_dbar;
    (((-1.82e-15 * p_dbar + 2.279e-10) * p_dbar - 2.2512e-5) * p_dbar + 9.72659) * p_dbar / gravity
}

/// Sound speed (m/s), Mackenzie 1981; `None` outside the equation's range (temperature −2 to
/// 30 °C, salinity 25 to 40, depth 0 to 8000 m), where Goby3 reports NaN.
pub fn sound_speed_mackenzie(t: f64, s: f64, d: f64) -> Option<f64> {
    let in_range =
        (-2.0..=30.0).contains(&t) && (25.0..=40.0).contains(&s) && (0.0..=8000.0).contains(&d);
    in_range.then_some({
        1448.96 + 4.591 * t - 5.304e-2 * t * t
            + 2.374e-4 * t * t * t
            + 1.340 * (s - 35.0)
            + 1.630e-2 * d
            + 1.675e-7 * d * d
            - 1.025e-2 * t * (s - 35.0)
            - 7.139e-13 * t * d * d * d
    })
}

/// Density (kg/m³) from salinity, temperature (°C) and pressure (dbar): EOS-80's density anomaly
/// plus 1000, as Goby3 reports it.
pub fn density_eos80(s: f64, t: f64, p_dbar: f64) -> f64 {
    const R3500: f64 = 1028.1063;
    const R4: f64 = 4.8314e-4;
    const DR350: f64 = 28.106331;
    let p = p_dbar / 10.0; // bars
    let sr = s.abs().sqrt();
    // One atmosphere: pure water (Bigg 1967) and the salinity terms.
    let r1 = ((((6.536332e-9 * t - 1.120083e-6) * t + 1.001685e-4) * t - 9.095290e-3) * t
        + 6.793952e-2)
        * t
        - 28.263737;
    let r2 = (((5.3875e-9 * t - 8.2467e-7) * t + 7.6438e-5) * t - 4.0899e-3) * t + 8.24493e-1;
    let r3 = (-1.6546e-6 * t + 1.0227e-4) * t - 5.72466e-3;
    let sig = (R4 * s + r3 * sr + r2) * s + r1;
    let mut v350p = 1.0 / R3500;
    let mut sva = -sig * v350p / (R3500 + sig);
    // The high-pressure equation (Millero et al. 1980): secant bulk modulus terms.
    let e = (9.1697e-10 * t + 2.0816e-8) * t - 9.9348e-7;
    let bw = (5.2787e-8 * t - 6.12293e-6) * t + 3.47718e-5;
    let b = bw + e * s;
    let d = 1.91075e-4;
    let c = (-1.6078e-6 * t - 1.0981e-5) * t + 2.2838e-3;
    let aw = ((-5.77905e-7 * t + 1.16092e-4) * t + 1.43713e-3) * t - 0.1194975;
    let a = (d * sr + c) * s + aw;
    let b1 = (-5.3009e-4 * t + 1.6483e-2) * t + 7.944e-2;
    let a1 = ((-6.1670e-5 * t + 1.09987e-2) * t - 0.603459) * t + 54.6746;
    let kw = (((-5.155288e-5 * t + 1.360477e-2) * t - 2.327105) * t + 148.4206) * t - 1930.06;
    let k0 = (b1 * sr + a1) * s + kw;
    let dk = (b * p + a) * p + k0;
    let k35 = (5.03217e-5 * p + 3.359406) * p + 21582.27;
    let gam = p / k35;
    let pk = 1.0 - gam;
    sva = sva * pk + (v350p + sva) * p * dk / (k35 * (k35 + dk));
    v350p *= pk;
    let dr35p = gam / v350p;
    let dvan = sva / (v350p * (v350p + sva));
    1000.0 + DR350 + dr35p - dvan
}

/// Goby3's `compute_missing(CTDSample)`: salinity from conductivity (NaN when the CTD sent
/// none), depth from pressure when the sample has no depth, sound speed and density, each with
/// its algorithm. Conductivity in S/m, temperature in °C, pressure in Pa (sea pressure).
pub fn fill_ctd(s: &mut CtdSample) {
    let p_dbar = s.pressure / PA_PER_DBAR;
    s.salinity = match s.conductivity {
        Some(c) => salinity_pss78(c / STANDARD_CONDUCTIVITY_S_PER_M, s.temperature, p_dbar),
        None => f64::NAN,
    };
    s.salinity_algorithm = Some(SalinityAlgorithm::Unesco44PrekinAndLewis1980 as i32);
    if s.global_fix.depth.is_none_or(|d| !d.is_finite()) {
        let lat = if s.global_fix.lat.is_finite() {
            s.global_fix.lat
        } else {
            0.0
        };
        s.global_fix.depth = Some(depth_unesco(p_dbar, lat));
    }
    let depth = s.global_fix.depth.unwrap_or(f64::NAN);
    s.sound_speed = sound_speed_mackenzie(s.temperature, s.salinity, depth).unwrap_or(f64::NAN);
    s.sound_speed_algorithm = Some(SoundSpeedAlgorithm::Mackenzie1981 as i32);
    s.density = density_eos80(s.salinity, s.temperature, p_dbar);
    s.density_algorithm = Some(DensityAlgorithm::Unesco38MilleroAndPoisson1981 as i32);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(got: f64, want: f64, tol: f64, what: &str) {
        assert!((got - want).abs() <= tol, "{what}: {got} vs {want}");
    }

    #[test]
    fn the_papers_check_values() {
        // UNESCO 44: SAL78(R = 1.888091, 40 °C, 10000 dbar) = 40.0000.
        close(
            salinity_pss78(1.888091, 40.0, 10000.0),
            40.0,
            1e-4,
            "PSS-78",
        );
        // Standard seawater is 35 by definition.
        close(
            salinity_pss78(1.0, 15.0, 0.0),
            35.0,
            1e-3,
            "PSS-78 at R = 1",
        );
        // UNESCO 44: depth(10000 dbar, 30°) = 9712.653 m.
        close(depth_unesco(10000.0, 30.0), 9712.653, 1e-3, "depth");
        // UNESCO 38 / EOS-80: sigma(40, 40 °C, 10000 dbar) = 59.82037 kg/m³.
        close(
            density_eos80(40.0, 40.0, 10000.0),
            1059.82037,
            1e-5,
            "EOS-80",
        );
        // Mackenzie 1981: c(25 °C, 35, 1000 m) = 1550.744 m/s.
        close(
            sound_speed_mackenzie(25.0, 35.0, 1000.0).unwrap(),
            1550.744,
            1e-3,
            "Mackenzie",
        );
        assert_eq!(
            sound_speed_mackenzie(31.0, 35.0, 10.0),
            None,
            "out of range"
        );
        assert_eq!(salinity_pss78(0.0, 10.0, 0.0), 0.0, "fresh water trap");
    }

    #[test]
    fn a_bluefin_ctd_line_is_completed_as_goby3_does() {
        // 4.2914 S/m, 15 °C, 0 Pa: standard seawater at the surface.
        let mut s = CtdSample {
            conductivity: Some(STANDARD_CONDUCTIVITY_S_PER_M),
            temperature: 15.0,
            pressure: 0.0,
            ..Default::default()
        };
        fill_ctd(&mut s);
        close(s.salinity, 35.0, 1e-3, "salinity");
        close(
            s.global_fix.depth.unwrap(),
            0.0,
            1e-9,
            "depth from pressure",
        );
        close(s.sound_speed, 1506.7, 0.1, "sound speed");
        close(s.density, 1025.97, 0.01, "density");
        assert_eq!(
            s.sound_speed_algorithm(),
            SoundSpeedAlgorithm::Mackenzie1981
        );
        // No conductivity: salinity unknown, and so is the sound speed.
        let mut s = CtdSample {
            temperature: 15.0,
            pressure: 1.0e5,
            ..Default::default()
        };
        fill_ctd(&mut s);
        assert!(s.salinity.is_nan() && s.sound_speed.is_nan());
        close(
            s.global_fix.depth.unwrap(),
            9.9,
            0.1,
            "10 dbar is about 9.9 m",
        );
    }
}
