//! Reading our own AIS back in the end-to-end tests (the reference decoder is pyais, in
//! tests/opencpn_ais.rs; these only need a vehicle's heading): a type 18 sentence's MMSI, true
//! heading and SOG by the bit layout of ITU-R M.1371 as the shared OpenCPN notes give it.

/// The payload's 6-bit values de-armoured into bits.
fn bits(payload: &str) -> Vec<u8> {
    let mut out = Vec::new();
    for c in payload.bytes() {
        let mut v = c.wrapping_sub(48);
        if v > 40 {
            v -= 8;
        }
        for i in (0..6).rev() {
            out.push((v >> i) & 1);
        }
    }
    out
}

fn uint(b: &[u8], off: usize, w: usize) -> u64 {
    b[off..off + w]
        .iter()
        .fold(0, |a, x| (a << 1) | u64::from(*x))
}

/// (MMSI, true heading, SOG in knots) of a type 18 sentence.
pub fn type18(line: &str) -> Option<(u64, u64, f64)> {
    let f: Vec<&str> = line.split(',').collect();
    let b = bits(f.get(5)?);
    (b.len() >= 168 && uint(&b, 0, 6) == 18).then(|| {
        (
            uint(&b, 8, 30),
            uint(&b, 124, 9),
            uint(&b, 46, 10) as f64 / 10.0,
        )
    })
}

/// The smallest difference of two headings. Unit: degrees.
pub fn angle_diff(a: f64, b: f64) -> f64 {
    ((a - b + 540.0).rem_euclid(360.0) - 180.0).abs()
}
