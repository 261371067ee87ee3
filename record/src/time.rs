//! Wall-clock helpers without a date crate: file names and metadata want UTC text.

use std::time::{Duration, SystemTime, UNIX_EPOCH};

/// Nanoseconds since the Unix epoch (0 before it, which only a broken clock gives).
pub fn unix_ns(t: SystemTime) -> u64 {
    t.duration_since(UNIX_EPOCH)
        .map(|d| u64::try_from(d.as_nanos()).unwrap_or(u64::MAX))
        .unwrap_or(0)
}

/// `20261125T141907Z` for file names (sortable, no characters a FAT card refuses).
pub fn compact_utc(ns: u64) -> String {
    let (y, mo, d, h, mi, s) = civil(ns);
    format!("{y:04}{mo:02}{d:02}T{h:02}{mi:02}{s:02}Z")
}

/// `2026-11-25T14:19:07.123Z`.
pub fn iso_utc(ns: u64) -> String {
    let (y, mo, d, h, mi, s) = civil(ns);
    let ms = (ns / 1_000_000) % 1000;
    format!("{y:04}-{mo:02}-{d:02}T{h:02}:{mi:02}:{s:02}.{ms:03}Z")
}

fn civil(ns: u64) -> (i64, u32, u32, u32, u32, u32) {
    let secs = ns / 1_000_000_000;
    let days = (secs / 86_400) as i64;
    let rem = secs % 86_400;
    // Howard Hinnant's days-from-civil inverse.
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    let y = yoe + era * 400 + i64::from(m <= 2);
    (
        y,
        m,
        d,
        (rem / 3600) as u32,
        ((rem % 3600) / 60) as u32,
        (rem % 60) as u32,
    )
}

/// Seconds, for printing a duration.
pub fn secs(ns: u64) -> f64 {
    Duration::from_nanos(ns).as_secs_f64()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn utc_text_of_known_instants() {
        assert_eq!(compact_utc(0), "19700101T000000Z");
        // 2026-11-25T14:19:07Z
        let ns = 1_795_616_347u64 * 1_000_000_000 + 5_000_000;
        assert_eq!(compact_utc(ns), "20261125T141907Z");
        assert_eq!(iso_utc(ns), "2026-11-25T14:19:07.005Z");
        // A leap day.
        assert_eq!(compact_utc(951_782_400 * 1_000_000_000), "20000229T000000Z");
    }
}
