//! The one ArduPilot emulator: an autopilot as a backseat sees it over MAVLink, on the
//! simulator's vehicle model, with a firmware switch — [`RoverSession`] (Rover, motorboat frame)
//! and [`SubSession`] (ArduSub, BlueROV2) are [`ArdupilotSession`] of [`Rover`] and [`Sub`].
//! Written once here: the session's frames in (COMMAND_LONG and SET_MODE among them), boot,
//! the mode (DO_SET_MODE's checks, the change announced by a HEARTBEAT), arming, COMMAND_ACK,
//! STATUSTEXT, the HEARTBEAT, the streams' schedule, and the fault hooks; the link side (frames,
//! clock, stream schedule, message layout) in `link`. Each firmware's differences are its own
//! small part ([`FirmwarePart`]): `rover` and `sub`.
//!
//! # Fault hooks (for the chaos harness and tests)
//! On a running [`Emulator`](frontseat_sim::emulator::Emulator) of either firmware, through
//! `emu.session()`; each takes effect without an output buffer:
//! - [`refuse_commands`](ArdupilotSession::refuse_commands)`(Some(MavResult::MAV_RESULT_DENIED))`:
//!   every COMMAND_LONG and SET_MODE addressed to the vehicle is answered so (any MAV_RESULT)
//!   and not acted on; `None` ends it.
//! - [`change_mode`](ArdupilotSession::change_mode)`(mode)`: the vehicle switches mode by itself
//!   at its next step (after boot), as a pilot's RC switch or a failsafe would, and announces it
//!   by a HEARTBEAT.
//! - [`go_silent`](ArdupilotSession::go_silent)`(true)`: the vehicle sends nothing (HEARTBEAT,
//!   streams, ACKs, STATUSTEXT) until `go_silent(false)`; it goes on hearing and acting.
//! - [`fault_counters`](ArdupilotSession::fault_counters)`()`: what the hooks made it do.
//! - dropping the backseat's connection is the runner's:
//!   [`emu.drop_connection()`](frontseat_sim::emulator::Emulator::drop_connection) (TCP).
//! - garbage and truncated frames are the runner's too: `emu.inject_bytes(bytes)`.

/// A firmware's stats (`$stats`, with `frames_in`, `bad_input`, `commands` and `statustexts`)
/// made the [`Counters`](link::Counters) the shared part counts in.
macro_rules! shared_counters {
    ($stats:ty) => {
        impl super::link::Counters for $stats {
            fn tally(&mut self) -> super::link::Tally<'_> {
                super::link::Tally {
                    frames_in: &mut self.frames_in,
                    bad_input: &mut self.bad_input,
                    commands: &mut self.commands,
                    statustexts: &mut self.statustexts,
                }
            }
        }
    };
}

mod link;
mod rover;
mod sub;

use mavlink::MessageData;

use frontseat_sim::vehicle::Vehicle;

use crate::codec::{MavMessage, decode};
use crate::dialect::*;
use crate::modes::Firmware;
use link::{Autopilot, Counters, MAX_TEXTS, Snapshot};

pub use link::FaultCounters;
pub use rover::{Rover, RoverOptions, RoverStats};
pub use sub::{Sub, SubOptions, SubStats, heading_error};

/// The emulated ArduPilot Rover.
pub type RoverSession = ArdupilotSession<Rover>;
/// The emulated ArduSub.
pub type SubSession = ArdupilotSession<Sub>;

/// An emulated ArduPilot autopilot running firmware `F`.
pub struct ArdupilotSession<F: FirmwarePart> {
    ap: Autopilot,
    vehicle: Vehicle,
    mode: u32,
    armed: bool,
    /// The firmware's own state.
    fw: F,
    pub stats: F::Stats,
}

/// What one firmware adds to the emulator: its options, counters, modes, targets, dynamics
/// and failsafes. Implemented by [`Rover`] and [`Sub`].
pub trait FirmwarePart: Sized + Send + 'static {
    /// How the vehicle starts.
    type Options;
    /// What it saw and did (frames, commands and STATUSTEXTs among them).
    type Stats: Counters + Default + Send;
    /// Its mode numbers and names.
    const FIRMWARE: Firmware;
    /// The mode at power on.
    const POWER_ON_MODE: u32;
    /// HEARTBEAT's system_status during boot.
    const BOOTING: MavState;
    /// A disarming is announced by a HEARTBEAT at once.
    const DISARM_HEARTBEAT: bool;

    /// The part, the vehicle model and the link, at power on.
    fn start(opts: Self::Options) -> (Self, Vehicle, Autopilot);
    /// HEARTBEAT's type.
    fn mav_type(&self) -> MavType;
    /// HEARTBEAT's base_mode flags in `mode`, beside custom mode and armed.
    fn mode_flags(mode: u32) -> MavModeFlag;
    /// A failsafe is on (HEARTBEAT says critical).
    fn failsafe(&self) -> bool;
    /// A known mode the firmware refuses now (saying why, if it does).
    fn refuses_mode(s: &mut ArdupilotSession<Self>, mode: u32, out: &mut Vec<u8>) -> bool;
    /// The vehicle is about to leave its mode for `mode`: what the old mode held is dropped.
    fn entering(s: &mut ArdupilotSession<Self>, mode: u32);
    /// A decoded message from system `sender`, other than COMMAND_LONG and SET_MODE.
    fn handle(s: &mut ArdupilotSession<Self>, sender: u8, msg: MavMessage, out: &mut Vec<u8>);
    /// The COMMAND_LONGs other than arming, modes and message intervals, addressed to us.
    fn command(
        s: &mut ArdupilotSession<Self>,
        c: &COMMAND_LONG_DATA,
        out: &mut Vec<u8>,
    ) -> MavResult;
    /// Just armed (before "Arming motors" is said).
    fn armed(s: &mut ArdupilotSession<Self>);
    /// Boot is over.
    fn booted(s: &mut ArdupilotSession<Self>, out: &mut Vec<u8>);
    /// `dt` sim seconds of the firmware's control and dynamics.
    fn drive(s: &mut ArdupilotSession<Self>, dt: f64, out: &mut Vec<u8>);
    /// The stream `id` (not HEARTBEAT) as the firmware sends it; `None`: nothing to send.
    fn stream(s: &mut ArdupilotSession<Self>, id: u32, snap: &Snapshot) -> Option<MavMessage>;
}

impl<F: FirmwarePart> ArdupilotSession<F> {
    pub fn new(opts: F::Options) -> Self {
        let (fw, vehicle, ap) = F::start(opts);
        Self {
            ap,
            vehicle,
            mode: F::POWER_ON_MODE,
            armed: false,
            fw,
            stats: F::Stats::default(),
        }
    }

    /// Which firmware it runs.
    pub fn firmware(&self) -> Firmware {
        F::FIRMWARE
    }

    pub fn mode(&self) -> u32 {
        self.mode
    }

    pub fn armed(&self) -> bool {
        self.armed
    }

    pub fn vehicle(&self) -> &Vehicle {
        &self.vehicle
    }

    pub fn sim_time(&self) -> f64 {
        self.ap.t
    }

    /// Fault hook: every COMMAND_LONG and SET_MODE addressed to the vehicle is answered with
    /// `answer` (MAV_RESULT_DENIED, _FAILED, …) and not acted on; `None` ends it.
    pub fn refuse_commands(&mut self, answer: Option<MavResult>) {
        self.ap.faults.refusal = answer;
    }

    /// Fault hook: the vehicle switches to `mode` by itself at its next step (after boot), as a
    /// pilot's RC switch or a failsafe would, announcing it by a HEARTBEAT.
    pub fn change_mode(&mut self, mode: u32) {
        self.ap.faults.own_mode = Some(mode);
    }

    /// Hook (tests, the bench): at its next step after boot the vehicle is armed and in GUIDED,
    /// as an operator at the ground station would leave it, for a backseat tested or measured
    /// without playing that operator. Call it once the firmware would take GUIDED (Rover:
    /// [`RoverSession::ekf_ready`]; Sub: [`SubSession::position_ok`]).
    pub fn operator_arms_guided(&mut self) {
        self.ap.faults.arm_guided = true;
    }

    /// Fault hook: the vehicle sends nothing (no HEARTBEAT, stream, ACK or STATUSTEXT) while
    /// `silent`, and goes on hearing and acting on what it is sent.
    pub fn go_silent(&mut self, silent: bool) {
        self.ap.faults.silent = silent;
    }

    /// What the fault hooks made the vehicle do.
    pub fn fault_counters(&self) -> FaultCounters {
        self.ap.faults.counters.clone()
    }

    /// Sends a STATUSTEXT (cut to the 50 characters the message holds).
    pub fn statustext(&mut self, severity: MavSeverity, text: &str, out: &mut Vec<u8>) {
        let cut: String = text.chars().take(50).collect();
        let texts = self.stats.tally().statustexts;
        if texts.len() < MAX_TEXTS {
            texts.push(cut.clone());
        }
        self.ap.send(
            MavMessage::STATUSTEXT(STATUSTEXT_DATA {
                severity,
                text: cut.as_str().into(),
            }),
            out,
        );
    }

    /// The vehicle is put in `mode`, announced by a HEARTBEAT at once as ArduPilot's GCS sees
    /// it (a no-op when in it).
    fn set_mode(&mut self, mode: u32, out: &mut Vec<u8>) {
        if mode != self.mode {
            F::entering(self, mode);
            self.mode = mode;
            self.heartbeat(out);
        }
    }

    fn heartbeat(&mut self, out: &mut Vec<u8>) {
        let mut base = MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | F::mode_flags(self.mode);
        if self.armed {
            base |= MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED;
        }
        let status = self
            .ap
            .system_status(F::BOOTING, self.fw.failsafe(), self.armed);
        self.ap
            .heartbeat(self.mode, self.fw.mav_type(), base, status, out);
    }

    /// Arming accepted after boot (a no-op when armed already).
    fn arm(&mut self, out: &mut Vec<u8>) {
        if !self.armed {
            self.armed = true;
            F::armed(self);
            self.statustext(MavSeverity::MAV_SEVERITY_INFO, "Arming motors", out);
        }
    }

    /// Disarming, saying `why` (a no-op when disarmed).
    fn disarm(&mut self, why: &str, out: &mut Vec<u8>) {
        if self.armed {
            self.armed = false;
            self.statustext(MavSeverity::MAV_SEVERITY_INFO, why, out);
            if F::DISARM_HEARTBEAT {
                self.heartbeat(out);
            }
        }
    }

    /// MAV_CMD_DO_SET_MODE: param1's custom-mode bit and a known mode number in param2, after
    /// boot, unless the firmware refuses it.
    fn mode_command(&mut self, c: &COMMAND_LONG_DATA, out: &mut Vec<u8>) -> MavResult {
        let m = c.param2;
        let valid = (c.param1 as u32) & 1 == 1
            && m.is_finite()
            && m >= 0.0
            && m.fract() == 0.0
            && F::FIRMWARE.mode_name(m as u32).is_some();
        if !valid || self.ap.initialising() || F::refuses_mode(self, m as u32, out) {
            MavResult::MAV_RESULT_FAILED
        } else {
            self.set_mode(m as u32, out);
            MavResult::MAV_RESULT_ACCEPTED
        }
    }

    /// A COMMAND_LONG addressed to us, answered by COMMAND_ACK: arming, modes and message
    /// intervals alike on every firmware, the rest the firmware's own.
    fn command(&mut self, c: &COMMAND_LONG_DATA, out: &mut Vec<u8>) {
        if !self.ap.for_me(c.target_system) {
            return;
        }
        *self.stats.tally().commands += 1;
        let result = if let Some(refusal) = self.ap.faults.refusal {
            self.ap.faults.counters.commands_refused += 1;
            refusal
        } else {
            match c.command {
                MavCmd::MAV_CMD_COMPONENT_ARM_DISARM => self.arm_command(c.param1, out),
                MavCmd::MAV_CMD_DO_SET_MODE => self.mode_command(c, out),
                MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL => self.ap.set_interval(c.param1, c.param2),
                _ => F::command(self, c, out),
            }
        };
        self.ap.send(
            MavMessage::COMMAND_ACK(COMMAND_ACK_DATA {
                command: c.command,
                result,
            }),
            out,
        );
    }

    /// MAV_CMD_COMPONENT_ARM_DISARM: param1 1 arms (not during boot), 0 disarms.
    fn arm_command(&mut self, param1: f32, out: &mut Vec<u8>) -> MavResult {
        if param1 == 1.0 {
            if self.ap.initialising() {
                self.statustext(
                    MavSeverity::MAV_SEVERITY_CRITICAL,
                    "PreArm: AHRS not healthy",
                    out,
                );
                MavResult::MAV_RESULT_FAILED
            } else {
                self.arm(out);
                MavResult::MAV_RESULT_ACCEPTED
            }
        } else if param1 == 0.0 {
            self.disarm("Disarming motors", out);
            MavResult::MAV_RESULT_ACCEPTED
        } else {
            MavResult::MAV_RESULT_DENIED
        }
    }

    /// Bytes from the backseat: each whole frame decoded and handled.
    fn receive(&mut self, bytes: &[u8], out: &mut Vec<u8>) {
        let mut frames = Vec::new();
        let mut bad = 0;
        self.ap.deframer.feed(bytes, &mut |r| match r {
            Ok(fr) => frames.push(fr),
            Err(_) => bad += 1,
        });
        *self.stats.tally().bad_input += bad;
        for fr in frames {
            match decode(&fr) {
                Ok((h, msg)) => {
                    *self.stats.tally().frames_in += 1;
                    match msg {
                        MavMessage::COMMAND_LONG(c) => self.command(&c, out),
                        // ArduPilot takes the old SET_MODE as DO_SET_MODE and acknowledges it so.
                        #[allow(deprecated)]
                        MavMessage::SET_MODE(m) => self.command(
                            &COMMAND_LONG_DATA {
                                command: MavCmd::MAV_CMD_DO_SET_MODE,
                                param1: f32::from(m.base_mode.bits()),
                                param2: m.custom_mode as f32,
                                target_system: m.target_system,
                                ..Default::default()
                            },
                            out,
                        ),
                        msg => F::handle(self, h.system_id, msg, out),
                    }
                }
                Err(_) => *self.stats.tally().bad_input += 1,
            }
        }
    }

    /// `dt` sim seconds: the end of boot, a mode change of the vehicle's own, the firmware's
    /// dynamics, then the streams due.
    fn advance(&mut self, dt: f64, out: &mut Vec<u8>) {
        let was_init = self.ap.initialising();
        self.ap.t += dt;
        if was_init && !self.ap.initialising() {
            F::booted(self, out);
        }
        if !self.ap.initialising()
            && let Some(mode) = self.ap.faults.own_mode.take()
        {
            self.ap.faults.counters.own_mode_changes += 1;
            self.set_mode(mode, out);
        }
        if !self.ap.initialising() && std::mem::take(&mut self.ap.faults.arm_guided) {
            self.arm(out);
            self.set_mode(F::FIRMWARE.guided(), out);
        }
        F::drive(self, dt, out);
        for id in self.ap.due() {
            if id == HEARTBEAT_DATA::ID {
                self.heartbeat(out);
            } else {
                let snap = self.ap.snapshot(&mut self.vehicle);
                if let Some(msg) = F::stream(self, id, &snap) {
                    self.ap.send(msg, out);
                }
            }
        }
    }

    /// A silent vehicle's output since `start` is withheld.
    fn withhold_if_silent(&mut self, start: usize, out: &mut Vec<u8>) {
        let faults = &mut self.ap.faults;
        if faults.silent && out.len() > start {
            faults.counters.bytes_withheld += (out.len() - start) as u64;
            out.truncate(start);
        }
    }
}

impl<F: FirmwarePart> frontseat_sim::emulator::Session for ArdupilotSession<F> {
    fn on_bytes(&mut self, bytes: &[u8], out: &mut Vec<u8>) {
        let start = out.len();
        self.receive(bytes, out);
        self.withhold_if_silent(start, out);
    }

    fn step(&mut self, dt: f64, out: &mut Vec<u8>) {
        let start = out.len();
        self.advance(dt, out);
        self.withhold_if_silent(start, out);
    }

    fn reset_input(&mut self) {
        self.ap.reset_input();
    }
}
