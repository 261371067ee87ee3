//! The Huxley side of one payload connection, as a pure state machine: payload sentences in,
//! Huxley sentences out, simulated time advanced by the caller. It owns which sentences the
//! payload enabled (`$BPLOG`), the mission state it reports (`$BFMIS`, `$BFMSC`, `$BFCTL`), the
//! acknowledgement of every payload sentence (`$BFACK`, or a refusal), and the vehicle model of
//! the basic simulator steered by `$BPRMB`. No socket, no clock: [`crate::server`] drives it.

use std::collections::HashSet;

use crate::codec::{
    Ack, AckStatus, AdjustStatus, FromHuxley, FromPayload, HorizontalMode, Nvg, Nvr, Sentence,
    SpeedMode, VerticalMode,
};
use frontseat_sim::vehicle::{Limits, Setpoint, Vehicle, short_turn};

/// How the emulated Huxley answers commands (a test of the driver's failure paths).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Refusal {
    /// Every payload sentence is acknowledged as successfully processed.
    #[default]
    None,
    /// Commands (RMB, BOY, TRM, SIL, RCE, ABT, SMC) are acknowledged as failed
    /// (status 1, "refused by emulator"); LOG, STS and data are accepted.
    Commands,
    /// Nothing is ever acknowledged: an unresponsive Huxley that still streams navigation.
    Silent,
    /// Commands get a "pending" ack (status 3) followed at once by the final "success" ack.
    PendingFirst,
}

/// Everything that shapes one emulated vehicle.
#[derive(Debug, Clone, PartialEq)]
pub struct HuxleyOptions {
    /// Where the vehicle starts (decimal degrees).
    pub lat: f64,
    pub lon: f64,
    pub limits: Limits,
    /// `$BFNVG` + `$BFNVR` per simulated second.
    pub nav_hz: f64,
    /// `$BFMIS` (and `$BFCTL`) per simulated second, `$BFRVL` at the same rate.
    pub status_hz: f64,
    /// Simulated seconds after the payload enables MIS before the mission runs and backseat
    /// control is offered (`$BFMIS Running`, then `$BFMSC`).
    pub control_delay_s: f64,
    /// Thruster RPM per m/s (RPM-mode `$BPRMB`, `$BFRVL`).
    pub rpm_per_mps: f64,
    /// Water depth (m): altitude = this − depth.
    pub water_depth: f64,
    pub refusal: Refusal,
    pub dive_file: String,
    /// Ocean current east, north (m/s).
    pub current: (f64, f64),
}

impl Default for HuxleyOptions {
    fn default() -> Self {
        Self {
            lat: 42.358456,
            lon: -71.087589,
            limits: Limits {
                accel: 0.5,
                hdg_rate: 30.0,
                z_rate: 0.5,
            },
            nav_hz: 5.0,
            status_hz: 1.0,
            control_delay_s: 1.0,
            rpm_per_mps: 400.0,
            water_depth: 100.0,
            refusal: Refusal::None,
            dive_file: "frontseat.dive".into(),
            current: (0.0, 0.0),
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mission {
    /// Waiting for the payload to enable MIS (and the control delay).
    Waiting,
    Running,
    /// Aborted by the payload.
    Stopped,
}

/// What one payload line did, for the caller's counters.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LineKind {
    /// A sentence the Huxley knows (acknowledged unless refused/silent or ACK is off).
    Known,
    /// A well-formed `$BP…` sentence of an id we do not emulate (answered "invalid").
    Unknown,
    /// Not a sentence, bad checksum or malformed fields: ignored, no ack.
    Bad,
}

/// One emulated Huxley + vehicle.
pub struct Huxley {
    opts: HuxleyOptions,
    vehicle: Vehicle,
    enabled: HashSet<String>,
    mission: Mission,
    /// Simulated seconds since the connection opened.
    t: f64,
    mis_enabled_at: Option<f64>,
    msc_sent: bool,
    next_nav: f64,
    next_status: f64,
    last_heading: f64,
    silent: bool,
    /// The last `$BPRMB` applied, for tests and logs.
    pub last_rmb: Option<crate::codec::Rmb>,
}

impl Huxley {
    pub fn new(opts: HuxleyOptions) -> Self {
        let vehicle = Vehicle::new(opts.lat, opts.lon, opts.limits, opts.current);
        Self {
            opts,
            vehicle,
            enabled: HashSet::new(),
            mission: Mission::Waiting,
            t: 0.0,
            mis_enabled_at: None,
            msc_sent: false,
            next_nav: 0.0,
            next_status: 0.0,
            last_heading: 0.0,
            silent: false,
            last_rmb: None,
        }
    }

    pub fn vehicle(&self) -> &Vehicle {
        &self.vehicle
    }

    pub fn sim_time(&self) -> f64 {
        self.t
    }

    pub fn is_enabled(&self, id: &str) -> bool {
        self.enabled.contains(id)
    }

    pub fn silent_mode(&self) -> bool {
        self.silent
    }

    fn out(&self, msg: FromHuxley, out: &mut Vec<String>) {
        out.push(msg.to_sentence().format());
    }

    fn ack(
        &self,
        tod: f64,
        msg: &FromPayload,
        status: AckStatus,
        text: &str,
        out: &mut Vec<String>,
    ) {
        if self.opts.refusal == Refusal::Silent || !self.enabled.contains("ACK") {
            return;
        }
        self.out(
            FromHuxley::Ack(Ack {
                time: tod,
                command: msg.id().to_string(),
                // LOG has no timestamp of its own: echo when it arrived, as Huxley does.
                command_time: match msg.time_text() {
                    t if t.is_empty() => crate::codec::format_time(tod),
                    t => t,
                },
                status,
                text: text.to_string(),
            }),
            out,
        );
    }

    /// Handles one payload line; `tod` is the time of day (s since UTC midnight) to stamp
    /// replies with. Replies are appended to `out`.
    pub fn on_line(&mut self, line: &str, tod: f64, out: &mut Vec<String>) -> LineKind {
        let Ok(s) = Sentence::parse(line) else {
            return LineKind::Bad;
        };
        let msg = match FromPayload::from_sentence(&s) {
            Ok(m) => m,
            Err(_) => return LineKind::Bad,
        };
        if let FromPayload::Other(_) = msg {
            self.ack(tod, &msg, AckStatus::Invalid, "unknown sentence", out);
            return LineKind::Unknown;
        }
        let is_command = matches!(
            msg,
            FromPayload::Rmb(_)
                | FromPayload::Trm { .. }
                | FromPayload::Boy { .. }
                | FromPayload::Sil { .. }
                | FromPayload::Rce { .. }
                | FromPayload::Abt { .. }
                | FromPayload::Smc { .. }
        );
        if is_command && self.opts.refusal == Refusal::Commands {
            self.ack(tod, &msg, AckStatus::Failed, "refused by emulator", out);
            return LineKind::Known;
        }
        // Enable first, so that `$BPLOG,ACK,ON` is itself acknowledged.
        if let FromPayload::Log { id, on } = &msg {
            if *on {
                if id == "MIS" && self.mis_enabled_at.is_none() {
                    self.mis_enabled_at = Some(self.t);
                }
                self.enabled.insert(id.clone());
            } else {
                self.enabled.remove(id);
            }
        }
        if is_command && self.opts.refusal == Refusal::PendingFirst {
            self.ack(tod, &msg, AckStatus::Pending, "", out);
        }
        self.ack(tod, &msg, AckStatus::Success, "", out);
        match msg {
            FromPayload::Rmb(r) => self.apply_rmb(r),
            FromPayload::Boy { .. } if self.enabled.contains("BOY") => {
                let est = -1.5;
                self.out(
                    FromHuxley::Boy(AdjustStatus {
                        time: tod,
                        status: 2,
                        error: 0,
                        text: "done".into(),
                        value: Some(est),
                        value2: None,
                    }),
                    out,
                );
            }
            FromPayload::Trm { .. } if self.enabled.contains("TRM") => {
                let status = if self.silent { 3 } else { 2 };
                let error = if self.silent { 2 } else { 0 };
                self.out(
                    FromHuxley::Trm(AdjustStatus {
                        time: tod,
                        status,
                        error,
                        text: if self.silent { "silent" } else { "done" }.into(),
                        value: Some(1.2),
                        value2: Some(0.3),
                    }),
                    out,
                );
            }
            FromPayload::Sil { silent, .. } => self.silent = silent,
            FromPayload::Abt { .. } => {
                self.mission = Mission::Stopped;
                let sp = self.vehicle.setpoint();
                self.vehicle.set_setpoint(Setpoint { speed: 0.0, ..sp });
                if self.enabled.contains("MIS") {
                    self.mission_status(tod, out);
                }
            }
            _ => {}
        }
        LineKind::Known
    }

    fn apply_rmb(&mut self, r: crate::codec::Rmb) {
        let cur = self.vehicle.setpoint();
        let heading = match r.horizontal_mode {
            HorizontalMode::Heading => r.horizontal,
            // Rudder: hold the heading we have (the emulator has no rudder dynamics).
            HorizontalMode::Rudder => self.vehicle.heading,
        };
        let depth = match r.vertical_mode {
            VerticalMode::Depth => r.vertical.max(0.0),
            VerticalMode::Altitude => (self.opts.water_depth - r.vertical).max(0.0),
            // Pitch: hold the depth we have.
            VerticalMode::Pitch => self.vehicle.depth,
        };
        let speed = match r.speed_mode {
            SpeedMode::Speed => r.translational,
            SpeedMode::Rpm if self.opts.rpm_per_mps > 0.0 => {
                r.translational / self.opts.rpm_per_mps
            }
            SpeedMode::Rpm => cur.speed,
        }
        .max(0.0);
        self.vehicle.set_setpoint(Setpoint {
            heading,
            speed,
            depth,
        });
        self.last_rmb = Some(r);
    }

    fn mission_status(&self, tod: f64, out: &mut Vec<String>) {
        let status = match self.mission {
            Mission::Waiting => "Waiting",
            Mission::Running => "Running",
            Mission::Stopped => "Stopped",
        };
        self.out(
            FromHuxley::Mis {
                time: tod,
                dive_file: self.opts.dive_file.clone(),
                status: status.into(),
            },
            out,
        );
    }

    /// Advances the vehicle by `dt` simulated seconds and appends what is due.
    pub fn advance(&mut self, dt: f64, tod: f64, out: &mut Vec<String>) {
        let dt = if dt.is_finite() { dt.max(0.0) } else { 0.0 };
        self.last_heading = self.vehicle.heading;
        if dt > 0.0 {
            self.vehicle.step(dt);
        }
        self.t += dt;
        if self.mission == Mission::Waiting
            && self
                .mis_enabled_at
                .is_some_and(|t0| self.t - t0 >= self.opts.control_delay_s)
        {
            self.mission = Mission::Running;
            self.next_status = self.t;
        }
        if self.opts.nav_hz > 0.0 && self.t >= self.next_nav {
            self.next_nav = self.t + 1.0 / self.opts.nav_hz;
            self.nav(dt, tod, out);
        }
        if self.opts.status_hz > 0.0 && self.t >= self.next_status {
            self.next_status = self.t + 1.0 / self.opts.status_hz;
            if self.enabled.contains("MIS") {
                self.mission_status(tod, out);
            }
            if self.mission == Mission::Running && self.enabled.contains("CTL") {
                self.out(
                    FromHuxley::Ctl {
                        time: tod,
                        control: true,
                    },
                    out,
                );
            }
            if self.enabled.contains("RVL") {
                let sp = self.vehicle.speed;
                self.out(
                    FromHuxley::Rvl {
                        time: tod,
                        rpm: (sp * self.opts.rpm_per_mps).round(),
                        speed: Some(sp),
                    },
                    out,
                );
            }
        }
        if self.mission == Mission::Running && !self.msc_sent && self.enabled.contains("MSC") {
            self.msc_sent = true;
            self.out(
                FromHuxley::Msc {
                    time: tod,
                    text: "backseat control enabled".into(),
                },
                out,
            );
        }
    }

    fn nav(&mut self, dt: f64, tod: f64, out: &mut Vec<String>) {
        let (lat, lon) = self.vehicle.lat_lon();
        let v = &self.vehicle;
        let h = v.heading.to_radians();
        let east = v.speed * h.sin() + self.opts.current.0;
        let north = v.speed * h.cos() + self.opts.current.1;
        let yaw_rate = if dt > 0.0 {
            short_turn(self.last_heading, v.heading) / dt
        } else {
            0.0
        };
        let (depth, heading) = (v.depth, v.heading);
        if self.enabled.contains("NVG") {
            self.out(
                FromHuxley::Nvg(Nvg {
                    time: tod,
                    lat,
                    lon,
                    quality: Some(if depth < 0.5 { 1 } else { 0 }),
                    altitude: Some((self.opts.water_depth - depth).max(0.0)),
                    depth: Some(depth),
                    heading: Some(heading),
                    roll: Some(0.0),
                    pitch: Some(0.0),
                    fix_time: Some(tod),
                }),
                out,
            );
        }
        if self.enabled.contains("NVR") {
            self.out(
                FromHuxley::Nvr(Nvr {
                    time: tod,
                    east: Some(east),
                    north: Some(north),
                    down: Some(0.0),
                    pitch_rate: Some(0.0),
                    roll_rate: Some(0.0),
                    yaw_rate: Some(yaw_rate),
                }),
                out,
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const T: f64 = 43_200.0;

    fn startup(h: &mut Huxley) -> Vec<String> {
        let mut out = Vec::new();
        for id in ["ACK", "NVG", "MIS", "MSC", "NVR"] {
            let line = FromPayload::Log {
                id: id.into(),
                on: true,
            }
            .to_sentence()
            .format();
            assert_eq!(h.on_line(&line, T, &mut out), LineKind::Known);
        }
        out
    }

    #[test]
    fn log_ack_on_is_itself_acknowledged_and_every_log_after() {
        let mut h = Huxley::new(HuxleyOptions::default());
        let out = startup(&mut h);
        assert_eq!(out.len(), 5);
        assert_eq!(out[0], "$BFACK,120000.000,LOG,120000.000,,2,0,*27");
        assert!(out.iter().all(|l| l.starts_with("$BFACK,")));
    }

    #[test]
    fn mission_runs_after_the_delay_then_offers_control_once() {
        let mut h = Huxley::new(HuxleyOptions::default());
        startup(&mut h);
        let mut out = Vec::new();
        h.advance(0.5, T, &mut out);
        assert!(out.iter().any(|l| l.contains("Waiting")), "{out:?}");
        assert!(!out.iter().any(|l| l.starts_with("$BFMSC")));
        out.clear();
        for _ in 0..10 {
            h.advance(0.2, T, &mut out);
        }
        assert!(out.iter().any(|l| l.contains(",Running*")), "{out:?}");
        assert_eq!(out.iter().filter(|l| l.starts_with("$BFMSC")).count(), 1);
        assert!(out.iter().any(|l| l.starts_with("$BFNVG")));
        assert!(out.iter().any(|l| l.starts_with("$BFNVR")));
    }

    #[test]
    fn rmb_steers_the_vehicle_and_stop_line_stops_it() {
        let mut h = Huxley::new(HuxleyOptions::default());
        startup(&mut h);
        let mut out = Vec::new();
        h.on_line("$BPRMB,120004.000,90,0,0,1.5,1,0", T, &mut out);
        assert_eq!(out, ["$BFACK,120000.000,RMB,120004.000,,2,0,*3A"]);
        for _ in 0..600 {
            h.advance(0.1, T, &mut Vec::new());
        }
        assert!((h.vehicle().heading - 90.0).abs() < 1e-9);
        assert!((h.vehicle().speed - 1.5).abs() < 1e-9);
        assert!(h.vehicle().x > 50.0);
        h.on_line("$BPRMB,120030.000,0,0,2,0,0,1", T, &mut out);
        for _ in 0..100 {
            h.advance(0.1, T, &mut Vec::new());
        }
        assert_eq!(h.vehicle().speed, 0.0);
        assert!(
            (h.vehicle().heading - 90.0).abs() < 1e-9,
            "rudder 0 holds heading"
        );
    }

    #[test]
    fn refusal_modes() {
        let mut h = Huxley::new(HuxleyOptions {
            refusal: Refusal::Commands,
            ..Default::default()
        });
        startup(&mut h);
        let mut out = Vec::new();
        h.on_line("$BPRMB,120004.000,90,0,0,1.5,1,0", T, &mut out);
        assert_eq!(
            out,
            ["$BFACK,120000.000,RMB,120004.000,,1,0,refused by emulator*4D"]
        );
        assert!(h.last_rmb.is_none());

        let mut h = Huxley::new(HuxleyOptions {
            refusal: Refusal::Silent,
            ..Default::default()
        });
        assert!(startup(&mut h).is_empty());

        let mut h = Huxley::new(HuxleyOptions {
            refusal: Refusal::PendingFirst,
            ..Default::default()
        });
        startup(&mut h);
        let mut out = Vec::new();
        h.on_line("$BPBOY,120004.000", T, &mut out);
        assert_eq!(out.len(), 2);
        assert!(out[0].contains(",BOY,120004.000,,3,"), "{out:?}");
        assert!(out[1].contains(",BOY,120004.000,,2,"), "{out:?}");
    }

    #[test]
    fn bad_lines_get_no_ack_unknown_ones_an_invalid_ack() {
        let mut h = Huxley::new(HuxleyOptions::default());
        startup(&mut h);
        let mut out = Vec::new();
        assert_eq!(h.on_line("$BPRMB,1*00", T, &mut out), LineKind::Bad);
        assert_eq!(h.on_line("garbage", T, &mut out), LineKind::Bad);
        assert_eq!(
            h.on_line("$BPRMB,120004.000,x,0,0,1,1,0", T, &mut out),
            LineKind::Bad
        );
        assert!(out.is_empty());
        assert_eq!(
            h.on_line("$BPXYZ,120004.000", T, &mut out),
            LineKind::Unknown
        );
        assert_eq!(
            out,
            ["$BFACK,120000.000,XYZ,120004.000,,0,0,unknown sentence*77"]
        );
    }

    #[test]
    fn abort_stops_the_mission() {
        let mut h = Huxley::new(HuxleyOptions::default());
        startup(&mut h);
        let mut out = Vec::new();
        h.on_line("$BPABT,120015.000,backseat abort,1", T, &mut out);
        assert!(out.iter().any(|l| l.contains(",Stopped*")), "{out:?}");
    }
}
