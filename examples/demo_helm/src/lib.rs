//! The example helm of `frontseat demo`: drives the Goby3 course homework path through the same
//! groups any helm uses (helm_state, desired_course in; node_status, status out) — due east, due
//! south, then northwest until the vehicle stops closing on its start point — and records the
//! track for the CSV and SVG the demo writes.
//!
//! An example, not part of the runtime: it uses only frontseat-actors' public bus and its
//! generated `DemoHelm` ports (declared in interface_yaml/demo_helm.yaml and generated into the
//! actors crate with every other application's), so a helm of your own can start from it.
#![forbid(unsafe_code)]

pub mod trail;

use std::fmt::Write as _;
use std::time::Duration;

use frontseat_actors::bus::{Bus, Undeliverable};
use frontseat_actors::clock::SimClock;
use frontseat_actors::ports::{DemoHelmInbox, DemoHelmPorts};
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    DesiredCourse, HelmState, HelmStateReport, InterfaceState, InterfaceStatus,
};
use frontseat_actors::state_machine::state_words;

#[derive(Clone, Debug)]
pub struct DemoParams {
    /// Seconds (sim time) of the east leg.
    pub east_s: f64,
    /// Seconds (sim time) of the south leg.
    pub south_s: f64,
    pub speed: f64,
    /// Safety cap on the whole run (sim time).
    pub max_s: f64,
    /// Depth asked for on the east, south and northwest legs (m, down; 0 at the surface).
    pub depths: [f64; 3],
}

impl Default for DemoParams {
    fn default() -> Self {
        Self {
            east_s: 60.0,
            south_s: 60.0,
            speed: 1.5,
            max_s: 900.0,
            depths: [0.0; 3],
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Leg {
    WaitingForCommand,
    East,
    South,
    NorthWest,
    Done,
    /// A follower of `frontseat demo --fleet` keeping its slot ([`trail`]).
    Trail,
}

impl Leg {
    /// The leg's depth among the east, south and northwest ones.
    fn depth(self, depths: &[f64; 3]) -> f64 {
        match self {
            Leg::East => depths[0],
            Leg::South => depths[1],
            Leg::NorthWest => depths[2],
            _ => 0.0,
        }
    }
    fn heading(self) -> f64 {
        match self {
            Leg::East => 90.0,
            Leg::South => 180.0,
            Leg::NorthWest => 315.0,
            _ => 0.0,
        }
    }
    pub fn name(self) -> &'static str {
        match self {
            Leg::WaitingForCommand => "waiting",
            Leg::East => "east",
            Leg::South => "south",
            Leg::NorthWest => "northwest",
            Leg::Done => "done",
            Leg::Trail => "trail",
        }
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct TrackPoint {
    pub t: f64,
    pub x: f64,
    pub y: f64,
    pub heading: f64,
    pub speed: f64,
    pub leg: Leg,
    /// Metres, positive down (0 when the vehicle reports none).
    pub depth: f64,
}

/// What the live status line shows.
#[derive(Clone, Debug, Default)]
pub struct LiveStatus {
    pub interface: String,
    pub frontseat: String,
    pub helm: String,
    pub x: f64,
    pub y: f64,
    pub heading: f64,
    pub speed: f64,
    pub leg: &'static str,
    pub t: f64,
}

impl LiveStatus {
    pub fn line(&self) -> String {
        format!(
            "t={:6.1}s {:<16} fs={:<28} helm={:<10} leg={:<9} x={:8.1} y={:8.1} hdg={:5.1} spd={:4.2}",
            self.t,
            self.interface,
            self.frontseat,
            self.helm,
            self.leg,
            self.x,
            self.y,
            self.heading,
            self.speed
        )
    }
}

#[derive(Clone, Debug)]
pub struct DemoReport {
    pub track: Vec<TrackPoint>,
    pub closest_approach_m: f64,
    pub reached_command: bool,
    pub completed: bool,
}

/// Runs the homework path to its end (or `max_s`). `on_status` is called about once per
/// second of sim time.
pub async fn run(
    bus: &Bus,
    clock: SimClock,
    params: DemoParams,
    mut on_status: impl FnMut(&LiveStatus),
) -> DemoReport {
    let ports = DemoHelmPorts::new(bus);
    let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel();
    let subs = DemoHelmInbox::subscribe_all(bus, "DemoHelm", 1024, move |m| {
        tx.send(m).map_err(|_| Undeliverable)
    });
    let mut leg = Leg::WaitingForCommand;
    let mut leg_start = 0.0;
    let mut track: Vec<TrackPoint> = Vec::new();
    let mut status = InterfaceStatus::default();
    let mut live = LiveStatus::default();
    let mut reached_command = false;
    let mut min_dist = f64::INFINITY;
    let mut tick = tokio::time::interval(clock.wall(Duration::from_secs(1)));
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
    loop {
        tokio::select! {
            _ = tick.tick() => {
                let t = clock.now().as_secs_f64();
                ports.publish_helm_state(HelmStateReport { state: HelmState::HelmDrive as i32 });
                if leg == Leg::WaitingForCommand && status.state == Some(InterfaceState::InterfaceCommand as i32) {
                    reached_command = true;
                    leg = Leg::East;
                    leg_start = t;
                }
                let elapsed = t - leg_start;
                match leg {
                    Leg::East if elapsed >= params.east_s => { leg = Leg::South; leg_start = t; }
                    Leg::South if elapsed >= params.south_s => { leg = Leg::NorthWest; leg_start = t; min_dist = f64::INFINITY; }
                    _ => {}
                }
                if leg == Leg::NorthWest {
                    let d = live.x.hypot(live.y);
                    if d < min_dist {
                        min_dist = d;
                    } else if elapsed > 10.0 && d > min_dist + 0.5 {
                        leg = Leg::Done;
                    }
                }
                if matches!(leg, Leg::East | Leg::South | Leg::NorthWest) {
                    ports.publish_desired_course(DesiredCourse {
                        time: SimClock::unix_now(),
                        heading: Some(leg.heading()),
                        speed: Some(params.speed),
                        depth: Some(leg.depth(&params.depths)),
                        ..Default::default()
                    });
                }
                live.t = t;
                live.leg = leg.name();
                on_status(&live);
                if leg == Leg::Done || t > params.max_s {
                    // Stop the vehicle before leaving the helm seat.
                    ports.publish_desired_course(DesiredCourse {
                        time: SimClock::unix_now(),
                        heading: Some(live.heading),
                        speed: Some(0.0),
                        depth: Some(0.0),
                        ..Default::default()
                    });
                    break;
                }
            }
            Some(m) = rx.recv() => match m {
                DemoHelmInbox::NodeStatus(env) => {
                    let ns = &env.msg;
                    if let Some(l) = &ns.local_fix {
                        live.x = l.x;
                        live.y = l.y;
                    }
                    live.heading = ns.pose.heading();
                    live.speed = ns.speed.over_ground;
                    track.push(TrackPoint {
                        t: clock.now().as_secs_f64(),
                        x: live.x,
                        y: live.y,
                        heading: live.heading,
                        speed: live.speed,
                        leg,
                        depth: ns.global_fix.depth.unwrap_or(0.0),
                    });
                }
                DemoHelmInbox::Status(env) => {
                    status = *env.msg;
                    live.interface = state_words(status.state()).to_string();
                    // Goby3's words: the protobuf enum names a Goby3 user knows.
                    live.frontseat = status.frontseat_state().as_str_name().to_string();
                    live.helm = status.helm_state().as_str_name().to_string();
                }
            },
        }
    }
    for s in subs {
        s.cancel();
    }
    let closest = track
        .iter()
        .filter(|p| p.leg == Leg::NorthWest)
        .map(|p| p.x.hypot(p.y))
        .fold(f64::INFINITY, f64::min);
    DemoReport {
        completed: leg == Leg::Done,
        track,
        closest_approach_m: closest,
        reached_command,
    }
}

pub fn track_csv(track: &[TrackPoint]) -> String {
    let mut s = String::from("t_s,x_m,y_m,heading_deg,speed_mps,leg\n");
    for p in track {
        let _ = writeln!(
            s,
            "{:.3},{:.3},{:.3},{:.2},{:.3},{}",
            p.t,
            p.x,
            p.y,
            p.heading,
            p.speed,
            p.leg.name()
        );
    }
    s
}

/// [`track_csv`] with a last column `depth_m` (m, positive down): the single-vehicle demo's
/// track, where a diving vehicle (ArduSub) shows its depth.
pub fn track_csv_with_depth(track: &[TrackPoint]) -> String {
    let mut s = String::from("t_s,x_m,y_m,heading_deg,speed_mps,leg,depth_m\n");
    for p in track {
        let _ = writeln!(
            s,
            "{:.3},{:.3},{:.3},{:.2},{:.3},{},{:.3}",
            p.t,
            p.x,
            p.y,
            p.heading,
            p.speed,
            p.leg.name(),
            p.depth
        );
    }
    s
}

/// How the track followed the depths asked for, leg by leg: what `frontseat demo --vehicle
/// ardusub` prints and its guide page reports.
#[derive(Clone, Debug, PartialEq)]
pub struct DepthLegFigures {
    pub leg: Leg,
    pub asked_m: f64,
    pub start_m: f64,
    /// Sim seconds from the leg's start until within 0.3 m of the depth asked for (and staying).
    pub time_to_depth_s: Option<f64>,
    /// Furthest past the depth asked for, in the direction of travel. Unit: m.
    pub overshoot_m: f64,
    /// Sim seconds from the leg's start until the heading is within 5° of the leg's.
    pub time_to_heading_s: Option<f64>,
    /// Largest heading error while the depth was still changing, once the heading had first
    /// come within 5°. Unit: degrees.
    pub heading_error_diving_deg: f64,
}

/// The depth figures of a track flown with `params`.
pub fn depth_figures(track: &[TrackPoint], params: &DemoParams) -> Vec<DepthLegFigures> {
    let mut out = Vec::new();
    for leg in [Leg::East, Leg::South, Leg::NorthWest] {
        let pts: Vec<&TrackPoint> = track.iter().filter(|p| p.leg == leg).collect();
        let Some(first) = pts.first() else { continue };
        let asked = leg.depth(&params.depths);
        let t0 = first.t;
        let start = first.depth;
        let down = asked >= start;
        let settled = pts
            .iter()
            .rposition(|p| (p.depth - asked).abs() > 0.3)
            .map_or(Some(0), |i| (i + 1 < pts.len()).then_some(i + 1));
        let time_to_depth_s = settled.map(|i| pts[i].t - t0);
        let overshoot_m = pts
            .iter()
            .map(|p| {
                if down {
                    p.depth - asked
                } else {
                    asked - p.depth
                }
            })
            .fold(0.0_f64, f64::max);
        let err = |p: &TrackPoint| {
            let d = (p.heading - leg.heading()).rem_euclid(360.0);
            if d > 180.0 { 360.0 - d } else { d }
        };
        let on_heading = pts.iter().position(|p| err(p) <= 5.0);
        let time_to_heading_s = on_heading.map(|i| pts[i].t - t0);
        let diving_until = settled.unwrap_or(pts.len());
        let heading_error_diving_deg = match on_heading {
            Some(h) if h < diving_until => pts[h..diving_until]
                .iter()
                .map(|p| err(p))
                .fold(0.0, f64::max),
            _ => 0.0,
        };
        out.push(DepthLegFigures {
            leg,
            asked_m: asked,
            start_m: start,
            time_to_depth_s,
            overshoot_m,
            time_to_heading_s,
            heading_error_diving_deg,
        });
    }
    out
}

/// A grid spacing of 1, 2 or 5 × 10^k metres giving about `lines` lines across `span`.
fn nice_step(span: f64, lines: f64) -> f64 {
    let raw = (span / lines).max(1e-9);
    let k = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * k)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * k)
}

const LEG_COLOURS: [(Leg, &str); 5] = [
    (Leg::WaitingForCommand, "#999999"),
    (Leg::East, "#d62728"),
    (Leg::South, "#1f77b4"),
    (Leg::NorthWest, "#2ca02c"),
    (Leg::Done, "#555555"),
];

/// A self-contained SVG of the track in the local grid (Goby3's: x east, y north of the datum,
/// metres), north up: a labelled metre grid, axes titles, a scale bar, one colour per leg with a
/// legend, and the start marked.
pub fn track_svg(track: &[TrackPoint]) -> String {
    let frame = PlotFrame::fit(track.iter(), 1.0);
    let (w, h) = (760.0, 680.0);
    let PlotFrame {
        left,
        top,
        plot,
        scale,
        ..
    } = frame;
    let px = |x: f64| frame.px(x);
    let py = |y: f64| frame.py(y);
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="sans-serif">"#
    );
    let _ = writeln!(s, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let _ = writeln!(
        s,
        r#"<text x="{left}" y="24" font-size="15">frontseat demo track — local grid (x east, y north of the datum)</text>"#
    );
    // Grid and tick labels.
    let step = grid_and_ticks(&mut s, &frame);
    // Axes titles.
    let _ = writeln!(
        s,
        r#"<text x="{:.1}" y="{:.1}" font-size="13" text-anchor="middle">x — east of the datum (m)</text>"#,
        left + plot / 2.0,
        top + plot + 36.0
    );
    let _ = writeln!(
        s,
        r#"<text x="18" y="{:.1}" font-size="13" text-anchor="middle" transform="rotate(-90 18 {:.1})">y — north of the datum (m)</text>"#,
        top + plot / 2.0,
        top + plot / 2.0
    );
    // The track, one colour per leg.
    for (leg, colour) in LEG_COLOURS {
        let pts: Vec<String> = track
            .iter()
            .filter(|p| p.leg == leg)
            .map(|p| format!("{:.1},{:.1}", px(p.x), py(p.y)))
            .collect();
        if pts.len() > 1 {
            let _ = writeln!(
                s,
                r#"<polyline fill="none" stroke="{colour}" stroke-width="2.5" points="{}"><title>{}</title></polyline>"#,
                pts.join(" "),
                leg.name()
            );
        }
    }
    let _ = writeln!(
        s,
        r#"<circle cx="{:.1}" cy="{:.1}" r="5" fill="black"><title>start</title></circle>"#,
        px(0.0),
        py(0.0)
    );
    // Legend.
    let lx = left + plot + 20.0;
    let _ = writeln!(
        s,
        r#"<text x="{lx}" y="{:.1}" font-size="13">legs</text>"#,
        top + 14.0
    );
    let mut ly = top + 36.0;
    for (leg, colour) in LEG_COLOURS {
        if !track.iter().any(|p| p.leg == leg) {
            continue;
        }
        let _ = writeln!(
            s,
            r#"<line x1="{lx}" y1="{ly:.1}" x2="{:.1}" y2="{ly:.1}" stroke="{colour}" stroke-width="3"/><text x="{:.1}" y="{:.1}" font-size="12">{}</text>"#,
            lx + 24.0,
            lx + 30.0,
            ly + 4.0,
            leg.name()
        );
        ly += 20.0;
    }
    let _ = writeln!(
        s,
        r#"<circle cx="{:.1}" cy="{ly:.1}" r="5" fill="black"/><text x="{:.1}" y="{:.1}" font-size="12">start</text>"#,
        lx + 12.0,
        lx + 30.0,
        ly + 4.0
    );
    // Scale bar: one grid step.
    let bar = step * scale;
    let by = top + plot - 20.0;
    let bx = left + 20.0;
    let _ = writeln!(
        s,
        r#"<g><rect x="{:.1}" y="{:.1}" width="{:.1}" height="22" fill="white" fill-opacity="0.8"/><line x1="{bx}" y1="{by}" x2="{:.1}" y2="{by}" stroke="black" stroke-width="3"/><text x="{:.1}" y="{:.1}" font-size="12" text-anchor="middle">{step:.0} m</text></g>"#,
        bx - 6.0,
        by - 16.0,
        bar + 12.0,
        bx + bar,
        bx + bar / 2.0,
        by - 5.0
    );
    let _ = writeln!(
        s,
        r##"<text x="{lx}" y="{:.1}" font-size="11" fill="#444">grid {step:.0} m</text>"##,
        top + plot
    );
    s.push_str("</svg>\n");
    s
}

/// One colour per vehicle of a fleet SVG (the leader first), repeating past ten.
const FLEET_COLOURS: [&str; 10] = [
    "#d62728", "#1f77b4", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f",
    "#bcbd22", "#17becf",
];

/// A self-contained SVG of every vehicle's track in the shared local grid, north up: a metre
/// grid with labels, one colour per vehicle with its name in the legend, a dot where each track
/// ends, and the datum marked.
pub fn fleet_svg(title: &str, tracks: &[(String, Vec<TrackPoint>)]) -> String {
    let pts = || tracks.iter().flat_map(|(_, t)| t.iter());
    let frame = PlotFrame::fit(pts(), 1.05);
    let PlotFrame {
        left, top, plot, ..
    } = frame;
    let px = |x: f64| frame.px(x);
    let py = |y: f64| frame.py(y);
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="820" height="680" viewBox="0 0 820 680" font-family="sans-serif">"#
    );
    let _ = writeln!(s, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let _ = writeln!(
        s,
        r#"<text x="{left}" y="24" font-size="15">{title}</text>"#
    );
    // Grid and tick labels.
    let step = grid_and_ticks(&mut s, &frame);
    let _ = writeln!(
        s,
        r#"<text x="{:.1}" y="{:.1}" font-size="13" text-anchor="middle">x — east of the datum (m); grid {step:.0} m</text>"#,
        left + plot / 2.0,
        top + plot + 36.0
    );
    let lx = left + plot + 20.0;
    for (i, (name, track)) in tracks.iter().enumerate() {
        let colour = FLEET_COLOURS[i % FLEET_COLOURS.len()];
        let line: Vec<String> = track
            .iter()
            .map(|p| format!("{:.1},{:.1}", px(p.x), py(p.y)))
            .collect();
        if line.len() > 1 {
            let _ = writeln!(
                s,
                r#"<polyline fill="none" stroke="{colour}" stroke-width="2" points="{}"><title>{name}</title></polyline>"#,
                line.join(" ")
            );
        }
        if let Some(p) = track.last() {
            let _ = writeln!(
                s,
                r#"<circle cx="{:.1}" cy="{:.1}" r="4" fill="{colour}"><title>{name} at the end</title></circle>"#,
                px(p.x),
                py(p.y)
            );
        }
        let ly = top + 20.0 + 20.0 * i as f64;
        let _ = writeln!(
            s,
            r#"<line x1="{lx}" y1="{ly:.1}" x2="{:.1}" y2="{ly:.1}" stroke="{colour}" stroke-width="3"/><text x="{:.1}" y="{:.1}" font-size="12">{name}</text>"#,
            lx + 24.0,
            lx + 30.0,
            ly + 4.0
        );
    }
    let _ = writeln!(
        s,
        r#"<circle cx="{:.1}" cy="{:.1}" r="5" fill="black"><title>datum</title></circle>"#,
        px(0.0),
        py(0.0)
    );
    s.push_str("</svg>\n");
    s
}

/// Square plot area of an SVG track plot: its origin and side in pixels, the span and lower
/// corner in metres, and the pixels per metre. One fit for the single-vehicle and fleet plots.
#[derive(Clone, Copy)]
struct PlotFrame {
    left: f64,
    top: f64,
    plot: f64,
    span: f64,
    minx: f64,
    miny: f64,
    scale: f64,
}

impl PlotFrame {
    /// A square view centred on `points` (and the datum), at least 10 m across, widened by `pad`.
    fn fit<'a>(points: impl Iterator<Item = &'a TrackPoint>, pad: f64) -> Self {
        let (mut minx, mut maxx, mut miny, mut maxy) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        for p in points {
            minx = minx.min(p.x);
            maxx = maxx.max(p.x);
            miny = miny.min(p.y);
            maxy = maxy.max(p.y);
        }
        let span = (maxx - minx).max(maxy - miny).max(10.0) * pad;
        let (cx, cy) = ((minx + maxx) / 2.0, (miny + maxy) / 2.0);
        let (left, top, plot) = (70.0, 40.0, 560.0);
        Self {
            left,
            top,
            plot,
            span,
            minx: cx - span / 2.0,
            miny: cy - span / 2.0,
            scale: plot / span,
        }
    }

    fn px(&self, x: f64) -> f64 {
        self.left + (x - self.minx) * self.scale
    }

    fn py(&self, y: f64) -> f64 {
        self.top + self.plot - (y - self.miny) * self.scale
    }
}

/// Writes the grid, the tick labels and the frame of a track plot; returns the grid step (m).
/// One writer for the single-vehicle and the fleet plots, so both draw the same axes.
fn grid_and_ticks(s: &mut String, f: &PlotFrame) -> f64 {
    let PlotFrame {
        left,
        top,
        plot,
        span,
        minx,
        miny,
        ..
    } = *f;
    let px = |x: f64| f.px(x);
    let py = |y: f64| f.py(y);
    let step = nice_step(span, 8.0);
    let first = |lo: f64| (lo / step).ceil() as i64;
    let last = |lo: f64| ((lo + span) / step).floor() as i64;
    let _ = writeln!(s, r##"<g stroke="#e4e4e4" stroke-width="1">"##);
    for i in first(minx)..=last(minx) {
        let x = px(i as f64 * step);
        let _ = writeln!(
            s,
            r#"<line x1="{x:.1}" y1="{top}" x2="{x:.1}" y2="{:.1}"/>"#,
            top + plot
        );
    }
    for i in first(miny)..=last(miny) {
        let y = py(i as f64 * step);
        let _ = writeln!(
            s,
            r#"<line x1="{left}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}"/>"#,
            left + plot
        );
    }
    let _ = writeln!(s, "</g>");
    let _ = writeln!(s, r##"<g font-size="11" fill="#444">"##);
    for i in first(minx)..=last(minx) {
        let v = i as f64 * step;
        let _ = writeln!(
            s,
            r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">{v:.0}</text>"#,
            px(v),
            top + plot + 16.0
        );
    }
    for i in first(miny)..=last(miny) {
        let v = i as f64 * step;
        let _ = writeln!(
            s,
            r#"<text x="{:.1}" y="{:.1}" text-anchor="end">{v:.0}</text>"#,
            left - 6.0,
            py(v) + 4.0
        );
    }
    let _ = writeln!(s, "</g>");
    let _ = writeln!(
        s,
        r##"<rect x="{left}" y="{top}" width="{plot}" height="{plot}" fill="none" stroke="#888"/>"##
    );
    step
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pt(t: f64, leg: Leg, heading: f64, depth: f64) -> TrackPoint {
        TrackPoint {
            t,
            x: 0.0,
            y: 0.0,
            heading,
            speed: 0.5,
            leg,
            depth,
        }
    }

    /// Time to depth (within 0.3 m and staying), overshoot past the depth in the direction of
    /// travel, time to heading (within 5°) and the heading error after it while still diving.
    #[test]
    fn depth_figures_of_a_known_track() {
        let params = DemoParams {
            depths: [5.0, 10.0, 5.0],
            ..Default::default()
        };
        let track = vec![
            pt(10.0, Leg::East, 0.0, 0.0),
            pt(11.0, Leg::East, 60.0, 1.0),
            pt(12.0, Leg::East, 88.0, 3.0),
            pt(13.0, Leg::East, 93.0, 4.8),
            pt(14.0, Leg::East, 90.0, 5.4),
            pt(15.0, Leg::East, 90.0, 5.1),
            pt(16.0, Leg::East, 90.0, 5.0),
            // Climbing on the south leg: 10 m asked, never reached.
            pt(20.0, Leg::South, 90.0, 5.0),
            pt(21.0, Leg::South, 180.0, 6.0),
        ];
        let f = depth_figures(&track, &params);
        assert_eq!(f.len(), 2);
        let e = &f[0];
        assert_eq!((e.leg, e.asked_m, e.start_m), (Leg::East, 5.0, 0.0));
        assert_eq!(
            e.time_to_depth_s,
            Some(5.0),
            "5.1 at t = 15 stays within 0.3"
        );
        assert!((e.overshoot_m - 0.4).abs() < 1e-9, "{}", e.overshoot_m);
        assert_eq!(e.time_to_heading_s, Some(2.0));
        assert_eq!(e.heading_error_diving_deg, 3.0);
        let s = &f[1];
        assert_eq!(s.time_to_depth_s, None);
        assert_eq!(s.overshoot_m, 0.0);
        let csv = track_csv_with_depth(&track);
        assert!(csv.starts_with("t_s,x_m,y_m,heading_deg,speed_mps,leg,depth_m\n"));
        assert!(csv.contains(",east,5.400\n"), "{csv}");
    }
}
