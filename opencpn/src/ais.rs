//! The AIS encoder: class B targets as OpenCPN draws them (shared facts §0, §4): type 18
//! position reports and type 24 static data (part A the name, part B type, call sign and size),
//! 6-bit armoured into `!AIVDM` sentences of one fragment each (168 bits = 28 characters, no fill
//! bits), so a fragment never interleaves with another (OpenCPN keeps one accumulator). Values
//! are rounded (pyais truncates SOG and COG; we round, as the facts advise), and clamped to the
//! field's range; an unknown value is the field's "not available" code.

use crate::nmea;

/// Knots per metre per second.
pub const KNOTS_PER_MPS: f64 = 3600.0 / 1852.0;

/// Bits appended most significant first; 168 bits are one single-fragment message.
#[derive(Default)]
struct Bits {
    bits: Vec<u8>,
}

impl Bits {
    fn uint(&mut self, v: u64, width: u32) {
        for i in (0..width).rev() {
            self.bits.push(((v >> i) & 1) as u8);
        }
    }

    fn int(&mut self, v: i64, width: u32) {
        // Two's complement in `width` bits.
        self.uint((v as u64) & ((1u64 << width) - 1), width);
    }

    /// `chars` characters of 6-bit ASCII, padded with `@` (0).
    fn text(&mut self, s: &str, chars: usize) {
        let mut n = 0;
        for c in s.chars().take(chars) {
            self.uint(u64::from(sixbit_char(c)), 6);
            n += 1;
        }
        for _ in n..chars {
            self.uint(0, 6);
        }
    }

    /// The payload's armoured characters and its fill bits.
    fn armour(&self) -> (String, u8) {
        let fill = (6 - self.bits.len() % 6) % 6;
        let mut s = String::with_capacity(self.bits.len() / 6 + 1);
        let padded = self
            .bits
            .iter()
            .copied()
            .chain(std::iter::repeat_n(0, fill))
            .collect::<Vec<_>>();
        for six in padded.chunks(6) {
            let v = six.iter().fold(0u8, |a, b| (a << 1) | b);
            s.push(armour_char(v));
        }
        (s, fill as u8)
    }
}

/// A 6-bit value as its payload character (`v+48` below 40, else `v+56`).
pub fn armour_char(v: u8) -> char {
    let v = v & 0x3f;
    char::from(if v < 40 { v + 48 } else { v + 56 })
}

/// A character in AIS's 6-bit ASCII: `@`..`_` are 0-31, space..`?` are 32-63; lower case is
/// upper-cased and anything else becomes a space.
pub fn sixbit_char(c: char) -> u8 {
    let c = c.to_ascii_uppercase();
    match c as u32 {
        64..=95 => (c as u32 - 64) as u8,
        32..=63 => c as u32 as u8,
        _ => 32,
    }
}

/// What a vehicle is, for type 24: from config.
#[derive(Debug, Clone, PartialEq)]
pub struct Static {
    pub mmsi: u32,
    /// Up to 20 characters (longer is cut).
    pub name: String,
    /// AIS ship and cargo type (33 = underwater operations, 37 = pleasure craft, ...).
    pub ship_type: u8,
    /// Up to 7 characters.
    pub call_sign: String,
    /// Up to 3 characters (the manufacturer's id in 24B).
    pub vendor: String,
    /// Metres from the reference point to bow, stern, port, starboard.
    pub to_bow: u16,
    pub to_stern: u16,
    pub to_port: u8,
    pub to_starboard: u8,
}

/// One position report's fields in their units; `None` is "not available".
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Position {
    pub mmsi: u32,
    pub lat: Option<f64>,
    pub lon: Option<f64>,
    /// Knots.
    pub sog_kn: Option<f64>,
    /// Degrees true.
    pub cog: Option<f64>,
    /// Degrees true.
    pub heading: Option<f64>,
    /// UTC second of the fix.
    pub second: Option<u8>,
    /// Position accuracy flag: better than 10 m (a DGPS fix). False: unknown or worse.
    pub accuracy_high: bool,
}

fn vdm(channel: char, bits: &Bits) -> String {
    let (payload, fill) = bits.armour();
    nmea::frame('!', &format!("AIVDM,1,1,,{channel},{payload},{fill}"))
}

/// The raw values of a position report, as they go into the bits (also what tests compare).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RawPosition {
    pub sog: u64,
    pub lon: i64,
    pub lat: i64,
    pub cog: u64,
    pub heading: u64,
    pub second: u64,
}

impl Position {
    pub fn raw(&self) -> RawPosition {
        let finite = |v: Option<f64>| v.filter(|x| x.is_finite());
        let sog = finite(self.sog_kn)
            .map(|s| (s * 10.0).round().clamp(0.0, 1022.0) as u64)
            .unwrap_or(1023);
        let (lat, lon) = match (
            finite(self.lat).filter(|l| l.abs() <= 90.0),
            finite(self.lon).filter(|l| l.abs() <= 180.0),
        ) {
            (Some(la), Some(lo)) => (
                (la * 600_000.0).round() as i64,
                (lo * 600_000.0).round() as i64,
            ),
            _ => (91 * 600_000, 181 * 600_000),
        };
        let cog = finite(self.cog)
            .map(|c| ((c.rem_euclid(360.0) * 10.0).round() as u64) % 3600)
            .unwrap_or(3600);
        let heading = finite(self.heading)
            .map(|h| (h.rem_euclid(360.0).round() as u64) % 360)
            .unwrap_or(511);
        let second = self.second.filter(|s| *s < 60).map_or(60, u64::from);
        RawPosition {
            sog,
            lon,
            lat,
            cog,
            heading,
            second,
        }
    }

    /// Type 18, class B "CS" position report: one `!AIVDM` sentence, CR LF included.
    pub fn type18(&self) -> String {
        let r = self.raw();
        let mut b = Bits::default();
        b.uint(18, 6);
        b.uint(0, 2);
        b.uint(u64::from(self.mmsi), 30);
        b.uint(0, 8);
        b.uint(r.sog, 10);
        b.uint(u64::from(self.accuracy_high), 1);
        b.int(r.lon, 28);
        b.int(r.lat, 27);
        b.uint(r.cog, 12);
        b.uint(r.heading, 9);
        b.uint(r.second, 6);
        b.uint(0, 2); // regional
        b.uint(1, 1); // CS unit
        b.uint(0, 5); // display, DSC, band, msg22, assigned
        b.uint(0, 1); // RAIM
        b.uint(0, 20); // radio
        vdm('A', &b)
    }
}

impl Static {
    /// Type 24 part A: the name.
    pub fn type24a(&self) -> String {
        let mut b = Bits::default();
        b.uint(24, 6);
        b.uint(0, 2);
        b.uint(u64::from(self.mmsi), 30);
        b.uint(0, 2);
        b.text(&self.name, 20);
        b.uint(0, 8);
        vdm('A', &b)
    }

    /// Type 24 part B: ship type, vendor, call sign and dimensions (never the mothership form:
    /// OpenCPN reads those bits as dimensions, facts §3.2).
    pub fn type24b(&self) -> String {
        let mut b = Bits::default();
        b.uint(24, 6);
        b.uint(0, 2);
        b.uint(u64::from(self.mmsi), 30);
        b.uint(1, 2);
        b.uint(u64::from(self.ship_type), 8);
        b.text(&self.vendor, 3);
        b.uint(0, 4); // model
        b.uint(0, 20); // serial
        b.text(&self.call_sign, 7);
        b.uint(u64::from(self.to_bow.min(511)), 9);
        b.uint(u64::from(self.to_stern.min(511)), 9);
        b.uint(u64::from(self.to_port.min(63)), 6);
        b.uint(u64::from(self.to_starboard.min(63)), 6);
        b.uint(0, 6);
        vdm('B', &b)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    // Goldens made with pyais 3.3.1 and checked against OpenCPN 5.10.2's offsets (shared facts §4).
    const G18: &str = "!AIVDM,1,1,,A,B4M9Ph@03vfaHsV3kJ9DI3g40000,0*05\r\n";
    const G24A: &str = "!AIVDM,1,1,,A,H4M9PhA@u1<T@F05=J3400000000,0*48\r\n";
    const G24B: &str = "!AIVDM,1,1,,B,H4M9PhDQ=B600001CFi0000@2110,0*56\r\n";

    fn golden_static() -> Static {
        Static {
            mmsi: 299_000_001,
            name: "TOPSIDE ASV 1".into(),
            ship_type: 33,
            call_sign: "ASV1".into(),
            vendor: "MRF".into(),
            to_bow: 2,
            to_stern: 2,
            to_port: 1,
            to_starboard: 1,
        }
    }

    #[test]
    fn type18_matches_the_golden() {
        let p = Position {
            mmsi: 299_000_001,
            lat: Some(42.358456),
            lon: Some(-71.087589),
            sog_kn: Some(1.5),
            cog: Some(135.0),
            heading: Some(135.0),
            second: Some(30),
            accuracy_high: true,
        };
        assert_eq!(p.raw().lon, -42652553);
        assert_eq!(p.raw().lat, 25415074);
        assert_eq!(p.type18(), G18);
    }

    #[test]
    fn type24_matches_the_goldens() {
        assert_eq!(golden_static().type24a(), G24A);
        assert_eq!(golden_static().type24b(), G24B);
    }

    #[test]
    fn unknown_values_are_not_available_codes() {
        let p = Position {
            mmsi: 299_000_001,
            ..Default::default()
        };
        let r = p.raw();
        assert_eq!((r.sog, r.cog, r.heading, r.second), (1023, 3600, 511, 60));
        assert_eq!((r.lat, r.lon), (91 * 600_000, 181 * 600_000));
        let p = Position {
            heading: Some(f64::NAN),
            sog_kn: Some(1e9),
            cog: Some(-0.01),
            ..p
        };
        let r = p.raw();
        assert_eq!((r.heading, r.sog, r.cog), (511, 1022, 0));
    }

    #[test]
    fn every_sentence_fits_nmea_82_characters() {
        let long = Static {
            name: "X".repeat(50),
            call_sign: "Y".repeat(20),
            ..golden_static()
        };
        for s in [long.type24a(), long.type24b(), Position::default().type18()] {
            assert!(s.len() <= nmea::MAX_WRITTEN, "{s}");
            assert!(nmea::parse(&s).is_ok());
        }
    }
}
