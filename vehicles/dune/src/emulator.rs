//! A DUNE LAUV as a backseat sees it on its BackSeat TCP server, on the simulator's vehicle
//! model: EstimatedState at 20 Hz (a reference point plus the NED offset, re-centred beyond
//! 1 km), VehicleState at 2 Hz and on change, PlanControlState, Heartbeat, Announce; PlanControl
//! START of a FollowReference (bare or in a PlanSpecification, dst = its id or 0xFFF0), the
//! References it follows (toward the point, at the speed and depth given, loitering when close),
//! the maneuver's timeout (References stop → FAILURE, SERVICE, thrust off), MANDONE, STOP and
//! Abort (dst = its id exactly); our own requests come back as DUNE loops them back.
//!
//! Fault hooks, for the chaos harness (`frontseat chaos --vehicle dune`), set through the
//! running emulator's session and acted on at its next step:
//! - [`DuneSession::refuse_plans`]: the vehicle refuses plans — the running maneuver fails
//!   ("plan refused by the vehicle") and every PlanControl START is answered FAILURE until the
//!   refusal is lifted; the vehicle stays in SERVICE.
//! - [`DuneSession::take_control`]: the vehicle changes mode on its own — the maneuver fails and
//!   the vehicle goes to the given op_mode (EXTERNAL: someone else holds the control loops;
//!   CALIBRATION; ERROR) until [`DuneSession::release_control`] puts it back in SERVICE.

use frontseat_sim::emulator::Session;
use frontseat_sim::vehicle::{Limits, Setpoint, Vehicle, wrap_heading};

use crate::imc::{self, ByteOrder, Deframer, Header, Message, consts};
use crate::infer::{self, TIMEOUT_TEXT};

/// How the emulated LAUV starts.
#[derive(Debug, Clone, PartialEq)]
pub struct DuneOptions {
    pub lat: f64,
    pub lon: f64,
    pub limits: Limits,
    pub imc_id: u16,
    pub sys_name: String,
    /// Sim seconds in BOOT before SERVICE.
    pub boot_s: f64,
    /// Water depth (EstimatedState.alt = this − depth).
    pub water_depth: f64,
    /// `Horizontal Tolerance` of the maneuver: within radius + this of the point it loiters.
    pub horizontal_tolerance: f64,
}

impl Default for DuneOptions {
    fn default() -> Self {
        Self {
            // lauv-simulator-1's GPS start (etc/lauv-simulator-1.ini).
            lat: 41.1850,
            lon: -8.7062,
            limits: Limits {
                accel: 0.3,
                hdg_rate: 10.0,
                z_rate: 0.15,
            },
            imc_id: 0x00D1,
            sys_name: "lauv-simulator-1".into(),
            boot_s: 1.0,
            water_depth: 50.0,
            horizontal_tolerance: 15.0,
        }
    }
}

/// What the emulated vehicle saw and did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DuneStats {
    pub packets_in: u64,
    pub bad_input: u64,
    /// Requests addressed elsewhere (dst 0xFFFF, another id): silently dropped, as DUNE does.
    pub not_for_us: u64,
    pub plans_started: u64,
    pub plans_refused: u64,
    pub references: u64,
    /// References from another source than the maneuver's control_src.
    pub references_refused: u64,
    pub timeouts: u64,
    pub mandone: u64,
    pub stops: u64,
    pub aborts: u64,
}

#[derive(Debug, Clone, PartialEq)]
struct Maneuver {
    control_src: u16,
    control_ent: u8,
    timeout: f64,
    started: f64,
    last_reference: Option<f64>,
    /// The point to go to (lat, lon in rad).
    target: Option<(f64, f64)>,
    radius: f64,
    request_id: u16,
    src: u16,
}

pub struct DuneSession {
    opts: DuneOptions,
    vehicle: Vehicle,
    deframer: Deframer,
    t: f64,
    op_mode: u8,
    loops: u32,
    maneuver: Option<Maneuver>,
    /// The plan id of the running (or last) plan, for replies.
    plan_id: String,
    last_error: String,
    last_outcome: u8,
    /// EstimatedState's reference point (lat, lon in degrees); x/y are true north/east metres
    /// from it, as DUNE's navigation gives them.
    reference: (f64, f64),
    next_es: f64,
    next_vs: f64,
    next_pcs: f64,
    next_hb: f64,
    next_announce: f64,
    /// Fault hook: refuse every plan START while set.
    refusing: bool,
    /// Fault hook: the op_mode to go to on its own at the next step (None: stay).
    take_over: Option<u8>,
    /// Fault hook: the running maneuver fails at the next step.
    fail_maneuver: bool,
    pub stats: DuneStats,
}

const ES_PERIOD: f64 = 0.05;
const VS_PERIOD: f64 = 0.5;
const PCS_PERIOD: f64 = 1.0 / 3.0;
/// DUNE's navigation re-centres its reference point beyond this offset.
const RECENTRE_M: f64 = 1000.0;
const BROADCAST: u16 = 0xFFF0;

impl DuneSession {
    pub fn new(opts: DuneOptions) -> Self {
        Self {
            vehicle: Vehicle::new(opts.lat, opts.lon, opts.limits, (0.0, 0.0)),
            deframer: Deframer::new(),
            t: 0.0,
            op_mode: consts::op_mode::BOOT,
            loops: 0,
            maneuver: None,
            plan_id: String::new(),
            last_error: String::new(),
            last_outcome: 0,
            reference: (opts.lat, opts.lon),
            next_es: 0.0,
            next_vs: 0.0,
            next_pcs: 0.0,
            next_hb: 0.0,
            next_announce: 0.0,
            refusing: false,
            take_over: None,
            fail_maneuver: false,
            stats: DuneStats::default(),
            opts,
        }
    }

    pub fn vehicle(&self) -> &Vehicle {
        &self.vehicle
    }

    pub fn op_mode(&self) -> u8 {
        self.op_mode
    }

    /// Sim seconds since boot.
    pub fn time(&self) -> f64 {
        self.t
    }

    pub fn maneuver_running(&self) -> bool {
        self.maneuver.is_some()
    }

    /// Fault hook: while `refuse`, the running maneuver fails (at the next step) and every plan
    /// START is refused; lifting it lets the next START in.
    pub fn refuse_plans(&mut self, refuse: bool) {
        self.refusing = refuse;
        self.fail_maneuver |= refuse;
    }

    /// Fault hook: at the next step the vehicle leaves any maneuver and goes to `op_mode` on its
    /// own (EXTERNAL, CALIBRATION or ERROR), where it stays until [`Self::release_control`].
    pub fn take_control(&mut self, op_mode: u8) {
        self.take_over = Some(op_mode);
        self.fail_maneuver = true;
    }

    /// Fault hook: the vehicle is back in SERVICE, ready for a plan.
    pub fn release_control(&mut self) {
        self.take_over = Some(consts::op_mode::SERVICE);
    }

    fn header(&self, dst: u16) -> Header {
        Header {
            src_ent: 0,
            ..Header::new(self.opts.imc_id, dst, 1.7e9 + self.t)
        }
    }

    fn emit(&self, dst: u16, msg: Message, out: &mut Vec<u8>) {
        if let Ok(b) = imc::encode(&self.header(dst), &msg, ByteOrder::Little) {
            out.extend_from_slice(&b);
        }
    }

    fn vehicle_state(&self, out: &mut Vec<u8>) {
        let m = self.maneuver.is_some();
        self.emit(
            imc::NULL_ADDRESS,
            imc::VehicleState {
                op_mode: self.op_mode,
                error_count: 0,
                error_ents: String::new(),
                maneuver_type: if m {
                    infer::FOLLOW_REFERENCE
                } else {
                    imc::NULL_ID
                },
                maneuver_stime: self.maneuver.as_ref().map_or(-1.0, |m| 1.7e9 + m.started),
                maneuver_eta: 0xFFFF,
                control_loops: self.loops,
                flags: 0,
                last_error: self.last_error.clone(),
                last_error_time: -1.0,
            }
            .into(),
            out,
        );
    }

    fn plan_control_state(&self, out: &mut Vec<u8>) {
        let m = self.maneuver.is_some();
        self.emit(
            imc::NULL_ADDRESS,
            imc::PlanControlState {
                state: if m {
                    consts::pcs::EXECUTING
                } else if self.op_mode == consts::op_mode::SERVICE {
                    consts::pcs::READY
                } else {
                    consts::pcs::BLOCKED
                },
                plan_id: if m {
                    self.plan_id.clone()
                } else {
                    String::new()
                },
                plan_eta: -1,
                plan_progress: -1.0,
                man_id: if m { "1".into() } else { String::new() },
                man_type: if m {
                    infer::FOLLOW_REFERENCE
                } else {
                    imc::NULL_ID
                },
                man_eta: -1,
                last_outcome: self.last_outcome,
            }
            .into(),
            out,
        );
    }

    fn estimated_state(&mut self, out: &mut Vec<u8>) {
        let (rlat, rlon) = self.reference;
        let (lat, lon) = self.vehicle.lat_lon();
        let (north, east) = infer::offset(
            rlat.to_radians(),
            rlon.to_radians(),
            lat.to_radians(),
            lon.to_radians(),
        );
        let v = &self.vehicle;
        let h = v.heading.to_radians();
        let psi = if h > std::f64::consts::PI {
            h - 2.0 * std::f64::consts::PI
        } else {
            h
        };
        self.emit(
            imc::NULL_ADDRESS,
            imc::EstimatedState {
                lat: rlat.to_radians(),
                lon: rlon.to_radians(),
                height: 0.0,
                x: north as f32,
                y: east as f32,
                z: v.depth as f32,
                psi: psi as f32,
                u: v.speed as f32,
                vx: (v.speed * h.cos()) as f32,
                vy: (v.speed * h.sin()) as f32,
                depth: v.depth as f32,
                alt: (self.opts.water_depth - v.depth) as f32,
                ..Default::default()
            }
            .into(),
            out,
        );
    }

    fn reply(&self, src: u16, pc: &imc::PlanControl, kind: u8, info: &str, out: &mut Vec<u8>) {
        self.emit(
            src,
            imc::PlanControl {
                kind,
                op: pc.op,
                request_id: pc.request_id,
                plan_id: pc.plan_id.clone(),
                flags: 0,
                arg: None,
                info: info.into(),
            }
            .into(),
            out,
        );
    }

    /// The PlanControl FAILURE answering `m`'s START: the vehicle aborted, refused or timed out
    /// the plan (`info` says which).
    fn plan_failed(&mut self, m: &Maneuver, info: &str, out: &mut Vec<u8>) {
        self.emit(
            m.src,
            imc::PlanControl {
                kind: consts::plan_control::FAILURE,
                op: consts::plan_control::START,
                request_id: m.request_id,
                plan_id: self.plan_id.clone(),
                flags: 0,
                arg: None,
                info: info.into(),
            }
            .into(),
            out,
        );
    }

    /// The maneuver ends: loops off, SERVICE, the setpoint's thrust off (the LAUV coasts and,
    /// positively buoyant, rises).
    fn end_maneuver(&mut self, outcome: u8, out: &mut Vec<u8>) {
        self.maneuver = None;
        self.loops = 0;
        self.last_outcome = outcome;
        self.op_mode = consts::op_mode::SERVICE;
        let sp = self.vehicle.setpoint();
        self.vehicle.set_setpoint(Setpoint {
            speed: 0.0,
            depth: 0.0,
            ..sp
        });
        self.vehicle_state(out);
        self.plan_control_state(out);
    }

    fn on_packet(&mut self, frame: &[u8], out: &mut Vec<u8>) {
        let (h, msg) = match imc::decode(frame) {
            Ok(x) => x,
            Err(_) => {
                self.stats.bad_input += 1;
                return;
            }
        };
        self.stats.packets_in += 1;
        match msg {
            Message::PlanControl(pc) if pc.kind == consts::plan_control::REQUEST => {
                // `Loopback Internal Messages = true`: the client's own request comes back.
                out.extend_from_slice(frame);
                if h.dst != self.opts.imc_id && h.dst != BROADCAST {
                    self.stats.not_for_us += 1;
                    return;
                }
                self.on_plan_control(h.src, &pc, out);
            }
            Message::Reference(r) => {
                if h.dst != self.opts.imc_id && h.dst != BROADCAST {
                    self.stats.not_for_us += 1;
                    return;
                }
                self.on_reference(h.src, h.src_ent, &r, out);
            }
            Message::Abort(_) => {
                out.extend_from_slice(frame);
                if h.dst != self.opts.imc_id {
                    self.stats.not_for_us += 1;
                    return;
                }
                self.stats.aborts += 1;
                if let Some(m) = self.maneuver.clone() {
                    self.plan_failed(&m, "aborted", out);
                }
                self.op_mode = consts::op_mode::ERROR;
                self.last_error = "got abort request".into();
                self.vehicle_state(out);
                self.end_maneuver(consts::plan_control::FAILURE, out);
            }
            _ => {}
        }
    }

    fn on_plan_control(&mut self, src: u16, pc: &imc::PlanControl, out: &mut Vec<u8>) {
        use consts::plan_control::*;
        match pc.op {
            START => {
                let fr = match pc.arg.as_deref() {
                    Some(Message::FollowReference(f)) => Some(f.clone()),
                    Some(Message::PlanSpecification(s)) => {
                        s.maneuvers.0.iter().find_map(|m| match m {
                            Message::PlanManeuver(pm) => match pm.data.as_deref() {
                                Some(Message::FollowReference(f)) => Some(f.clone()),
                                _ => None,
                            },
                            _ => None,
                        })
                    }
                    _ => None,
                };
                let Some(fr) = fr else {
                    self.stats.plans_refused += 1;
                    return self.reply(
                        src,
                        pc,
                        FAILURE,
                        "the emulator runs FollowReference plans only",
                        out,
                    );
                };
                if self.refusing {
                    self.stats.plans_refused += 1;
                    return self.reply(src, pc, FAILURE, "plan refused by the vehicle", out);
                }
                if self.op_mode != consts::op_mode::SERVICE || self.maneuver.is_some() {
                    self.stats.plans_refused += 1;
                    return self.reply(src, pc, FAILURE, "vehicle not in SERVICE", out);
                }
                self.stats.plans_started += 1;
                self.plan_id = pc.plan_id.clone();
                self.reply(src, pc, SUCCESS, "plan loaded", out);
                self.reply(
                    src,
                    pc,
                    SUCCESS,
                    &format!("{}: executing maneuver", pc.plan_id),
                    out,
                );
                self.maneuver = Some(Maneuver {
                    control_src: fr.control_src,
                    control_ent: fr.control_ent,
                    timeout: f64::from(fr.timeout),
                    started: self.t,
                    last_reference: None,
                    target: None,
                    radius: 0.0,
                    request_id: pc.request_id,
                    src,
                });
                self.op_mode = consts::op_mode::MANEUVER;
                self.last_error.clear();
                // Waiting in place until a Reference comes.
                let sp = self.vehicle.setpoint();
                self.vehicle.set_setpoint(Setpoint { speed: 0.0, ..sp });
                self.emit(
                    src,
                    imc::FollowRefState {
                        control_src: fr.control_src,
                        control_ent: fr.control_ent,
                        reference: None,
                        state: consts::follow_ref_state::WAIT,
                        proximity: 0,
                    }
                    .into(),
                    out,
                );
                self.vehicle_state(out);
            }
            STOP => {
                self.stats.stops += 1;
                self.reply(src, pc, SUCCESS, "OK", out);
                if self.maneuver.is_some() {
                    self.end_maneuver(FAILURE, out);
                }
            }
            _ => self.reply(src, pc, FAILURE, "unsupported operation", out),
        }
    }

    fn on_reference(&mut self, src: u16, src_ent: u8, r: &imc::Reference, out: &mut Vec<u8>) {
        let Some(m) = self.maneuver.clone() else {
            return;
        };
        let src_ok = m.control_src == imc::NULL_ADDRESS || m.control_src == src;
        let ent_ok = m.control_ent == imc::ANY_ENTITY || m.control_ent == src_ent;
        if !(src_ok && ent_ok) {
            self.stats.references_refused += 1;
            return;
        }
        self.stats.references += 1;
        if r.flags & consts::reference::MANDONE != 0 {
            self.stats.mandone += 1;
            self.emit(
                m.src,
                imc::PlanControl {
                    kind: consts::plan_control::SUCCESS,
                    op: consts::plan_control::START,
                    request_id: m.request_id,
                    plan_id: self.plan_id.clone(),
                    flags: 0,
                    arg: None,
                    info: "plan completed".into(),
                }
                .into(),
                out,
            );
            return self.end_maneuver(consts::plan_control::SUCCESS, out);
        }
        let mut sp = self.vehicle.setpoint();
        let mut target = m.target;
        if r.flags & consts::reference::LOCATION != 0 && r.lat.is_finite() && r.lon.is_finite() {
            let (n, e) = infer::offset(
                self.opts.lat.to_radians(),
                self.opts.lon.to_radians(),
                r.lat,
                r.lon,
            );
            if n.is_finite() && e.is_finite() && n.hypot(e) < 1e6 {
                target = Some((r.lat, r.lon));
            }
        }
        if r.flags & consts::reference::SPEED != 0
            && let Some(Message::DesiredSpeed(s)) = r.speed.as_deref()
            && s.speed_units == consts::METERS_PS
            && s.value.is_finite()
        {
            sp.speed = s.value.clamp(0.0, 3.0);
        }
        if r.flags & consts::reference::Z != 0
            && let Some(Message::DesiredZ(z)) = r.z.as_deref()
            && z.z_units == consts::Z_DEPTH
            && z.value.is_finite()
        {
            // DUNE clamps to the vehicle's maximum depth.
            sp.depth = f64::from(z.value).clamp(0.0, 100.0);
        }
        self.loops = if sp.speed > 0.0 {
            consts::CL_PATH
                | consts::CL_DEPTH
                | consts::CL_YAW
                | consts::CL_SPEED
                | consts::CL_TORQUE
        } else {
            0
        };
        self.vehicle.set_setpoint(sp);
        let radius = if r.flags & consts::reference::RADIUS != 0 && r.radius.is_finite() {
            f64::from(r.radius).max(0.0)
        } else {
            0.0
        };
        if let Some(mm) = &mut self.maneuver {
            mm.last_reference = Some(self.t);
            mm.target = target;
            mm.radius = radius;
        }
        let (state, proximity) = self.steer();
        self.emit(
            src,
            imc::FollowRefState {
                control_src: m.control_src,
                control_ent: m.control_ent,
                reference: Some(Box::new(r.clone().into())),
                state,
                proximity,
            }
            .into(),
            out,
        );
    }

    /// Points the vehicle at its target; the maneuver's state and proximity.
    fn steer(&mut self) -> (u8, u8) {
        let Some(m) = &self.maneuver else {
            return (consts::follow_ref_state::WAIT, 0);
        };
        let Some((tlat, tlon)) = m.target else {
            return (consts::follow_ref_state::WAIT, 0);
        };
        let radius = m.radius;
        // The true bearing from where the vehicle says it is, as DUNE's path controller steers.
        let (lat, lon) = self.vehicle.lat_lon();
        let (dn, de) = infer::offset(lat.to_radians(), lon.to_radians(), tlat, tlon);
        let mut sp = self.vehicle.setpoint();
        if dn.hypot(de) <= radius + self.opts.horizontal_tolerance {
            // Loitering at the point: the emulator holds still.
            sp.speed = 0.0;
            self.vehicle.set_setpoint(sp);
            return (
                consts::follow_ref_state::LOITER,
                consts::follow_ref_state::XY_NEAR,
            );
        }
        sp.heading = wrap_heading(de.atan2(dn).to_degrees());
        self.vehicle.set_setpoint(sp);
        (
            consts::follow_ref_state::GOTO,
            consts::follow_ref_state::FAR,
        )
    }
}

impl Session for DuneSession {
    fn on_bytes(&mut self, bytes: &[u8], out: &mut Vec<u8>) {
        let mut frames = Vec::new();
        self.deframer.feed(bytes, &mut |r| frames.push(r));
        for f in frames {
            match f {
                Ok(f) => self.on_packet(&f, out),
                Err(_) => self.stats.bad_input += 1,
            }
        }
    }

    fn step(&mut self, dt: f64, out: &mut Vec<u8>) {
        self.t += dt;
        if std::mem::take(&mut self.fail_maneuver)
            && let Some(m) = self.maneuver.clone()
        {
            self.plan_failed(&m, "plan refused by the vehicle", out);
            self.end_maneuver(consts::plan_control::FAILURE, out);
        }
        if let Some(mode) = self.take_over.take()
            && self.op_mode != consts::op_mode::BOOT
        {
            self.op_mode = mode;
            self.vehicle_state(out);
        }
        if self.op_mode == consts::op_mode::BOOT && self.t >= self.opts.boot_s {
            self.op_mode = consts::op_mode::SERVICE;
            self.vehicle_state(out);
        }
        if let Some(m) = self.maneuver.clone() {
            let since = self.t - m.last_reference.unwrap_or(m.started);
            if m.timeout > 0.0 && since > m.timeout {
                self.stats.timeouts += 1;
                self.emit(
                    m.src,
                    imc::FollowRefState {
                        control_src: m.control_src,
                        control_ent: m.control_ent,
                        reference: None,
                        state: consts::follow_ref_state::TIMEOUT,
                        proximity: 0,
                    }
                    .into(),
                    out,
                );
                self.plan_failed(&m, TIMEOUT_TEXT, out);
                self.last_error = TIMEOUT_TEXT.into();
                self.end_maneuver(consts::plan_control::FAILURE, out);
            } else {
                self.steer();
            }
        }
        self.vehicle.step(dt);
        let (lat, lon) = self.vehicle.lat_lon();
        let (rlat, rlon) = self.reference;
        let (n, e) = infer::offset(
            rlat.to_radians(),
            rlon.to_radians(),
            lat.to_radians(),
            lon.to_radians(),
        );
        if n.hypot(e) > RECENTRE_M {
            self.reference = (lat, lon);
        }
        while self.next_es <= self.t {
            self.next_es += ES_PERIOD;
            self.estimated_state(out);
        }
        if self.next_vs <= self.t {
            self.next_vs = self.t + VS_PERIOD;
            self.vehicle_state(out);
        }
        if self.next_pcs <= self.t {
            self.next_pcs = self.t + PCS_PERIOD;
            self.plan_control_state(out);
        }
        if self.next_hb <= self.t {
            self.next_hb = self.t + 1.0;
            self.emit(imc::NULL_ADDRESS, imc::Heartbeat {}.into(), out);
        }
        if self.next_announce <= self.t {
            self.next_announce = self.t + 10.0;
            let (lat, lon) = self.vehicle.lat_lon();
            self.emit(
                imc::NULL_ADDRESS,
                imc::Announce {
                    sys_name: self.opts.sys_name.clone(),
                    sys_type: 2,
                    owner: 0xFFFF,
                    lat: lat.to_radians(),
                    lon: lon.to_radians(),
                    height: 0.0,
                    services: "imc+tcp://127.0.0.1:6006/".into(),
                }
                .into(),
                out,
            );
        }
    }

    fn reset_input(&mut self) {
        self.deframer = Deframer::new();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const US: u16 = 0x4001;

    fn start() -> Vec<u8> {
        let opts = DuneOptions::default();
        imc::encode(
            &Header::new(US, opts.imc_id, 0.0),
            &imc::PlanControl {
                kind: consts::plan_control::REQUEST,
                op: consts::plan_control::START,
                request_id: 1,
                plan_id: "p".into(),
                flags: 0,
                arg: Some(Box::new(
                    imc::FollowReference {
                        control_src: US,
                        control_ent: 0xFF,
                        timeout: 10.0,
                        ..Default::default()
                    }
                    .into(),
                )),
                info: String::new(),
            }
            .into(),
            ByteOrder::Little,
        )
        .unwrap()
    }

    #[test]
    fn refusing_plans_fails_the_running_one_and_refuses_starts_until_lifted() {
        let mut emu = DuneSession::new(DuneOptions::default());
        let mut out = Vec::new();
        emu.step(2.0, &mut out);
        emu.on_bytes(&start(), &mut out);
        assert!(emu.maneuver_running());
        emu.refuse_plans(true);
        emu.step(0.1, &mut out);
        assert!(!emu.maneuver_running());
        assert_eq!(emu.op_mode(), consts::op_mode::SERVICE);
        emu.on_bytes(&start(), &mut out);
        assert!(!emu.maneuver_running());
        assert_eq!(emu.stats.plans_refused, 1);
        emu.refuse_plans(false);
        emu.on_bytes(&start(), &mut out);
        assert!(emu.maneuver_running());
    }

    #[test]
    fn taking_control_leaves_the_maneuver_until_released() {
        let mut emu = DuneSession::new(DuneOptions::default());
        let mut out = Vec::new();
        emu.step(2.0, &mut out);
        emu.on_bytes(&start(), &mut out);
        assert!(emu.maneuver_running());
        emu.take_control(consts::op_mode::EXTERNAL);
        emu.step(0.1, &mut out);
        assert!(!emu.maneuver_running());
        assert_eq!(emu.op_mode(), consts::op_mode::EXTERNAL);
        emu.on_bytes(&start(), &mut out);
        assert!(!emu.maneuver_running(), "a START taken while EXTERNAL");
        emu.release_control();
        emu.step(0.1, &mut out);
        assert_eq!(emu.op_mode(), consts::op_mode::SERVICE);
        emu.on_bytes(&start(), &mut out);
        assert!(emu.maneuver_running());
    }
}
