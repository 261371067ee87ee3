//! The MAVLink wire, bounded: a streaming deframer that cuts bytes into CRC-checked frames
//! (MAVLink 2, and 1 for old radios) with a fixed-size buffer and resynchronisation after noise,
//! and decode/encode of the ArduPilot dialect through the `mavlink` crate's generated messages.
//! The crate's own connections are blocking, so only its parser and serializer are used; the
//! I/O is ours (tokio, with bounds and reconnects).

use mavlink::{MAVLinkV2MessageRaw, MavHeader, MavlinkVersion, Message, calculate_crc};

pub use crate::dialect::MavMessage;

/// Largest MAVLink 2 frame: STX, 9 header bytes, 255 payload, CRC, 13 signature bytes.
pub const MAX_FRAME: usize = 1 + 9 + 255 + 2 + 13;
const STX_V2: u8 = 0xFD;
const STX_V1: u8 = 0xFE;
const IFLAG_SIGNED: u8 = 0x01;

/// What can be wrong with bytes from the other side.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum FrameError {
    #[error("{0} bytes of noise outside any frame")]
    Noise(usize),
    #[error("bad CRC (message id {msgid}); resynchronising")]
    BadCrc { msgid: u32 },
    #[error("unknown message id {0} (not in the ardupilotmega dialect); frame skipped")]
    UnknownMessage(u32),
    #[error("unsupported incompatibility flags {0:#04x}; frame skipped")]
    IncompatFlags(u8),
    #[error("message {msgid} does not decode: {why}")]
    Decode { msgid: u32, why: String },
    #[error("not a MAVLink frame")]
    NotAFrame,
}

/// A frame's header fields, as read from its bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FrameHeader {
    pub version: MavlinkVersion,
    pub sequence: u8,
    pub system_id: u8,
    pub component_id: u8,
    pub message_id: u32,
}

fn is_known(msgid: u32) -> bool {
    MavMessage::default_message_from_id(msgid).is_some()
}

/// Length of the frame starting at `b[0]` (a start byte), or None while its header is incomplete.
fn frame_len(b: &[u8]) -> Option<Result<usize, FrameError>> {
    match *b.first()? {
        STX_V2 => {
            if b.len() < 10 {
                return None;
            }
            let len = b[1] as usize;
            let flags = b[2];
            if flags & !IFLAG_SIGNED != 0 {
                return Some(Err(FrameError::IncompatFlags(flags)));
            }
            let sig = if flags & IFLAG_SIGNED != 0 { 13 } else { 0 };
            Some(Ok(10 + len + 2 + sig))
        }
        STX_V1 => {
            if b.len() < 6 {
                return None;
            }
            Some(Ok(6 + b[1] as usize + 2))
        }
        _ => Some(Err(FrameError::NotAFrame)),
    }
}

/// The header of a complete frame (no CRC check).
pub fn header(frame: &[u8]) -> Result<FrameHeader, FrameError> {
    match frame.first() {
        Some(&STX_V2) if frame.len() >= 12 => Ok(FrameHeader {
            version: MavlinkVersion::V2,
            sequence: frame[4],
            system_id: frame[5],
            component_id: frame[6],
            message_id: u32::from_le_bytes([frame[7], frame[8], frame[9], 0]),
        }),
        Some(&STX_V1) if frame.len() >= 8 => Ok(FrameHeader {
            version: MavlinkVersion::V1,
            sequence: frame[2],
            system_id: frame[3],
            component_id: frame[4],
            message_id: u32::from(frame[5]),
        }),
        _ => Err(FrameError::NotAFrame),
    }
}

/// Checks a complete frame: known message, good CRC. Returns its header.
fn check(frame: &[u8]) -> Result<FrameHeader, FrameError> {
    let h = header(frame)?;
    let (hdr_end, len) = match h.version {
        MavlinkVersion::V2 => (10, frame[1] as usize),
        MavlinkVersion::V1 => (6, frame[1] as usize),
    };
    let crc_at = hdr_end + len;
    if frame.len() < crc_at + 2 {
        return Err(FrameError::NotAFrame);
    }
    if !is_known(h.message_id) {
        return Err(FrameError::UnknownMessage(h.message_id));
    }
    let want = u16::from_le_bytes([frame[crc_at], frame[crc_at + 1]]);
    let got = calculate_crc(&frame[1..crc_at], MavMessage::extra_crc(h.message_id));
    if want != got {
        return Err(FrameError::BadCrc {
            msgid: h.message_id,
        });
    }
    Ok(h)
}

/// Decodes a frame the [`Deframer`] produced (checks it again: it may come from elsewhere).
pub fn decode(frame: &[u8]) -> Result<(FrameHeader, MavMessage), FrameError> {
    let h = check(frame)?;
    let start = match h.version {
        MavlinkVersion::V2 => 10,
        MavlinkVersion::V1 => 6,
    };
    let payload = &frame[start..start + frame[1] as usize];
    MavMessage::parse(h.version, h.message_id, payload)
        .map(|m| (h, m))
        .map_err(|e| FrameError::Decode {
            msgid: h.message_id,
            why: e.to_string(),
        })
}

/// One MAVLink 2 frame of `msg` from (`system_id`, `component_id`) with sequence `seq`.
pub fn encode(system_id: u8, component_id: u8, seq: u8, msg: &MavMessage) -> Vec<u8> {
    let mut raw = MAVLinkV2MessageRaw::new();
    raw.serialize_message(
        MavHeader {
            system_id: u32::from(system_id),
            component_id,
            sequence: seq,
        },
        msg,
    );
    raw.raw_bytes().to_vec()
}

/// A sender's identity and sequence counter.
#[derive(Debug, Clone)]
pub struct Sender {
    pub system_id: u8,
    pub component_id: u8,
    seq: u8,
}

impl Sender {
    pub fn new(system_id: u8, component_id: u8) -> Self {
        Self {
            system_id,
            component_id,
            seq: 0,
        }
    }

    pub fn frame(&mut self, msg: &MavMessage) -> Vec<u8> {
        let f = encode(self.system_id, self.component_id, self.seq, msg);
        self.seq = self.seq.wrapping_add(1);
        f
    }
}

/// Cuts a byte stream into checked frames with a buffer of at most [`MAX_FRAME`] bytes plus one
/// read. After a bad CRC it drops only the start byte, so a real frame hidden behind a false
/// start is still found.
#[derive(Debug, Default)]
pub struct Deframer {
    buf: Vec<u8>,
    noise: usize,
}

impl Deframer {
    pub fn new() -> Self {
        Self::default()
    }

    /// Feeds bytes; each checked frame (`Ok`, bytes from the start byte through CRC/signature)
    /// or problem (`Err`) goes to `out`, in order.
    pub fn feed(&mut self, bytes: &[u8], out: &mut dyn FnMut(Result<Vec<u8>, FrameError>)) {
        // In slices, so the buffer never holds more than one frame plus one slice.
        for chunk in bytes.chunks(MAX_FRAME) {
            self.buf.extend_from_slice(chunk);
            self.drain(out);
        }
        if self.noise > 0 && self.buf.is_empty() {
            out(Err(FrameError::Noise(std::mem::take(&mut self.noise))));
        }
    }

    fn drain(&mut self, out: &mut dyn FnMut(Result<Vec<u8>, FrameError>)) {
        loop {
            let Some(start) = self.buf.iter().position(|&b| b == STX_V2 || b == STX_V1) else {
                self.noise += self.buf.len();
                self.buf.clear();
                return;
            };
            if start > 0 {
                self.noise += start;
                self.buf.drain(..start);
            }
            if self.noise > 0 {
                out(Err(FrameError::Noise(std::mem::take(&mut self.noise))));
            }
            let len = match frame_len(&self.buf) {
                None => return,
                Some(Ok(n)) => n,
                Some(Err(e)) => {
                    out(Err(e));
                    self.buf.drain(..1);
                    continue;
                }
            };
            if self.buf.len() < len {
                return;
            }
            match check(&self.buf[..len]) {
                Ok(_) => {
                    out(Ok(self.buf[..len].to_vec()));
                    self.buf.drain(..len);
                }
                Err(e @ FrameError::UnknownMessage(_)) => {
                    // Its length is all we know; a real frame's length is the best guess.
                    out(Err(e));
                    self.buf.drain(..len);
                }
                Err(e) => {
                    out(Err(e));
                    self.buf.drain(..1);
                }
            }
        }
    }

    /// Bytes held waiting for the rest of a frame.
    pub fn buffered(&self) -> usize {
        self.buf.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dialect::*;

    fn hb() -> MavMessage {
        MavMessage::HEARTBEAT(HEARTBEAT_DATA {
            custom_mode: 15,
            mavtype: MavType::MAV_TYPE_SURFACE_BOAT,
            autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
            base_mode: MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED
                | MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
            system_status: MavState::MAV_STATE_ACTIVE,
            mavlink_version: 3,
        })
    }

    fn run(bytes: &[u8]) -> Vec<Result<Vec<u8>, FrameError>> {
        let mut d = Deframer::new();
        let mut v = Vec::new();
        d.feed(bytes, &mut |r| v.push(r));
        v
    }

    #[test]
    fn round_trip_and_resync_after_noise_and_bad_crc() {
        let f = encode(1, 1, 7, &hb());
        let mut bad = f.clone();
        let n = bad.len();
        bad[n - 1] ^= 0xFF;
        let mut input = b"noise".to_vec();
        input.extend_from_slice(&bad);
        input.extend_from_slice(&f);
        let out = run(&input);
        let frames: Vec<_> = out.iter().filter_map(|r| r.as_ref().ok()).collect();
        assert_eq!(frames, vec![&f]);
        assert!(out.contains(&Err(FrameError::BadCrc { msgid: 0 })));
        assert!(matches!(out[0], Err(FrameError::Noise(5))));
        let (h, m) = decode(&f).unwrap();
        assert_eq!((h.system_id, h.component_id, h.sequence), (1, 1, 7));
        assert_eq!(m, hb());
    }

    #[test]
    fn byte_by_byte_and_unknown_id_and_flags() {
        let f = encode(1, 1, 0, &hb());
        let mut d = Deframer::new();
        let mut got = Vec::new();
        for b in &f {
            d.feed(std::slice::from_ref(b), &mut |r| got.push(r));
        }
        assert_eq!(got, vec![Ok(f.clone())]);
        // An id outside the dialect: skipped whole, counted, and the next frame still found.
        let mut unk = f.clone();
        unk[7] = 0x55;
        unk[8] = 0x55;
        let mut input = unk.clone();
        input.extend_from_slice(&f);
        let out = run(&input);
        assert_eq!(out[0], Err(FrameError::UnknownMessage(0x5555)));
        assert_eq!(out[1], Ok(f.clone()));
        let mut flagged = f.clone();
        flagged[2] = 0x02;
        assert_eq!(run(&flagged)[0], Err(FrameError::IncompatFlags(0x02)));
    }

    #[test]
    fn buffer_stays_bounded_on_endless_garbage() {
        let mut d = Deframer::new();
        let garbage = vec![0xFDu8; 10_000];
        let mut n = 0;
        d.feed(&garbage, &mut |_| n += 1);
        assert!(d.buffered() <= MAX_FRAME * 2, "{}", d.buffered());
        assert!(n > 0);
    }
}
