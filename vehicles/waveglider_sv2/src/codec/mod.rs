//! The Wave Glider SV2 payload protocol, pure: CRC-16/ARC, byte stuffing, a bounded
//! resynchronising frame decoder, and the typed messages both sides exchange. No I/O.
//!
//! Layout (unescaped): `7E | size u16 | dest u16 | src u16 | txn u16 | type u16 | payload | crc
//! u16`, little-endian; size = bytes after the start byte, CRC included; the CRC covers bytes 1
//! up to the CRC; every byte after the start byte is escaped (`7D` → `7D 5D`, `7E` → `7D 5E`).

/// Start-of-frame byte.
pub const START: u8 = 0x7E;
/// Escape byte.
pub const ESC: u8 = 0x7D;
/// Largest unescaped frame, start byte included (Goby3 and ACFR both size buffers for this).
pub const MAX_FRAME: usize = 557;
/// Start byte + 10 header bytes.
pub const HEADER_LEN: usize = 11;
/// Header plus CRC, nothing else.
pub const MIN_FRAME: usize = HEADER_LEN + 2;
/// Bit 15 of message_type: "no ACK requested".
pub const NO_ACK_BIT: u16 = 0x8000;
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

/// CRC-16/ARC: reflected polynomial 0xA001, initial 0, no final XOR.
pub fn crc16(data: &[u8]) -> u16 {
    let mut crc: u16 = 0;
    for &b in data {
        crc ^= u16::from(b);
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xA001
            } else {
                crc >> 1
            };
        }
    }
    crc
}

/// The ten header bytes after the start byte (size excluded: it follows from the payload).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Header {
    pub dest: u16,
    pub src: u16,
    pub transaction_id: u16,
    /// As on the wire, bit 15 included.
    pub message_type: u16,
}

impl Header {
    /// The type without the "no ACK requested" bit.
    pub fn kind(&self) -> u16 {
        self.message_type & !NO_ACK_BIT
    }
}

/// A CRC-checked frame: header and the payload between header and CRC.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Frame {
    pub header: Header,
    pub payload: Vec<u8>,
}

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum EncodeError {
    #[error("frame of {0} bytes exceeds the protocol's {MAX_FRAME}")]
    TooLarge(usize),
}

impl Frame {
    /// The unescaped bytes, start byte and CRC included.
    pub fn unescaped(&self) -> Result<Vec<u8>, EncodeError> {
        let len = MIN_FRAME + self.payload.len();
        if len > MAX_FRAME {
            return Err(EncodeError::TooLarge(len));
        }
        let mut b = Vec::with_capacity(len);
        b.push(START);
        b.extend_from_slice(&((len - 1) as u16).to_le_bytes());
        for v in [
            self.header.dest,
            self.header.src,
            self.header.transaction_id,
            self.header.message_type,
        ] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        b.extend_from_slice(&self.payload);
        let crc = crc16(&b[1..]);
        b.extend_from_slice(&crc.to_le_bytes());
        Ok(b)
    }

    /// Parses an unescaped frame (start byte included), checking size and CRC.
    pub fn from_unescaped(b: &[u8]) -> Result<Frame, FrameError> {
        if b.first() != Some(&START) {
            return Err(FrameError::Noise(b.len()));
        }
        if !(MIN_FRAME..=MAX_FRAME).contains(&b.len()) {
            return Err(FrameError::BadSize(b.len().saturating_sub(1)));
        }
        let size = usize::from(u16::from_le_bytes([b[1], b[2]]));
        if size + 1 != b.len() {
            return Err(FrameError::BadSize(size));
        }
        let n = b.len();
        let got = u16::from_le_bytes([b[n - 2], b[n - 1]]);
        let computed = crc16(&b[1..n - 2]);
        if got != computed {
            return Err(FrameError::BadCrc { got, computed });
        }
        let w = |i: usize| u16::from_le_bytes([b[i], b[i + 1]]);
        Ok(Frame {
            header: Header {
                dest: w(3),
                src: w(5),
                transaction_id: w(7),
                message_type: w(9),
            },
            payload: b[HEADER_LEN..n - 2].to_vec(),
        })
    }

    /// The bytes to put on the wire (escaped).
    pub fn encode(&self) -> Result<Vec<u8>, EncodeError> {
        Ok(escape(&self.unescaped()?))
    }
}

/// Escapes everything after the start byte of an unescaped frame.
pub fn escape(unescaped: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(unescaped.len() + 8);
    for (i, &b) in unescaped.iter().enumerate() {
        if i > 0 && (b == START || b == ESC) {
            out.push(ESC);
            out.push(b ^ 0x20);
        } else {
            out.push(b);
        }
    }
    out
}

/// Why bytes did not make a frame. The decoder is back hunting for a start byte after each.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum FrameError {
    #[error("{0} bytes of line noise before a start byte")]
    Noise(usize),
    #[error("bad escape 0x7D 0x{0:02X}")]
    BadEscape(u8),
    #[error("start byte inside a frame after {0} bytes: frame truncated")]
    Truncated(usize),
    #[error("size field {0}: frames are {min}..={max} bytes", min = MIN_FRAME - 1, max = MAX_FRAME - 1)]
    BadSize(usize),
    #[error("CRC 0x{got:04X}, computed 0x{computed:04X}")]
    BadCrc { got: u16, computed: u16 },
}

/// Incremental decoder with bounded memory (one frame of at most [`MAX_FRAME`] bytes): it
/// hunts for the start byte, unescapes, checks the size and the CRC, and resynchronises on the
/// next start byte after any error.
#[derive(Debug, Default)]
pub struct FrameDecoder {
    /// Unescaped bytes of the current frame after the start byte; empty while hunting.
    buf: Vec<u8>,
    in_frame: bool,
    escaped: bool,
    noise: usize,
    /// Size field of the current frame once read.
    want: Option<usize>,
}

impl FrameDecoder {
    pub fn new() -> Self {
        Self::default()
    }

    /// True when no partial frame or noise is pending (for "a truncated frame at the end").
    pub fn is_idle(&self) -> bool {
        !self.in_frame && self.noise == 0
    }

    fn restart(&mut self) {
        self.buf.clear();
        self.in_frame = true;
        self.escaped = false;
        self.want = None;
    }

    fn hunt(&mut self) {
        self.buf.clear();
        self.in_frame = false;
        self.escaped = false;
        self.want = None;
    }

    /// Feeds bytes; every finished frame or error goes to `out` in order.
    pub fn feed(&mut self, bytes: &[u8], out: &mut dyn FnMut(Result<Frame, FrameError>)) {
        for &b in bytes {
            if let Some(r) = self.push(b) {
                out(r);
            }
            // A start byte that ended a frame with an error also begins the next one.
            if b == START && !self.in_frame {
                self.restart();
            }
        }
    }

    /// One byte; `Some` when it finished a frame or revealed an error.
    fn push(&mut self, b: u8) -> Option<Result<Frame, FrameError>> {
        if !self.in_frame {
            if b == START {
                self.restart();
                if self.noise > 0 {
                    let n = std::mem::take(&mut self.noise);
                    return Some(Err(FrameError::Noise(n)));
                }
            } else {
                self.noise = self.noise.saturating_add(1);
            }
            return None;
        }
        if b == START {
            // An unescaped start byte can only begin a frame: the current one was cut short.
            let n = self.buf.len() + 1;
            self.hunt();
            return Some(Err(FrameError::Truncated(n)));
        }
        let b = if self.escaped {
            self.escaped = false;
            match b {
                0x5D => ESC,
                0x5E => START,
                other => {
                    self.hunt();
                    return Some(Err(FrameError::BadEscape(other)));
                }
            }
        } else if b == ESC {
            self.escaped = true;
            return None;
        } else {
            b
        };
        self.buf.push(b);
        if self.want.is_none() && self.buf.len() == 2 {
            let size = usize::from(u16::from_le_bytes([self.buf[0], self.buf[1]]));
            if !(MIN_FRAME - 1..=MAX_FRAME - 1).contains(&size) {
                self.hunt();
                return Some(Err(FrameError::BadSize(size)));
            }
            self.want = Some(size);
        }
        if Some(self.buf.len()) == self.want {
            let r = self.finish();
            self.hunt();
            return Some(r);
        }
        None
    }

    fn finish(&self) -> Result<Frame, FrameError> {
        let b = &self.buf;
        let n = b.len();
        let got = u16::from_le_bytes([b[n - 2], b[n - 1]]);
        let computed = crc16(&b[..n - 2]);
        if got != computed {
            return Err(FrameError::BadCrc { got, computed });
        }
        let w = |i: usize| u16::from_le_bytes([b[i], b[i + 1]]);
        Ok(Frame {
            header: Header {
                dest: w(2),
                src: w(4),
                transaction_id: w(6),
                message_type: w(8),
            },
            payload: b[10..n - 2].to_vec(),
        })
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    fn hex(s: &str) -> Vec<u8> {
        s.split_whitespace()
            .map(|h| u8::from_str_radix(h, 16).unwrap())
            .collect()
    }

    fn decode_all(bytes: &[u8]) -> Vec<Result<Frame, FrameError>> {
        let mut d = FrameDecoder::new();
        let mut v = Vec::new();
        d.feed(bytes, &mut |r| v.push(r));
        v
    }

    #[test]
    fn crc_check_value() {
        assert_eq!(crc16(b"123456789"), 0xBB3D);
    }

    /// The constructed frames of the fact sheet (waveglider_sv2.md §2.2, §7).
    #[test]
    fn golden_frames_encode_and_decode() {
        let addr = 0x0301;
        let cases: Vec<(&str, Packet)> = vec![
            (
                "7E 10 00 FF FF 00 00 01 00 10 00 01 00 01 00 B6 E2",
                Packet {
                    dest: 0xFFFF,
                    src: 0,
                    transaction_id: 1,
                    message: Message::RequestEnumerate {
                        protocols_supported: 1,
                        commands_supported: 1,
                    },
                },
            ),
            (
                "7E 3C 00 00 00 01 03 01 00 01 00 10 00 01 00 01 00 01 00 01 10 01 03 30 30 30 30 30 31 00 01 00 00 00 \
                 08 00 00 01 00 69 46 72 6F 6E 74 53 65 61 74 20 44 72 69 76 65 72 00 00 00 40 30",
                Packet {
                    dest: 0,
                    src: addr,
                    transaction_id: 1,
                    message: Message::EnumerateReply {
                        original_msg_type: 0x0010,
                        device: DeviceInfo::goby(addr),
                    },
                },
            ),
            (
                "7E 1B 00 01 03 00 00 02 00 22 00 00 00 0C 0A 0A 18 00 00 00 00 00 00 00 00 59 16 46",
                Packet {
                    dest: addr,
                    src: 0,
                    transaction_id: 2,
                    message: Message::RequestStatus {
                        time: [0, 0, 12, 10, 10, 24],
                        latitude: 0,
                        longitude: 0,
                        fix_valid: b'Y',
                    },
                },
            ),
            (
                "7E 1E 00 00 00 01 03 03 00 01 00 22 00 01 00 01 00 01 80 01 03 00 00 00 00 00 00 00 00 0B A3",
                Packet {
                    dest: 0,
                    src: addr,
                    transaction_id: 3,
                    message: Message::StatusReply {
                        original_msg_type: 0x0022,
                        status: PayloadStatus {
                            devices_responding: 1,
                            devices_in_message: 1,
                            version: 0x8001,
                            board_address: addr,
                            ..Default::default()
                        },
                    },
                },
            ),
            (
                "7E 0C 00 01 03 00 00 04 00 40 00 02 03",
                Packet {
                    dest: addr,
                    src: 0,
                    transaction_id: 4,
                    message: Message::RequestQueuedMessage,
                },
            ),
            (
                "7E 29 00 01 00 01 03 04 00 01 00 40 00 01 00 0A FF FF FF FF 12 00 10 08 00 00 00 00 5A 00 \
                 00 00 00 00 00 00 00 00 02 19 99 D9",
                Packet {
                    dest: 1,
                    src: addr,
                    transaction_id: 4,
                    message: Message::QueuedCommandReply {
                        original_msg_type: 0x0040,
                        command: HeadingCommand::follow_heading(90),
                    },
                },
            ),
            (
                "7E 11 00 01 03 01 00 04 00 41 00 01 00 00 00 00 8D 71",
                Packet {
                    dest: addr,
                    src: 1,
                    transaction_id: 4,
                    message: Message::QueuedMessageAckNak {
                        command_format: 1,
                        response_code: 0,
                        message: vec![],
                    },
                },
            ),
        ];
        for (wire, pkt) in cases {
            let wire = hex(wire);
            assert_eq!(pkt.to_frame().unescaped().unwrap(), wire, "{pkt:?}");
            let frames = decode_all(&wire);
            assert_eq!(frames.len(), 1);
            let f = frames[0].clone().unwrap();
            assert_eq!(Packet::from_frame(&f).unwrap(), pkt);
            assert_eq!(Frame::from_unescaped(&wire), Ok(f));
        }
    }

    #[test]
    fn escaping_example_from_the_fact_sheet() {
        let pkt = Packet {
            dest: 1,
            src: 0x0301,
            transaction_id: 0x007D,
            message: Message::QueuedCommandReply {
                original_msg_type: 0x0040,
                command: HeadingCommand::follow_heading(126),
            },
        };
        let wire = hex(
            "7E 29 00 01 00 01 03 7D 5D 00 01 00 40 00 01 00 0A FF FF FF FF 12 00 10 08 00 00 00 00 7D 5E \
             00 00 00 00 00 00 00 00 00 42 A6 D4 0A",
        );
        assert_eq!(pkt.encode().unwrap(), wire);
        let f = decode_all(&wire).remove(0).unwrap();
        assert_eq!(Packet::from_frame(&f).unwrap(), pkt);
    }

    #[test]
    fn bad_input_is_reported_and_the_decoder_resynchronises() {
        let good = Packet {
            dest: 0x0301,
            src: 0,
            transaction_id: 9,
            message: Message::RequestQueuedMessage,
        }
        .encode()
        .unwrap();
        let mut bad_crc = good.clone();
        let n = bad_crc.len();
        bad_crc[n - 1] ^= 0xFF;
        let mut bytes = b"noise".to_vec();
        bytes.extend_from_slice(&good[..6]); // truncated by the next start byte
        bytes.extend_from_slice(&bad_crc);
        bytes.extend_from_slice(&[START, 0x05, ESC, 0x33]); // bad escape
        bytes.extend_from_slice(&[START, 0xFF, 0xFF]); // size beyond the protocol
        bytes.extend_from_slice(&[START, 0x02, 0x00]); // size below the header
        bytes.extend_from_slice(&good);
        let r = decode_all(&bytes);
        assert_eq!(
            r.iter()
                .map(|x| x.as_ref().err().cloned())
                .collect::<Vec<_>>(),
            vec![
                Some(FrameError::Noise(5)),
                Some(FrameError::Truncated(6)),
                Some(FrameError::BadCrc {
                    got: u16::from_le_bytes([bad_crc[n - 2], bad_crc[n - 1]]),
                    computed: crc16(&good[1..n - 2]),
                }),
                Some(FrameError::BadEscape(0x33)),
                Some(FrameError::BadSize(0xFFFF)),
                Some(FrameError::BadSize(2)),
                None,
            ]
        );
    }

    #[test]
    fn position_unit_round_trips() {
        for d in [0.0, 42.3584, -71.0876, 179.999, -89.5] {
            assert!((wire_to_degrees(degrees_to_wire(d)) - d).abs() < 1e-6);
        }
    }

    #[test]
    fn headings_wrap_and_round() {
        for (h, want) in [
            (90.0, Some(90)),
            (90.4, Some(90)),
            (90.6, Some(91)),
            (359.7, Some(0)),
            (-10.0, Some(350)),
            (720.0 + 45.0, Some(45)),
            (f64::NAN, None),
            (f64::INFINITY, None),
        ] {
            assert_eq!(heading_to_wire(h), want, "{h}");
        }
    }
}
