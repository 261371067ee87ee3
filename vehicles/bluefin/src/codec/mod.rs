//! The Bluefin Huxley "Standard Payload Interface" sentences: `$BF…` from the vehicle, `$BP…`
//! from the payload, NMEA-framed with an XOR checksum. Pure text in, typed values out (and
//! back); no I/O, no clock. Both the driver (`driver.rs`) and the
//! Huxley emulator ([`crate::emulator`]) speak through this module, so a golden session replays
//! against both sides with the same bytes.
//!
//! Facts (field order, units, mode codes) are from Goby3's Bluefin driver as recorded in the
//! project's protocol fact sheet; where Goby3 reads input loosely (NaN for a bad number, fixed
//! digit counts for longitude) this codec is strict or robust instead, and says so.

use std::fmt::Write as _;

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
    /// checksum is optional, as in Goby3, but when present it must match.
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

fn opt_num(x: Option<f64>) -> String {
    x.filter(|v| v.is_finite()).map(num).unwrap_or_default()
}

// ---------------------------------------------------------------------------------------------
// Sentences from the Huxley (`$BF…`).

/// `$BFNVG` navigation update.
#[derive(Debug, Clone, PartialEq)]
pub struct Nvg {
    pub time: f64,
    pub lat: f64,
    pub lon: f64,
    /// Field 6: `1` is a GPS-quality position.
    pub quality: Option<i64>,
    /// Metres above the bottom.
    pub altitude: Option<f64>,
    pub depth: Option<f64>,
    pub heading: Option<f64>,
    pub roll: Option<f64>,
    pub pitch: Option<f64>,
    /// Seconds since midnight UTC of the computed fix.
    pub fix_time: Option<f64>,
}

/// `$BFNVR` velocity and rate update.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Nvr {
    pub time: f64,
    pub east: Option<f64>,
    pub north: Option<f64>,
    pub down: Option<f64>,
    pub pitch_rate: Option<f64>,
    pub roll_rate: Option<f64>,
    pub yaw_rate: Option<f64>,
}

/// `$BFACK` status (field 5).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AckStatus {
    Invalid = 0,
    Failed = 1,
    Success = 2,
    Pending = 3,
}

/// `$BFACK` acknowledgement of one payload sentence.
#[derive(Debug, Clone, PartialEq)]
pub struct Ack {
    pub time: f64,
    /// The 3-letter id of the sentence acknowledged (`RMB`, `LOG`, …), upper-case.
    pub command: String,
    /// The acknowledged sentence's own timestamp, as text (empty for LOG).
    pub command_time: String,
    pub status: AckStatus,
    pub text: String,
}

/// `$BFBOY` buoyancy status / `$BFTRM` trim status.
#[derive(Debug, Clone, PartialEq)]
pub struct AdjustStatus {
    pub time: f64,
    /// 0 idle, 1 in progress, 2 completed ok, 3 completed not ok.
    pub status: i32,
    pub error: i32,
    pub text: String,
    /// Buoyancy newtons, or pitch trim degrees.
    pub value: Option<f64>,
    /// Roll trim degrees (TRM only).
    pub value2: Option<f64>,
}

/// `$BFDVL` raw DVL.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Dvl {
    pub time: f64,
    pub u: Option<f64>,
    pub v: Option<f64>,
    pub w: Option<f64>,
    pub beams: [Option<f64>; 4],
    pub temperature: Option<f64>,
    /// Seconds since midnight of the DVL sample (Goby3 reads the `hhmmss.ss` text as a plain
    /// number of seconds; we read it as a time).
    pub dvl_time: Option<f64>,
}

/// `$BFCTD` raw CTD (conductivity µS/cm, temperature °C, pressure kPa).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CtdIn {
    pub time: f64,
    pub conductivity_us_cm: Option<f64>,
    pub temperature: Option<f64>,
    pub pressure_kpa: Option<f64>,
}

/// Everything the Huxley sends that the driver acts on.
#[derive(Debug, Clone, PartialEq)]
pub enum FromHuxley {
    Nvg(Nvg),
    Nvr(Nvr),
    Ack(Ack),
    /// `$BFMIS`: dive file and mission status text (`Running`, `Stopped`, …).
    Mis {
        time: f64,
        dive_file: String,
        status: String,
    },
    /// `$BFMSC`: a free-text mission-state message; its arrival is the hook.
    Msc {
        time: f64,
        text: String,
    },
    /// `$BFCTL`: backseat control on/off.
    Ctl {
        time: f64,
        control: bool,
    },
    Boy(AdjustStatus),
    Trm(AdjustStatus),
    Dvl(Dvl),
    /// `$BFRVL`: thruster RPM and the speed the vehicle's lookup table gives for it.
    Rvl {
        time: f64,
        rpm: f64,
        speed: Option<f64>,
    },
    Ctd(CtdIn),
    /// `$BFSHT`: the vehicle is shutting down.
    Sht {
        time: f64,
    },
    /// A sentence known by name that carries nothing we act on (SVS, MBS, MBE, TOP, …).
    Other(String),
}

struct F<'a> {
    s: &'a Sentence,
    name: &'static str,
}

impl<'a> F<'a> {
    fn raw(&self, i: usize) -> Option<&'a str> {
        self.s.field(i).map(str::trim)
    }
    fn req_str(&self, i: usize, what: &'static str) -> Result<&'a str, CodecError> {
        self.raw(i).ok_or(CodecError::Missing {
            sentence: self.name,
            index: i,
            what,
        })
    }
    fn invalid(&self, i: usize, what: &'static str) -> CodecError {
        CodecError::Invalid {
            sentence: self.name,
            index: i,
            what,
            value: self.raw(i).unwrap_or_default().chars().take(40).collect(),
        }
    }
    /// Empty or absent → None; present but not a finite number → error.
    fn opt(&self, i: usize, what: &'static str) -> Result<Option<f64>, CodecError> {
        match self.raw(i) {
            None | Some("") => Ok(None),
            Some(v) => match v.parse::<f64>() {
                Ok(x) if x.is_finite() => Ok(Some(x)),
                _ => Err(self.invalid(i, what)),
            },
        }
    }
    fn req(&self, i: usize, what: &'static str) -> Result<f64, CodecError> {
        self.opt(i, what)?.ok_or_else(|| match self.raw(i) {
            None => CodecError::Missing {
                sentence: self.name,
                index: i,
                what,
            },
            Some(_) => self.invalid(i, what),
        })
    }
    fn int(&self, i: usize, what: &'static str) -> Result<Option<i64>, CodecError> {
        match self.raw(i) {
            None | Some("") => Ok(None),
            Some(v) => v
                .parse::<i64>()
                .map(Some)
                .map_err(|_| self.invalid(i, what)),
        }
    }
    fn time(&self, i: usize) -> Result<f64, CodecError> {
        let v = self.req_str(i, "timestamp")?;
        parse_time(v).ok_or_else(|| self.invalid(i, "timestamp"))
    }
    fn opt_time(&self, i: usize, what: &'static str) -> Result<Option<f64>, CodecError> {
        match self.raw(i) {
            None | Some("") => Ok(None),
            Some(v) => parse_time(v).map(Some).ok_or_else(|| self.invalid(i, what)),
        }
    }
}

fn adjust(f: &F, two_values: bool) -> Result<AdjustStatus, CodecError> {
    Ok(AdjustStatus {
        time: f.time(1)?,
        status: f.int(2, "status")?.unwrap_or(0).clamp(0, 3) as i32,
        error: f.int(3, "error")?.unwrap_or(0).clamp(0, 3) as i32,
        text: f.raw(4).unwrap_or_default().to_string(),
        value: f.opt(5, "estimate")?,
        value2: if two_values {
            f.opt(6, "roll trim")?
        } else {
            None
        },
    })
}

impl FromHuxley {
    /// Interprets a sentence from the Huxley by its 3-letter id.
    pub fn from_sentence(s: &Sentence) -> Result<Self, CodecError> {
        let name: &'static str = match s.id.as_str() {
            "NVG" => "BFNVG",
            "NVR" => "BFNVR",
            "ACK" => "BFACK",
            "MIS" => "BFMIS",
            "MSC" => "BFMSC",
            "CTL" => "BFCTL",
            "BOY" => "BFBOY",
            "TRM" => "BFTRM",
            "DVL" => "BFDVL",
            "RVL" => "BFRVL",
            "CTD" => "BFCTD",
            "SHT" => "BFSHT",
            _ => return Ok(Self::Other(s.id.clone())),
        };
        let f = F { s, name };
        Ok(match s.id.as_str() {
            "NVG" => {
                let lat = parse_lat_lon(f.req_str(2, "latitude")?, f.raw(3).unwrap_or(""), true)
                    .ok_or_else(|| f.invalid(2, "latitude"))?;
                let lon = parse_lat_lon(f.req_str(4, "longitude")?, f.raw(5).unwrap_or(""), false)
                    .ok_or_else(|| f.invalid(4, "longitude"))?;
                Self::Nvg(Nvg {
                    time: f.time(1)?,
                    lat,
                    lon,
                    quality: f.int(6, "position quality")?,
                    altitude: f.opt(7, "altitude")?,
                    depth: f.opt(8, "depth")?,
                    heading: f.opt(9, "heading")?,
                    roll: f.opt(10, "roll")?,
                    pitch: f.opt(11, "pitch")?,
                    fix_time: f.opt_time(12, "fix time")?,
                })
            }
            "NVR" => Self::Nvr(Nvr {
                time: f.time(1)?,
                east: f.opt(2, "east velocity")?,
                north: f.opt(3, "north velocity")?,
                down: f.opt(4, "down velocity")?,
                pitch_rate: f.opt(5, "pitch rate")?,
                roll_rate: f.opt(6, "roll rate")?,
                yaw_rate: f.opt(7, "yaw rate")?,
            }),
            "ACK" => {
                let status = match f.int(5, "status")? {
                    Some(0) => AckStatus::Invalid,
                    Some(1) => AckStatus::Failed,
                    Some(2) => AckStatus::Success,
                    Some(3) => AckStatus::Pending,
                    _ => return Err(f.invalid(5, "status")),
                };
                let command = f.req_str(2, "command")?.to_ascii_uppercase();
                Self::Ack(Ack {
                    time: f.time(1)?,
                    command,
                    command_time: f.raw(3).unwrap_or_default().to_string(),
                    status,
                    // Free text: a comma in it became more fields; put them back.
                    text: s.fields.get(6..).map(|t| t.join(",")).unwrap_or_default(),
                })
            }
            "MIS" => Self::Mis {
                time: f.time(1)?,
                dive_file: f.raw(2).unwrap_or_default().to_string(),
                status: f.raw(3).unwrap_or_default().to_string(),
            },
            "MSC" => Self::Msc {
                time: f.time(1)?,
                text: s.fields.get(1..).map(|t| t.join(",")).unwrap_or_default(),
            },
            "CTL" => {
                let v = f.req_str(2, "control")?;
                Self::Ctl {
                    time: f.time(1)?,
                    control: v == "1" || v.eq_ignore_ascii_case("true"),
                }
            }
            "BOY" => Self::Boy(adjust(&f, false)?),
            "TRM" => Self::Trm(adjust(&f, true)?),
            "DVL" => Self::Dvl(Dvl {
                time: f.time(1)?,
                u: f.opt(2, "x velocity")?,
                v: f.opt(3, "y velocity")?,
                w: f.opt(4, "z velocity")?,
                beams: [
                    f.opt(5, "beam 1 range")?,
                    f.opt(6, "beam 2 range")?,
                    f.opt(7, "beam 3 range")?,
                    f.opt(8, "beam 4 range")?,
                ],
                temperature: f.opt(9, "temperature")?,
                dvl_time: f.opt_time(10, "dvl time")?,
            }),
            "RVL" => Self::Rvl {
                time: f.time(1)?,
                rpm: f.req(2, "rpm")?,
                speed: f.opt(3, "speed")?,
            },
            "CTD" => Self::Ctd(CtdIn {
                time: f.time(1)?,
                conductivity_us_cm: f.opt(2, "conductivity")?,
                temperature: f.opt(3, "temperature")?,
                pressure_kpa: f.opt(4, "pressure")?,
            }),
            "SHT" => Self::Sht { time: f.time(1)? },
            _ => Self::Other(s.id.clone()),
        })
    }

    pub fn to_sentence(&self) -> Sentence {
        let t = format_time;
        let (id, fields): (&str, Vec<String>) = match self {
            Self::Nvg(n) => {
                let (lat, ns) = format_lat_lon(n.lat, true);
                let (lon, ew) = format_lat_lon(n.lon, false);
                (
                    "NVG",
                    vec![
                        t(n.time),
                        lat,
                        ns.to_string(),
                        lon,
                        ew.to_string(),
                        n.quality.map(|q| q.to_string()).unwrap_or_default(),
                        opt_num(n.altitude),
                        opt_num(n.depth),
                        opt_num(n.heading),
                        opt_num(n.roll),
                        opt_num(n.pitch),
                        n.fix_time.map(t).unwrap_or_default(),
                    ],
                )
            }
            Self::Nvr(n) => (
                "NVR",
                vec![
                    t(n.time),
                    opt_num(n.east),
                    opt_num(n.north),
                    opt_num(n.down),
                    opt_num(n.pitch_rate),
                    opt_num(n.roll_rate),
                    opt_num(n.yaw_rate),
                ],
            ),
            Self::Ack(a) => (
                "ACK",
                vec![
                    t(a.time),
                    a.command.clone(),
                    a.command_time.clone(),
                    String::new(),
                    (a.status as i32).to_string(),
                    "0".into(),
                    a.text.clone(),
                ],
            ),
            Self::Mis {
                time,
                dive_file,
                status,
            } => ("MIS", vec![t(*time), dive_file.clone(), status.clone()]),
            Self::Msc { time, text } => ("MSC", vec![t(*time), text.clone()]),
            Self::Ctl { time, control } => (
                "CTL",
                vec![t(*time), if *control { "1" } else { "0" }.into()],
            ),
            Self::Boy(b) => (
                "BOY",
                vec![
                    t(b.time),
                    b.status.to_string(),
                    b.error.to_string(),
                    b.text.clone(),
                    opt_num(b.value),
                ],
            ),
            Self::Trm(b) => (
                "TRM",
                vec![
                    t(b.time),
                    b.status.to_string(),
                    b.error.to_string(),
                    b.text.clone(),
                    opt_num(b.value),
                    opt_num(b.value2),
                ],
            ),
            Self::Dvl(d) => {
                let mut v = vec![t(d.time), opt_num(d.u), opt_num(d.v), opt_num(d.w)];
                v.extend(d.beams.iter().map(|b| opt_num(*b)));
                v.push(opt_num(d.temperature));
                v.push(d.dvl_time.map(t).unwrap_or_default());
                ("DVL", v)
            }
            Self::Rvl { time, rpm, speed } => ("RVL", vec![t(*time), num(*rpm), opt_num(*speed)]),
            Self::Ctd(c) => (
                "CTD",
                vec![
                    t(c.time),
                    opt_num(c.conductivity_us_cm),
                    opt_num(c.temperature),
                    opt_num(c.pressure_kpa),
                    t(c.time),
                ],
            ),
            Self::Sht { time } => ("SHT", vec![t(*time)]),
            Self::Other(id) => return Sentence::new("BF", id, Vec::new()),
        };
        Sentence::new("BF", id, fields)
    }
}

// ---------------------------------------------------------------------------------------------
// Sentences from the payload (`$BP…`).

/// `$BPRMB` vertical mode (field 4).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VerticalMode {
    Depth = 0,
    Altitude = 1,
    Pitch = 2,
}

/// `$BPRMB` translational mode (field 6).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SpeedMode {
    Rpm = 0,
    Speed = 1,
}

/// `$BPRMB` horizontal mode (field 7).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HorizontalMode {
    Heading = 0,
    Rudder = 1,
}

/// `$BPRMB` "modify current behaviour": the payload's setpoint.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rmb {
    pub time: f64,
    pub horizontal: f64,
    pub vertical: f64,
    pub vertical_mode: VerticalMode,
    pub translational: f64,
    pub speed_mode: SpeedMode,
    pub horizontal_mode: HorizontalMode,
}

impl Rmb {
    /// Zero rudder, zero pitch, zero RPM: Goby3's stop line.
    pub fn stop(time: f64) -> Self {
        Self {
            time,
            horizontal: 0.0,
            vertical: 0.0,
            vertical_mode: VerticalMode::Pitch,
            translational: 0.0,
            speed_mode: SpeedMode::Rpm,
            horizontal_mode: HorizontalMode::Rudder,
        }
    }
}

/// `$BPCTD` (conductivity S/m, temperature °C, pressure kPa).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CtdOut {
    pub time: f64,
    pub conductivity: Option<f64>,
    pub temperature: Option<f64>,
    pub pressure_kpa: Option<f64>,
    pub sample_time: f64,
}

/// Everything the payload sends.
#[derive(Debug, Clone, PartialEq)]
pub enum FromPayload {
    /// `$BPLOG,<id>,ON|OFF` (no timestamp).
    Log {
        id: String,
        on: bool,
    },
    /// `$BPSTS` heartbeat: all ok, status text.
    Sts {
        time: f64,
        ok: bool,
        text: String,
    },
    Rmb(Rmb),
    Trm {
        time: f64,
    },
    Boy {
        time: f64,
    },
    /// `$BPSIL`: silent mode on/off.
    Sil {
        time: f64,
        silent: bool,
    },
    /// `$BPRCE`: cancel current behaviour / mission end confirm.
    Rce {
        time: f64,
    },
    /// `$BPABT`: abort; `with_errors` false means a successful mission.
    Abt {
        time: f64,
        with_errors: bool,
    },
    /// `$BPSMC`: mission start confirm.
    Smc {
        time: f64,
    },
    Ctd(CtdOut),
    /// `$BPDCL`: base64 of a DCCL message.
    Dcl {
        time: f64,
        base64: String,
    },
    /// `$BPTMR`: a modem line, `,`→`:` and `*`→`/`.
    Tmr {
        time: f64,
        line: String,
    },
    /// Any other `$BP…` sentence (raw pass-through).
    Other(Sentence),
}

impl FromPayload {
    /// The 3-letter id the Huxley acknowledges this sentence by.
    pub fn id(&self) -> &str {
        match self {
            Self::Log { .. } => "LOG",
            Self::Sts { .. } => "STS",
            Self::Rmb(_) => "RMB",
            Self::Trm { .. } => "TRM",
            Self::Boy { .. } => "BOY",
            Self::Sil { .. } => "SIL",
            Self::Rce { .. } => "RCE",
            Self::Abt { .. } => "ABT",
            Self::Smc { .. } => "SMC",
            Self::Ctd(_) => "CTD",
            Self::Dcl { .. } => "DCL",
            Self::Tmr { .. } => "TMR",
            Self::Other(s) => &s.id,
        }
    }

    /// The sentence's own timestamp field as text, as the Huxley echoes it in `$BFACK` field 3.
    pub fn time_text(&self) -> String {
        match self {
            Self::Log { .. } => String::new(),
            Self::Other(s) => s.field(1).unwrap_or_default().to_string(),
            other => other.to_sentence().field(1).unwrap_or_default().to_string(),
        }
    }

    pub fn from_sentence(s: &Sentence) -> Result<Self, CodecError> {
        let name: &'static str = match s.id.as_str() {
            "LOG" => "BPLOG",
            "STS" => "BPSTS",
            "RMB" => "BPRMB",
            "TRM" => "BPTRM",
            "BOY" => "BPBOY",
            "SIL" => "BPSIL",
            "RCE" => "BPRCE",
            "ABT" => "BPABT",
            "SMC" => "BPSMC",
            "CTD" => "BPCTD",
            "DCL" => "BPDCL",
            "TMR" => "BPTMR",
            _ => return Ok(Self::Other(s.clone())),
        };
        let f = F { s, name };
        Ok(match s.id.as_str() {
            "LOG" => {
                let id = f.req_str(1, "sentence id")?;
                if id.len() != 3 || !id.bytes().all(|b| b.is_ascii_alphanumeric()) {
                    return Err(f.invalid(1, "sentence id"));
                }
                let on = match f.req_str(2, "ON/OFF")? {
                    v if v.eq_ignore_ascii_case("ON") => true,
                    v if v.eq_ignore_ascii_case("OFF") => false,
                    _ => return Err(f.invalid(2, "ON/OFF")),
                };
                Self::Log {
                    id: id.to_ascii_uppercase(),
                    on,
                }
            }
            "STS" => Self::Sts {
                time: f.time(1)?,
                ok: f.req_str(2, "status")? == "1",
                text: s.fields.get(2..).map(|t| t.join(",")).unwrap_or_default(),
            },
            "RMB" => {
                let mode = |i, what| -> Result<i64, CodecError> {
                    f.int(i, what)?.ok_or(CodecError::Missing {
                        sentence: name,
                        index: i,
                        what,
                    })
                };
                let vertical_mode = match mode(4, "vertical mode")? {
                    0 => VerticalMode::Depth,
                    1 => VerticalMode::Altitude,
                    2 => VerticalMode::Pitch,
                    _ => return Err(f.invalid(4, "vertical mode")),
                };
                let speed_mode = match mode(6, "translational mode")? {
                    0 => SpeedMode::Rpm,
                    1 => SpeedMode::Speed,
                    _ => return Err(f.invalid(6, "translational mode")),
                };
                let horizontal_mode = match mode(7, "horizontal mode")? {
                    0 => HorizontalMode::Heading,
                    1 => HorizontalMode::Rudder,
                    _ => return Err(f.invalid(7, "horizontal mode")),
                };
                Self::Rmb(Rmb {
                    time: f.time(1)?,
                    horizontal: f.req(2, "horizontal")?,
                    vertical: f.req(3, "vertical")?,
                    vertical_mode,
                    translational: f.req(5, "translational")?,
                    speed_mode,
                    horizontal_mode,
                })
            }
            "TRM" => Self::Trm { time: f.time(1)? },
            "BOY" => Self::Boy { time: f.time(1)? },
            "SIL" => Self::Sil {
                time: f.time(1)?,
                silent: match f.int(2, "silent mode")? {
                    Some(0) => false,
                    Some(1) => true,
                    _ => return Err(f.invalid(2, "silent mode")),
                },
            },
            "RCE" => Self::Rce { time: f.time(1)? },
            "ABT" => Self::Abt {
                time: f.time(1)?,
                with_errors: f.int(3, "reason")? != Some(0),
            },
            "SMC" => Self::Smc { time: f.time(1)? },
            "CTD" => Self::Ctd(CtdOut {
                time: f.time(1)?,
                conductivity: f.opt(2, "conductivity")?,
                temperature: f.opt(3, "temperature")?,
                pressure_kpa: f.opt(4, "pressure")?,
                sample_time: f.opt_time(5, "sample time")?.unwrap_or(0.0),
            }),
            "DCL" => Self::Dcl {
                time: f.time(1)?,
                base64: f.req_str(2, "dccl")?.to_string(),
            },
            "TMR" => Self::Tmr {
                time: f.time(1)?,
                line: f.raw(3).unwrap_or_default().to_string(),
            },
            _ => Self::Other(s.clone()),
        })
    }

    pub fn to_sentence(&self) -> Sentence {
        let t = format_time;
        let (id, fields): (&str, Vec<String>) = match self {
            Self::Log { id, on } => (
                "LOG",
                vec![
                    id.to_ascii_uppercase(),
                    if *on { "ON" } else { "OFF" }.into(),
                ],
            ),
            Self::Sts { time, ok, text } => (
                "STS",
                vec![t(*time), if *ok { "1" } else { "0" }.into(), text.clone()],
            ),
            Self::Rmb(r) => (
                "RMB",
                vec![
                    t(r.time),
                    num(r.horizontal),
                    num(r.vertical),
                    (r.vertical_mode as i32).to_string(),
                    num(r.translational),
                    (r.speed_mode as i32).to_string(),
                    (r.horizontal_mode as i32).to_string(),
                ],
            ),
            Self::Trm { time } => ("TRM", vec![t(*time)]),
            Self::Boy { time } => ("BOY", vec![t(*time)]),
            Self::Sil { time, silent } => (
                "SIL",
                vec![t(*time), if *silent { "1" } else { "0" }.into()],
            ),
            Self::Rce { time } => ("RCE", vec![t(*time), "0".into()]),
            Self::Abt { time, with_errors } => (
                "ABT",
                vec![
                    t(*time),
                    "backseat abort".into(),
                    if *with_errors { "1" } else { "0" }.into(),
                ],
            ),
            Self::Smc { time } => ("SMC", vec![t(*time), "1".into()]),
            Self::Ctd(c) => {
                let ten =
                    |x: Option<f64>| x.filter(|v| v.is_finite()).map(sig10).unwrap_or_default();
                (
                    "CTD",
                    vec![
                        t(c.time),
                        ten(c.conductivity),
                        ten(c.temperature),
                        ten(c.pressure_kpa),
                        t(c.sample_time),
                    ],
                )
            }
            Self::Dcl { time, base64 } => ("DCL", vec![t(*time), base64.trim().to_string()]),
            Self::Tmr { time, line } => ("TMR", vec![t(*time), "3".into(), tmr_escape(line)]),
            Self::Other(s) => return s.clone(),
        };
        Sentence::new("BP", id, fields)
    }
}

/// A modem line made safe for one `$BPTMR` field: `,`→`:`, `*`→`/`, and CR *and* LF → space
/// (Goby3 replaces only CR, so a LF would end the sentence early).
pub fn tmr_escape(line: &str) -> String {
    line.chars()
        .map(|c| match c {
            ',' => ':',
            '*' => '/',
            '\r' | '\n' => ' ',
            c => c,
        })
        .collect()
}

/// At most 10 significant digits, trailing zeros dropped (Goby3's precision for BPCTD).
fn sig10(x: f64) -> String {
    if x == 0.0 {
        return "0".into();
    }
    let mag = x.abs().log10().floor() as i32;
    let decimals = (9 - mag).clamp(0, 17) as usize;
    let mut s = String::new();
    let _ = write!(s, "{x:.decimals$}");
    if s.contains('.') {
        while s.ends_with('0') {
            s.pop();
        }
        if s.ends_with('.') {
            s.pop();
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Lines from the fact sheet's constructed transcript (checksums as printed there).
    #[test]
    fn fact_sheet_lines_keep_their_checksums() {
        for line in [
            "$BPLOG,ACK,ON*1E",
            "$BPLOG,NVG,ON*08",
            "$BPSTS,120000.000,1,Deploy*6D",
            "$BPRMB,120004.000,180,10,0,1.5,1,0*59",
            "$BPTRM,120011.000*68",
            "$BPBOY,120012.000*74",
            "$BPSIL,120013.000,1*6A",
            "$BPRCE,120014.000,0*6E",
            "$BPABT,120015.000,backseat abort,1*03",
            "$BPSMC,120016.000,1*64",
            "$BPCTD,120017.000,4.2,12.5,201.325,120016.900*7C",
            "$BPDCL,120018.000,CgQIARAC*60",
            "$BPTMR,120019.000,3,$CARXD:1:0:0:1:1/51*1B",
            "$BPRMB,120030.000,0,0,2,0,0,1*7E",
        ] {
            let s = Sentence::parse(line).unwrap_or_else(|e| panic!("{line}: {e}"));
            assert_eq!(s.format(), line, "sentence round trip");
            let typed = FromPayload::from_sentence(&s).unwrap_or_else(|e| panic!("{line}: {e}"));
            assert!(!matches!(typed, FromPayload::Other(_)), "{line}");
            assert_eq!(typed.to_sentence().format(), line, "typed round trip");
        }
        for line in [
            "$BFACK,120000.120,LOG,120000.000,,2,0,*24",
            "$BFNVG,120002.000,4221.5040,N,07105.2560,W,1,25.3,0.0,90.0,0.5,-1.2,120001.950*42",
            "$BFNVR,120002.010,1.50,0.00,0.00,0.10,0.00,0.20*7B",
            "$BFMIS,120003.000,demo.dive,Running*15",
            "$BFMSC,120003.500,backseat control enabled*48",
            "$BFACK,120029.000,RMB,120028.000,,1,0,depth too deep*31",
            "$BFMIS,120020.000,demo.dive,Stopped*1A",
            "$BFCTL,120021.000,1*70",
            "$BFCTL,120022.000,0*72",
            "$BFBOY,120023.000,2,0,done,-1.5*65",
            "$BFTRM,120024.000,2,0,done,1.2,0.3*56",
            "$BFRVL,120025.000,1200,1.5*53",
            "$BFDVL,120026.000,1.5,0.01,-0.02,10.1,10.2,10.3,10.4,12.5,120025.900*48",
            "$BFCTD,120027.000,42000,12.5,201.325,120026.900*74",
            "$BFSHT,120028.000*70",
        ] {
            let s = Sentence::parse(line).unwrap_or_else(|e| panic!("{line}: {e}"));
            assert_eq!(s.format(), line);
            let typed = FromHuxley::from_sentence(&s).unwrap_or_else(|e| panic!("{line}: {e}"));
            assert!(!matches!(typed, FromHuxley::Other(_)), "{line}");
        }
    }

    #[test]
    fn nvg_reads_the_fact_sheet_example() {
        let s = Sentence::parse(
            "$BFNVG,120002.000,4221.5040,N,07105.2560,W,1,25.3,0.0,90.0,0.5,-1.2,120001.950*42",
        )
        .unwrap();
        let FromHuxley::Nvg(n) = FromHuxley::from_sentence(&s).unwrap() else {
            panic!()
        };
        assert!((n.lat - 42.3584).abs() < 1e-9, "{}", n.lat);
        assert!((n.lon + 71.0876).abs() < 1e-9, "{}", n.lon);
        assert_eq!(n.quality, Some(1));
        assert_eq!(
            (n.altitude, n.depth, n.heading, n.roll, n.pitch),
            (Some(25.3), Some(0.0), Some(90.0), Some(0.5), Some(-1.2))
        );
        assert_eq!(n.fix_time, Some(12.0 * 3600.0 + 1.95));
        assert_eq!(n.time, 12.0 * 3600.0 + 2.0);
    }

    #[test]
    fn checksum_is_optional_but_checked_when_present() {
        assert!(Sentence::parse("$BFSHT,120028.000").is_ok());
        assert!(Sentence::parse("  $BFSHT,120028.000*70  ").is_ok());
        assert!(Sentence::parse("$BFSHT,120028.000*70\r").is_ok());
        assert_eq!(
            Sentence::parse("$BFSHT,120028.000*71"),
            Err(CodecError::BadChecksum {
                given: 0x71,
                computed: 0x70
            })
        );
        assert!(matches!(
            Sentence::parse("$BFSHT,120028.000*ZZ"),
            Err(CodecError::MalformedChecksum(_))
        ));
    }

    #[test]
    fn malformed_lines_are_typed_errors() {
        type Want = fn(&CodecError) -> bool;
        let cases: &[(&str, Want)] = &[
            ("", |e| *e == CodecError::Empty),
            ("   ", |e| *e == CodecError::Empty),
            ("BFSHT,120000.000", |e| *e == CodecError::NoStart),
            ("$BFSH,1", |e| matches!(e, CodecError::BadAddress(_))),
            ("$BFSHTX,1", |e| matches!(e, CodecError::BadAddress(_))),
            ("$", |e| matches!(e, CodecError::BadAddress(_))),
            ("$BF\u{e9}HT,1", |e| *e == CodecError::NotAscii),
        ];
        for (line, want) in cases {
            let e = Sentence::parse(line).unwrap_err();
            assert!(want(&e), "{line:?}: {e:?}");
        }
        let long = format!("$BFMSC,{}", "x".repeat(MAX_SENTENCE_BYTES));
        assert!(matches!(
            Sentence::parse(&long),
            Err(CodecError::TooLong(_))
        ));
        let wide = format!("$BFMSC{}", ",".repeat(MAX_FIELDS + 1));
        assert_eq!(Sentence::parse(&wide), Err(CodecError::TooManyFields));
    }

    #[test]
    fn typed_errors_name_the_field() {
        for (line, index) in [
            ("$BFNVG,120002.000,42x1.5040,N,07105.2560,W,1,,,,,,", 2),
            ("$BFNVG,120002.000,4221.5040,N,07105.2560,Q,1,,,,,,", 4),
            ("$BFNVG,120002.000,4221.5040,N,07105.2560,W,1,nan,,,,,", 7),
            ("$BFNVG,1200,4221.5040,N,07105.2560,W,1,,,,,,", 1),
            ("$BFACK,120000.000,RMB,,,7,0,", 5),
            ("$BFNVR,120000.000,inf", 2),
            ("$BPRMB,120004.000,180,10,9,1.5,1,0", 4),
            ("$BPLOG,NVGX,ON", 1),
        ] {
            let s = Sentence::parse(line).unwrap();
            let e = if s.talker == "BF" {
                FromHuxley::from_sentence(&s).unwrap_err()
            } else {
                FromPayload::from_sentence(&s).unwrap_err()
            };
            match e {
                CodecError::Invalid { index: i, .. } | CodecError::Missing { index: i, .. } => {
                    assert_eq!(i, index, "{line}: {e}")
                }
                other => panic!("{line}: {other:?}"),
            }
        }
    }

    #[test]
    fn time_of_day_round_trips_with_three_decimals() {
        for (secs, text) in [
            (0.0, "000000.000"),
            (43_200.0, "120000.000"),
            (43_201.95, "120001.950"),
            (86_399.999_4, "235959.999"),
            (86_399.999_6, "000000.000"),
        ] {
            assert_eq!(format_time(secs), text);
        }
        assert_eq!(parse_time("120001.950"), Some(43_201.95));
        assert_eq!(parse_time("120001"), Some(43_201.0));
        for bad in ["", "12000", "250000.0", "126000.0", "12a000.0", "120000.-1"] {
            assert_eq!(parse_time(bad), None, "{bad}");
        }
    }

    #[test]
    fn nvg_time_of_day_takes_the_nearest_date() {
        let day = 20_000.0 * 86_400.0;
        assert_eq!(
            unix_of_time_of_day(43_200.0, day + 43_201.0),
            day + 43_200.0
        );
        // Read just after midnight, stamped just before: yesterday.
        assert_eq!(unix_of_time_of_day(86_399.9, day + 0.1), day - 0.1);
        // Read just before midnight, stamped just after: tomorrow.
        assert_eq!(
            unix_of_time_of_day(0.1, day + 86_399.9),
            day + 86_400.0 + 0.1
        );
    }

    #[test]
    fn lat_lon_format_and_parse_agree() {
        assert_eq!(format_lat_lon(42.3584, true), ("4221.5040".into(), 'N'));
        assert_eq!(format_lat_lon(-71.0876, false), ("07105.2560".into(), 'W'));
        assert_eq!(format_lat_lon(-0.5, true), ("0030.0000".into(), 'S'));
        assert_eq!(
            format_lat_lon(5.99999999, false),
            ("00600.0000".into(), 'E')
        );
        // Unpadded longitude (Goby3 would read 710 degrees 5.256 minutes).
        let lon = parse_lat_lon("7105.256", "W", false).unwrap();
        assert!((lon + 71.0876).abs() < 1e-9);
        assert_eq!(parse_lat_lon("4260.0000", "N", true), None);
        assert_eq!(parse_lat_lon("9100.0000", "N", true), None);
        assert_eq!(parse_lat_lon("4221.5", "X", true), None);
        assert_eq!(parse_lat_lon("21", "N", true), None);
        for deg in [0.0f64, 12.345678, -33.999999, 89.9, -179.5, 179.99999] {
            for is_lat in [true, false] {
                if is_lat && deg.abs() > 90.0 {
                    continue;
                }
                let (t, h) = format_lat_lon(deg, is_lat);
                let back = parse_lat_lon(&t, &h.to_string(), is_lat).unwrap();
                // 4 decimals of a minute: 0.0001/60 degree ≈ 0.2 m.
                assert!((back - deg).abs() < 1e-6, "{deg} → {t}{h} → {back}");
            }
        }
    }

    #[test]
    fn ack_text_keeps_its_commas() {
        let s =
            Sentence::parse("$BFACK,120029.000,rmb,120028.000,,1,0,too deep, and slow").unwrap();
        let FromHuxley::Ack(a) = FromHuxley::from_sentence(&s).unwrap() else {
            panic!()
        };
        assert_eq!(a.command, "RMB");
        assert_eq!(a.status, AckStatus::Failed);
        assert_eq!(a.text, "too deep, and slow");
    }

    #[test]
    fn payload_sentences_know_their_ack_id_and_time() {
        let rmb = FromPayload::Rmb(Rmb::stop(43_230.0));
        assert_eq!(rmb.id(), "RMB");
        assert_eq!(rmb.time_text(), "120030.000");
        let log = FromPayload::Log {
            id: "nvg".into(),
            on: true,
        };
        assert_eq!(log.id(), "LOG");
        assert_eq!(log.time_text(), "");
        assert_eq!(log.to_sentence().format(), "$BPLOG,NVG,ON*08");
    }

    #[test]
    fn tmr_escape_keeps_the_sentence_one_line() {
        assert_eq!(tmr_escape("$CARXD,1*51\r\n"), "$CARXD:1/51  ");
    }

    #[test]
    fn ctd_numbers_have_ten_significant_digits() {
        assert_eq!(sig10(201.325), "201.325");
        assert_eq!(sig10(4.2), "4.2");
        assert_eq!(sig10(1.0 / 3.0), "0.3333333333");
        assert_eq!(sig10(123456.789012), "123456.789");
    }
}
