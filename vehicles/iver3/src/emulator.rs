//! The Iver3 UVC's side of Remote Helm, emulated on the basic simulator's vehicle model:
//! answers `$OSD` polls with `$GPRMC`, `$OSI` and `$C` (feet, knots), steers on `$OMS` (depth in
//! feet or metres by Remote Helm version, speed in knots), drops a command that is not refreshed
//! within its timeout, and acknowledges commands with `$ACK`.

use crate::codec::{Ack, Compass, FEET_PER_METRE, MAX_SENTENCE, MPS_PER_KNOT, Oms, Osi, Sentence};

use frontseat_sim::emulator::Session;
use frontseat_sim::vehicle::{Limits, Setpoint, Vehicle};

/// How the emulated UVC starts.
#[derive(Debug, Clone, PartialEq)]
pub struct IverOptions {
    pub lat: f64,
    pub lon: f64,
    pub limits: Limits,
    /// `$OMS` depth is feet below 5, metres from 5 on.
    pub remote_helm_version_major: i32,
    /// Mode letter at start (`N` normal).
    pub mode: String,
    /// Send `$ACK` for commands (the Remote Helm manual's behaviour; off = a silent UVC).
    pub send_acks: bool,
}

impl Default for IverOptions {
    fn default() -> Self {
        Self {
            lat: 42.358456,
            lon: -71.087589,
            limits: Limits {
                accel: 0.5,
                hdg_rate: 45.0,
                z_rate: 2.0,
            },
            remote_helm_version_major: 5,
            mode: "N".into(),
            send_acks: true,
        }
    }
}

/// What the emulated UVC saw.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct IverStats {
    pub osd: u64,
    pub oms: u64,
    pub omstart: u64,
    pub omstop: u64,
    pub bad_lines: u64,
    pub oversized_lines: u64,
    pub oms_timeouts: u64,
    pub last_oms: Option<Oms>,
}

pub struct IverSession {
    opts: IverOptions,
    vehicle: Vehicle,
    mode: String,
    /// The mission the last `$OMSTART` named (reported in `$OSI`).
    pub mission: String,
    /// Simulated seconds since start.
    t: f64,
    /// When the current `$OMS` expires (simulated seconds).
    oms_until: Option<f64>,
    line: Vec<u8>,
    discarding: bool,
    unix0: f64,
    pub stats: IverStats,
}

impl IverSession {
    pub fn new(opts: IverOptions) -> Self {
        let unix0 = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_secs_f64())
            .unwrap_or(0.0);
        Self {
            vehicle: Vehicle::new(opts.lat, opts.lon, opts.limits, (0.0, 0.0)),
            mode: opts.mode.clone(),
            mission: String::new(),
            opts,
            t: 0.0,
            oms_until: None,
            line: Vec::with_capacity(128),
            discarding: false,
            unix0,
            stats: IverStats::default(),
        }
    }

    pub fn vehicle(&self) -> &Vehicle {
        &self.vehicle
    }

    /// Changes the mode letter(s) reported in `$OSI` (e.g. "S" stopped, "P" parking).
    pub fn set_mode(&mut self, mode: &str) {
        self.mode = mode.to_string();
    }

    fn send(out: &mut Vec<u8>, s: &Sentence) {
        out.extend_from_slice(s.to_line().as_bytes());
        out.extend_from_slice(b"\r\n");
    }

    fn ack(&self, out: &mut Vec<u8>, msg_type: u32, err: u32) {
        if self.opts.send_acks {
            Self::send(
                out,
                &Sentence::Ack(Ack {
                    msg_type,
                    status: u32::from(err != 0),
                    err,
                }),
            );
        }
    }

    fn on_line(&mut self, line: &str, out: &mut Vec<u8>) {
        let s = match Sentence::parse(line) {
            Ok(s) => s,
            Err(e) => {
                self.stats.bad_lines += 1;
                tracing::debug!(line, error = %e, "emulated UVC: bad sentence");
                return;
            }
        };
        match s {
            Sentence::Osd {
                gps,
                compass,
                state,
                power: _,
            } => {
                self.stats.osd += 1;
                let (lat, lon) = self.vehicle.lat_lon();
                let v = self.vehicle.clone();
                let speed_kn = v.speed / MPS_PER_KNOT;
                if gps {
                    Self::send(
                        out,
                        &crate::codec::rmc(lat, lon, speed_kn, v.heading, self.unix0 + self.t),
                    );
                }
                if state {
                    Self::send(
                        out,
                        &Sentence::Osi(Box::new(Osi {
                            fin_motor: "7F7F7F7F80".into(),
                            mode: self.mode.clone(),
                            next_wp: "0".into(),
                            lat,
                            lon,
                            speed_kn,
                            dist_to_next: "0.0".into(),
                            error: "N".into(),
                            altimeter_ft: 100.0,
                            park_time: "P0".into(),
                            mag_declination: "-14.5".into(),
                            mission: self.mission.clone(),
                            remaining_time: "0".into(),
                            heading: v.heading,
                            depth_ft: v.depth * FEET_PER_METRE,
                        })),
                    );
                }
                if compass {
                    Self::send(
                        out,
                        &Sentence::Compass(Compass {
                            heading: v.heading,
                            pitch: 0.0,
                            roll: 0.0,
                            temperature: 12.0,
                            depth_ft: v.depth * FEET_PER_METRE,
                        }),
                    );
                }
            }
            Sentence::Oms(o) => {
                self.stats.oms += 1;
                let valid = (0.0..=360.0).contains(&o.heading)
                    && o.depth >= 0.0
                    && o.speed_kn >= 0.0
                    && o.timeout_s <= 120;
                if !valid {
                    // Remote Helm error 20: "OMS incorrect values".
                    self.ack(out, crate::codec::ack_type::OMS, 20);
                    return;
                }
                let depth_m = if Oms::depth_unit_is_feet(self.opts.remote_helm_version_major) {
                    o.depth / FEET_PER_METRE
                } else {
                    o.depth
                };
                self.vehicle.set_setpoint(Setpoint {
                    heading: o.heading,
                    speed: o.speed_kn * MPS_PER_KNOT,
                    depth: depth_m,
                });
                self.oms_until = Some(self.t + f64::from(o.timeout_s));
                self.stats.last_oms = Some(o);
                self.ack(out, crate::codec::ack_type::OMS, 0);
            }
            Sentence::OmStart { mission } => {
                self.stats.omstart += 1;
                self.mission = mission;
                self.mode = "W".into();
                self.ack(out, crate::codec::ack_type::OMSTART, 0);
            }
            Sentence::OmStop => {
                self.stats.omstop += 1;
                self.mode = "N".into();
                self.ack(out, crate::codec::ack_type::OMSTOP, 0);
            }
            _ => {
                self.stats.bad_lines += 1;
            }
        }
    }
}

impl Session for IverSession {
    fn on_bytes(&mut self, bytes: &[u8], out: &mut Vec<u8>) {
        for &b in bytes {
            if b == b'\n' {
                if !self.discarding {
                    let line = std::mem::take(&mut self.line);
                    match std::str::from_utf8(&line) {
                        Ok(l) => self.on_line(l.trim_end_matches('\r'), out),
                        Err(_) => self.stats.bad_lines += 1,
                    }
                }
                self.line.clear();
                self.discarding = false;
            } else if !self.discarding {
                if self.line.len() > MAX_SENTENCE {
                    self.stats.oversized_lines += 1;
                    self.discarding = true;
                    self.line.clear();
                } else {
                    self.line.push(b);
                }
            }
        }
    }

    fn step(&mut self, dt: f64, _out: &mut Vec<u8>) {
        self.t += dt;
        if let Some(until) = self.oms_until
            && self.t > until
        {
            // The command lapsed: the UVC stops where it is (holding heading and depth).
            self.stats.oms_timeouts += 1;
            self.oms_until = None;
            let sp = self.vehicle.setpoint();
            self.vehicle.set_setpoint(Setpoint { speed: 0.0, ..sp });
        }
        self.vehicle.step(dt);
    }

    fn reset_input(&mut self) {
        self.line.clear();
        self.discarding = false;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lines(out: &[u8]) -> Vec<String> {
        String::from_utf8(out.to_vec())
            .unwrap()
            .split_terminator("\r\n")
            .map(String::from)
            .collect()
    }

    #[test]
    fn answers_osd_and_steers_on_oms_in_feet_or_metres() {
        for (rh, depth_field, want_m) in [(5, "3.0", 3.0), (4, "9.8", 9.8 * 0.3048)] {
            let mut s = IverSession::new(IverOptions {
                remote_helm_version_major: rh,
                ..Default::default()
            });
            let mut out = Vec::new();
            s.on_bytes(b"$OSD,G,C,S,P,,,,*5F\r\n", &mut out);
            let l = lines(&out);
            assert_eq!(l.len(), 3, "{l:?}");
            assert!(l[0].starts_with("$GPRMC,"));
            assert!(l[1].starts_with("$OSI,7F7F7F7F80,N,"));
            assert!(l[2].starts_with("$C0.0P"));
            out.clear();
            let oms = crate::codec::with_checksum(&format!("OMS,180.0,{depth_field},45.0,2.9,5"));
            s.on_bytes(format!("{oms}\r\n").as_bytes(), &mut out);
            assert_eq!(lines(&out), vec!["$ACK,9,0,0*5C"]);
            let sp = s.vehicle().setpoint();
            assert!((sp.depth - want_m).abs() < 1e-9, "{sp:?}");
            assert!((sp.speed - 2.9 * MPS_PER_KNOT).abs() < 1e-9);
            assert_eq!(sp.heading, 180.0);
            // Not refreshed: the command lapses after its timeout.
            for _ in 0..60 {
                s.step(0.1, &mut out);
            }
            assert_eq!(s.stats.oms_timeouts, 1);
            assert_eq!(s.vehicle().setpoint().speed, 0.0);
        }
    }

    #[test]
    fn noise_and_oversized_lines_are_counted_not_fatal() {
        let mut s = IverSession::new(IverOptions::default());
        let mut out = Vec::new();
        let mut junk = vec![b'x'; 5000];
        junk.extend_from_slice(b"\r\n\xff\xfe\r\n$OSD,G,C,S,P,,,,*00\r\n$OSD,,,S,,,,,\r\n");
        s.on_bytes(&junk, &mut out);
        assert_eq!(s.stats.oversized_lines, 1);
        assert_eq!(s.stats.bad_lines, 2);
        assert_eq!(lines(&out).len(), 1, "the good poll is answered");
    }
}
