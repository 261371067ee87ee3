//! The messages the gateway writes and reads, as XCDR1 bytes: Goby3's protobuf messages (the bus's
//! types) ↔ `frontseat_msgs` (presence rule: `bool has_<f>` before each proto2 optional, see
//! `frontseat_msgs/msg/*.msg`), a NodeStatus → `nav_msgs/Odometry` and `sensor_msgs/NavSatFix`
//! (REP-103/105), the interface's detail → `diagnostic_msgs/DiagnosticArray`, and the graph's
//! `rmw_dds_common/ParticipantEntitiesInfo`. Decoding is only for what a peer may send us
//! (DesiredCourse, HelmStateReport, CommandRequest): fixed-size messages, every float finite,
//! every enum one of its values, or a typed refusal.

use frontseat_actors::generated::proto::frontseat::protobuf::InterfaceDetail;
use frontseat_actors::generated::proto::goby::middleware::frontseat::protobuf as fs;

use crate::cdr::{CdrError, Reader, Writer};

/// Largest payload we accept from a peer: every input type is fixed-size (the largest,
/// CommandRequest, is under 200 bytes); anything this long is not one of them.
pub const MAX_INPUT_BYTES: usize = 1024;

/// Frames of the Odometry and NavSatFix we publish.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Frames {
    /// Odometry `header.frame_id`: ENU about the interface's datum.
    pub odom: String,
    /// Odometry `child_frame_id` and NavSatFix `header.frame_id`.
    pub base: String,
}

/// Why an input sample was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum InputError {
    #[error(transparent)]
    Cdr(#[from] CdrError),
    #[error("{field} = {value} is not finite")]
    NotFinite { field: &'static str, value: f64 },
    #[error("{field} = {value} is not one of its enum's values")]
    BadEnum { field: &'static str, value: i32 },
}

impl InputError {
    /// The counter this refusal goes to.
    pub fn kind(&self) -> &'static str {
        match self {
            InputError::Cdr(CdrError::Oversized { .. })
            | InputError::Cdr(CdrError::StringTooLong { .. })
            | InputError::Cdr(CdrError::SequenceTooLong { .. }) => "oversized",
            InputError::Cdr(_) => "malformed",
            InputError::NotFinite { .. } => "not_finite",
            InputError::BadEnum { .. } => "bad_enum",
        }
    }
}

fn stamp(w: &mut Writer, t: f64) {
    let (sec, nanosec) = split_time(t);
    w.i32(sec);
    w.u32(nanosec);
}

/// Seconds since the epoch → (sec, nanosec) of `builtin_interfaces/Time`; out of range → 0.
pub fn split_time(t: f64) -> (i32, u32) {
    if !t.is_finite() || t < 0.0 || t >= i32::MAX as f64 {
        return (0, 0);
    }
    let sec = t.floor();
    let nanosec = ((t - sec) * 1e9).round().min(999_999_999.0);
    (sec as i32, nanosec as u32)
}

fn header(w: &mut Writer, t: f64, frame: &str) {
    stamp(w, t);
    w.string(frame);
}

/// ENU/FLU quaternion (x, y, z, w) of a marine attitude: heading 0 = north, clockwise; pitch
/// positive bow up... in NED/FRD; all degrees (facts file §4: NED/FRD (r, p, h) = ENU/FLU
/// (r, −p, 90° − h)).
pub fn enu_quaternion(roll_deg: f64, pitch_deg: f64, heading_deg: f64) -> [f64; 4] {
    let r = roll_deg.to_radians();
    let p = -pitch_deg.to_radians();
    let y = (90.0 - heading_deg).to_radians();
    let y = y.sin().atan2(y.cos());
    let (sr, cr) = (r / 2.0).sin_cos();
    let (sp, cp) = (p / 2.0).sin_cos();
    let (sy, cy) = (y / 2.0).sin_cos();
    [
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
        cr * cp * cy + sr * sp * sy,
    ]
}

fn finite_or(v: Option<f64>, d: f64) -> f64 {
    v.filter(|x| x.is_finite()).unwrap_or(d)
}

/// `nav_msgs/msg/Odometry` of a NodeStatus: position ENU about the datum (the interface's local
/// fix: x east, y north, z up = −depth), orientation from heading/pitch/roll, twist in the body
/// frame (FLU: forward speed over ground, rates with REP-103's signs). Covariances are unknown
/// (zero).
pub fn odometry(ns: &fs::NodeStatus, frames: &Frames) -> Vec<u8> {
    let mut w = Writer::new();
    header(&mut w, ns.time, &frames.odom);
    w.string(&frames.base);
    let (x, y) = ns
        .local_fix
        .as_ref()
        .map(|l| (l.x, l.y))
        .unwrap_or((0.0, 0.0));
    let z = match (&ns.local_fix, ns.global_fix.depth) {
        (Some(l), _) if l.z.is_some() => finite_or(l.z, 0.0),
        (_, Some(d)) => 0.0 - finite_or(Some(d), 0.0),
        _ => 0.0,
    };
    w.f64_array(&[x, y, z]);
    let p = &ns.pose;
    let q = enu_quaternion(
        finite_or(p.roll, 0.0),
        finite_or(p.pitch, 0.0),
        finite_or(p.heading, 90.0),
    );
    w.f64_array(&q);
    w.f64_array(&[0.0; 36]);
    let deg = |v: Option<f64>| finite_or(v, 0.0).to_radians();
    w.f64_array(&[finite_or(Some(ns.speed.over_ground), 0.0), 0.0, 0.0]);
    // `0.0 - x`, not `-x`: a zero rate stays +0.0 on the wire, as any other publisher writes it.
    w.f64_array(&[
        deg(p.roll_rate),
        0.0 - deg(p.pitch_rate),
        0.0 - deg(p.heading_rate),
    ]);
    w.f64_array(&[0.0; 36]);
    w.finish()
}

/// NavSatStatus values.
const STATUS_NO_FIX: i8 = -1;
const STATUS_FIX: i8 = 0;
const SERVICE_GPS: u16 = 1;

/// `sensor_msgs/msg/NavSatFix` of a NodeStatus: status FIX while the latitude and longitude are
/// finite (a node_status only reaches the bus past the navigation gate), NO_FIX otherwise;
/// service GPS when the position's source says so; altitude the fix's altitude, else −depth,
/// else NaN; covariance unknown.
pub fn nav_sat_fix(ns: &fs::NodeStatus, frames: &Frames) -> Vec<u8> {
    let mut w = Writer::new();
    header(&mut w, ns.time, &frames.base);
    let g = &ns.global_fix;
    let fix = g.lat.is_finite() && g.lon.is_finite();
    w.i8(if fix { STATUS_FIX } else { STATUS_NO_FIX });
    let gps = ns
        .source
        .as_ref()
        .and_then(|s| s.position)
        .is_some_and(|p| p == fs::source::Sensor::Gps as i32);
    w.u16(if gps { SERVICE_GPS } else { 0 });
    w.f64(g.lat);
    w.f64(g.lon);
    let altitude = match (g.altitude, g.depth) {
        (Some(a), _) if a.is_finite() => a,
        (_, Some(d)) if d.is_finite() => 0.0 - d,
        _ => f64::NAN,
    };
    w.f64(altitude);
    w.f64_array(&[0.0; 9]);
    w.u8(0);
    w.finish()
}

fn opt_f64(w: &mut Writer, v: Option<f64>) {
    w.bool(v.is_some());
    w.f64(v.unwrap_or(0.0));
}
fn opt_i32(w: &mut Writer, v: Option<i32>) {
    w.bool(v.is_some());
    w.i32(v.unwrap_or(0));
}
fn opt_bool(w: &mut Writer, v: Option<bool>) {
    w.bool(v.is_some());
    w.bool(v.unwrap_or(false));
}
fn opt_string(w: &mut Writer, v: Option<&str>) {
    w.bool(v.is_some());
    w.string(v.unwrap_or(""));
}

/// `frontseat_msgs/msg/NodeStatus`, field for field.
pub fn node_status(ns: &fs::NodeStatus) -> Vec<u8> {
    let mut w = Writer::new();
    w.f64(ns.time);
    opt_string(&mut w, ns.name.as_deref());
    opt_i32(&mut w, ns.r#type);
    let g = &ns.global_fix;
    w.f64(g.lat);
    w.f64(g.lon);
    opt_f64(&mut w, g.depth);
    opt_f64(&mut w, g.altitude);
    w.bool(ns.local_fix.is_some());
    let l = ns.local_fix.unwrap_or_default();
    w.f64(l.x);
    w.f64(l.y);
    opt_f64(&mut w, l.z);
    let p = &ns.pose;
    for v in [
        p.roll,
        p.pitch,
        p.heading,
        p.course_over_ground,
        p.roll_rate,
        p.pitch_rate,
        p.heading_rate,
    ] {
        opt_f64(&mut w, v);
    }
    w.f64(ns.speed.over_ground);
    opt_f64(&mut w, ns.speed.over_water);
    w.bool(ns.source.is_some());
    let s = ns.source.unwrap_or_default();
    for v in [s.position, s.depth, s.speed, s.heading] {
        opt_i32(&mut w, v);
    }
    w.finish()
}

/// `frontseat_msgs/msg/InterfaceStatus`, field for field.
pub fn interface_status(s: &fs::InterfaceStatus) -> Vec<u8> {
    let mut w = Writer::new();
    for v in [
        s.state,
        s.frontseat_state,
        s.helm_state,
        s.helm_error,
        s.frontseat_error,
    ] {
        opt_i32(&mut w, v);
    }
    opt_bool(&mut w, s.frontseat_providing_data);
    w.finish()
}

/// `frontseat_msgs/msg/CommandResponse`, field for field.
pub fn command_response(r: &fs::CommandResponse) -> Vec<u8> {
    let mut w = Writer::new();
    opt_bool(&mut w, r.request_successful);
    opt_i32(&mut w, r.request_id);
    opt_i32(&mut w, r.error_code);
    opt_string(&mut w, r.error_string.as_deref());
    w.finish()
}

/// DiagnosticStatus levels.
pub const DIAG_OK: u8 = 0;
pub const DIAG_WARN: u8 = 1;
pub const DIAG_ERROR: u8 = 2;

/// One `diagnostic_msgs/DiagnosticStatus`.
#[derive(Debug, Clone, PartialEq)]
pub struct DiagStatus {
    pub level: u8,
    pub name: String,
    pub message: String,
    pub hardware_id: String,
    pub values: Vec<(String, String)>,
}

/// `diagnostic_msgs/msg/DiagnosticArray`.
pub fn diagnostic_array(t: f64, statuses: &[DiagStatus]) -> Vec<u8> {
    let mut w = Writer::new();
    header(&mut w, t, "");
    w.seq_len(statuses.len());
    for s in statuses {
        w.u8(s.level);
        w.string(&s.name);
        w.string(&s.message);
        w.string(&s.hardware_id);
        w.seq_len(s.values.len());
        for (k, v) in &s.values {
            w.string(k);
            w.string(v);
        }
    }
    w.finish()
}

fn enum_name(
    v: Option<i32>,
    f: impl Fn(i32) -> Option<&'static str>,
) -> (String, Option<&'static str>) {
    match v {
        None => ("absent".into(), None),
        Some(n) => match f(n) {
            Some(s) => (s.to_string(), Some(s)),
            None => (n.to_string(), None),
        },
    }
}

/// The interface's state, errors and driver health as `rqt_runtime_monitor` shows them: one
/// status for the interface (OK in STANDBY/LISTEN/COMMAND, WARN in a helm error, ERROR in a
/// frontseat error) and one for the driver (ERROR when not connected, WARN when not providing
/// data), plus the gateway's own counters.
pub fn diagnostics(
    namespace: &str,
    detail: &InterfaceDetail,
    gateway: &[(&'static str, u64)],
) -> Vec<DiagStatus> {
    let st = detail.status.unwrap_or_default();
    let hw = namespace.trim_start_matches('/').to_string();
    let name_of = |n: i32| {
        fs::InterfaceState::try_from(n)
            .ok()
            .map(|s| s.as_str_name())
    };
    let (state, state_name) = enum_name(st.state, name_of);
    let level = match state_name {
        Some("INTERFACE_HELM_ERROR") => DIAG_WARN,
        Some("INTERFACE_FS_ERROR") => DIAG_ERROR,
        Some(_) => DIAG_OK,
        None => DIAG_WARN,
    };
    let fstate = enum_name(st.frontseat_state, |n| {
        fs::FrontSeatState::try_from(n)
            .ok()
            .map(|s| s.as_str_name())
    });
    let helm = enum_name(st.helm_state, |n| {
        fs::HelmState::try_from(n).ok().map(|s| s.as_str_name())
    });
    let helm_err = enum_name(st.helm_error, |n| {
        fs::HelmError::try_from(n).ok().map(|s| s.as_str_name())
    });
    let fs_err = enum_name(st.frontseat_error, |n| {
        fs::FrontSeatError::try_from(n)
            .ok()
            .map(|s| s.as_str_name())
    });
    let providing = detail
        .frontseat_providing_data
        .or(st.frontseat_providing_data);
    let opt = |v: Option<u64>| v.map_or_else(|| "absent".to_string(), |n| n.to_string());
    let interface = DiagStatus {
        level,
        name: format!("{namespace}/frontseat: interface"),
        message: state.clone(),
        hardware_id: hw.clone(),
        values: vec![
            ("state".into(), state),
            ("helm_state".into(), helm.0),
            ("helm_error".into(), helm_err.0),
            ("frontseat_error".into(), fs_err.0.clone()),
            ("commands_gated".into(), opt(detail.commands_gated)),
            ("setpoints_refused".into(), opt(detail.setpoints_refused)),
            ("nav_refused".into(), opt(detail.nav_refused)),
            ("bus_dropped".into(), opt(detail.bus_dropped)),
            (
                "uptime_s".into(),
                detail
                    .uptime_s
                    .map_or_else(|| "absent".into(), |u| format!("{u:.1}")),
            ),
        ],
    };
    let (dlevel, dmsg) = match (fstate.1, providing) {
        (Some("FRONTSEAT_NOT_CONNECTED") | None, _) => (DIAG_ERROR, "not connected"),
        (_, Some(false)) => (DIAG_WARN, "connected, not providing data"),
        _ => (DIAG_OK, "connected, providing data"),
    };
    let driver = DiagStatus {
        level: dlevel,
        name: format!("{namespace}/frontseat: driver"),
        message: dmsg.into(),
        hardware_id: hw.clone(),
        values: vec![
            ("driver".into(), detail.driver.clone().unwrap_or_default()),
            ("frontseat_state".into(), fstate.0),
            (
                "providing_data".into(),
                providing.map_or_else(|| "absent".into(), |p| p.to_string()),
            ),
            (
                "restarts".into(),
                opt(detail.driver_restarts.map(u64::from)),
            ),
            ("frontseat_error".into(), fs_err.0),
        ],
    };
    let refused: u64 = gateway
        .iter()
        .filter(|(k, _)| k.starts_with("refused"))
        .map(|(_, v)| v)
        .sum();
    let gw = DiagStatus {
        level: if refused > 0 { DIAG_WARN } else { DIAG_OK },
        name: format!("{namespace}/frontseat: ros2 gateway"),
        message: if refused > 0 {
            format!("{refused} input samples refused")
        } else {
            "ok".into()
        },
        hardware_id: hw,
        values: gateway
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect(),
    };
    vec![interface, driver, gw]
}

/// `rmw_dds_common/msg/ParticipantEntitiesInfo` (Iron and later: 16-byte Gid) for one node.
pub fn participant_entities_info(
    participant: [u8; 16],
    node_namespace: &str,
    node_name: &str,
    readers: &[[u8; 16]],
    writers: &[[u8; 16]],
) -> Vec<u8> {
    let mut w = Writer::new();
    w.bytes_raw(&participant);
    w.seq_len(1);
    w.string(node_namespace);
    w.string(node_name);
    w.seq_len(readers.len());
    for g in readers {
        w.bytes_raw(g);
    }
    w.seq_len(writers.len());
    for g in writers {
        w.bytes_raw(g);
    }
    w.finish()
}

fn finite(field: &'static str, v: f64) -> Result<f64, InputError> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(InputError::NotFinite { field, value: v })
    }
}

fn read_opt_f64(r: &mut Reader<'_>, field: &'static str) -> Result<Option<f64>, InputError> {
    let has = r.bool(field)?;
    let v = r.f64(field)?;
    if has {
        finite(field, v).map(Some)
    } else {
        Ok(None)
    }
}

fn read_opt_i32(r: &mut Reader<'_>, field: &'static str) -> Result<Option<i32>, InputError> {
    let has = r.bool(field)?;
    let v = r.i32(field)?;
    Ok(has.then_some(v))
}

fn read_opt_bool(r: &mut Reader<'_>, field: &'static str) -> Result<Option<bool>, InputError> {
    let has = r.bool(field)?;
    let v = r.bool(field)?;
    Ok(has.then_some(v))
}

fn read_course(r: &mut Reader<'_>) -> Result<fs::DesiredCourse, InputError> {
    let time = finite("time", r.f64("time")?)?;
    Ok(fs::DesiredCourse {
        time,
        heading: read_opt_f64(r, "heading")?,
        speed: read_opt_f64(r, "speed")?,
        depth: read_opt_f64(r, "depth")?,
        pitch: read_opt_f64(r, "pitch")?,
        roll: read_opt_f64(r, "roll")?,
        z_rate: read_opt_f64(r, "z_rate")?,
        altitude: read_opt_f64(r, "altitude")?,
    })
}

/// A peer's `frontseat_msgs/msg/DesiredCourse`. Its range (heading, speed, depth against
/// `[limits]`) is the command gate's to judge, as for any helm.
pub fn decode_desired_course(payload: &[u8]) -> Result<fs::DesiredCourse, InputError> {
    let mut r = Reader::new(payload, MAX_INPUT_BYTES)?;
    read_course(&mut r)
}

/// A peer's `frontseat_msgs/msg/HelmStateReport`: `state` must be a HelmState value.
pub fn decode_helm_state(payload: &[u8]) -> Result<fs::HelmStateReport, InputError> {
    let mut r = Reader::new(payload, MAX_INPUT_BYTES)?;
    let state = r.i32("state")?;
    if fs::HelmState::try_from(state).is_err() {
        return Err(InputError::BadEnum {
            field: "state",
            value: state,
        });
    }
    Ok(fs::HelmStateReport { state })
}

/// A peer's `frontseat_msgs/msg/CommandRequest`.
pub fn decode_command_request(payload: &[u8]) -> Result<fs::CommandRequest, InputError> {
    let mut r = Reader::new(payload, MAX_INPUT_BYTES)?;
    let has_course = r.bool("has_desired_course")?;
    let course = read_course(&mut r);
    // An absent course's bytes are ignored, whatever they hold (the presence rule).
    let desired_course = match (has_course, course) {
        (true, c) => Some(c?),
        (false, Err(InputError::Cdr(e))) => return Err(e.into()),
        (false, _) => None,
    };
    Ok(fs::CommandRequest {
        desired_course,
        response_requested: read_opt_bool(&mut r, "response_requested")?,
        request_id: read_opt_i32(&mut r, "request_id")?,
        cancel_request_id: read_opt_i32(&mut r, "cancel_request_id")?,
    })
}

/// Encoders of the input types, for tests and Rust helms.
pub mod encode {
    use super::*;

    fn course(w: &mut Writer, c: &fs::DesiredCourse) {
        w.f64(c.time);
        for v in [
            c.heading, c.speed, c.depth, c.pitch, c.roll, c.z_rate, c.altitude,
        ] {
            opt_f64(w, v);
        }
    }
    pub fn desired_course(c: &fs::DesiredCourse) -> Vec<u8> {
        let mut w = Writer::new();
        course(&mut w, c);
        w.finish()
    }
    pub fn helm_state(h: &fs::HelmStateReport) -> Vec<u8> {
        let mut w = Writer::new();
        w.i32(h.state);
        w.finish()
    }
    pub fn command_request(c: &fs::CommandRequest) -> Vec<u8> {
        let mut w = Writer::new();
        w.bool(c.desired_course.is_some());
        course(&mut w, &c.desired_course.unwrap_or_default());
        opt_bool(&mut w, c.response_requested);
        opt_i32(&mut w, c.request_id);
        opt_i32(&mut w, c.cancel_request_id);
        w.finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use frontseat_actors::generated::proto::goby::middleware::protobuf::LatLonPoint;

    fn fixture(text: &str) -> Vec<u8> {
        let hex: String = text
            .lines()
            .filter(|l| !l.starts_with('#'))
            .collect::<String>();
        (0..hex.len())
            .step_by(2)
            .map(|i| u8::from_str_radix(&hex[i..i + 2], 16).unwrap())
            .collect()
    }

    fn frames() -> Frames {
        Frames {
            odom: "odom".into(),
            base: "base_link".into(),
        }
    }

    /// The facts file's Odometry sample (heading 030), except the covariances we leave unknown.
    #[test]
    fn odometry_matches_the_bytes_checked_against_cyclone() {
        let golden = fixture(include_str!("../tests/fixtures/odometry_heading030.hex"));
        let ns = fs::NodeStatus {
            time: 1_700_000_000.5,
            local_fix: Some(fs::CartesianCoordinate {
                x: 12.5,
                y: -3.25,
                z: Some(-2.0),
            }),
            pose: fs::EulerAngles {
                heading: Some(30.0),
                roll: Some(0.0),
                pitch: Some(0.0),
                // angular.z = 0.01 rad/s counter-clockwise = a clockwise rate of -0.01 rad/s.
                heading_rate: Some(-0.01f64.to_degrees()),
                ..Default::default()
            },
            speed: fs::Speed {
                over_ground: 1.5,
                over_water: None,
            },
            ..Default::default()
        };
        let ours = odometry(&ns, &frames());
        assert_eq!(ours.len(), golden.len());
        // Covariance cells are the facts file's example values: compare everything else.
        let cov = |o: usize| (4 + o)..(4 + o + 288);
        let mut a = ours.clone();
        let mut b = golden.clone();
        for r in [cov(96), cov(432)] {
            a[r.clone()].fill(0);
            b[r].fill(0);
        }
        // The quaternion and the rate go through trigonometry: equal to the last bit or two.
        for off in [64usize, 72, 80, 88, 424] {
            let at = 4 + off;
            let x = f64::from_le_bytes(a[at..at + 8].try_into().unwrap());
            let y = f64::from_le_bytes(b[at..at + 8].try_into().unwrap());
            assert!((x - y).abs() < 1e-12, "offset {off}: {x} vs {y}");
            a[at..at + 8].fill(0);
            b[at..at + 8].fill(0);
        }
        assert_eq!(a, b);
    }

    #[test]
    fn nav_sat_fix_matches_the_hand_encoded_bytes() {
        let golden = fixture(include_str!("../tests/fixtures/navsatfix.hex"));
        let ns = fs::NodeStatus {
            time: 1_700_000_000.25,
            global_fix: LatLonPoint {
                lat: 42.358,
                lon: -70.9,
                depth: None,
                altitude: None,
            },
            source: Some(fs::Source {
                position: Some(fs::source::Sensor::Gps as i32),
                ..Default::default()
            }),
            ..Default::default()
        };
        let f = Frames {
            odom: "odom".into(),
            base: "gps".into(),
        };
        let ours = nav_sat_fix(&ns, &f);
        assert_eq!(&ours[..golden.len()], &golden[..]);
        // rmw_cyclonedds pads the payload to a multiple of 4 with zeros.
        assert_eq!(ours.len(), 128);
        assert!(ours[golden.len()..].iter().all(|b| *b == 0));
    }

    #[test]
    fn heading_to_quaternion_as_the_facts_file_lists() {
        const H: f64 = std::f64::consts::FRAC_1_SQRT_2;
        let close = |a: [f64; 4], b: [f64; 4]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-4);
        assert!(close(enu_quaternion(0.0, 0.0, 0.0), [0.0, 0.0, H, H]));
        assert!(close(enu_quaternion(0.0, 0.0, 90.0), [0.0, 0.0, 0.0, 1.0]));
        assert!(close(enu_quaternion(0.0, 0.0, 180.0), [0.0, 0.0, -H, H]));
        assert!(close(
            enu_quaternion(0.0, 0.0, 30.0),
            [0.0, 0.0, 0.5, 0.8660]
        ));
    }

    #[test]
    fn inputs_round_trip_and_refuse_what_is_wrong() {
        let c = fs::DesiredCourse {
            time: 1.0,
            heading: Some(45.0),
            speed: Some(1.5),
            depth: None,
            ..Default::default()
        };
        assert_eq!(decode_desired_course(&encode::desired_course(&c)), Ok(c));
        let mut nan = c;
        nan.speed = Some(f64::NAN);
        assert!(matches!(
            decode_desired_course(&encode::desired_course(&nan)),
            Err(InputError::NotFinite { field: "speed", .. })
        ));
        // NaN in an absent field is no value at all.
        let mut bytes = encode::desired_course(&c);
        let depth_at = 4 + 8 + 16 + 16 + 8;
        bytes[depth_at..depth_at + 8].copy_from_slice(&f64::NAN.to_le_bytes());
        assert_eq!(decode_desired_course(&bytes), Ok(c));
        let h = fs::HelmStateReport { state: 1 };
        assert_eq!(decode_helm_state(&encode::helm_state(&h)), Ok(h));
        assert!(matches!(
            decode_helm_state(&encode::helm_state(&fs::HelmStateReport { state: 7 })),
            Err(InputError::BadEnum { value: 7, .. })
        ));
        let req = fs::CommandRequest {
            desired_course: Some(c),
            response_requested: Some(true),
            request_id: Some(9),
            cancel_request_id: None,
        };
        assert_eq!(
            decode_command_request(&encode::command_request(&req)),
            Ok(req)
        );
        let e = decode_desired_course(&[0u8; 4096]).unwrap_err();
        assert_eq!(e.kind(), "oversized");
        let e = decode_desired_course(&[0, 1, 0, 0, 1]).unwrap_err();
        assert_eq!(e.kind(), "malformed");
        let mut bad_bool = encode::desired_course(&fs::DesiredCourse::default());
        bad_bool[4 + 8] = 2;
        assert_eq!(
            decode_desired_course(&bad_bool).unwrap_err().kind(),
            "malformed"
        );
    }

    #[test]
    fn participant_entities_info_has_the_facts_file_layout() {
        let b =
            participant_entities_info([1; 16], "/auv1", "ros2_bridge", &[], &[[2; 16], [3; 16]]);
        // 92 bytes in the facts file's capture.
        assert_eq!(b.len(), 92);
        assert_eq!(&b[20..24], &1u32.to_le_bytes());
        assert_eq!(&b[24..28], &6u32.to_le_bytes());
        assert_eq!(&b[28..34], b"/auv1\0");
    }
}
