//! The emulator's fault hooks (the chaos harness's levers on an ArduPilot vehicle), on both
//! firmwares: a vehicle that refuses every command, one that changes mode by itself, one that
//! goes silent — run against the session directly, sim time stepped by hand — and the runner
//! dropping the backseat's connection, over a real loopback TCP socket.

use std::time::Duration;

use frontseat_ardupilot::codec::{Deframer, MavMessage, Sender, decode};
use frontseat_ardupilot::dialect::*;
use frontseat_ardupilot::emulator::{RoverOptions, RoverSession};
use frontseat_ardupilot::modes::{rover, sub};
use frontseat_ardupilot::sub_emulator::{SubOptions, SubSession};
use frontseat_sim::emulator::{Emulator, Endpoint, Session};
use tokio::io::AsyncReadExt;
use tokio::net::TcpStream;

/// A GCS on the session: frames in, frames out, sim time by hand.
struct Gcs<S: Session> {
    s: S,
    tx: Sender,
    rx: Deframer,
    heard: Vec<MavMessage>,
    bytes_heard: usize,
}

impl<S: Session> Gcs<S> {
    fn new(s: S) -> Self {
        Self {
            s,
            tx: Sender::new(255, 190),
            rx: Deframer::new(),
            heard: Vec::new(),
            bytes_heard: 0,
        }
    }

    /// Runs `f` on the session and hears what it sends.
    fn on(&mut self, f: impl FnOnce(&mut S, &mut Vec<u8>)) {
        let mut out = Vec::new();
        f(&mut self.s, &mut out);
        self.bytes_heard += out.len();
        let mut frames = Vec::new();
        self.rx
            .feed(&out, &mut |r| frames.push(r.expect("good frames")));
        let decoded = frames.iter().map(|f| decode(f).expect("decodes").1);
        self.heard.extend(decoded);
    }

    fn send(&mut self, msg: MavMessage) {
        let frame = self.tx.frame(&msg);
        self.on(|s, out| s.on_bytes(&frame, out));
    }

    fn run(&mut self, seconds: f64) {
        for _ in 0..(seconds / 0.1).round() as usize {
            self.on(|s, out| s.step(0.1, out));
        }
    }

    /// The COMMAND_ACK for `command`, if one was heard since the last `clear`.
    fn ack(&self, command: MavCmd) -> Option<MavResult> {
        self.heard.iter().find_map(|m| match m {
            MavMessage::COMMAND_ACK(a) if a.command == command => Some(a.result),
            _ => None,
        })
    }

    fn command(&mut self, command: MavCmd, p1: f32, p2: f32) -> Option<MavResult> {
        self.heard.clear();
        self.send(MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
            command,
            param1: p1,
            param2: p2,
            target_system: 1,
            target_component: 1,
            ..Default::default()
        }));
        self.ack(command)
    }

    #[allow(deprecated)] // SET_MODE: a GCS may still send it, and the vehicle answers it.
    fn set_mode_message(&mut self, mode: u32) -> Option<MavResult> {
        self.heard.clear();
        self.send(MavMessage::SET_MODE(SET_MODE_DATA {
            custom_mode: mode,
            target_system: 1,
            base_mode: MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
        }));
        self.ack(MavCmd::MAV_CMD_DO_SET_MODE)
    }

    fn heartbeat_modes(&self) -> Vec<u32> {
        self.heard
            .iter()
            .filter_map(|m| match m {
                MavMessage::HEARTBEAT(h) => Some(h.custom_mode),
                _ => None,
            })
            .collect()
    }
}

/// The same checks on each firmware: `$new` a booting session of type `$ty`, `$other` a mode that the
/// vehicle may be put in once booted and is not in after boot.
macro_rules! hook_tests {
    ($name:ident, $ty:ty, $new:expr, $other:expr) => {
        mod $name {
            use super::*;

            fn booted() -> Gcs<$ty> {
                let mut g: Gcs<$ty> = Gcs::new($new);
                // Past boot and the EKF's position (5 s): every mode may be entered.
                g.run(6.0);
                g
            }

            #[test]
            fn a_refusing_vehicle_answers_every_command_so_and_does_none() {
                let mut g: Gcs<$ty> = Gcs::new($new);
                g.run(6.0);
                let before = g.s.mode();
                g.s.refuse_commands(Some(MavResult::MAV_RESULT_DENIED));
                let set_mode = MavCmd::MAV_CMD_DO_SET_MODE;
                let arm = MavCmd::MAV_CMD_COMPONENT_ARM_DISARM;
                assert_eq!(
                    g.command(set_mode, 1.0, $other as f32),
                    Some(MavResult::MAV_RESULT_DENIED)
                );
                assert_eq!(g.command(arm, 1.0, 0.0), Some(MavResult::MAV_RESULT_DENIED));
                g.s.refuse_commands(Some(MavResult::MAV_RESULT_FAILED));
                assert_eq!(
                    g.set_mode_message($other),
                    Some(MavResult::MAV_RESULT_FAILED)
                );
                g.run(1.0);
                assert_eq!(g.s.mode(), before);
                assert!(!g.s.armed());
                assert_eq!(g.s.fault_counters().commands_refused, 3);

                g.s.refuse_commands(None);
                assert_eq!(
                    g.command(arm, 1.0, 0.0),
                    Some(MavResult::MAV_RESULT_ACCEPTED)
                );
                assert!(g.s.armed());
                // The old SET_MODE is taken as DO_SET_MODE and acknowledged so.
                assert_eq!(
                    g.set_mode_message($other),
                    Some(MavResult::MAV_RESULT_ACCEPTED)
                );
                assert_eq!(g.s.mode(), $other);
                assert_eq!(g.s.fault_counters().commands_refused, 3);
            }

            #[test]
            fn a_vehicle_changes_mode_by_itself_at_its_next_step_and_says_so() {
                let mut g = booted();
                g.heard.clear();
                g.s.change_mode($other);
                assert_ne!(g.s.mode(), $other, "not before the vehicle's next step");
                g.run(0.1);
                assert_eq!(g.s.mode(), $other);
                let modes = g.heartbeat_modes();
                assert!(!modes.is_empty(), "announced at once");
                assert!(modes.iter().all(|m| *m == $other), "{modes:?}");
                assert_eq!(g.s.fault_counters().own_mode_changes, 1);
            }

            #[test]
            fn a_mode_change_asked_during_boot_waits_for_its_end() {
                let mut g: Gcs<$ty> = Gcs::new($new);
                g.s.change_mode($other);
                g.run(0.5);
                assert_ne!(g.s.mode(), $other);
                assert_eq!(g.s.fault_counters().own_mode_changes, 0);
                g.run(1.0);
                assert_eq!(g.s.mode(), $other);
                assert_eq!(g.s.fault_counters().own_mode_changes, 1);
            }

            #[test]
            fn a_silent_vehicle_sends_nothing_and_still_acts() {
                let mut g = booted();
                g.s.go_silent(true);
                g.heard.clear();
                let heard_before = g.bytes_heard;
                g.run(3.0);
                let arm = MavCmd::MAV_CMD_COMPONENT_ARM_DISARM;
                assert_eq!(
                    g.command(arm, 1.0, 0.0),
                    None,
                    "no ACK from a silent vehicle"
                );
                g.run(1.0);
                assert_eq!(g.bytes_heard, heard_before);
                assert!(g.s.armed(), "it heard the command");
                let withheld = g.s.fault_counters().bytes_withheld;
                assert!(withheld > 0);

                g.s.go_silent(false);
                g.run(1.1);
                assert!(!g.heartbeat_modes().is_empty(), "HEARTBEATs again");
                assert_eq!(g.s.fault_counters().bytes_withheld, withheld);
            }
        }
    };
}

hook_tests!(
    rover_hooks,
    RoverSession,
    RoverSession::new(RoverOptions::default()),
    rover::HOLD
);
hook_tests!(
    sub_hooks,
    SubSession,
    SubSession::new(SubOptions::default()),
    sub::ALT_HOLD
);

const WITHIN: Duration = Duration::from_secs(10);

/// Reads until `n` bytes came, or the peer closed (`None`).
async fn read_bytes(c: &mut TcpStream, n: usize) -> Option<usize> {
    let mut got = 0;
    let mut buf = [0u8; 1024];
    while got < n {
        match tokio::time::timeout(WITHIN, c.read(&mut buf)).await {
            Ok(Ok(0)) | Ok(Err(_)) => return None,
            Ok(Ok(k)) => got += k,
            Err(_) => panic!("nothing from the emulator in {WITHIN:?}"),
        }
    }
    Some(got)
}

/// Reads (and drops) what is in flight until the peer closes.
async fn closed(c: &mut TcpStream) {
    let mut buf = [0u8; 1024];
    loop {
        match tokio::time::timeout(WITHIN, c.read(&mut buf)).await {
            Ok(Ok(0)) | Ok(Err(_)) => return,
            Ok(Ok(_)) => {}
            Err(_) => panic!("the connection was not closed in {WITHIN:?}"),
        }
    }
}

#[tokio::test]
async fn the_runner_drops_the_connection_and_takes_the_next_one() {
    let emu = Emulator::start(
        SubSession::new(SubOptions::default()),
        Endpoint::Tcp(([127, 0, 0, 1], 0).into()),
        20.0,
    )
    .await
    .expect("emulator binds loopback");
    let addr = emu.tcp_addr().expect("a TCP emulator has an address");
    let mut first = TcpStream::connect(addr).await.expect("connects");
    // A HEARTBEAT is 21 bytes on MAVLink 2: the vehicle is talking to us.
    assert!(read_bytes(&mut first, 21).await.is_some());

    emu.drop_connection();
    closed(&mut first).await;

    let mut second = TcpStream::connect(addr).await.expect("connects again");
    assert!(
        read_bytes(&mut second, 21).await.is_some(),
        "the vehicle talks on the next connection"
    );
}
