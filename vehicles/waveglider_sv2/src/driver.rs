//! The Wave Glider SV2 driver: Goby3's `WavegliderSV2FrontSeat` as a payload polled by the C&C
//! board, with its gaps closed — every frame is CRC-checked and bad ones dropped and counted, a
//! generic NAK is logged and reading goes on (Goby3 went deaf), headings are wrapped and
//! rounded, the C&C's ACK/NAK of a pulled command becomes a CommandResponse, and the state
//! drops to NOT_CONNECTED when the port goes away.

use std::sync::Arc;
use std::time::Duration;

use frontseat_config::InterfaceConfig;

use crate::edge::{
    self as codec, DeviceInfo, Frame, HeadingCommand, Message, Packet, PayloadStatus, WAITING_BIT,
    msg_type,
};
use frontseat_actors::clock::SimClock;
use frontseat_actors::driver::{Driver, DriverContext, DriverIoEvent, SignalSink};
use frontseat_actors::drivers::kit::{
    Asker, LinkState, OwnedTask, TIMED_OUT, config_secs, log_due, raw_binary, refuse, send_bytes,
};
use frontseat_actors::drivers::vehicle_link;
use frontseat_actors::link::byte::{self, ByteLinkConfig, LinkStats};
use frontseat_actors::link::framing::{FrameCutter, Framing};
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CommandRequest, FrontSeatState, InterfaceData, Raw,
};
use frontseat_actors::ratelog::RateLimitedLog;

/// C&C main task: where enumerate and status replies go (as in Goby3).
const CC_MAIN: u16 = 0x0000;
/// C&C command task: where the queued command goes.
const CC_COMMAND: u16 = 0x0001;

#[derive(Clone, Debug)]
pub struct Settings {
    pub link: ByteLinkConfig,
    /// board_id << 8 | task_id.
    pub address: u16,
    pub providing_data_timeout: Duration,
    pub ack_timeout: Duration,
    pub publish_navigation: bool,
}

impl Settings {
    pub fn from_config(cfg: &InterfaceConfig) -> Self {
        let c = &cfg.driver.waveglider_sv2;
        Self {
            link: vehicle_link(
                &c.link,
                &c.pm_serial_port,
                c.pm_serial_baud,
                Framing::Frames(sv2_frames),
            ),
            address: ((c.board_id.min(255) as u16) << 8) | c.task_id.min(255) as u16,
            providing_data_timeout: config_secs(c.providing_data_timeout),
            ack_timeout: config_secs(c.link.ack_timeout),
            publish_navigation: c.publish_navigation,
        }
    }
}

#[derive(Debug, Clone, Copy)]
struct Queued {
    heading: u16,
    asker: Asker,
}

#[derive(Debug, Clone, Copy)]
struct InFlight {
    cmd: Queued,
    transaction_id: u16,
    deadline: Duration,
}

#[derive(Debug, Default, Clone, PartialEq)]
pub struct Sv2Counters {
    pub enumerates: u64,
    pub status_requests: u64,
    pub commands_sent: u64,
    pub acks: u64,
    pub naks: u64,
    pub bad_frames: u64,
    pub unhandled: u64,
    pub empty_queue_pulls: u64,
    pub superseded: u64,
    pub ack_timeouts: u64,
    pub write_failures: u64,
}

pub struct WavegliderSv2Driver {
    settings: Settings,
    /// Its data watch: the C&C's status requests.
    link: LinkState,
    link_task: OwnedTask,
    pub link_stats: Arc<LinkStats>,
    queued: Option<Queued>,
    in_flight: Option<InFlight>,
    bad_log: RateLimitedLog,
    pub counters: Sv2Counters,
}

impl WavegliderSv2Driver {
    pub fn new(settings: Settings) -> Self {
        Self {
            settings,
            link: LinkState::default(),
            link_task: OwnedTask::default(),
            link_stats: Arc::new(LinkStats::default()),
            queued: None,
            in_flight: None,
            bad_log: RateLimitedLog::for_bad_input(),
            counters: Sv2Counters::default(),
        }
    }

    fn bad(&mut self, what: &str) {
        self.counters.bad_frames += 1;
        // The process-wide count (frontseat.bad_lines, the interface's detail) every driver bumps.
        frontseat_actors::drivers::kit::bad_line();
        if let Some(suppressed) = log_due(&mut self.bad_log) {
            tracing::warn!(%what, suppressed, "bad input from the Wave Glider C&C");
        }
    }

    fn send(&mut self, p: Packet, sig: &mut dyn SignalSink) -> bool {
        let Some(w) = self.link.writer() else {
            self.counters.write_failures += 1;
            return false;
        };
        let bytes = match p.encode() {
            Ok(b) => b,
            Err(e) => {
                tracing::warn!(error = %e, "SV2 frame not encodable");
                return false;
            }
        };
        match send_bytes(w, bytes, sig) {
            Ok(()) => true,
            Err(e) => {
                self.counters.write_failures += 1;
                if let Some(suppressed) = log_due(&mut self.bad_log) {
                    tracing::warn!(error = %e, suppressed, "frame to the C&C not sent");
                }
                false
            }
        }
    }

    fn handle_frame(&mut self, bytes: &[u8], now: Duration, sig: &mut dyn SignalSink) {
        sig.raw_from_frontseat(raw_binary(bytes.to_vec()));
        let frame = match Frame::from_unescaped(bytes) {
            Ok(f) => f,
            Err(e) => return self.bad(&e.to_string()),
        };
        let packet = match Packet::from_frame(&frame) {
            Ok(p) => p,
            Err(e) => return self.bad(&e.to_string()),
        };
        let me = self.settings.address;
        let txn = packet.transaction_id;
        let original = frame.header.message_type;
        match packet.message {
            Message::RequestEnumerate { .. } => {
                self.counters.enumerates += 1;
                self.send(
                    Packet {
                        dest: CC_MAIN,
                        src: me,
                        transaction_id: txn,
                        message: Message::EnumerateReply {
                            original_msg_type: original,
                            device: DeviceInfo::goby(me),
                        },
                    },
                    sig,
                );
            }
            Message::RequestStatus {
                latitude,
                longitude,
                fix_valid,
                ..
            } => {
                self.counters.status_requests += 1;
                self.link.data.fresh(now);
                let waiting = self.queued.is_some();
                self.send(
                    Packet {
                        dest: CC_MAIN,
                        src: me,
                        transaction_id: txn,
                        message: Message::StatusReply {
                            original_msg_type: original,
                            status: PayloadStatus {
                                devices_responding: 1,
                                devices_in_message: 1,
                                version: if waiting { WAITING_BIT | 1 } else { 1 },
                                board_address: me,
                                ..Default::default()
                            },
                        },
                    },
                    sig,
                );
                if self.settings.publish_navigation
                    && fix_valid == b'Y'
                    && let Some(ns) =
                        codec::status_to_node_status(latitude, longitude, SimClock::unix_now())
                {
                    sig.data_from_frontseat(InterfaceData {
                        node_status: Some(ns),
                        ..Default::default()
                    });
                }
            }
            Message::RequestQueuedMessage => {
                let Some(cmd) = self.queued.take() else {
                    // As Goby3: nothing to give, no reply; the C&C times out.
                    self.counters.empty_queue_pulls += 1;
                    tracing::debug!("C&C pulled a queued message but none is queued");
                    return;
                };
                let sent = self.send(
                    Packet {
                        dest: CC_COMMAND,
                        src: me,
                        transaction_id: txn,
                        message: Message::QueuedCommandReply {
                            original_msg_type: original,
                            command: HeadingCommand::follow_heading(cmd.heading),
                        },
                    },
                    sig,
                );
                if sent {
                    self.counters.commands_sent += 1;
                    if let Some(old) = self.in_flight.take() {
                        old.cmd.asker.fail(
                            sig,
                            TIMED_OUT,
                            "no ACK/NAK from the C&C before the next command",
                        );
                    }
                    self.in_flight = Some(InFlight {
                        cmd,
                        transaction_id: txn,
                        deadline: now + self.settings.ack_timeout,
                    });
                } else {
                    cmd.asker.fail(sig, 1, "C&C link gone");
                }
            }
            Message::QueuedMessageAckNak { response_code, .. } => {
                self.counters.acks += 1;
                if let Some(f) = self.in_flight.take() {
                    if f.transaction_id != txn {
                        tracing::debug!(
                            expected = f.transaction_id,
                            got = txn,
                            "ACK/NAK for another transaction; taken as the verdict on the last command"
                        );
                    }
                    let ok = response_code == 0;
                    f.cmd.asker.answer(
                        sig,
                        ok,
                        i32::from(response_code),
                        (!ok).then(|| {
                            format!("C&C refused the heading command (code {response_code})")
                        }),
                    );
                }
            }
            Message::Nak {
                original_msg_type,
                response_code,
                ..
            } => {
                // Goby3 decoded this as the wrong type and stopped reading; we log and go on.
                self.counters.naks += 1;
                if let Some(s) = log_due(&mut self.bad_log) {
                    tracing::warn!(
                        original_msg_type,
                        response_code,
                        suppressed = s,
                        "generic NAK from the C&C"
                    );
                }
                if original_msg_type & !WAITING_BIT == msg_type::ACK
                    && let Some(f) = self.in_flight.take()
                {
                    f.cmd.asker.fail(
                        sig,
                        i32::from(response_code),
                        format!("C&C NAK (code {response_code})"),
                    );
                }
            }
            Message::Ack { .. } => {
                self.counters.acks += 1;
            }
            other => {
                self.counters.unhandled += 1;
                tracing::debug!(message_type = other.message_type(), "unhandled SV2 message");
            }
        }
    }
}

impl Driver for WavegliderSv2Driver {
    fn name(&self) -> &str {
        "waveglider_sv2"
    }

    fn start(&mut self, ctx: DriverContext) {
        self.link_task.set(byte::spawn(
            self.settings.link.clone(),
            ctx.io,
            self.link_stats.clone(),
        ));
    }

    fn handle_io(&mut self, ev: DriverIoEvent, now: Duration, sig: &mut dyn SignalSink) {
        match ev {
            DriverIoEvent::Connected(w) => {
                tracing::info!(link = %self.settings.link.transport.describe(), "connected to the Wave Glider C&C");
                // As Goby3: accepting as soon as the port is open; the C&C decides by polling.
                self.link
                    .opened(w, FrontSeatState::FrontseatAcceptingCommands);
            }
            DriverIoEvent::Frame(b) => self.handle_frame(&b, now, sig),
            DriverIoEvent::Line(_) => self.bad("text line on an SV2 frame link"),
            DriverIoEvent::BadInput(what) => self.bad(&what),
            DriverIoEvent::Disconnected(reason) => {
                tracing::warn!(%reason, "Wave Glider link lost; reopening");
                self.link.lost();
            }
        }
    }

    fn send_command_to_frontseat(
        &mut self,
        req: &CommandRequest,
        _now: Duration,
        sig: &mut dyn SignalSink,
    ) {
        let Some(heading) = req
            .desired_course
            .as_ref()
            .and_then(|c| codec::heading_to_wire(c.heading()))
        else {
            refuse(
                req,
                "the Wave Glider takes only a finite desired_course heading",
                sig,
            );
            return;
        };
        // One slot, as Goby3: a newer heading replaces one the C&C has not pulled yet.
        // No setpoint lane here (no `direct_command`): the payload never writes a command on
        // its own, the C&C pulls it with RequestQueuedMessage and the heading goes out as the
        // reply to that transaction, so there is nothing a publisher's thread could write at
        // once (ARCHITECTURE.md "The lane per vehicle family").
        let new = Queued {
            heading,
            asker: Asker::of(req),
        };
        if let Some(old) = self.queued.replace(new) {
            self.counters.superseded += 1;
            old.asker.fail(
                sig,
                2,
                "superseded by a newer command before the C&C pulled it",
            );
        }
    }

    fn send_data_to_frontseat(
        &mut self,
        _data: &InterfaceData,
        _now: Duration,
        _sig: &mut dyn SignalSink,
    ) {
        // As Goby3: no data path to the C&C.
    }

    fn send_raw_to_frontseat(&mut self, _raw: &Raw, _now: Duration, _sig: &mut dyn SignalSink) {
        // As Goby3: the payload only answers; unsolicited frames would break the polling.
        tracing::debug!(
            "raw_send_request ignored by the Wave Glider driver (payload only answers)"
        );
    }

    fn do_loop(&mut self, now: Duration, sig: &mut dyn SignalSink) {
        if self
            .link
            .data
            .expired(now, self.settings.providing_data_timeout)
        {
            tracing::warn!(
                "no status request from the C&C for {:?}: not providing data",
                self.settings.providing_data_timeout
            );
        }
        if let Some(f) = self.in_flight
            && f.deadline <= now
        {
            self.in_flight = None;
            self.counters.ack_timeouts += 1;
            f.cmd.asker.fail(
                sig,
                TIMED_OUT,
                format!(
                    "no ACK/NAK from the C&C within {:?}",
                    self.settings.ack_timeout
                ),
            );
        }
    }

    fn frontseat_state(&self) -> FrontSeatState {
        self.link.state
    }

    fn frontseat_providing_data(&self) -> bool {
        self.link.data.providing()
    }

    fn stop(&mut self) {
        self.link.close();
    }
}

/// The SV2's frames on a byte link (start byte 0x7E, escaping, size field, CRC-16/ARC), cut by
/// the codec's resynchronising decoder.
pub fn sv2_frames() -> Box<dyn FrameCutter> {
    Box::new(Sv2Frames(codec::FrameDecoder::new()))
}

struct Sv2Frames(codec::FrameDecoder);

impl FrameCutter for Sv2Frames {
    fn feed(&mut self, bytes: &[u8], out: &mut dyn FnMut(Result<Vec<u8>, String>)) {
        self.0.feed(bytes, &mut |r| match r {
            Ok(f) => out(f.unescaped().map_err(|e| e.to_string())),
            Err(e) => out(Err(format!("SV2 framing: {e}"))),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use frontseat_actors::link::LineWriter;
    use frontseat_actors::proto::goby::middleware::frontseat::protobuf::DesiredCourse;
    use tokio::sync::mpsc::Receiver;

    type Sink = frontseat_actors::driver::RecordingSink;

    fn driver() -> (WavegliderSv2Driver, Receiver<Vec<u8>>, Sink) {
        let mut cfg = InterfaceConfig::default();
        cfg.driver.waveglider_sv2.pm_serial_port = "/dev/null".into();
        cfg.driver.waveglider_sv2.publish_navigation = true;
        let mut d = WavegliderSv2Driver::new(Settings::from_config(&cfg));
        let mut sink = Sink::default();
        let (w, rx) = LineWriter::for_test();
        d.handle_io(DriverIoEvent::Connected(w), Duration::ZERO, &mut sink);
        (d, rx, sink)
    }

    fn from_cc(d: &mut WavegliderSv2Driver, sink: &mut Sink, txn: u16, m: Message, now: u64) {
        let f = Packet {
            dest: 0x0301,
            src: 0,
            transaction_id: txn,
            message: m,
        }
        .to_frame()
        .unescaped()
        .unwrap();
        d.handle_io(DriverIoEvent::Frame(f), Duration::from_secs(now), sink);
    }

    fn reply(rx: &mut Receiver<Vec<u8>>) -> Packet {
        let b = rx.try_recv().expect("a reply");
        let mut dec = codec::FrameDecoder::new();
        let mut v = Vec::new();
        dec.feed(&b, &mut |r| v.push(r));
        Packet::from_frame(&v.remove(0).unwrap()).unwrap()
    }

    fn status() -> Message {
        Message::RequestStatus {
            time: [0; 6],
            latitude: codec::degrees_to_wire(42.0),
            longitude: codec::degrees_to_wire(-71.0),
            fix_valid: b'Y',
        }
    }

    fn course(h: f64, id: i32) -> CommandRequest {
        CommandRequest {
            desired_course: Some(DesiredCourse {
                time: 0.0,
                heading: Some(h),
                ..Default::default()
            }),
            response_requested: Some(true),
            request_id: Some(id),
            ..Default::default()
        }
    }

    /// The golden exchange of the fact sheet (§7): enumerate, status, queue, pull, ACK/NAK.
    #[test]
    fn golden_exchange() {
        let (mut d, mut rx, mut sink) = driver();
        assert_eq!(
            d.frontseat_state(),
            FrontSeatState::FrontseatAcceptingCommands
        );
        from_cc(
            &mut d,
            &mut sink,
            1,
            Message::RequestEnumerate {
                protocols_supported: 1,
                commands_supported: 1,
            },
            0,
        );
        let wire = rx.try_recv().unwrap();
        assert_eq!(wire.len(), 61);
        assert_eq!(&wire[wire.len() - 2..], &[0x40, 0x30]);
        from_cc(&mut d, &mut sink, 2, status(), 1);
        assert!(d.frontseat_providing_data());
        let Message::StatusReply { status: s, .. } = reply(&mut rx).message else {
            panic!()
        };
        assert_eq!(s.version, 1);
        assert_eq!(sink.data.len(), 1, "navigation from the status request");

        d.send_command_to_frontseat(&course(90.0, 7), Duration::from_secs(1), &mut sink);
        from_cc(&mut d, &mut sink, 3, status(), 2);
        let Message::StatusReply { status: s, .. } = reply(&mut rx).message else {
            panic!()
        };
        assert_eq!(s.version, 0x8001);
        from_cc(&mut d, &mut sink, 4, Message::RequestQueuedMessage, 2);
        let wire = rx.try_recv().unwrap();
        let golden: Vec<u8> = "7E 29 00 01 00 01 03 04 00 01 00 40 00 01 00 0A FF FF FF FF 12 00 10 08 00 00 00 00 5A 00 00 00 00 00 00 00 00 00 02 19 99 D9"
            .split(' ')
            .map(|h| u8::from_str_radix(h, 16).unwrap())
            .collect();
        assert_eq!(wire, golden);
        assert!(sink.responses.is_empty());
        from_cc(
            &mut d,
            &mut sink,
            4,
            Message::QueuedMessageAckNak {
                command_format: 1,
                response_code: 0,
                message: vec![],
            },
            2,
        );
        assert_eq!(sink.responses.len(), 1);
        assert_eq!(sink.responses[0].request_successful, Some(true));
        assert_eq!(sink.responses[0].request_id, Some(7));
        // Nothing queued: no reply, counted.
        from_cc(&mut d, &mut sink, 5, Message::RequestQueuedMessage, 3);
        assert!(rx.try_recv().is_err());
        assert_eq!(d.counters.empty_queue_pulls, 1);
    }

    #[test]
    fn nak_does_not_stop_the_driver_and_supersede_and_timeout_answer() {
        let (mut d, mut rx, mut sink) = driver();
        from_cc(
            &mut d,
            &mut sink,
            1,
            Message::Nak {
                original_msg_type: 0x0001,
                response_code: 4,
                details: vec![],
            },
            0,
        );
        assert_eq!(d.counters.naks, 1);
        from_cc(&mut d, &mut sink, 2, status(), 0);
        assert!(matches!(
            reply(&mut rx).message,
            Message::StatusReply { .. }
        ));

        d.send_command_to_frontseat(&course(10.0, 1), Duration::ZERO, &mut sink);
        d.send_command_to_frontseat(&course(20.0, 2), Duration::ZERO, &mut sink);
        assert_eq!(sink.responses.len(), 1);
        assert_eq!(sink.responses[0].request_id, Some(1));
        assert_eq!(sink.responses[0].request_successful, Some(false));
        from_cc(&mut d, &mut sink, 3, Message::RequestQueuedMessage, 0);
        let Message::QueuedCommandReply { command, .. } = reply(&mut rx).message else {
            panic!()
        };
        assert_eq!(command.heading, 20);
        d.do_loop(Duration::from_secs(9), &mut sink);
        assert_eq!(sink.responses.len(), 1);
        d.do_loop(Duration::from_secs(10), &mut sink);
        assert_eq!(sink.responses.len(), 2);
        assert_eq!(sink.responses[1].request_id, Some(2));
        assert_eq!(sink.responses[1].request_successful, Some(false));

        // Polling stops: not providing data after 30 s.
        d.do_loop(Duration::from_secs(31), &mut sink);
        assert!(!d.frontseat_providing_data());
        // Bad frames and stray lines are counted, here and in the process-wide metric (only
        // ever grows, so other tests bumping it at once cannot make this fail).
        let process_wide = frontseat_telemetry::metrics::bad_lines();
        d.handle_io(
            DriverIoEvent::Frame(vec![0x7E, 1, 2]),
            Duration::ZERO,
            &mut sink,
        );
        d.handle_io(DriverIoEvent::Line("x".into()), Duration::ZERO, &mut sink);
        assert_eq!(d.counters.bad_frames, 2);
        assert!(frontseat_telemetry::metrics::bad_lines() >= process_wide + 2);
        d.handle_io(
            DriverIoEvent::Disconnected("x".into()),
            Duration::ZERO,
            &mut sink,
        );
        assert_eq!(d.frontseat_state(), FrontSeatState::FrontseatNotConnected);
    }
}
