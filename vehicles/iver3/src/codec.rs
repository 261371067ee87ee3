//! The Iver3 UVC "Remote Helm" NMEA sentences, pure: checksums, the sentences the backseat
//! sends (`$OSD`, `$OMS`, `$OMSTART`, `$OMSTOP`) and those the UVC sends (`$OSI`, the `$C`
//! compass string, `$--RMC`, `$ACK`), in the vehicle's own units (feet, knots). Unit conversion
//! is the driver's job, at its edge. No I/O.

/// Longest sentence either side accepts, terminator excluded (NMEA says 82; Remote Helm `$OSI`
/// lines run longer, so a generous bound that still caps memory).
pub const MAX_SENTENCE: usize = 512;

pub const FEET_PER_METRE: f64 = 1.0 / 0.3048;
/// m/s per knot (1852 m per hour).
pub const MPS_PER_KNOT: f64 = 1852.0 / 3600.0;

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SentenceError {
    #[error("empty line")]
    Empty,
    #[error("line of {0} bytes exceeds {MAX_SENTENCE}")]
    TooLong(usize),
    #[error("does not start with `$`")]
    NoDollar,
    #[error("checksum field `{0}` is not two hex digits")]
    BadChecksumField(String),
    #[error("checksum 0x{got:02X}, computed 0x{computed:02X}")]
    BadChecksum { got: u8, computed: u8 },
    #[error("{sentence}: {need} fields needed, {got} present")]
    TooFewFields {
        sentence: &'static str,
        need: usize,
        got: usize,
    },
    #[error("{sentence} field {index} `{value}` is not a finite number")]
    BadNumber {
        sentence: &'static str,
        index: usize,
        value: String,
    },
    #[error("compass string without `{0}`")]
    CompassMissing(char),
}

/// XOR of the bytes between `$` and `*`.
pub fn checksum(body: &str) -> u8 {
    body.bytes().fold(0, |a, b| a ^ b)
}

/// `$body*HH`.
pub fn with_checksum(body: &str) -> String {
    format!("${body}*{:02X}", checksum(body))
}

/// Splits a line into its fields (talker first, without `$`), checking the optional checksum.
pub fn fields(line: &str) -> Result<Vec<&str>, SentenceError> {
    let line = line.trim_end_matches(['\r', '\n']);
    if line.is_empty() {
        return Err(SentenceError::Empty);
    }
    if line.len() > MAX_SENTENCE {
        return Err(SentenceError::TooLong(line.len()));
    }
    let body = line.strip_prefix('$').ok_or(SentenceError::NoDollar)?;
    // A checksum is optional, but when `*HH` ends the line it must match.
    let n = body.len();
    let body = if n >= 3 && body.as_bytes()[n - 3] == b'*' {
        let (b, cs) = (&body[..n - 3], &body[n - 2..]);
        let got = cs
            .bytes()
            .all(|c| c.is_ascii_hexdigit())
            .then(|| u8::from_str_radix(cs, 16).ok())
            .flatten()
            .ok_or_else(|| SentenceError::BadChecksumField(cs.to_string()))?;
        let computed = checksum(b);
        if got != computed {
            return Err(SentenceError::BadChecksum { got, computed });
        }
        b
    } else {
        body
    };
    Ok(body.split(',').collect())
}

fn num(sentence: &'static str, f: &[&str], index: usize) -> Result<f64, SentenceError> {
    let v = f.get(index).copied().unwrap_or("");
    match v.trim().parse::<f64>() {
        Ok(x) if x.is_finite() => Ok(x),
        _ => Err(SentenceError::BadNumber {
            sentence,
            index,
            value: v.chars().take(32).collect(),
        }),
    }
}

fn at_least(sentence: &'static str, f: &[&str], need: usize) -> Result<(), SentenceError> {
    if f.len() < need {
        return Err(SentenceError::TooFewFields {
            sentence,
            need,
            got: f.len(),
        });
    }
    Ok(())
}

/// `$OMS`: a course in the UVC's units.
#[derive(Debug, Clone, PartialEq)]
pub struct Oms {
    /// Degrees in [0, 360).
    pub heading: f64,
    /// Feet (Remote Helm < 5) or metres (≥ 5): see [`Oms::depth_unit_is_feet`].
    pub depth: f64,
    /// Degrees.
    pub max_pitch: f64,
    /// Knots.
    pub speed_kn: f64,
    /// Seconds the UVC keeps the command without a refresh.
    pub timeout_s: u32,
}

impl Oms {
    /// Remote Helm changed `$OMS` depth from feet to metres in major version 5.
    pub fn depth_unit_is_feet(remote_helm_version_major: i32) -> bool {
        remote_helm_version_major < 5
    }
}

/// `$OSI`: the UVC's state, fields as sent (feet, knots, decimal degrees).
#[derive(Debug, Clone, PartialEq)]
pub struct Osi {
    pub fin_motor: String,
    pub mode: String,
    pub next_wp: String,
    pub lat: f64,
    pub lon: f64,
    pub speed_kn: f64,
    pub dist_to_next: String,
    pub error: String,
    pub altimeter_ft: f64,
    pub park_time: String,
    pub mag_declination: String,
    pub mission: String,
    pub remaining_time: String,
    pub heading: f64,
    pub depth_ft: f64,
}

/// The `$C` compass string: heading, pitch, roll (degrees), temperature (°C), depth (feet).
#[derive(Debug, Clone, PartialEq)]
pub struct Compass {
    pub heading: f64,
    pub pitch: f64,
    pub roll: f64,
    pub temperature: f64,
    pub depth_ft: f64,
}

/// `$ACK,<msg_type>,<status>,<err_num>`: the UVC's verdict on a command (Remote Helm doc v3.7
/// numbering: 1 OMSTOP, 3 OMSTART, 8 OSD, 9 OMS; status 0 = no error).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Ack {
    pub msg_type: u32,
    pub status: u32,
    pub err: u32,
}

pub mod ack_type {
    pub const OMSTOP: u32 = 1;
    pub const OMSTART: u32 = 3;
    pub const OSD: u32 = 8;
    pub const OMS: u32 = 9;
}

/// Every sentence either side sends, by meaning.
#[derive(Debug, Clone, PartialEq)]
pub enum Sentence {
    /// `$OSD`: the poll; which answers are wanted (GPS, compass, state, power).
    Osd {
        gps: bool,
        compass: bool,
        state: bool,
        power: bool,
    },
    Oms(Oms),
    OmStart {
        mission: String,
    },
    OmStop,
    Osi(Box<Osi>),
    Compass(Compass),
    /// `$--RMC`; only its presence matters to the driver (Goby3 uses it only for NTP).
    Rmc {
        talker: String,
        fields: Vec<String>,
    },
    Ack(Ack),
    /// Anything else, by its talker.
    Other(String),
}

/// Goby3's `$OMS` fields: rounded to one decimal.
fn d1(x: f64) -> String {
    let r = (x * 10.0).round() / 10.0;
    // Near f64::MAX the scaling overflows; such a value has no decimals to round anyway.
    format!("{:.1}", if r.is_finite() { r } else { x })
}

impl Sentence {
    /// The line with `$`, checksum, and no terminator.
    pub fn to_line(&self) -> String {
        let yn = |b: bool, c: &str| if b { c.to_string() } else { String::new() };
        let body = match self {
            Sentence::Osd {
                gps,
                compass,
                state,
                power,
            } => format!(
                "OSD,{},{},{},{},,,,",
                yn(*gps, "G"),
                yn(*compass, "C"),
                yn(*state, "S"),
                yn(*power, "P")
            ),
            Sentence::Oms(o) => format!(
                "OMS,{},{},{},{},{}",
                d1(o.heading),
                d1(o.depth),
                d1(o.max_pitch),
                d1(o.speed_kn),
                o.timeout_s
            ),
            Sentence::OmStart { mission } => format!("OMSTART,0,0,0,0,{mission},"),
            Sentence::OmStop => "OMSTOP,0".to_string(),
            Sentence::Osi(o) => format!(
                "OSI,{},{},{},{:.6},{:.6},{:.1},{},{},{:.1},{},{},{},{},{:.1},{:.1}",
                o.fin_motor,
                o.mode,
                o.next_wp,
                o.lat,
                o.lon,
                o.speed_kn,
                o.dist_to_next,
                o.error,
                o.altimeter_ft,
                o.park_time,
                o.mag_declination,
                o.mission,
                o.remaining_time,
                o.heading,
                o.depth_ft
            ),
            Sentence::Compass(c) => format!(
                "C{:.1}P{:.2}R{:.2}T{:.1}D{:.1}",
                c.heading, c.pitch, c.roll, c.temperature, c.depth_ft
            ),
            Sentence::Rmc { talker, fields } => format!("{talker},{}", fields.join(",")),
            Sentence::Ack(a) => format!("ACK,{},{},{}", a.msg_type, a.status, a.err),
            Sentence::Other(t) => t.clone(),
        };
        with_checksum(&body)
    }

    pub fn parse(line: &str) -> Result<Sentence, SentenceError> {
        let f = fields(line)?;
        let talker = f[0];
        Ok(match talker {
            "OSD" => {
                let has = |i: usize, c: &str| f.get(i).is_some_and(|v| *v == c);
                Sentence::Osd {
                    gps: has(1, "G"),
                    compass: has(2, "C"),
                    state: has(3, "S"),
                    power: has(4, "P"),
                }
            }
            "OMS" => {
                at_least("OMS", &f, 6)?;
                let timeout = num("OMS", &f, 5)?;
                Sentence::Oms(Oms {
                    heading: num("OMS", &f, 1)?,
                    depth: num("OMS", &f, 2)?,
                    max_pitch: num("OMS", &f, 3)?,
                    speed_kn: num("OMS", &f, 4)?,
                    timeout_s: timeout.clamp(0.0, f64::from(u32::MAX)) as u32,
                })
            }
            "OMSTART" => {
                at_least("OMSTART", &f, 6)?;
                Sentence::OmStart {
                    mission: f[5].to_string(),
                }
            }
            "OMSTOP" => Sentence::OmStop,
            "OSI" => {
                // Goby3 reads up to index 15; shorter lines publish nothing.
                at_least("OSI", &f, 16)?;
                let s = |i: usize| f[i].to_string();
                Sentence::Osi(Box::new(Osi {
                    fin_motor: s(1),
                    mode: s(2),
                    next_wp: s(3),
                    lat: num("OSI", &f, 4)?,
                    lon: num("OSI", &f, 5)?,
                    speed_kn: num("OSI", &f, 6)?,
                    dist_to_next: s(7),
                    error: s(8),
                    altimeter_ft: num("OSI", &f, 9)?,
                    park_time: s(10),
                    mag_declination: s(11),
                    mission: s(12),
                    remaining_time: s(13),
                    heading: num("OSI", &f, 14)?,
                    depth_ft: num("OSI", &f, 15)?,
                }))
            }
            "ACK" => {
                at_least("ACK", &f, 4)?;
                let n = |i| num("ACK", &f, i).map(|x| x.clamp(0.0, f64::from(u32::MAX)) as u32);
                Sentence::Ack(Ack {
                    msg_type: n(1)?,
                    status: n(2)?,
                    err: n(3)?,
                })
            }
            t if t.starts_with('C') => Sentence::Compass(parse_compass(t)?),
            t if t.len() == 5 && t.ends_with("RMC") => {
                at_least("RMC", &f, 12)?;
                Sentence::Rmc {
                    talker: t.to_string(),
                    fields: f[1..].iter().map(|s| s.to_string()).collect(),
                }
            }
            t => Sentence::Other(t.chars().take(16).collect()),
        })
    }
}

/// `C82.8P-3.89R-2.63T20.3D3.2` → the five numbers.
fn parse_compass(s: &str) -> Result<Compass, SentenceError> {
    let mut vals = [None::<f64>; 5];
    let keys = ['C', 'P', 'R', 'T', 'D'];
    let mut rest = s;
    while let Some(k) = rest.chars().next() {
        let Some(slot) = keys.iter().position(|c| *c == k) else {
            return Err(SentenceError::BadNumber {
                sentence: "C",
                index: 0,
                value: rest.chars().take(32).collect(),
            });
        };
        let body = &rest[1..];
        let end = body.find(|c: char| keys.contains(&c)).unwrap_or(body.len());
        let v = body[..end].parse::<f64>().ok().filter(|x| x.is_finite());
        vals[slot] = Some(v.ok_or_else(|| SentenceError::BadNumber {
            sentence: "C",
            index: slot,
            value: body[..end].chars().take(32).collect(),
        })?);
        rest = &body[end..];
    }
    let get = |i: usize| vals[i].ok_or(SentenceError::CompassMissing(keys[i]));
    Ok(Compass {
        heading: get(0)?,
        pitch: get(1)?,
        roll: get(2)?,
        temperature: vals[3].unwrap_or(0.0),
        depth_ft: vals[4].unwrap_or(0.0),
    })
}

/// A `$GPRMC` for a position (decimal degrees) at a UTC time (seconds of the day, day number
/// since 1970) as the UVC would send it.
pub fn rmc(lat: f64, lon: f64, speed_kn: f64, course: f64, unix_s: f64) -> Sentence {
    let secs = unix_s.max(0.0);
    let day_s = secs % 86_400.0;
    let (h, m, s) = (
        (day_s / 3600.0).floor(),
        ((day_s % 3600.0) / 60.0).floor(),
        day_s % 60.0,
    );
    let (y, mo, d) = civil_from_days((secs / 86_400.0).floor() as i64);
    let dm = |v: f64| {
        let a = v.abs();
        let deg = a.floor();
        (deg, (a - deg) * 60.0)
    };
    let (la, lam) = dm(lat);
    let (lo, lom) = dm(lon);
    Sentence::Rmc {
        talker: "GPRMC".into(),
        fields: vec![
            format!("{h:02}{m:02}{s:05.2}"),
            "A".into(),
            format!("{la:02}{lam:07.4}"),
            if lat < 0.0 { "S" } else { "N" }.into(),
            format!("{lo:03}{lom:07.4}"),
            if lon < 0.0 { "W" } else { "E" }.into(),
            format!("{speed_kn:.1}"),
            format!("{course:.1}"),
            format!("{d:02}{mo:02}{:02}", y.rem_euclid(100)),
            "".into(),
            "".into(),
        ],
    }
}

/// Days since 1970-01-01 → (year, month, day) (Howard Hinnant's algorithm).
fn civil_from_days(z: i64) -> (i64, u32, u32) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let y = yoe + era * 400;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    (if m <= 2 { y + 1 } else { y }, m, d)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The constructed examples of the fact sheet (iver3.md §2.1, §7).
    #[test]
    fn golden_sentences() {
        let osd = Sentence::Osd {
            gps: true,
            compass: true,
            state: true,
            power: true,
        };
        assert_eq!(osd.to_line(), "$OSD,G,C,S,P,,,,*5F");
        let oms = |depth| {
            Sentence::Oms(Oms {
                heading: 180.0,
                depth,
                max_pitch: 45.0,
                speed_kn: 1.5 / MPS_PER_KNOT,
                timeout_s: 5,
            })
        };
        assert_eq!(oms(3.0).to_line(), "$OMS,180.0,3.0,45.0,2.9,5*78");
        assert_eq!(
            oms(3.0 * FEET_PER_METRE).to_line(),
            "$OMS,180.0,9.8,45.0,2.9,5*7A"
        );
        assert_eq!(
            Sentence::OmStart {
                mission: "demo.mis".into()
            }
            .to_line(),
            "$OMSTART,0,0,0,0,demo.mis,*18"
        );
        assert_eq!(Sentence::OmStop.to_line(), "$OMSTOP,0*06");

        let osi = "$OSI,7F7F7F7F80,N,0,42.358400,-71.087600,2.9,0.0,N,32.8,P0,-14.5,demo.mis,0,90.0,10.5*47";
        let Sentence::Osi(o) = Sentence::parse(osi).unwrap() else {
            panic!()
        };
        assert_eq!(o.mode, "N");
        assert_eq!((o.lat, o.lon, o.speed_kn), (42.3584, -71.0876, 2.9));
        assert_eq!((o.altimeter_ft, o.heading, o.depth_ft), (32.8, 90.0, 10.5));
        assert_eq!(Sentence::Osi(o).to_line(), osi);

        let c = "$C90.0P-1.20R0.50T20.3D10.5*68";
        let Sentence::Compass(cc) = Sentence::parse(c).unwrap() else {
            panic!()
        };
        assert_eq!((cc.heading, cc.pitch, cc.roll), (90.0, -1.2, 0.5));
        assert_eq!(Sentence::Compass(cc).to_line(), c);
        // Goby3's own example (no checksum check needed: it is correct too).
        assert!(matches!(
            Sentence::parse("$C82.8P-3.89R-2.63T20.3D3.2*78"),
            Ok(Sentence::Compass(_))
        ));

        assert_eq!(
            Sentence::parse("$ACK,9,0,0*5C").unwrap(),
            Sentence::Ack(Ack {
                msg_type: 9,
                status: 0,
                err: 0
            })
        );
        let rmc = "$GPRMC,120000.00,A,4221.5040,N,07105.2560,W,0.0,90.0,101024,14.5,W*52";
        assert!(matches!(Sentence::parse(rmc), Ok(Sentence::Rmc { .. })));
    }

    #[test]
    fn bad_lines_are_typed_errors() {
        assert_eq!(
            Sentence::parse("$OSD,G,C,S,P,,,,*00"),
            Err(SentenceError::BadChecksum {
                got: 0,
                computed: 0x5F
            })
        );
        assert!(matches!(
            Sentence::parse("$OSI,7F,N,0,42.3"),
            Err(SentenceError::TooFewFields { .. })
        ));
        assert!(matches!(
            Sentence::parse("$OMS,nan,1,2,3,4"),
            Err(SentenceError::BadNumber { .. })
        ));
        assert_eq!(Sentence::parse("OSD"), Err(SentenceError::NoDollar));
        assert_eq!(Sentence::parse(""), Err(SentenceError::Empty));
        assert!(matches!(
            Sentence::parse("$CxP1R2"),
            Err(SentenceError::BadNumber { .. })
        ));
        assert_eq!(Sentence::parse("$P1R2"), Ok(Sentence::Other("P1R2".into())));
        let long = format!("${}", "A".repeat(MAX_SENTENCE));
        assert!(matches!(
            Sentence::parse(&long),
            Err(SentenceError::TooLong(_))
        ));
    }

    #[test]
    fn rmc_has_the_fields_goby_requires() {
        let Sentence::Rmc { fields, .. } = rmc(42.3584, -71.0876, 0.0, 90.0, 1_728_561_600.0)
        else {
            panic!()
        };
        assert_eq!(fields.len(), 11);
        assert_eq!(fields[0], "120000.00");
        assert_eq!(fields[2], "4221.5040");
        assert_eq!(fields[4], "07105.2560");
        assert_eq!(fields[8], "101024");
    }
}
