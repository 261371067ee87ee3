//! The SV2 messages: what each frame's payload means, by message type, both ways, with their
//! addressing ([`Packet`]) and the C&C's units for position and heading. Built on the frame
//! layer (`frame`), which knows nothing of them.

use super::frame::{EncodeError, Frame, Header, crc16};

/// Bit 15 of the status reply's version (Goby3) or of a reply's original_msg_type (ACFR):
/// a command is waiting to be pulled.
pub const WAITING_BIT: u16 = 0x8000;

pub mod msg_type {
    pub const NAK: u16 = 0x0000;
    pub const ACK: u16 = 0x0001;
    pub const REQUEST_ENUMERATE: u16 = 0x0010;
    pub const TELEMETRY: u16 = 0x0015;
    pub const REQUEST_STATUS: u16 = 0x0022;
    pub const FORWARD_MESSAGE: u16 = 0x0024;
    pub const POWER: u16 = 0x0030;
    pub const REQUEST_QUEUED_MESSAGE: u16 = 0x0040;
    pub const QUEUED_MESSAGE_ACK_NAK: u16 = 0x0041;
}

/// The device description in an enumerate reply (Goby3's 42-byte block).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DeviceInfo {
    pub devices_responding: u16,
    pub devices_in_message: u16,
    pub version: u16,
    pub device_type: u16,
    pub board_address: u16,
    pub serial_number: [u8; 6],
    pub location: u8,
    /// Seconds between status polls the payload asks for.
    pub polling_frequency: u32,
    pub extra_info: u8,
    pub firmware_major: u8,
    pub firmware_minor: u8,
    pub firmware_revision: u16,
    pub description: [u8; 20],
}

impl DeviceInfo {
    /// What Goby3's driver sends, at `address`.
    pub fn goby(address: u16) -> Self {
        let mut description = [0u8; 20];
        let d = b"iFrontSeat Driver";
        description[..d.len()].copy_from_slice(d);
        Self {
            devices_responding: 1,
            devices_in_message: 1,
            version: 1,
            device_type: 0x1001,
            board_address: address,
            serial_number: *b"000001",
            location: 0,
            polling_frequency: 1,
            extra_info: 0x08,
            firmware_major: 0,
            firmware_minor: 0,
            firmware_revision: 1,
            description,
        }
    }
}

/// The payload's state as reported in a status reply.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct PayloadStatus {
    pub devices_responding: u16,
    pub devices_in_message: u16,
    /// Bit 15 set = a command is waiting (Goby3's placement).
    pub version: u16,
    pub board_address: u16,
    pub alarms: u16,
    pub leak1: u8,
    pub leak2: u8,
    pub humidity_temp: u8,
    pub humidity: u8,
    pub pressure_temp: u8,
    pub pressure: u8,
}

/// A "follow fixed heading" command as carried in a queued-command reply.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct HeadingCommand {
    pub command_format: u16,
    pub level2_id: u8,
    pub wgms_id: u32,
    pub structure_id: u8,
    pub command_value: u16,
    /// Whole degrees, 0..=359.
    pub heading: u16,
    pub latitude: u32,
    pub longitude: u32,
}

impl HeadingCommand {
    /// Goby3's constants around a heading.
    pub fn follow_heading(heading: u16) -> Self {
        Self {
            command_format: 1,
            level2_id: 0x0A,
            wgms_id: 0xFFFF_FFFF,
            structure_id: 0x10,
            command_value: 0x0008,
            heading,
            latitude: 0,
            longitude: 0,
        }
    }
}

/// Every message either side sends, by meaning. Replies travel as type ACK (0x0001) and are
/// told apart by their original_msg_type.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Message {
    RequestEnumerate {
        protocols_supported: u16,
        commands_supported: u16,
    },
    /// Time: second, minute, hour, day, month, years since 2000. Position: signed 1/10000 of an
    /// arc minute (see docs/goby3-differences.md), fix_valid `b'Y'`/`b'N'`.
    RequestStatus {
        time: [u8; 6],
        latitude: u32,
        longitude: u32,
        fix_valid: u8,
    },
    RequestQueuedMessage,
    QueuedMessageAckNak {
        command_format: u16,
        response_code: u8,
        message: Vec<u8>,
    },
    Nak {
        original_msg_type: u16,
        response_code: u8,
        details: Vec<u8>,
    },
    Ack {
        original_msg_type: u16,
        details: Vec<u8>,
    },
    EnumerateReply {
        original_msg_type: u16,
        device: DeviceInfo,
    },
    StatusReply {
        original_msg_type: u16,
        status: PayloadStatus,
    },
    QueuedCommandReply {
        original_msg_type: u16,
        command: HeadingCommand,
    },
    Other {
        message_type: u16,
        payload: Vec<u8>,
    },
}

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum DecodeError {
    #[error("message type 0x{kind:04X} needs {need} payload bytes, got {got}")]
    Short { kind: u16, need: usize, got: usize },
    #[error("declared length {declared} but {got} bytes follow")]
    BadLength { declared: usize, got: usize },
    #[error("inner CRC 0x{got:04X}, computed 0x{computed:04X}")]
    BadInnerCrc { got: u16, computed: u16 },
}

struct Rd<'a> {
    b: &'a [u8],
    at: usize,
}

impl Rd<'_> {
    fn u8(&mut self) -> u8 {
        let v = self.b[self.at];
        self.at += 1;
        v
    }
    fn u16(&mut self) -> u16 {
        let v = u16::from_le_bytes([self.b[self.at], self.b[self.at + 1]]);
        self.at += 2;
        v
    }
    fn u32(&mut self) -> u32 {
        let s = &self.b[self.at..self.at + 4];
        self.at += 4;
        u32::from_le_bytes([s[0], s[1], s[2], s[3]])
    }
    fn arr<const N: usize>(&mut self) -> [u8; N] {
        let mut a = [0u8; N];
        a.copy_from_slice(&self.b[self.at..self.at + N]);
        self.at += N;
        a
    }
    fn rest(&mut self) -> Vec<u8> {
        let v = self.b[self.at..].to_vec();
        self.at = self.b.len();
        v
    }
}

fn need(kind: u16, p: &[u8], n: usize) -> Result<Rd<'_>, DecodeError> {
    if p.len() < n {
        return Err(DecodeError::Short {
            kind,
            need: n,
            got: p.len(),
        });
    }
    Ok(Rd { b: p, at: 0 })
}

const DEVICE_INFO_LEN: usize = 46;
const STATUS_LEN: usize = 16;
const COMMAND_LEN: usize = 27;

impl Message {
    /// The wire message_type (replies are ACK; the "no ACK requested" bit is never set by us).
    pub fn message_type(&self) -> u16 {
        use msg_type::*;
        match self {
            Message::RequestEnumerate { .. } => REQUEST_ENUMERATE,
            Message::RequestStatus { .. } => REQUEST_STATUS,
            Message::RequestQueuedMessage => REQUEST_QUEUED_MESSAGE,
            Message::QueuedMessageAckNak { .. } => QUEUED_MESSAGE_ACK_NAK,
            Message::Nak { .. } => NAK,
            Message::Ack { .. }
            | Message::EnumerateReply { .. }
            | Message::StatusReply { .. }
            | Message::QueuedCommandReply { .. } => ACK,
            Message::Other { message_type, .. } => *message_type,
        }
    }

    pub fn payload(&self) -> Vec<u8> {
        let mut p = Vec::new();
        let u16le = |p: &mut Vec<u8>, v: u16| p.extend_from_slice(&v.to_le_bytes());
        match self {
            Message::RequestEnumerate {
                protocols_supported,
                commands_supported,
            } => {
                u16le(&mut p, *protocols_supported);
                u16le(&mut p, *commands_supported);
            }
            Message::RequestStatus {
                time,
                latitude,
                longitude,
                fix_valid,
            } => {
                p.extend_from_slice(time);
                p.extend_from_slice(&latitude.to_le_bytes());
                p.extend_from_slice(&longitude.to_le_bytes());
                p.push(*fix_valid);
            }
            Message::RequestQueuedMessage => {}
            Message::QueuedMessageAckNak {
                command_format,
                response_code,
                message,
            } => {
                u16le(&mut p, *command_format);
                p.push(*response_code);
                u16le(&mut p, message.len().min(usize::from(u16::MAX)) as u16);
                p.extend_from_slice(message);
            }
            Message::Nak {
                original_msg_type,
                response_code,
                details,
            } => {
                u16le(&mut p, *original_msg_type);
                p.push(*response_code);
                p.extend_from_slice(details);
            }
            Message::Ack {
                original_msg_type,
                details,
            } => {
                u16le(&mut p, *original_msg_type);
                p.extend_from_slice(details);
            }
            Message::EnumerateReply {
                original_msg_type,
                device: d,
            } => {
                u16le(&mut p, *original_msg_type);
                u16le(&mut p, d.devices_responding);
                u16le(&mut p, d.devices_in_message);
                u16le(&mut p, d.version);
                u16le(&mut p, d.device_type);
                u16le(&mut p, d.board_address);
                p.extend_from_slice(&d.serial_number);
                p.push(d.location);
                p.extend_from_slice(&d.polling_frequency.to_le_bytes());
                p.push(d.extra_info);
                p.push(d.firmware_major);
                p.push(d.firmware_minor);
                u16le(&mut p, d.firmware_revision);
                p.extend_from_slice(&d.description);
            }
            Message::StatusReply {
                original_msg_type,
                status: s,
            } => {
                u16le(&mut p, *original_msg_type);
                u16le(&mut p, s.devices_responding);
                u16le(&mut p, s.devices_in_message);
                u16le(&mut p, s.version);
                u16le(&mut p, s.board_address);
                u16le(&mut p, s.alarms);
                p.extend_from_slice(&[
                    s.leak1,
                    s.leak2,
                    s.humidity_temp,
                    s.humidity,
                    s.pressure_temp,
                    s.pressure,
                ]);
            }
            Message::QueuedCommandReply {
                original_msg_type,
                command: c,
            } => {
                u16le(&mut p, *original_msg_type);
                u16le(&mut p, c.command_format);
                let inner_start = p.len();
                p.push(c.level2_id);
                p.extend_from_slice(&c.wgms_id.to_le_bytes());
                u16le(&mut p, 18);
                p.push(c.structure_id);
                u16le(&mut p, c.command_value);
                p.extend_from_slice(&[0, 0, 0]);
                u16le(&mut p, c.heading);
                p.extend_from_slice(&c.latitude.to_le_bytes());
                p.extend_from_slice(&c.longitude.to_le_bytes());
                // Goby3 covers the level-2 header too (fact sheet §8.6): kept for compatibility.
                let inner = crc16(&p[inner_start..]);
                u16le(&mut p, inner);
            }
            Message::Other { payload, .. } => p.extend_from_slice(payload),
        }
        p
    }

    /// Decodes a frame's payload by its type. Fixed-size messages accept trailing bytes (a newer
    /// C&C may append fields); shorter payloads are errors.
    pub fn decode(header: &Header, p: &[u8]) -> Result<Message, DecodeError> {
        use msg_type::*;
        let kind = header.kind();
        Ok(match kind {
            REQUEST_ENUMERATE => {
                let mut r = need(kind, p, 4)?;
                Message::RequestEnumerate {
                    protocols_supported: r.u16(),
                    commands_supported: r.u16(),
                }
            }
            REQUEST_STATUS => {
                let mut r = need(kind, p, 15)?;
                Message::RequestStatus {
                    time: r.arr::<6>(),
                    latitude: r.u32(),
                    longitude: r.u32(),
                    fix_valid: r.u8(),
                }
            }
            REQUEST_QUEUED_MESSAGE => Message::RequestQueuedMessage,
            QUEUED_MESSAGE_ACK_NAK => {
                let mut r = need(kind, p, 5)?;
                let command_format = r.u16();
                let response_code = r.u8();
                let declared = usize::from(r.u16());
                let message = r.rest();
                if message.len() != declared {
                    return Err(DecodeError::BadLength {
                        declared,
                        got: message.len(),
                    });
                }
                Message::QueuedMessageAckNak {
                    command_format,
                    response_code,
                    message,
                }
            }
            NAK => {
                let mut r = need(kind, p, 3)?;
                Message::Nak {
                    original_msg_type: r.u16(),
                    response_code: r.u8(),
                    details: r.rest(),
                }
            }
            ACK => {
                let mut r = need(kind, p, 2)?;
                let original_msg_type = r.u16();
                match original_msg_type & !WAITING_BIT {
                    REQUEST_ENUMERATE => {
                        let mut r = need(kind, p, 2 + DEVICE_INFO_LEN)?;
                        r.at = 2;
                        Message::EnumerateReply {
                            original_msg_type,
                            device: DeviceInfo {
                                devices_responding: r.u16(),
                                devices_in_message: r.u16(),
                                version: r.u16(),
                                device_type: r.u16(),
                                board_address: r.u16(),
                                serial_number: r.arr::<6>(),
                                location: r.u8(),
                                polling_frequency: r.u32(),
                                extra_info: r.u8(),
                                firmware_major: r.u8(),
                                firmware_minor: r.u8(),
                                firmware_revision: r.u16(),
                                description: r.arr::<20>(),
                            },
                        }
                    }
                    REQUEST_STATUS => {
                        let mut r = need(kind, p, 2 + STATUS_LEN)?;
                        r.at = 2;
                        Message::StatusReply {
                            original_msg_type,
                            status: PayloadStatus {
                                devices_responding: r.u16(),
                                devices_in_message: r.u16(),
                                version: r.u16(),
                                board_address: r.u16(),
                                alarms: r.u16(),
                                leak1: r.u8(),
                                leak2: r.u8(),
                                humidity_temp: r.u8(),
                                humidity: r.u8(),
                                pressure_temp: r.u8(),
                                pressure: r.u8(),
                            },
                        }
                    }
                    REQUEST_QUEUED_MESSAGE => {
                        let mut r = need(kind, p, 2 + COMMAND_LEN)?;
                        r.at = 2;
                        let command_format = r.u16();
                        let inner_start = r.at;
                        let level2_id = r.u8();
                        let wgms_id = r.u32();
                        let data_size = usize::from(r.u16());
                        if data_size != 18 {
                            return Err(DecodeError::BadLength {
                                declared: data_size,
                                got: 18,
                            });
                        }
                        let structure_id = r.u8();
                        let command_value = r.u16();
                        let _reserved = r.arr::<3>();
                        let heading = r.u16();
                        let latitude = r.u32();
                        let longitude = r.u32();
                        let computed = crc16(&p[inner_start..r.at]);
                        let got = r.u16();
                        if got != computed {
                            return Err(DecodeError::BadInnerCrc { got, computed });
                        }
                        Message::QueuedCommandReply {
                            original_msg_type,
                            command: HeadingCommand {
                                command_format,
                                level2_id,
                                wgms_id,
                                structure_id,
                                command_value,
                                heading,
                                latitude,
                                longitude,
                            },
                        }
                    }
                    _ => Message::Ack {
                        original_msg_type,
                        details: r.rest(),
                    },
                }
            }
            _ => Message::Other {
                message_type: header.message_type,
                payload: p.to_vec(),
            },
        })
    }
}

/// A message with its addressing.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Packet {
    pub dest: u16,
    pub src: u16,
    pub transaction_id: u16,
    pub message: Message,
}

impl Packet {
    pub fn to_frame(&self) -> Frame {
        Frame {
            header: Header {
                dest: self.dest,
                src: self.src,
                transaction_id: self.transaction_id,
                message_type: self.message.message_type(),
            },
            payload: self.message.payload(),
        }
    }

    /// Wire bytes (escaped).
    pub fn encode(&self) -> Result<Vec<u8>, EncodeError> {
        self.to_frame().encode()
    }

    pub fn from_frame(f: &Frame) -> Result<Packet, DecodeError> {
        Ok(Packet {
            dest: f.header.dest,
            src: f.header.src,
            transaction_id: f.header.transaction_id,
            message: Message::decode(&f.header, &f.payload)?,
        })
    }
}

/// Degrees → the status request's position unit (signed 1/10000 arc minute, as u32 bits).
pub fn degrees_to_wire(deg: f64) -> u32 {
    let v = (deg * 600_000.0).round();
    (v.clamp(i32::MIN as f64, i32::MAX as f64) as i32) as u32
}

/// The status request's position unit → degrees.
pub fn wire_to_degrees(v: u32) -> f64 {
    f64::from(v as i32) / 600_000.0
}

/// A heading in degrees → the command's whole degrees in 0..=359 (Goby3 truncates and does
/// not wrap: -10 or 720 went out as garbage). Non-finite → None.
pub fn heading_to_wire(h: f64) -> Option<u16> {
    if !h.is_finite() {
        return None;
    }
    let r = h.rem_euclid(360.0).round();
    Some(if r >= 360.0 { 0 } else { r as u16 })
}
