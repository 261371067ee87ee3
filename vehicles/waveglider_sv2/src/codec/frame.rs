//! The SV2 frame layer: bytes ↔ CRC-checked frames. CRC-16/ARC, byte stuffing, the header
//! and a bounded decoder that resynchronises after noise; it knows nothing of what a payload
//! means.
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
