//! The line codec of the basic simulator protocol: pure parsing and formatting, no I/O.
//!
//! Owns the exact keys and fields (`START`, `CMD` in; `NAV`, `CTRL`, `CMD,RESULT`, `ERROR` out),
//! validation of START and CMD values with a reason a person can act on, and the number
//! formatting of every line we send (see PROTOCOL.md). Lines here carry no `\r\n`.

use std::fmt::{self, Write as _};

/// Largest FREQ (Hz) we accept: beyond it a tick is shorter than the scheduler can keep.
pub const MAX_FREQ: f64 = 1000.0;
/// Smallest FREQ (Hz) and WARP we accept. The `sim_codec` fuzz target found FREQ:1e-308
/// accepted, formatted to 0 at our 12 decimals and refused when read back; and the tick schedule
/// turns `n / (FREQ·WARP)` into a `Duration`, which panics past 2^64 s (a rate below about 5e-20).
pub const MIN_FREQ: f64 = 0.001;
pub const MIN_WARP: f64 = 0.001;
/// Largest WARP we accept.
pub const MAX_WARP: f64 = 10_000.0;
/// Largest |SPEED| in a CMD, m/s.
pub const MAX_SPEED: f64 = 100.0;
/// Largest DEPTH in a CMD, m (deeper than any ocean).
pub const MAX_DEPTH: f64 = 12_000.0;

/// Decimals of LAT/LON in NAV (1.1 mm of latitude), trailing zeros trimmed.
pub const LAT_LON_DECIMALS: usize = 8;
/// Decimals of DEPTH/HEADING/SPEED in NAV, trailing zeros trimmed.
pub const VALUE_DECIMALS: usize = 6;

/// A validated START.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StartParams {
    /// Degrees, [-90, 90].
    pub lat: f64,
    /// Degrees, [-180, 180].
    pub lon: f64,
    /// Seconds of simulated time; 0 = never ends.
    pub duration: f64,
    /// Control ticks per simulated second.
    pub freq: f64,
    /// m/s².
    pub accel: f64,
    /// deg/s.
    pub hdg_rate: f64,
    /// m/s.
    pub z_rate: f64,
    /// Simulated seconds per wall second.
    pub warp: f64,
}

impl StartParams {
    /// The given position with every optional field at its protocol default.
    pub fn new(lat: f64, lon: f64) -> Self {
        Self {
            lat,
            lon,
            duration: 0.0,
            freq: 10.0,
            accel: 0.5,
            hdg_rate: 45.0,
            z_rate: 2.0,
            warp: 1.0,
        }
    }
}

/// A validated CMD.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Command {
    pub heading: f64,
    pub speed: f64,
    pub depth: f64,
}

/// What a backseat line means.
#[derive(Debug, Clone, PartialEq)]
pub enum Inbound {
    Start(StartParams),
    Cmd(Command),
}

/// Why a field was refused.
#[derive(Debug, Clone, PartialEq)]
pub enum Problem {
    Missing,
    NotANumber(String),
    NotFinite(String),
    OutOfRange { value: f64, rule: &'static str },
}

/// A refused field of START or CMD.
#[derive(Debug, Clone, PartialEq)]
pub struct FieldError {
    pub field: &'static str,
    pub problem: Problem,
}

impl fmt::Display for FieldError {
    // No commas: the text goes into a comma-separated line.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let field = self.field;
        match &self.problem {
            Problem::Missing => write!(f, "{field} is missing (required)"),
            Problem::NotANumber(v) => write!(f, "{field} value '{}' is not a number", clean(v)),
            Problem::NotFinite(v) => write!(f, "{field} value '{}' is not finite", clean(v)),
            Problem::OutOfRange { value, rule } => {
                write!(f, "{field} {value} is out of range: {rule}")
            }
        }
    }
}

/// A value quoted back in a reason: no commas or control characters, and short.
fn clean(v: &str) -> String {
    v.chars()
        .take(32)
        .map(|c| if c == ',' || c.is_control() { '?' } else { c })
        .collect()
}

/// Why a line was not acted on.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LineError {
    #[error("empty line")]
    Empty,
    #[error("unknown key '{0}'")]
    UnknownKey(String),
    #[error("invalid START: {0}")]
    Start(FieldError),
    #[error("invalid CMD: {0}")]
    Cmd(FieldError),
}

/// Fields of a line after its key: split at ',', each at its first ':', names and values trimmed.
/// The first occurrence of a field wins; fields without ':' have no value.
struct Fields<'a>(Vec<(&'a str, Option<&'a str>)>);

impl<'a> Fields<'a> {
    fn parse(rest: &'a str) -> Self {
        Fields(
            rest.split(',')
                .map(|f| match f.split_once(':') {
                    Some((k, v)) => (k.trim(), Some(v.trim())),
                    None => (f.trim(), None),
                })
                .collect(),
        )
    }

    fn raw(&self, name: &str) -> Option<Option<&'a str>> {
        self.0.iter().find(|(k, _)| *k == name).map(|(_, v)| *v)
    }

    fn number(&self, name: &'static str) -> Result<Option<f64>, FieldError> {
        let err = |problem| FieldError {
            field: name,
            problem,
        };
        match self.raw(name) {
            None | Some(None) | Some(Some("")) => Ok(None),
            Some(Some(v)) => match v.parse::<f64>() {
                Ok(x) if x.is_finite() => Ok(Some(x)),
                Ok(_) => Err(err(Problem::NotFinite(v.to_string()))),
                Err(_) => Err(err(Problem::NotANumber(v.to_string()))),
            },
        }
    }

    fn required(&self, name: &'static str) -> Result<f64, FieldError> {
        self.number(name)?.ok_or(FieldError {
            field: name,
            problem: Problem::Missing,
        })
    }
}

fn check(field: &'static str, value: f64, ok: bool, rule: &'static str) -> Result<f64, FieldError> {
    if ok {
        Ok(value)
    } else {
        Err(FieldError {
            field,
            problem: Problem::OutOfRange { value, rule },
        })
    }
}

fn parse_start(fields: &Fields) -> Result<StartParams, FieldError> {
    let d = StartParams::new(0.0, 0.0);
    let lat = fields.required("LAT")?;
    let lat = check(
        "LAT",
        lat,
        (-90.0..=90.0).contains(&lat),
        "must be in -90..90 degrees",
    )?;
    let lon = fields.required("LON")?;
    let lon = check(
        "LON",
        lon,
        (-180.0..=180.0).contains(&lon),
        "must be in -180..180 degrees",
    )?;
    let opt = |name: &'static str, default: f64| fields.number(name).map(|v| v.unwrap_or(default));
    let duration = opt("DURATION", d.duration)?;
    let duration = check(
        "DURATION",
        duration,
        duration >= 0.0,
        "must be >= 0 s (0 = never ends)",
    )?;
    let freq = opt("FREQ", d.freq)?;
    let freq = check(
        "FREQ",
        freq,
        (MIN_FREQ..=MAX_FREQ).contains(&freq),
        "must be >= 0.001 and <= 1000 Hz",
    )?;
    let accel = opt("ACCEL", d.accel)?;
    let accel = check("ACCEL", accel, accel >= 0.0, "must be >= 0 m/s^2")?;
    let hdg_rate = opt("HDG_RATE", d.hdg_rate)?;
    let hdg_rate = check("HDG_RATE", hdg_rate, hdg_rate >= 0.0, "must be >= 0 deg/s")?;
    let z_rate = opt("Z_RATE", d.z_rate)?;
    let z_rate = check("Z_RATE", z_rate, z_rate >= 0.0, "must be >= 0 m/s")?;
    let warp = opt("WARP", d.warp)?;
    let warp = check(
        "WARP",
        warp,
        (MIN_WARP..=MAX_WARP).contains(&warp),
        "must be >= 0.001 and <= 10000",
    )?;
    Ok(StartParams {
        lat,
        lon,
        duration,
        freq,
        accel,
        hdg_rate,
        z_rate,
        warp,
    })
}

fn parse_cmd(fields: &Fields) -> Result<Command, FieldError> {
    let heading = fields.required("HEADING")?;
    let speed = fields.required("SPEED")?;
    let speed = check(
        "SPEED",
        speed,
        (0.0..=MAX_SPEED).contains(&speed),
        "must be in 0..100 m/s",
    )?;
    let depth = fields.required("DEPTH")?;
    let depth = check(
        "DEPTH",
        depth,
        (0.0..=MAX_DEPTH).contains(&depth),
        "must be in 0..12000 m",
    )?;
    Ok(Command {
        heading,
        speed,
        depth,
    })
}

/// Parse one backseat line (without its terminator). Surrounding whitespace is ignored, the key
/// must match exactly, field order is free and unknown fields are ignored.
pub fn parse_inbound(line: &str) -> Result<Inbound, LineError> {
    let line = line.trim();
    if line.is_empty() {
        return Err(LineError::Empty);
    }
    let (key, rest) = line.split_once(',').unwrap_or((line, ""));
    let fields = Fields::parse(rest);
    match key.trim() {
        "START" => parse_start(&fields)
            .map(Inbound::Start)
            .map_err(LineError::Start),
        "CMD" => parse_cmd(&fields).map(Inbound::Cmd).map_err(LineError::Cmd),
        other => Err(LineError::UnknownKey(clean(other))),
    }
}

/// Which reply a line that could not be decoded as UTF-8 is owed, judged from its first bytes.
pub fn reply_due_for_bytes(line: &[u8]) -> Option<&'static str> {
    let t = line.trim_ascii_start();
    if t.starts_with(b"CMD,") || t == b"CMD" {
        Some("CMD")
    } else if t.starts_with(b"START,") || t == b"START" {
        Some("START")
    } else {
        None
    }
}

/// The state the frontseat reports in CTRL lines.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum CtrlState {
    /// The payload (backseat) may command.
    Payload,
    /// The frontseat is in control (Goby3's driver: FRONTSEAT_IN_CONTROL).
    Auv,
    /// Not running; no NAV until the next START.
    Idle,
}

impl CtrlState {
    pub fn as_str(self) -> &'static str {
        match self {
            CtrlState::Payload => "PAYLOAD",
            CtrlState::Auv => "AUV",
            CtrlState::Idle => "IDLE",
        }
    }
}

/// One NAV report.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Nav {
    pub lat: f64,
    pub lon: f64,
    pub depth: f64,
    pub heading: f64,
    pub speed: f64,
}

/// A simulator line as a client reads it.
#[derive(Debug, Clone, PartialEq)]
pub enum Outbound {
    Nav(Nav),
    Ctrl(CtrlState),
    CmdResult { ok: bool },
    Error { reason: String },
}

/// Append `v` with at most `decimals` decimals, trailing zeros and a lone '-' of a rounded zero
/// removed.
pub fn push_number(out: &mut String, v: f64, decimals: usize) {
    let start = out.len();
    let _ = write!(out, "{v:.decimals$}");
    if out[start..].contains('.') {
        let trimmed = out[start..]
            .trim_end_matches('0')
            .trim_end_matches('.')
            .len();
        out.truncate(start + trimmed);
    }
    if &out[start..] == "-0" {
        out.truncate(start);
        out.push('0');
    }
}

/// Heading as it goes on the wire: rounded first, so that 359.9999999 becomes 0, not 360.
fn wire_heading(h: f64) -> f64 {
    let scale = 10f64.powi(VALUE_DECIMALS as i32);
    let r = (h * scale).round() / scale;
    if (0.0..360.0).contains(&r) { r } else { 0.0 }
}

/// Append the NAV line for `nav` to `out`.
pub fn push_nav(out: &mut String, nav: &Nav) {
    out.push_str("NAV,LAT:");
    push_number(out, nav.lat, LAT_LON_DECIMALS);
    out.push_str(",LON:");
    push_number(out, nav.lon, LAT_LON_DECIMALS);
    out.push_str(",DEPTH:");
    push_number(out, nav.depth, VALUE_DECIMALS);
    out.push_str(",HEADING:");
    push_number(out, wire_heading(nav.heading), VALUE_DECIMALS);
    out.push_str(",SPEED:");
    push_number(out, nav.speed, VALUE_DECIMALS);
}

pub fn format_nav(nav: &Nav) -> String {
    let mut s = String::with_capacity(80);
    push_nav(&mut s, nav);
    s
}

pub fn format_ctrl(state: CtrlState) -> String {
    format!("CTRL,STATE:{}", state.as_str())
}

pub fn format_cmd_result(ok: bool) -> &'static str {
    if ok {
        "CMD,RESULT:OK"
    } else {
        "CMD,RESULT:ERROR"
    }
}

/// `ERROR,REASON:<reason>`; commas in the reason become ';' so the line stays one field.
pub fn format_error(reason: &str) -> String {
    let reason: String = reason
        .chars()
        .map(|c| if c == ',' || c.is_control() { ';' } else { c })
        .collect();
    format!("ERROR,REASON:{reason}")
}

/// A START line with every field written out (what a client sends).
pub fn format_start(p: &StartParams) -> String {
    let mut s = String::from("START,LAT:");
    push_number(&mut s, p.lat, 12);
    s.push_str(",LON:");
    push_number(&mut s, p.lon, 12);
    for (name, v) in [
        ("DURATION", p.duration),
        ("FREQ", p.freq),
        ("ACCEL", p.accel),
        ("HDG_RATE", p.hdg_rate),
        ("Z_RATE", p.z_rate),
        ("WARP", p.warp),
    ] {
        s.push(',');
        s.push_str(name);
        s.push(':');
        push_number(&mut s, v, 12);
    }
    s
}

/// A CMD line (what a client sends).
pub fn format_cmd(c: &Command) -> String {
    let mut s = String::from("CMD,HEADING:");
    push_number(&mut s, c.heading, 12);
    s.push_str(",SPEED:");
    push_number(&mut s, c.speed, 12);
    s.push_str(",DEPTH:");
    push_number(&mut s, c.depth, 12);
    s
}

/// Parse a simulator line (client side; used by tests and the capacity benchmark).
pub fn parse_outbound(line: &str) -> Result<Outbound, LineError> {
    let line = line.trim();
    if line.is_empty() {
        return Err(LineError::Empty);
    }
    let (key, rest) = line.split_once(',').unwrap_or((line, ""));
    let fields = Fields::parse(rest);
    match key {
        "NAV" => {
            let n = |name| fields.required(name).map_err(LineError::Cmd);
            Ok(Outbound::Nav(Nav {
                lat: n("LAT")?,
                lon: n("LON")?,
                depth: n("DEPTH")?,
                heading: n("HEADING")?,
                speed: n("SPEED")?,
            }))
        }
        "CTRL" => match fields.raw("STATE").flatten() {
            Some("PAYLOAD") => Ok(Outbound::Ctrl(CtrlState::Payload)),
            Some("AUV") => Ok(Outbound::Ctrl(CtrlState::Auv)),
            Some("IDLE") => Ok(Outbound::Ctrl(CtrlState::Idle)),
            _ => Err(LineError::UnknownKey(clean(line))),
        },
        "CMD" => match fields.raw("RESULT").flatten() {
            Some("OK") => Ok(Outbound::CmdResult { ok: true }),
            Some("ERROR") => Ok(Outbound::CmdResult { ok: false }),
            _ => Err(LineError::UnknownKey(clean(line))),
        },
        "ERROR" => Ok(Outbound::Error {
            reason: rest.strip_prefix("REASON:").unwrap_or(rest).to_string(),
        }),
        other => Err(LineError::UnknownKey(clean(other))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn start(line: &str) -> Result<StartParams, FieldError> {
        match parse_inbound(line) {
            Ok(Inbound::Start(p)) => Ok(p),
            Err(LineError::Start(e)) => Err(e),
            other => panic!("{line}: {other:?}"),
        }
    }

    #[test]
    fn start_full_and_defaults() {
        let p = start(
            "START,LAT:42.1234,LON:-72,DURATION:600,FREQ:10,ACCEL:0.5,HDG_RATE:45,Z_RATE:1,WARP:1",
        )
        .unwrap();
        assert_eq!(
            p,
            StartParams {
                lat: 42.1234,
                lon: -72.0,
                duration: 600.0,
                freq: 10.0,
                accel: 0.5,
                hdg_rate: 45.0,
                z_rate: 1.0,
                warp: 1.0
            }
        );
        assert_eq!(
            start("START,LON:3,LAT:4").unwrap(),
            StartParams::new(4.0, 3.0)
        );
        assert_eq!(
            start("  START,LAT:1,LON:2,FOO:bar,WARP: 2 ,\t")
                .unwrap()
                .warp,
            2.0
        );
        assert_eq!(
            start("START,LAT:1,LAT:5,LON:2").unwrap().lat,
            1.0,
            "first wins"
        );
    }

    #[test]
    fn start_refusals_name_field_and_reason() {
        // (line, field, reason fragment)
        let rows = [
            ("START,LON:-71", "LAT", "missing"),
            ("START,LAT,LON:-71", "LAT", "missing"),
            ("START,LAT:42", "LON", "missing"),
            ("START,LAT:abc,LON:-71", "LAT", "not a number"),
            ("START,LAT:95,LON:-71", "LAT", "out of range"),
            ("START,LAT:-90.5,LON:-71", "LAT", "out of range"),
            ("START,LAT:nan,LON:-71", "LAT", "not finite"),
            ("START,LAT:42,LON:inf", "LON", "not finite"),
            ("START,LAT:42,LON:181", "LON", "out of range"),
            ("START,LAT:42,LON:1,FREQ:0", "FREQ", "out of range"),
            ("START,LAT:42,LON:1,FREQ:-10", "FREQ", "out of range"),
            ("START,LAT:42,LON:1,FREQ:1e9", "FREQ", "out of range"),
            // Found by the sim_codec fuzz target: 1e-308 formatted to 0 and did not read back
            // (and a rate this small would overflow the tick schedule's Duration).
            ("START,LAT:42,LON:1,FREQ:1e-308", "FREQ", "out of range"),
            ("START,LAT:42,LON:1,FREQ:0.0009", "FREQ", "out of range"),
            ("START,LAT:42,LON:1,WARP:1e-20", "WARP", "out of range"),
            ("START,LAT:42,LON:1,WARP:0", "WARP", "out of range"),
            ("START,LAT:42,LON:1,WARP:20000", "WARP", "out of range"),
            ("START,LAT:42,LON:1,DURATION:-1", "DURATION", "out of range"),
            ("START,LAT:42,LON:1,ACCEL:-0.1", "ACCEL", "out of range"),
            (
                "START,LAT:42,LON:1,HDG_RATE:-45",
                "HDG_RATE",
                "out of range",
            ),
            ("START,LAT:42,LON:1,Z_RATE:-1", "Z_RATE", "out of range"),
            ("START,LAT:42,LON:1,Z_RATE:1x", "Z_RATE", "not a number"),
            ("START", "LAT", "missing"),
        ];
        for (line, field, frag) in rows {
            let e = start(line).unwrap_err();
            assert_eq!(e.field, field, "{line}");
            let text = e.to_string();
            assert!(text.contains(frag), "{line}: {text}");
            assert!(!text.contains(','), "{line}: {text}");
        }
        // Edges are inside the ranges.
        for line in [
            "START,LAT:90,LON:180",
            "START,LAT:-90,LON:-180,FREQ:1000,WARP:10000,DURATION:0,ACCEL:0,HDG_RATE:0,Z_RATE:0",
        ] {
            start(line).unwrap();
        }
    }

    #[test]
    fn cmd_parsing_table() {
        // (line, Ok(heading) or Err(field))
        let rows: [(&str, Result<f64, &str>); 14] = [
            ("CMD,HEADING:260,SPEED:1.5,DEPTH:100", Ok(260.0)),
            ("CMD,DEPTH:0,SPEED:1,HEADING:90", Ok(90.0)),
            ("CMD,HEADING:90,SPEED:1.5,DEPTH:0,EXTRA:1", Ok(90.0)),
            ("CMD,HEADING:90,HEADING:180,SPEED:1.5,DEPTH:0", Ok(90.0)),
            ("  CMD,HEADING:90,SPEED:1.5,DEPTH:0  ", Ok(90.0)),
            ("CMD,HEADING:1e2,SPEED:1.5,DEPTH:0", Ok(100.0)),
            ("CMD,HEADING:90 ,SPEED:1.5,DEPTH:0", Ok(90.0)),
            ("CMD,HEADING:90,SPEED:1.5,DEPTH:0,", Ok(90.0)),
            ("CMD,HEADING", Err("HEADING")),
            ("CMD,SPEED:1,DEPTH:0", Err("HEADING")),
            ("CMD,HEADING:90,DEPTH:0", Err("SPEED")),
            ("CMD,HEADING:90:5,SPEED:1.5,DEPTH:0", Err("HEADING")),
            ("CMD,heading:90,SPEED:1.5,DEPTH:0", Err("HEADING")),
            ("CMD,HEADING:abc,SPEED:1.5,DEPTH:0", Err("HEADING")),
        ];
        for (line, want) in rows {
            match (parse_inbound(line), want) {
                (Ok(Inbound::Cmd(c)), Ok(h)) => assert_eq!(c.heading, h, "{line}"),
                (Err(LineError::Cmd(e)), Err(f)) => assert_eq!(e.field, f, "{line}"),
                (got, want) => panic!("{line}: {got:?} vs {want:?}"),
            }
        }
        for bad in [
            "CMD,HEADING:90,SPEED:-1,DEPTH:0",
            "CMD,HEADING:90,SPEED:1,DEPTH:-5",
            "CMD,HEADING:inf,SPEED:1,DEPTH:0",
            "CMD,HEADING:90,SPEED:1e300,DEPTH:0",
        ] {
            assert!(
                matches!(parse_inbound(bad), Err(LineError::Cmd(_))),
                "{bad}"
            );
        }
    }

    #[test]
    fn other_lines() {
        assert_eq!(parse_inbound(""), Err(LineError::Empty));
        assert_eq!(parse_inbound("  \t"), Err(LineError::Empty));
        for l in [
            "FOO",
            "cmd,HEADING:90,SPEED:1.5,DEPTH:0",
            "CTRL,STATE:PAYLOAD",
            "NAV,LAT:1",
        ] {
            assert!(
                matches!(parse_inbound(l), Err(LineError::UnknownKey(_))),
                "{l}"
            );
        }
        assert_eq!(reply_due_for_bytes(b"CMD,HEADING:\xff"), Some("CMD"));
        assert_eq!(reply_due_for_bytes(b" START,LAT:\xff"), Some("START"));
        assert_eq!(reply_due_for_bytes(b"\xff\xfe"), None);
    }

    #[test]
    fn number_formatting() {
        let rows = [
            (42.358456, 8, "42.358456"),
            (42.3584560448, 8, "42.35845604"),
            (-71.0875889953, 8, "-71.087589"),
            (-0.0, 6, "0"),
            (-0.0000000001, 6, "0"),
            (4.5, 6, "4.5"),
            (0.1 + 0.2, 6, "0.3"),
            (100.0, 6, "100"),
            (0.025, 6, "0.025"),
            (1e-7, 6, "0"),
        ];
        for (v, d, want) in rows {
            let mut s = String::new();
            push_number(&mut s, v, d);
            assert_eq!(s, want, "{v}");
        }
        let nav = Nav {
            lat: 1.0,
            lon: 2.0,
            depth: -0.0,
            heading: 359.99999999,
            speed: 0.05,
        };
        assert_eq!(
            format_nav(&nav),
            "NAV,LAT:1,LON:2,DEPTH:0,HEADING:0,SPEED:0.05"
        );
    }

    #[test]
    fn round_trips() {
        let starts = [
            StartParams::new(42.358456, -71.087589),
            StartParams {
                lat: -33.123456789,
                lon: 179.5,
                duration: 600.0,
                freq: 2.5,
                accel: 0.25,
                hdg_rate: 90.0,
                z_rate: 0.5,
                warp: 100.0,
            },
        ];
        for p in starts {
            assert_eq!(parse_inbound(&format_start(&p)), Ok(Inbound::Start(p)));
        }
        let c = Command {
            heading: 260.5,
            speed: 1.5,
            depth: 100.0,
        };
        assert_eq!(parse_inbound(&format_cmd(&c)), Ok(Inbound::Cmd(c)));
        let nav = Nav {
            lat: 42.35846129,
            lon: -71.08752681,
            depth: 2.925,
            heading: 274.5,
            speed: 1.95,
        };
        assert_eq!(parse_outbound(&format_nav(&nav)), Ok(Outbound::Nav(nav)));
        for s in [CtrlState::Payload, CtrlState::Auv, CtrlState::Idle] {
            assert_eq!(parse_outbound(&format_ctrl(s)), Ok(Outbound::Ctrl(s)));
        }
        for ok in [true, false] {
            assert_eq!(
                parse_outbound(format_cmd_result(ok)),
                Ok(Outbound::CmdResult { ok })
            );
        }
        let e = format_error("LAT 95 is out of range, sorry");
        assert_eq!(
            parse_outbound(&e),
            Ok(Outbound::Error {
                reason: "LAT 95 is out of range; sorry".into()
            })
        );
    }
}
