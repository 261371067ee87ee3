//! What the Huxley says, read: `$BFNVG` + `$BFNVR` into NodeStatus, the mission, control and
//! `$BFMSC` sentences into the frontseat state (per the accepting-commands hook), CTD into a
//! CtdSample, and buoyancy, trim, DVL and thruster sentences into the Bluefin extension's data.

use std::time::Duration;

use frontseat_config::AcceptingCommandsHook;

use super::{BluefinDriver, DATA};
use crate::codec::{self, AdjustStatus, FromHuxley, Nvr, Sentence};
use frontseat_actors::driver::{DriverExtension, SignalSink, raw_ascii};
use frontseat_actors::proto::frontseat::protobuf::bluefin as bf;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    BluefinExtraData, BuoyancyStatus, CtdSample, EulerAngles, FrontSeatState, InterfaceData,
    NodeStatus, Source, Speed, TrimStatus,
    bluefin_extra_data::{RawDvl, RawThrusterRotation},
    source::Sensor,
};
use frontseat_actors::proto::goby::middleware::protobuf::LatLonPoint;

impl BluefinDriver {
    pub(super) fn handle_line(&mut self, line: &str, now: Duration, sig: &mut dyn SignalSink) {
        sig.raw_from_frontseat(raw_ascii(line, ""));
        let sentence = match Sentence::parse(line) {
            Ok(s) => s,
            Err(codec::CodecError::Empty) => return,
            Err(e) => {
                self.stats.bad_lines += 1;
                frontseat_actors::drivers::kit::bad_line();
                self.problem(&format!("bad line from the Huxley: {e}"), line);
                return;
            }
        };
        // Anything well-formed proves the Huxley is alive.
        self.demerits = 0;
        let msg = match FromHuxley::from_sentence(&sentence) {
            Ok(m) => m,
            Err(e) => {
                self.stats.bad_lines += 1;
                frontseat_actors::drivers::kit::bad_line();
                self.problem(&format!("bad sentence from the Huxley: {e}"), line);
                return;
            }
        };
        match msg {
            FromHuxley::Nvg(n) => {
                self.nvg = Some(n);
                self.link.data.fresh(now);
            }
            FromHuxley::Nvr(r) => {
                if let Some(ns) = self.node_status(&r, now) {
                    sig.data_from_frontseat(InterfaceData {
                        node_status: Some(ns),
                        ..Default::default()
                    });
                }
            }
            FromHuxley::Ack(a) => self.handle_ack(a, now, sig),
            FromHuxley::Msc { .. } => {
                if self.settings.hook == AcceptingCommandsHook::BfmscTrigger {
                    self.link.state = FrontSeatState::FrontseatAcceptingCommands;
                }
            }
            FromHuxley::Mis { status, .. } => {
                if status.contains("Running") {
                    if self.settings.hook == AcceptingCommandsHook::BfmisRunningTrigger {
                        self.link.state = FrontSeatState::FrontseatAcceptingCommands;
                    } else if self.link.state != FrontSeatState::FrontseatAcceptingCommands {
                        self.link.state = FrontSeatState::FrontseatInControl;
                    }
                } else {
                    self.link.state = FrontSeatState::FrontseatIdle;
                }
            }
            FromHuxley::Ctl { control, .. } => {
                if self.settings.hook == AcceptingCommandsHook::BfctlTrigger {
                    if control {
                        self.link.state = FrontSeatState::FrontseatAcceptingCommands;
                    } else if self.link.state == FrontSeatState::FrontseatAcceptingCommands {
                        self.link.state = FrontSeatState::FrontseatInControl;
                    }
                }
            }
            FromHuxley::Boy(b) => emit(
                sig,
                extra(BluefinExtraData {
                    buoyancy_status: Some(buoyancy(&b)),
                    ..Default::default()
                }),
            ),
            FromHuxley::Trm(t) => emit(
                sig,
                extra(BluefinExtraData {
                    trim_status: Some(trim(&t)),
                    ..Default::default()
                }),
            ),
            FromHuxley::Dvl(d) => emit(
                sig,
                extra(BluefinExtraData {
                    dvl: Some(RawDvl {
                        dvl_time: d
                            .dvl_time
                            .map(|t| codec::unix_of_time_of_day(t, (self.wall)(now))),
                        u: d.u,
                        v: d.v,
                        w: d.w,
                        beam1_range: d.beams[0],
                        beam2_range: d.beams[1],
                        beam3_range: d.beams[2],
                        beam4_range: d.beams[3],
                        temperature: d.temperature,
                    }),
                    ..Default::default()
                }),
            ),
            FromHuxley::Rvl { rpm, speed, .. } => emit(
                sig,
                extra(BluefinExtraData {
                    thruster: Some(RawThrusterRotation {
                        rotation: rpm,
                        speed_from_lookup_table: speed,
                    }),
                    ..Default::default()
                }),
            ),
            FromHuxley::Ctd(c) => {
                let fix = self.nvg.as_ref().map(|n| (n.lat, n.lon, n.depth));
                let (Some(t), Some(p)) = (c.temperature, c.pressure_kpa) else {
                    self.stats.bad_lines += 1;
                    frontseat_actors::drivers::kit::bad_line();
                    self.problem("BFCTD without temperature or pressure", line);
                    return;
                };
                let nan = f64::NAN;
                let mut sample = CtdSample {
                    time: (self.wall)(now),
                    conductivity: c.conductivity_us_cm.map(|us| us / 1e4),
                    temperature: t,
                    pressure: p * 1000.0,
                    global_fix: LatLonPoint {
                        lat: fix.map_or(nan, |f| f.0),
                        lon: fix.map_or(nan, |f| f.1),
                        depth: fix.and_then(|f| f.2),
                        altitude: None,
                    },
                    ..Default::default()
                };
                // Salinity, sound speed, density (and depth without a $BFNVG), as Goby3.
                crate::seawater::fill_ctd(&mut sample);
                sig.data_from_frontseat(InterfaceData {
                    ctd_sample: Some(sample),
                    ..Default::default()
                });
            }
            FromHuxley::Sht { .. } => {
                tracing::warn!(target: super::LOG_TARGET, "the Huxley says it is shutting down ($BFSHT)");
            }
            FromHuxley::Other(id) => {
                self.stats.ignored_sentences += 1;
                tracing::debug!(target: super::LOG_TARGET, %id, "Huxley sentence not acted on");
            }
        }
    }

    fn node_status(&self, r: &Nvr, now: Duration) -> Option<NodeStatus> {
        let n = self.nvg.as_ref()?;
        let unix = (self.wall)(now);
        let tod = n.fix_time.unwrap_or(n.time);
        let speed = match (r.east, r.north) {
            (Some(e), Some(no)) => e.hypot(no),
            _ => 0.0,
        };
        Some(NodeStatus {
            time: codec::unix_of_time_of_day(tod, unix),
            global_fix: LatLonPoint {
                lat: n.lat,
                lon: n.lon,
                depth: Some(n.depth.unwrap_or(0.0)),
                altitude: n.altitude,
            },
            pose: EulerAngles {
                roll: n.roll,
                pitch: n.pitch,
                heading: n.heading,
                pitch_rate: r.pitch_rate,
                roll_rate: r.roll_rate,
                heading_rate: r.yaw_rate,
                ..Default::default()
            },
            speed: Speed {
                over_ground: speed,
                over_water: None,
            },
            source: (n.quality == Some(1)).then(|| {
                let mut s = Source::default();
                s.set_position(Sensor::Gps);
                s
            }),
            ..Default::default()
        })
    }
}

fn extra(data: BluefinExtraData) -> bf::InterfaceData {
    bf::InterfaceData {
        bluefin_data: Some(data),
        ..Default::default()
    }
}

fn buoyancy(b: &AdjustStatus) -> BuoyancyStatus {
    BuoyancyStatus {
        status: Some(b.status),
        error: Some(b.error),
        debug_string: Some(b.text.clone()),
        buoyancy_newtons: b.value,
    }
}

fn trim(t: &AdjustStatus) -> TrimStatus {
    TrimStatus {
        status: Some(t.status),
        error: Some(t.error.min(2)),
        debug_string: Some(t.text.clone()),
        pitch_trim_degrees: t.value,
        roll_trim_degrees: t.value2,
    }
}

/// Extension data to the interface, tagged with its type.
fn emit(sig: &mut dyn SignalSink, data: bf::InterfaceData) {
    sig.extension_from_frontseat(DriverExtension::encode(DATA, "Bluefin", &data));
}
