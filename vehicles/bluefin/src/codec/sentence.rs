//! The NMEA layer both directions share: one sentence (`$`, talker, id, fields, XOR checksum)
//! parsed and formatted with bounded size, the typed [`CodecError`], the field formats (time of
//! day, `DDMM.MMMM` positions, Goby3's numbers) and [`F`], the field reader every typed sentence
//! is read through. It knows no sentence by name.

/// Longest sentence accepted, `$` to checksum inclusive. NMEA says 82; Huxley status text and
/// payload status lines are longer, so the bound is generous but finite.
pub const MAX_SENTENCE_BYTES: usize = 1024;
/// Most comma-separated fields in one sentence (BPSTS with payload messages is the widest).
pub const MAX_FIELDS: usize = 64;

/// Why a line is not a sentence, or not the sentence it claims to be.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CodecError {
    #[error("empty line")]
    Empty,
    #[error("sentence over {MAX_SENTENCE_BYTES} bytes ({0})")]
    TooLong(usize),
    #[error("more than {MAX_FIELDS} fields")]
    TooManyFields,
    #[error("does not start with `$` or `!`")]
    NoStart,
    #[error("not ASCII")]
    NotAscii,
    #[error("bad checksum: sentence says {given:02X}, bytes give {computed:02X}")]
    BadChecksum { given: u8, computed: u8 },
    #[error("malformed checksum `{0}`")]
    MalformedChecksum(String),
    #[error("first field `{0}` is not a 5-letter talker + sentence id")]
    BadAddress(String),
    #[error("{sentence}: missing field {index} ({what})")]
    Missing {
        sentence: &'static str,
        index: usize,
        what: &'static str,
    },
    #[error("{sentence}: field {index} ({what}) is not valid: `{value}`")]
    Invalid {
        sentence: &'static str,
        index: usize,
        what: &'static str,
        value: String,
    },
}

/// One NMEA sentence: `$` + talker (2) + id (3), fields, checksum.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Sentence {
    /// `BF` (Huxley) or `BP` (payload); not checked, as Goby3 does not check it.
    pub talker: String,
    /// The 3-letter sentence id (`NVG`, `ACK`, `RMB`, …), upper-case as received.
    pub id: String,
    /// The fields after the address, without the checksum.
    pub fields: Vec<String>,
}

/// XOR of every byte of `body` (the text between `$` and `*`).
pub fn checksum(body: &str) -> u8 {
    body.bytes().fold(0u8, |a, b| a ^ b)
}

impl Sentence {
    pub fn new(talker: &str, id: &str, fields: Vec<String>) -> Self {
        Self {
            talker: talker.to_string(),
            id: id.to_string(),
            fields,
        }
    }

    /// Parses one line (terminator already removed; surrounding whitespace ignored). A `*HH`
    /// checksum is optional, as in Goby3, but when present it must match. The size bound
    /// counts a line with its checksum (one without is counted as if it had one).
    pub fn parse(line: &str) -> Result<Self, CodecError> {
        let line = line.trim();
        if line.is_empty() {
            return Err(CodecError::Empty);
        }
        if line.len() > MAX_SENTENCE_BYTES {
            return Err(CodecError::TooLong(line.len()));
        }
        if !line.is_ascii() {
            return Err(CodecError::NotAscii);
        }
        let body = line
            .strip_prefix('$')
            .or_else(|| line.strip_prefix('!'))
            .ok_or(CodecError::NoStart)?;
        let body = match body.len().checked_sub(3).map(|i| body.split_at(i)) {
            Some((b, cs)) if cs.starts_with('*') => {
                let given = u8::from_str_radix(&cs[1..], 16)
                    .map_err(|_| CodecError::MalformedChecksum(cs.to_string()))?;
                let computed = checksum(b);
                if given != computed {
                    return Err(CodecError::BadChecksum { given, computed });
                }
                b
            }
            // Without a checksum the bound counts the three bytes `format` adds: a sentence we
            // accept always formats to a line we accept (found by the bluefin_codec fuzzer: a
            // 1 024-byte line without one formatted to 1 027 bytes and was refused on the way back).
            _ if line.len() + 3 > MAX_SENTENCE_BYTES => {
                return Err(CodecError::TooLong(line.len() + 3));
            }
            _ => body,
        };
        let mut parts = body.split(',');
        let address = parts.next().unwrap_or_default();
        if address.len() != 5 || !address.bytes().all(|b| b.is_ascii_alphanumeric()) {
            return Err(CodecError::BadAddress(address.to_string()));
        }
        let mut fields = Vec::new();
        for f in parts {
            if fields.len() == MAX_FIELDS {
                return Err(CodecError::TooManyFields);
            }
            fields.push(f.to_string());
        }
        Ok(Self {
            talker: address[..2].to_string(),
            id: address[2..].to_ascii_uppercase(),
            fields,
        })
    }

    /// The line with a fresh upper-case checksum, without a terminator.
    pub fn format(&self) -> String {
        let mut body = String::with_capacity(64);
        body.push_str(&self.talker);
        body.push_str(&self.id);
        for f in &self.fields {
            body.push(',');
            body.push_str(f);
        }
        format!("${body}*{:02X}", checksum(&body))
    }

    /// Field `i` counting the address as 0 (the fact sheet's numbering).
    pub fn field(&self, i: usize) -> Option<&str> {
        i.checked_sub(1)
            .and_then(|i| self.fields.get(i))
            .map(String::as_str)
    }
}

/// Seconds since midnight UTC → `hhmmss.sss` (exactly three decimals, as Huxley wants).
pub fn format_time(seconds_of_day: f64) -> String {
    let ms = if seconds_of_day.is_finite() {
        (seconds_of_day.rem_euclid(86_400.0) * 1000.0).round() as u64 % 86_400_000
    } else {
        0
    };
    let (h, rest) = (ms / 3_600_000, ms % 3_600_000);
    let (m, rest) = (rest / 60_000, rest % 60_000);
    format!("{h:02}{m:02}{:02}.{:03}", rest / 1000, rest % 1000)
}

/// `hhmmss[.s…]` → seconds since midnight; None unless the digits make a time of day.
pub fn parse_time(s: &str) -> Option<f64> {
    let s = s.trim();
    let (whole, frac) = s.split_once('.').unwrap_or((s, ""));
    if whole.len() != 6 || !whole.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    if !frac.bytes().all(|b| b.is_ascii_digit()) || frac.len() > 9 {
        return None;
    }
    let h: u32 = whole[0..2].parse().ok()?;
    let m: u32 = whole[2..4].parse().ok()?;
    let sec: u32 = whole[4..6].parse().ok()?;
    if h > 23 || m > 59 || sec > 60 {
        return None;
    }
    let frac: f64 = if frac.is_empty() {
        0.0
    } else {
        format!("0.{frac}").parse().ok()?
    };
    Some(f64::from(h * 3600 + m * 60 + sec) + frac)
}

/// Seconds since midnight UTC of a Unix time.
pub fn seconds_of_day(unix: f64) -> f64 {
    unix.rem_euclid(86_400.0)
}

/// The Unix time of a time of day, on the UTC date that puts it nearest `now_unix` (a fix
/// stamped 23:59:59.9 read at 00:00:00.1 is yesterday's, not today's).
pub fn unix_of_time_of_day(tod: f64, now_unix: f64) -> f64 {
    let day = (now_unix / 86_400.0).floor() * 86_400.0;
    [day - 86_400.0, day, day + 86_400.0]
        .into_iter()
        .map(|d| d + tod)
        .min_by(|a, b| (a - now_unix).abs().total_cmp(&(b - now_unix).abs()))
        .unwrap_or(day + tod)
}

/// Decimal degrees → `DDMM.MMMM` / `DDDMM.MMMM` and the hemisphere letter.
pub fn format_lat_lon(deg: f64, is_lat: bool) -> (String, char) {
    let hemi = match (is_lat, deg < 0.0) {
        (true, false) => 'N',
        (true, true) => 'S',
        (false, false) => 'E',
        (false, true) => 'W',
    };
    let a = deg.abs();
    let mut d = a.trunc();
    let mut m = ((a - d) * 60.0 * 10_000.0).round() / 10_000.0;
    if m >= 60.0 {
        d += 1.0;
        m -= 60.0;
    }
    let text = if is_lat {
        format!("{:02}{:07.4}", d as u32, m)
    } else {
        format!("{:03}{:07.4}", d as u32, m)
    };
    (text, hemi)
}

/// `DDMM.MMMM` (any number of degree digits: the minutes are the two digits before the point)
/// and a hemisphere letter → decimal degrees. Goby3 takes a fixed 2 or 3 leading digits as
/// degrees, which misreads an unpadded longitude; this does not.
pub fn parse_lat_lon(value: &str, hemi: &str, is_lat: bool) -> Option<f64> {
    let v = value.trim();
    let int_len = v.find('.').unwrap_or(v.len());
    if int_len < 3 || !v.bytes().all(|b| b.is_ascii_digit() || b == b'.') {
        return None;
    }
    let deg: f64 = v[..int_len - 2].parse().ok()?;
    let min: f64 = v[int_len - 2..].parse().ok()?;
    if min >= 60.0 {
        return None;
    }
    let x = deg + min / 60.0;
    let sign = match (hemi.trim(), is_lat) {
        ("N", true) | ("E", false) => 1.0,
        ("S", true) | ("W", false) => -1.0,
        _ => return None,
    };
    let limit = if is_lat { 90.0 } else { 180.0 };
    (x <= limit).then_some(sign * x)
}

/// A number the way Goby3 writes it: the shortest text that reads back as the same double.
pub fn num(x: f64) -> String {
    format!("{x}")
}

pub(super) fn opt_num(x: Option<f64>) -> String {
    x.filter(|v| v.is_finite()).map(num).unwrap_or_default()
}

/// Reads a sentence's fields by index into typed values, every problem a [`CodecError`] naming
/// the sentence, the field and what it should have held.
pub(super) struct F<'a> {
    pub(super) s: &'a Sentence,
    pub(super) name: &'static str,
}

impl<'a> F<'a> {
    pub(super) fn raw(&self, i: usize) -> Option<&'a str> {
        self.s.field(i).map(str::trim)
    }
    pub(super) fn req_str(&self, i: usize, what: &'static str) -> Result<&'a str, CodecError> {
        self.raw(i).ok_or(CodecError::Missing {
            sentence: self.name,
            index: i,
            what,
        })
    }
    pub(super) fn invalid(&self, i: usize, what: &'static str) -> CodecError {
        CodecError::Invalid {
            sentence: self.name,
            index: i,
            what,
            value: self.raw(i).unwrap_or_default().chars().take(40).collect(),
        }
    }
    /// Empty or absent → None; present but not a finite number → error.
    pub(super) fn opt(&self, i: usize, what: &'static str) -> Result<Option<f64>, CodecError> {
        match self.raw(i) {
            None | Some("") => Ok(None),
            Some(v) => match v.parse::<f64>() {
                Ok(x) if x.is_finite() => Ok(Some(x)),
                _ => Err(self.invalid(i, what)),
            },
        }
    }
    pub(super) fn req(&self, i: usize, what: &'static str) -> Result<f64, CodecError> {
        self.opt(i, what)?.ok_or_else(|| match self.raw(i) {
            None => CodecError::Missing {
                sentence: self.name,
                index: i,
                what,
            },
            Some(_) => self.invalid(i, what),
        })
    }
    pub(super) fn int(&self, i: usize, what: &'static str) -> Result<Option<i64>, CodecError> {
        match self.raw(i) {
            None | Some("") => Ok(None),
            Some(v) => v
                .parse::<i64>()
                .map(Some)
                .map_err(|_| self.invalid(i, what)),
        }
    }
    pub(super) fn time(&self, i: usize) -> Result<f64, CodecError> {
        let v = self.req_str(i, "timestamp")?;
        parse_time(v).ok_or_else(|| self.invalid(i, "timestamp"))
    }
    pub(super) fn opt_time(&self, i: usize, what: &'static str) -> Result<Option<f64>, CodecError> {
        match self.raw(i) {
            None | Some("") => Ok(None),
            Some(v) => parse_time(v).map(Some).ok_or_else(|| self.invalid(i, what)),
        }
    }
}
