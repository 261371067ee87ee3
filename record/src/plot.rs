//! `frontseat log plot`: what the vehicle did against what the helm asked, from a recording.
//! The samples are read by reflection with the file's own schemas (node_status for the actual
//! track, speed, heading and depth; desired_course for the commanded ones; status for the
//! interface's state), and drawn as a plain SVG of three panels against time under a band of
//! the interface's state. The track itself is drawn by the caller (the demo's SVG).

use std::collections::HashMap;
use std::fmt::Write as _;
use std::io::Read;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use prost_reflect::{DynamicMessage, MessageDescriptor, ReflectMessage, Value};

use crate::reader::{ReadError, Recording};

pub const NODE_STATUS: &str = "goby::middleware::frontseat::node_status";
pub const DESIRED_COURSE: &str = "goby::middleware::frontseat::desired_course";
pub const STATUS: &str = "goby::middleware::frontseat::status";
/// The band's colour of each interface state (the pages' plots use the same).
const STATE_COLOURS: [(&str, &str); 5] = [
    ("INTERFACE_STANDBY", "#bdbdbd"),
    ("INTERFACE_LISTEN", "#6baed6"),
    ("INTERFACE_COMMAND", "#31a354"),
    ("INTERFACE_HELM_ERROR", "#fd8d3c"),
    ("INTERFACE_FS_ERROR", "#de2d26"),
];
/// Any other state a file names.
const STATE_OTHER: &str = "#9e9ac8";
/// Samples kept per series: a day at 10 Hz is 864 000; beyond this every n-th is kept.
const MAX_SAMPLES: usize = 20_000;
/// Vehicles drawn apart in one file (a topside's); samples of further ones are skipped.
const MAX_VEHICLES: usize = 64;
/// One colour per vehicle, cycled.
const PALETTE: [&str; 8] = [
    "#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#8c564b", "#e377c2", "#17becf", "#bcbd22",
];

/// One sample; `None` where the message lacks the field.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sample {
    /// Index in [`Series::vehicles`] of the vehicle this sample is of.
    pub vehicle: u16,
    /// Seconds since the first message of the file.
    pub t: f64,
    pub x: Option<f64>,
    pub y: Option<f64>,
    pub speed: Option<f64>,
    pub heading: Option<f64>,
    pub depth: Option<f64>,
}

/// The interface entering a state (status), kept only when it changed.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StateChange {
    pub vehicle: u16,
    pub t: f64,
    /// The enum value's name from the file's schema (at most 48 characters), or its number.
    pub state: String,
}

#[derive(Clone, Debug, Default)]
pub struct Series {
    pub actual: Vec<Sample>,
    pub commanded: Vec<Sample>,
    pub states: Vec<StateChange>,
    /// The vehicles, in order of first appearance: `""` for a vehicle's own recording (topic =
    /// the group), the platform for a topside's (topic = `<platform>/<group>`).
    pub vehicles: Vec<String>,
}

impl Series {
    /// The samples of vehicle `v`, in file order.
    fn of(v: usize, samples: &[Sample]) -> impl Iterator<Item = &Sample> {
        samples.iter().filter(move |s| usize::from(s.vehicle) == v)
    }

    /// The vehicle count, at least one (an empty series draws empty panels).
    fn vehicle_count(&self) -> usize {
        self.vehicles.len().max(1)
    }
}

/// Which of the three plotted groups `topic` is (0 node_status, 1 desired_course, 2 status),
/// and of which platform: the group itself in a vehicle's recording, `<platform>/<group>` in a
/// topside's.
fn classify(topic: &str) -> Option<(usize, &str)> {
    for (which, group) in [(0, NODE_STATUS), (1, DESIRED_COURSE), (2, STATUS)] {
        if topic == group {
            return Some((which, ""));
        }
        if let Some(p) = topic
            .strip_suffix(group)
            .and_then(|p| p.strip_suffix('/'))
            .filter(|p| !p.is_empty() && !p.contains('/'))
        {
            return Some((which, p));
        }
    }
    None
}

fn get(msg: &DynamicMessage, path: &[&str]) -> Option<f64> {
    let (last, head) = path.split_last()?;
    let mut cur = msg.clone();
    for p in head {
        let f = cur.descriptor().get_field_by_name(p)?;
        if !cur.has_field(&f) {
            return None;
        }
        cur = cur.get_field(&f).as_message()?.clone();
    }
    let f = cur.descriptor().get_field_by_name(last)?;
    if !cur.has_field(&f) {
        return None;
    }
    match cur.get_field(&f).as_ref() {
        Value::F64(v) => Some(*v),
        Value::F32(v) => Some(f64::from(*v)),
        Value::I32(v) => Some(f64::from(*v)),
        _ => None,
    }
    .filter(|v| v.is_finite())
}

/// The name of enum field `name` of `msg` (its number when the schema does not name it).
fn enum_name(msg: &DynamicMessage, name: &str) -> Option<String> {
    let f = msg.descriptor().get_field_by_name(name)?;
    if !msg.has_field(&f) {
        return None;
    }
    let Value::EnumNumber(n) = msg.get_field(&f).as_ref().clone() else {
        return None;
    };
    let named = f
        .kind()
        .as_enum()
        .and_then(|e| e.get_value(n))
        .map(|v| v.name().chars().take(48).collect());
    Some(named.unwrap_or_else(|| n.to_string()))
}

/// Which series (0 actual, 1 commanded, 2 states) and which vehicle a channel's messages go to.
type Route = (usize, u16);

/// Reads node_status and desired_course samples (decimated past [`MAX_SAMPLES`]).
pub fn series<R: Read>(mut rec: Recording<R>) -> Result<Series, ReadError> {
    let mut descs: HashMap<u16, Option<MessageDescriptor>> = HashMap::new();
    let mut routes: HashMap<u16, (Arc<str>, Option<Route>)> = HashMap::new();
    let mut out = Series::default();
    let mut start = None;
    let mut seen = [0usize; 3];
    while let Some(m) = rec.next_message()? {
        let t0 = *start.get_or_insert(m.log_time);
        let Some(ch) = rec.channel(m.channel_id) else {
            continue;
        };
        // Which series and vehicle a channel is, decided once per channel definition (keyed by
        // its topic's allocation): the work per message does not grow with the topic's length.
        let route = match routes.get(&m.channel_id) {
            Some((t, r)) if Arc::ptr_eq(t, &ch.topic) => *r,
            _ => {
                let r = classify(&ch.topic).and_then(|(which, platform)| {
                    let vehicle = match out.vehicles.iter().position(|v| v == platform) {
                        Some(i) => i,
                        None if out.vehicles.len() < MAX_VEHICLES => {
                            out.vehicles.push(platform.to_string());
                            out.vehicles.len() - 1
                        }
                        None => return None,
                    };
                    Some((which, u16::try_from(vehicle).unwrap_or(u16::MAX)))
                });
                routes.insert(m.channel_id, (ch.topic.clone(), r));
                r
            }
        };
        let Some((which, vehicle)) = route else {
            continue;
        };
        seen[which] += 1;
        // Decimate evenly once past the bound: keep every k-th, k growing with the count. A
        // state is kept only when it changes, so it is never decimated (a change is never lost).
        let k = seen[which].div_ceil(MAX_SAMPLES).max(1);
        if which != 2 && seen[which] % k != 0 {
            continue;
        }
        let schema_id = ch.schema_id;
        let Some(desc) = descs
            .entry(schema_id)
            .or_insert_with(|| {
                let s = rec.schema(schema_id)?;
                crate::schema::decode_untrusted_pool(&s.data)?.get_message_by_name(&s.name)
            })
            .clone()
        else {
            continue;
        };
        let Ok(msg) = DynamicMessage::decode(desc, m.data.as_slice()) else {
            continue;
        };
        let t = m.log_time.saturating_sub(t0) as f64 / 1e9;
        if which == 2 {
            let Some(state) = enum_name(&msg, "state") else {
                continue;
            };
            let last = out.states.iter().rev().find(|c| c.vehicle == vehicle);
            if last.is_none_or(|c| c.state != state) && out.states.len() < MAX_SAMPLES {
                out.states.push(StateChange { vehicle, t, state });
            }
            continue;
        }
        let s = if which == 0 {
            Sample {
                vehicle,
                t,
                x: get(&msg, &["local_fix", "x"]),
                y: get(&msg, &["local_fix", "y"]),
                speed: get(&msg, &["speed", "over_ground"]),
                heading: get(&msg, &["pose", "heading"]),
                depth: get(&msg, &["global_fix", "depth"]),
            }
        } else {
            Sample {
                vehicle,
                t,
                speed: get(&msg, &["speed"]),
                heading: get(&msg, &["heading"]),
                depth: get(&msg, &["depth"]),
                ..Default::default()
            }
        };
        let v = if which == 0 {
            &mut out.actual
        } else {
            &mut out.commanded
        };
        if v.len() < 2 * MAX_SAMPLES {
            v.push(s);
        }
    }
    Ok(out)
}

/// Picks one quantity of a sample.
type Field = fn(&Sample) -> Option<f64>;

/// Speed, heading and depth against time, actual (blue) and commanded (orange), as one SVG.
/// Writes `dir/track.svg` and `dir/time.svg` (creating `dir`); the two paths written. Each file
/// goes through [`crate::output::Output`]: an existing one is replaced only with `force`, never
/// when it is `input`, never through a symlink.
pub fn write_dir(
    s: &Series,
    dir: &Path,
    force: bool,
    input: &Path,
) -> Result<[PathBuf; 2], crate::output::OutputError> {
    std::fs::create_dir_all(dir).map_err(|source| crate::output::OutputError::Io {
        what: "create the directory",
        path: dir.to_path_buf(),
        source,
    })?;
    let track = dir.join("track.svg");
    let time = dir.join("time.svg");
    // Both refused before either is written.
    let mut outs = Vec::new();
    for p in [&track, &time] {
        outs.push(crate::output::Output::create(p, force, &[input])?);
    }
    for (mut o, text) in outs.into_iter().zip([track_svg(s), time_svg(s)]) {
        let at = o.temp_path().to_path_buf();
        o.write_all(text.as_bytes())
            .map_err(|source| crate::output::OutputError::Io {
                what: "write",
                path: at,
                source,
            })?;
        o.commit()?;
    }
    Ok([track, time])
}

pub fn time_svg(s: &Series) -> String {
    let panels: [(&str, Field); 3] = [
        ("speed (m/s)", |p| p.speed),
        ("heading (deg)", |p| p.heading),
        ("depth (m)", |p| p.depth),
    ];
    let (w, ph, left) = (900.0, 200.0, 70.0);
    let pw = w - left - 30.0;
    let tmax = s
        .actual
        .iter()
        .chain(&s.commanded)
        .map(|p| p.t)
        .chain(s.states.iter().map(|c| c.t))
        .fold(1e-3f64, f64::max);
    // The interface's state: one band a vehicle, under the title, above the panels.
    let band_h = 14.0;
    let band_top = 52.0;
    let bands = if s.states.is_empty() {
        0
    } else {
        s.vehicle_count()
    };
    let top = band_top + bands as f64 * (band_h + 4.0) + 40.0;
    let h = top + 3.0 * (ph + 40.0) + 20.0;
    let mut out = String::new();
    let _ = writeln!(
        out,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="sans-serif">"#
    );
    let _ = writeln!(out, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let _ = writeln!(
        out,
        r##"<text x="{left}" y="24" font-size="15">actual (node_status, <tspan fill="#1f77b4">blue</tspan>) and commanded (desired_course, <tspan fill="#ff7f0e">orange</tspan>) against time, {tmax:.1} s</text>"##
    );
    state_bands(&mut out, s, left, pw, band_top, band_h, tmax);
    for (i, (name, f)) in panels.iter().enumerate() {
        let y0 = top + i as f64 * (ph + 40.0);
        let vals: Vec<f64> = s.actual.iter().chain(&s.commanded).filter_map(f).collect();
        let (lo, hi) = vals
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                (a.min(*v), b.max(*v))
            });
        let (lo, hi) = if vals.is_empty() {
            (0.0, 1.0)
        } else if hi - lo < 1e-9 {
            (lo - 0.5, hi + 0.5)
        } else {
            (lo, hi)
        };
        let px = |t: f64| left + t / tmax * pw;
        let py = |v: f64| y0 + ph - (v - lo) / (hi - lo) * ph;
        let _ = writeln!(
            out,
            r##"<rect x="{left}" y="{y0}" width="{pw}" height="{ph}" fill="none" stroke="#bbb"/>"##
        );
        let _ = writeln!(
            out,
            r##"<text x="{left}" y="{:.1}" font-size="12">{name}</text><text x="{:.1}" y="{:.1}" font-size="11" text-anchor="end" fill="#444">{hi:.1}</text><text x="{:.1}" y="{:.1}" font-size="11" text-anchor="end" fill="#444">{lo:.1}</text>"##,
            y0 - 4.0,
            left - 6.0,
            y0 + 10.0,
            left - 6.0,
            y0 + ph
        );
        // One vehicle: actual blue, commanded orange. Several: a colour per vehicle, its
        // commanded dashed; each vehicle its own line, never one zig-zagging between them.
        let many = s.vehicle_count() > 1;
        for v in 0..s.vehicle_count() {
            for (series, commanded) in [(&s.actual, false), (&s.commanded, true)] {
                let colour = match (many, commanded) {
                    (true, _) => PALETTE[v % PALETTE.len()],
                    (false, false) => "#1f77b4",
                    (false, true) => "#ff7f0e",
                };
                let dash = if many && commanded {
                    r#" stroke-dasharray="5,3""#
                } else {
                    ""
                };
                let pts: Vec<String> = Series::of(v, series)
                    .filter_map(|p| f(p).map(|val| format!("{:.1},{:.1}", px(p.t), py(val))))
                    .collect();
                if !pts.is_empty() {
                    let _ = writeln!(
                        out,
                        r#"<polyline fill="none" stroke="{colour}" stroke-width="1.5"{dash} points="{}"/>"#,
                        pts.join(" ")
                    );
                }
            }
        }
    }
    legend(&mut out, s, left, h - 10.0);
    let _ = writeln!(out, "</svg>");
    out
}

/// The interface's state against time, one band a vehicle: each state holds until the next
/// change (the last until the end of the file), with its name in a `<title>` and a
/// `data-state` attribute, and a legend of the colours.
fn state_bands(out: &mut String, s: &Series, left: f64, pw: f64, top: f64, bh: f64, tmax: f64) {
    if s.states.is_empty() {
        return;
    }
    let px = |t: f64| left + t / tmax * pw;
    let _ = writeln!(
        out,
        r##"<text x="{left}" y="{:.1}" font-size="12">interface state (status)</text>"##,
        top - 4.0
    );
    for v in 0..s.vehicle_count() {
        let y = top + v as f64 * (bh + 4.0);
        let changes: Vec<&StateChange> = s
            .states
            .iter()
            .filter(|c| usize::from(c.vehicle) == v)
            .collect();
        for (i, c) in changes.iter().enumerate() {
            let end = changes.get(i + 1).map_or(tmax, |n| n.t);
            let colour = STATE_COLOURS
                .iter()
                .find(|(k, _)| *k == c.state)
                .map_or(STATE_OTHER, |(_, col)| col);
            let state = xml_escape(&c.state);
            let _ = writeln!(
                out,
                r#"<rect class="state" data-state="{state}" x="{:.1}" y="{y:.1}" width="{:.1}" height="{bh}" fill="{colour}"><title>{state} from {:.1} s</title></rect>"#,
                px(c.t),
                (px(end) - px(c.t)).max(0.5),
                c.t
            );
        }
        if s.vehicle_count() > 1
            && let Some(name) = s.vehicles.get(v)
        {
            let _ = writeln!(
                out,
                r#"<text x="{:.1}" y="{:.1}" font-size="10" text-anchor="end">{}</text>"#,
                left - 4.0,
                y + bh - 3.0,
                xml_escape(name)
            );
        }
    }
    let legend_y = top + s.vehicle_count() as f64 * (bh + 4.0) + 12.0;
    let mut x = left;
    for (k, colour) in STATE_COLOURS {
        let word = k.trim_start_matches("INTERFACE_");
        let _ = write!(
            out,
            r#"<rect x="{x:.0}" y="{:.0}" width="10" height="10" fill="{colour}"/><text x="{:.0}" y="{legend_y:.0}" font-size="11">{word}</text>"#,
            legend_y - 9.0,
            x + 13.0
        );
        x += 26.0 + 8.0 * word.len() as f64;
    }
    let _ = writeln!(out);
}

/// The vehicles' names in their colours, when a file holds several.
fn legend(out: &mut String, s: &Series, left: f64, y: f64) {
    if s.vehicle_count() < 2 {
        return;
    }
    let mut x = left;
    for (i, name) in s.vehicles.iter().enumerate() {
        let _ = write!(
            out,
            r#"<text x="{x:.0}" y="{y:.0}" font-size="12" fill="{}">{}</text>"#,
            PALETTE[i % PALETTE.len()],
            xml_escape(name)
        );
        x += 12.0 + 8.0 * name.chars().count() as f64;
    }
    let _ = writeln!(out);
}

/// Platform names come from the file: escaped before they go into the SVG.
fn xml_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// The actual track on the local grid (x east, y north of the datum), equal scales, start marked.
pub fn track_svg(s: &Series) -> String {
    let pts: Vec<(f64, f64)> = s.actual.iter().filter_map(|p| Some((p.x?, p.y?))).collect();
    let (w, left, top, plot) = (680.0, 60.0, 40.0, 580.0);
    let (mut minx, mut maxx, mut miny, mut maxy) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for (x, y) in &pts {
        minx = minx.min(*x);
        maxx = maxx.max(*x);
        miny = miny.min(*y);
        maxy = maxy.max(*y);
    }
    let span = (maxx - minx).max(maxy - miny).max(10.0);
    let (cx, cy) = ((minx + maxx) / 2.0, (miny + maxy) / 2.0);
    let (minx, miny) = (cx - span / 2.0, cy - span / 2.0);
    let px = |x: f64| left + (x - minx) / span * plot;
    let py = |y: f64| top + plot - (y - miny) / span * plot;
    let h = top + plot + 40.0;
    let mut out = String::new();
    let _ = writeln!(
        out,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="sans-serif">"#
    );
    let _ = writeln!(out, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let _ = writeln!(
        out,
        r#"<text x="{left}" y="24" font-size="15">recorded track (node_status local_fix), {} points, {span:.0} m across</text>"#,
        pts.len()
    );
    let _ = writeln!(
        out,
        r##"<rect x="{left}" y="{top}" width="{plot}" height="{plot}" fill="none" stroke="#bbb"/>"##
    );
    for v in 0..s.vehicle_count() {
        let colour = if s.vehicle_count() > 1 {
            PALETTE[v % PALETTE.len()]
        } else {
            "#1f77b4"
        };
        let pts: Vec<(f64, f64)> = Series::of(v, &s.actual)
            .filter_map(|p| Some((p.x?, p.y?)))
            .collect();
        let Some((x0, y0)) = pts.first() else {
            continue;
        };
        let line: Vec<String> = pts
            .iter()
            .map(|(x, y)| format!("{:.1},{:.1}", px(*x), py(*y)))
            .collect();
        let _ = writeln!(
            out,
            r##"<polyline fill="none" stroke="{colour}" stroke-width="2" points="{}"/>"##,
            line.join(" ")
        );
        let _ = writeln!(
            out,
            r#"<circle cx="{:.1}" cy="{:.1}" r="5" fill="black"><title>start</title></circle>"#,
            px(*x0),
            py(*y0)
        );
    }
    legend(&mut out, s, left, h - 10.0);
    let _ = writeln!(out, "</svg>");
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn svgs_of_empty_and_flat_series_are_finite() {
        let empty = Series::default();
        for s in [time_svg(&empty), track_svg(&empty)] {
            assert!(s.starts_with("<svg") && s.trim_end().ends_with("</svg>"));
            assert!(!s.contains("NaN") && !s.contains("inf"), "{s}");
        }
        let flat = Series {
            actual: vec![
                Sample {
                    vehicle: 0,
                    t: 0.0,
                    x: Some(1.0),
                    y: Some(1.0),
                    speed: Some(1.0),
                    heading: Some(90.0),
                    depth: Some(0.0),
                },
                Sample {
                    vehicle: 0,
                    t: 1.0,
                    x: Some(1.0),
                    y: Some(1.0),
                    speed: Some(1.0),
                    heading: Some(90.0),
                    depth: Some(0.0),
                },
            ],
            commanded: vec![Sample {
                t: 0.5,
                speed: Some(1.5),
                ..Default::default()
            }],
            vehicles: Vec::new(),
            states: Vec::new(),
        };
        let t = time_svg(&flat);
        assert_eq!(t.matches("<polyline").count(), 4, "3 actual + 1 commanded");
        assert!(!t.contains("NaN"));
        assert!(track_svg(&flat).contains("<circle"));
    }

    #[test]
    fn each_vehicle_has_its_band_and_a_state_holds_until_the_next() {
        let change = |vehicle, t, state: &str| StateChange {
            vehicle,
            t,
            state: state.into(),
        };
        let s = Series {
            actual: vec![Sample {
                t: 10.0,
                speed: Some(1.0),
                ..Default::default()
            }],
            states: vec![
                change(0, 0.0, "INTERFACE_LISTEN"),
                change(1, 1.0, "<odd>"),
                change(0, 5.0, "INTERFACE_COMMAND"),
            ],
            vehicles: vec!["auv1".into(), "auv2".into()],
            ..Default::default()
        };
        let svg = time_svg(&s);
        let rects: Vec<&str> = svg
            .lines()
            .filter(|l| l.starts_with(r#"<rect class="state""#))
            .collect();
        assert_eq!(rects.len(), 3, "{svg}");
        // auv1's band first: LISTEN from 0 to 5 s of 10, half the panel's width (800 px), then
        // COMMAND to the end; then auv2's, one row down, its unknown state escaped.
        assert!(
            rects[0].contains(r#"x="70.0""#) && rects[0].contains(r#"width="400.0""#),
            "{}",
            rects[0]
        );
        assert!(
            rects[1].contains(r#"x="470.0""#) && rects[1].contains(r#"width="400.0""#),
            "{}",
            rects[1]
        );
        assert!(
            rects[2].contains("&lt;odd&gt;")
                && rects[2].contains(STATE_OTHER)
                && rects[2].contains(r#"y="70.0""#),
            "{}",
            rects[2]
        );
        // No status in the file: no band, the panels where they were.
        let bare = time_svg(&Series {
            states: Vec::new(),
            ..s
        });
        assert!(!bare.contains("interface state"));
    }

    #[test]
    fn a_topside_topic_names_its_platform_and_others_are_not_plotted() {
        assert_eq!(classify(NODE_STATUS), Some((0, "")));
        assert_eq!(classify(DESIRED_COURSE), Some((1, "")));
        assert_eq!(classify(&format!("auv1/{NODE_STATUS}")), Some((0, "auv1")));
        assert_eq!(classify(&format!("a/b/{NODE_STATUS}")), None);
        assert_eq!(classify(&format!("/{NODE_STATUS}")), None);
        assert_eq!(classify(STATUS), Some((2, "")));
        assert_eq!(classify(&format!("auv2/{STATUS}")), Some((2, "auv2")));
        assert_eq!(classify("goby::middleware::frontseat::helm_state"), None);
        assert_eq!(classify(&format!("auv1{NODE_STATUS}")), None);
    }

    #[test]
    fn two_vehicles_are_two_tracks_with_a_legend() {
        let at = |vehicle, x| Sample {
            vehicle,
            t: x,
            x: Some(x),
            y: Some(-x),
            ..Default::default()
        };
        let s = Series {
            actual: vec![at(0, 0.0), at(1, 5.0), at(0, 1.0), at(1, 6.0)],
            commanded: Vec::new(),
            vehicles: vec!["auv1".into(), "<auv2>".into()],
            states: Vec::new(),
        };
        let t = track_svg(&s);
        assert_eq!(t.matches("<polyline").count(), 2, "{t}");
        assert_eq!(t.matches("<circle").count(), 2);
        assert!(t.contains(">auv1<") && t.contains("&lt;auv2&gt;"), "{t}");
        // Each vehicle's line holds only its own points.
        let first = t.lines().find(|l| l.contains("<polyline")).unwrap();
        assert_eq!(first.matches(',').count(), 2, "{first}");
    }
}
