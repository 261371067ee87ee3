//! What the payload sends, composed: a desired course as `$BPRMB` (in RPM through the table when
//! configured), the Bluefin commands, CTD, DCCL and modem lines, and the `$BPSTS` heartbeat with
//! the payload statuses it carries. Each becomes one sentence handed to the write queue.

use std::collections::BTreeMap;
use std::time::Duration;

use base64::Engine as _;

use super::{BluefinDriver, Cmd, MAX_PAYLOAD_STATUSES, Settings, error_code};
use crate::codec::{self, CtdOut, FromPayload, HorizontalMode, Rmb, SpeedMode, VerticalMode};
use frontseat_actors::driver::SignalSink;
use frontseat_actors::proto::frontseat::protobuf::bluefin as bf;
use frontseat_actors::proto::goby::acomms::protobuf::ModemRaw;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    DesiredCourse, InterfaceData,
    bluefin_extra_commands::{AbortReason, BluefinCommand, SilentMode},
    bluefin_extra_data::PayloadStatus,
};

impl BluefinDriver {
    pub(super) fn heartbeat(&mut self, now: Duration, sig: &mut dyn SignalSink) {
        self.last_heartbeat = Some(now);
        let unix = (self.wall)(now);
        let now_us = (unix * 1e6).max(0.0) as u64;
        self.payload_status.retain(|p| p.expire_time > now_us);
        // One entry per payload id: the one that expires first (Goby3's choice).
        let mut by_id: BTreeMap<i32, &PayloadStatus> = BTreeMap::new();
        for p in &self.payload_status {
            by_id
                .entry(p.id)
                .and_modify(|e| {
                    if p.expire_time < e.expire_time {
                        *e = p;
                    }
                })
                .or_insert(p);
        }
        let ok = !self.interface_in_error && by_id.values().all(|p| p.all_ok);
        let text = if by_id.is_empty() {
            "Deploy".to_string()
        } else {
            let mut t = goby_time_text(unix);
            for p in by_id.values() {
                t.push_str("; ");
                t.push_str(&p.msg);
            }
            t
        };
        let msg = FromPayload::Sts {
            time: codec::seconds_of_day(unix),
            ok,
            text,
        };
        self.enqueue(msg, None, now, sig);
    }

    fn rmb(&self, c: &DesiredCourse, tod: f64) -> Result<Rmb, String> {
        rmb(&self.settings, c, tod)
    }

    /// The common path of plain and Bluefin-extended CommandRequests.
    pub(super) fn command(&mut self, c: Cmd<'_>, now: Duration, sig: &mut dyn SignalSink) {
        let Cmd {
            desired,
            ext,
            response_requested,
            request_id,
            cancel_request_id,
        } = c;
        let request = response_requested.then_some(request_id);
        let mut cancelled = false;
        if let Some(cancel) = cancel_request_id {
            cancelled = self.cancel(cancel, sig);
        }
        let tod = self.tod(now);
        let ext_cmd = ext.map(|e| e.command()).filter(|c| {
            !matches!(
                c,
                BluefinCommand::UnknownCommand | BluefinCommand::DesiredCourse
            )
        });
        let msg = match (ext_cmd, ext) {
            (Some(cmd), Some(e)) => {
                if desired.is_some() {
                    tracing::warn!(
                        target: super::LOG_TARGET,
                        ?cmd,
                        "a Bluefin command and a desired_course in one request: only the command is sent"
                    );
                }
                match cmd {
                    BluefinCommand::TrimAdjust => FromPayload::Trm { time: tod },
                    BluefinCommand::BuoyancyAdjust => FromPayload::Boy { time: tod },
                    BluefinCommand::SilentMode => FromPayload::Sil {
                        time: tod,
                        silent: e.silent_mode() == SilentMode::Silent,
                    },
                    BluefinCommand::CancelCurrentBehavior | BluefinCommand::MissionEndConfirm => {
                        FromPayload::Rce { time: tod }
                    }
                    BluefinCommand::AbortMission => FromPayload::Abt {
                        time: tod,
                        with_errors: e.abort_reason() != AbortReason::SuccessfulMission,
                    },
                    BluefinCommand::MissionStartConfirm => FromPayload::Smc { time: tod },
                    BluefinCommand::UnknownCommand | BluefinCommand::DesiredCourse => return,
                }
            }
            _ => match desired {
                Some(c) => match self.rmb(c, tod) {
                    Ok(r) => FromPayload::Rmb(r),
                    Err(why) => {
                        self.problem("desired_course not sent", &why);
                        if let Some(id) = request {
                            Self::answer(sig, id, false, error_code::BAD_REQUEST, why);
                        }
                        return;
                    }
                },
                None => {
                    if let Some(id) = request {
                        if cancel_request_id.is_some() {
                            Self::answer(
                                sig,
                                id,
                                cancelled,
                                error_code::BAD_REQUEST,
                                "no such outstanding request",
                            );
                        } else {
                            Self::answer(
                                sig,
                                id,
                                false,
                                error_code::BAD_REQUEST,
                                "nothing to send: no desired_course and no Bluefin command",
                            );
                        }
                    }
                    return;
                }
            },
        };
        self.enqueue(msg, request, now, sig);
    }

    pub(super) fn data(&mut self, base: &InterfaceData, now: Duration, sig: &mut dyn SignalSink) {
        let unix = (self.wall)(now);
        let tod = codec::seconds_of_day(unix);
        if let Some(c) = &base.ctd_sample {
            let finite = |x: f64| x.is_finite().then_some(x);
            self.enqueue(
                FromPayload::Ctd(CtdOut {
                    time: tod,
                    conductivity: c.conductivity.and_then(finite),
                    temperature: finite(c.temperature),
                    pressure_kpa: finite(c.pressure).map(|p| p / 1000.0),
                    sample_time: codec::seconds_of_day(c.time),
                }),
                None,
                now,
                sig,
            );
        }
        if let Some(d) = &base.dccl_message {
            let b64 = base64::engine::general_purpose::STANDARD.encode(d);
            self.enqueue(
                FromPayload::Dcl {
                    time: tod,
                    base64: b64,
                },
                None,
                now,
                sig,
            );
        }
    }
}

/// Goby3's payload-status time text, `2024-Oct-10 12:00:31.000000`.
pub fn goby_time_text(unix: f64) -> String {
    let unix = if unix.is_finite() { unix.max(0.0) } else { 0.0 };
    let days = (unix / 86_400.0).floor() as i64;
    let tod = unix - days as f64 * 86_400.0;
    // Civil from days (Howard Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    const MONTHS: [&str; 12] = [
        "Jan", "Feb", "Mar", "Apr", "May", "Jun", "Jul", "Aug", "Sep", "Oct", "Nov", "Dec",
    ];
    let us = (tod * 1e6).round() as u64;
    let (h, rest) = (us / 3_600_000_000, us % 3_600_000_000);
    let (mi, rest) = (rest / 60_000_000, rest % 60_000_000);
    format!(
        "{y}-{}-{d:02} {h:02}:{mi:02}:{:02}.{:06}",
        MONTHS[(m - 1).clamp(0, 11) as usize],
        rest / 1_000_000,
        rest % 1_000_000
    )
}

impl BluefinDriver {
    pub fn send_bluefin_command(
        &mut self,
        req: &bf::CommandRequest,
        now: Duration,
        sig: &mut dyn SignalSink,
    ) {
        let c = Cmd {
            desired: req.desired_course.as_ref(),
            ext: req.bluefin_command.as_ref(),
            response_requested: req.response_requested(),
            request_id: req.request_id,
            cancel_request_id: req.cancel_request_id,
        };
        self.command(c, now, sig);
    }

    pub fn send_bluefin_data(
        &mut self,
        data: &bf::InterfaceData,
        now: Duration,
        sig: &mut dyn SignalSink,
    ) {
        let base = InterfaceData {
            node_status: None,
            ctd_sample: data.ctd_sample,
            dccl_message: data.dccl_message.clone(),
        };
        self.data(&base, now, sig);
        let Some(extra) = &data.bluefin_data else {
            return;
        };
        for p in &extra.payload_status {
            if self.payload_status.len() >= MAX_PAYLOAD_STATUSES {
                self.payload_status.remove(0);
            }
            self.payload_status.push(p.clone());
        }
        if self.settings.send_tmr
            && let Some(ModemRaw { raw, .. }) = &extra.micro_modem_raw_in
        {
            let line = String::from_utf8_lossy(raw).to_string();
            let tod = self.tod(now);
            self.enqueue(FromPayload::Tmr { time: tod, line }, None, now, sig);
        }
    }
}

fn rpm_for(settings: &Settings, speed: f64) -> Option<f64> {
    let t = settings.rpm_table.as_ref()?;
    let (first, last) = (t.first()?, t.last()?);
    if t.len() < 2 || speed <= first.0 {
        return Some(first.1);
    }
    if speed >= last.0 {
        return Some(last.1);
    }
    let i = t.iter().position(|p| p.0 >= speed)?;
    let (a, b) = (t[i - 1], t[i]);
    let f = if b.0 > a.0 {
        (speed - a.0) / (b.0 - a.0)
    } else {
        0.0
    };
    Some((a.1 + f * (b.1 - a.1)).round())
}

/// `$BPRMB` for a desired course; an error text when a value cannot be written.
pub(super) fn rmb(settings: &Settings, c: &DesiredCourse, tod: f64) -> Result<Rmb, String> {
    let (heading, depth, speed) = (c.heading(), c.depth(), c.speed());
    if !(heading.is_finite() && depth.is_finite() && speed.is_finite()) {
        return Err(format!(
            "desired_course has a non-finite value (heading {heading}, depth {depth}, speed {speed})"
        ));
    }
    if speed < 0.01 {
        return Ok(Rmb::stop(tod));
    }
    let (translational, speed_mode) = match rpm_for(settings, speed) {
        Some(rpm) => (rpm, SpeedMode::Rpm),
        None => (speed, SpeedMode::Speed),
    };
    Ok(Rmb {
        time: tod,
        horizontal: heading,
        vertical: depth,
        vertical_mode: VerticalMode::Depth,
        translational,
        speed_mode,
        horizontal_mode: HorizontalMode::Heading,
    })
}
