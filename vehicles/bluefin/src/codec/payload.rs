//! The sentences from the payload (`$BP…`): the setpoint (`$BPRMB`), sentence logging, the
//! heartbeat, the Bluefin commands, CTD, DCCL and modem lines — written from [`FromPayload`] (the
//! driver's side) and read back (the emulator's side), through the shared NMEA layer.

use std::fmt::Write as _;

use super::sentence::{CodecError, F, Sentence, format_time, num};

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
pub(super) fn sig10(x: f64) -> String {
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
