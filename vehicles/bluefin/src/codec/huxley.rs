//! The sentences from the Huxley (`$BF…`): navigation, velocities, acknowledgements, mission
//! and control status, buoyancy and trim, DVL and CTD — read into [`FromHuxley`] (the driver's
//! side) and written back (the emulator's side), through the shared NMEA layer.

use super::sentence::{
    CodecError, F, Sentence, format_lat_lon, format_time, num, opt_num, parse_lat_lon,
};

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
