//! The Wave Glider SV2 Command & Control board, emulated on the basic simulator's vehicle model:
//! it is the master — enumerates the payload, polls its status at the payload's requested
//! period (sending time and its GPS position), pulls a waiting command when the status reply
//! says one is queued (Goby3's version bit or ACFR's original-type bit), steers to the heading
//! at a fixed cruise speed (the glider has no speed control through this path), and answers
//! with an ACK/NAK of the queued message.

use crate::codec::{FrameDecoder, HeadingCommand, Message, Packet, WAITING_BIT};

use frontseat_sim::emulator::Session;
use frontseat_sim::vehicle::{Limits, Setpoint, Vehicle};

/// The C&C board's own address (board 0x00, main task).
pub const CC_ADDRESS: u16 = 0x0000;

#[derive(Debug, Clone, PartialEq)]
pub struct Sv2Options {
    pub lat: f64,
    pub lon: f64,
    pub limits: Limits,
    /// Through-the-water speed when following a heading, m/s.
    pub cruise_speed: f64,
    /// Where the payload is expected (board << 8 | task).
    pub payload_address: u16,
    /// Re-enumerate after this many simulated seconds without an enumerate reply.
    pub enumerate_retry_s: f64,
}

impl Default for Sv2Options {
    fn default() -> Self {
        Self {
            lat: 42.358456,
            lon: -71.087589,
            limits: Limits {
                accel: 0.2,
                hdg_rate: 20.0,
                z_rate: 0.0,
            },
            cruise_speed: 1.5,
            payload_address: 0x0301,
            enumerate_retry_s: 2.0,
        }
    }
}

#[derive(Debug, Clone, Default, PartialEq)]
pub struct Sv2Stats {
    pub enumerate_replies: u64,
    pub status_replies: u64,
    pub commands: u64,
    pub last_heading: Option<u16>,
    pub frame_errors: u64,
    pub decode_errors: u64,
    pub other: u64,
}

pub struct Sv2Session {
    opts: Sv2Options,
    vehicle: Vehicle,
    decoder: FrameDecoder,
    t: f64,
    next_send: f64,
    poll_period: f64,
    enumerated: bool,
    txn: u16,
    unix0: f64,
    /// Stop polling (a silent C&C), for tests of the providing-data watchdog.
    pub paused: bool,
    pub stats: Sv2Stats,
}

impl Sv2Session {
    pub fn new(opts: Sv2Options) -> Self {
        let unix0 = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_secs_f64())
            .unwrap_or(0.0);
        Self {
            vehicle: Vehicle::new(opts.lat, opts.lon, opts.limits, (0.0, 0.0)),
            opts,
            decoder: FrameDecoder::new(),
            t: 0.0,
            next_send: 0.0,
            poll_period: 1.0,
            enumerated: false,
            txn: 0,
            unix0,
            paused: false,
            stats: Sv2Stats::default(),
        }
    }

    pub fn vehicle(&self) -> &Vehicle {
        &self.vehicle
    }

    fn send(&mut self, dest: u16, message: Message, out: &mut Vec<u8>) {
        self.txn = self.txn.wrapping_add(1);
        let p = Packet {
            dest,
            src: CC_ADDRESS,
            transaction_id: self.txn,
            message,
        };
        if let Ok(b) = p.encode() {
            out.extend_from_slice(&b);
        }
    }

    fn status_request(&mut self) -> Message {
        let (lat, lon) = self.vehicle.lat_lon();
        let now = (self.unix0 + self.t).max(0.0);
        let day = now % 86_400.0;
        let time = [
            (day % 60.0) as u8,
            ((day / 60.0) % 60.0) as u8,
            (day / 3600.0) as u8,
            1,
            1,
            ((now / 31_557_600.0) as i64 - 30).clamp(0, 255) as u8,
        ];
        Message::RequestStatus {
            time,
            latitude: crate::codec::degrees_to_wire(lat),
            longitude: crate::codec::degrees_to_wire(lon),
            fix_valid: b'Y',
        }
    }

    fn on_packet(&mut self, p: Packet, out: &mut Vec<u8>) {
        let payload = self.opts.payload_address;
        match p.message {
            Message::EnumerateReply { device, .. } => {
                self.stats.enumerate_replies += 1;
                self.enumerated = true;
                self.poll_period = f64::from(device.polling_frequency.clamp(1, 3600));
                self.next_send = self.t;
            }
            Message::StatusReply {
                original_msg_type,
                status,
            } => {
                self.stats.status_replies += 1;
                if status.version & WAITING_BIT != 0 || original_msg_type & WAITING_BIT != 0 {
                    self.send(payload, Message::RequestQueuedMessage, out);
                }
            }
            Message::QueuedCommandReply { command, .. } => {
                self.stats.commands += 1;
                let ok = command.command_value == 0x0008 && command.heading < 360;
                if ok {
                    self.stats.last_heading = Some(command.heading);
                    self.vehicle.set_setpoint(Setpoint {
                        heading: f64::from(command.heading),
                        speed: self.opts.cruise_speed,
                        depth: 0.0,
                    });
                }
                // ACFR's codes: 0 ACK, 2 invalid data.
                self.send(
                    payload,
                    Message::QueuedMessageAckNak {
                        command_format: 1,
                        response_code: if ok { 0 } else { 2 },
                        message: Vec::new(),
                    },
                    out,
                );
            }
            _ => self.stats.other += 1,
        }
    }
}

impl Session for Sv2Session {
    fn on_bytes(&mut self, bytes: &[u8], out: &mut Vec<u8>) {
        let mut frames = Vec::new();
        self.decoder.feed(bytes, &mut |r| frames.push(r));
        for f in frames {
            match f {
                Ok(f) => match Packet::from_frame(&f) {
                    Ok(p) => self.on_packet(p, out),
                    Err(_) => self.stats.decode_errors += 1,
                },
                Err(_) => self.stats.frame_errors += 1,
            }
        }
    }

    fn step(&mut self, dt: f64, out: &mut Vec<u8>) {
        self.t += dt;
        self.vehicle.step(dt);
        if self.paused || self.t + 1e-9 < self.next_send {
            return;
        }
        if self.enumerated {
            let m = self.status_request();
            self.send(self.opts.payload_address, m, out);
            self.next_send = self.t + self.poll_period;
        } else {
            self.send(
                0xFFFF,
                Message::RequestEnumerate {
                    protocols_supported: 1,
                    commands_supported: 1,
                },
                out,
            );
            self.next_send = self.t + self.opts.enumerate_retry_s;
        }
    }

    fn reset_input(&mut self) {
        self.decoder = FrameDecoder::new();
    }
}

/// A follow-heading command for `heading` degrees as the payload would queue it.
pub fn heading_command(heading: u16) -> HeadingCommand {
    HeadingCommand::follow_heading(heading)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::codec::{DeviceInfo, PayloadStatus, msg_type};

    fn packets(out: &[u8]) -> Vec<Packet> {
        let mut d = FrameDecoder::new();
        let mut v = Vec::new();
        d.feed(out, &mut |r| {
            v.push(Packet::from_frame(&r.unwrap()).unwrap())
        });
        v
    }

    #[test]
    fn enumerates_polls_pulls_and_steers() {
        let mut s = Sv2Session::new(Sv2Options::default());
        let mut out = Vec::new();
        s.step(0.1, &mut out);
        let p = packets(&out);
        assert!(matches!(p[0].message, Message::RequestEnumerate { .. }));
        out.clear();
        let reply = |txn, message| {
            Packet {
                dest: 0,
                src: 0x0301,
                transaction_id: txn,
                message,
            }
            .encode()
            .unwrap()
        };
        s.on_bytes(
            &reply(
                1,
                Message::EnumerateReply {
                    original_msg_type: msg_type::REQUEST_ENUMERATE,
                    device: DeviceInfo::goby(0x0301),
                },
            ),
            &mut out,
        );
        s.step(0.1, &mut out);
        let p = packets(&out);
        assert!(matches!(
            p[0].message,
            Message::RequestStatus {
                fix_valid: b'Y',
                ..
            }
        ));
        out.clear();
        s.on_bytes(
            &reply(
                2,
                Message::StatusReply {
                    original_msg_type: msg_type::REQUEST_STATUS,
                    status: PayloadStatus {
                        version: 0x8001,
                        ..Default::default()
                    },
                },
            ),
            &mut out,
        );
        assert_eq!(packets(&out)[0].message, Message::RequestQueuedMessage);
        out.clear();
        s.on_bytes(
            &reply(
                3,
                Message::QueuedCommandReply {
                    original_msg_type: msg_type::REQUEST_QUEUED_MESSAGE,
                    command: heading_command(90),
                },
            ),
            &mut out,
        );
        assert!(matches!(
            packets(&out)[0].message,
            Message::QueuedMessageAckNak {
                response_code: 0,
                ..
            }
        ));
        assert_eq!(s.vehicle().setpoint().heading, 90.0);
        assert_eq!(s.stats.last_heading, Some(90));
    }
}
