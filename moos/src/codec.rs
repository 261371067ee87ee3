//! The MOOS wire format as MOOSDB V10 speaks it: the 32-byte banner, packet framing and the
//! `CMOOSMsg` layout (see `shared/protocol/moos/protocol.md` §2–§5). Pure functions, no I/O.
//!
//! Decoding is zero-copy (every string field is a slice of the packet's `Bytes`), strict (any
//! length that does not add up is a typed error, never a panic) and bounded: a packet length above
//! the caller's maximum is refused before anything is allocated for it.

use std::borrow::Cow;
use std::fmt;

use bytes::{BufMut, Bytes, BytesMut};

use crate::error::{MoosError, Result};

/// The protocol text a client sends first; the DB compares it case-insensitively up to the first NUL.
pub const BANNER_TEXT: &[u8] = b"ELKS CAN'T DANCE 2/8/10";
/// Length of the banner on the wire (text + NUL padding).
pub const BANNER_LEN: usize = 32;
/// The exact 32 banner bytes: text followed by 9 NULs.
pub const BANNER: [u8; BANNER_LEN] = make_banner();
/// Packet header: length (i32) + message count (i32) + compressed flag (u8).
pub const PACKET_HEADER_LEN: usize = 9;
/// Size of a message whose five strings are all empty.
pub const MESSAGE_MIN_LEN: usize = 54;
/// Default upper bound for one packet (both directions).
pub const DEFAULT_MAX_PACKET: usize = 1 << 20;
/// Handshake key of an asynchronous client; also the WELCOME's string value.
pub const ASYNC_KEY: &str = "asynchronous";
/// Key of TIMING messages.
pub const TIMING_KEY: &str = "_async_timing";

const fn make_banner() -> [u8; BANNER_LEN] {
    let mut b = [0u8; BANNER_LEN];
    let mut i = 0;
    while i < BANNER_TEXT.len() {
        b[i] = BANNER_TEXT[i];
        i += 1;
    }
    b
}

/// Whether `received` is an acceptable banner, judged as MOOSDB does: as a C string (up to the
/// first NUL), compared case-insensitively.
pub fn banner_ok(received: &[u8]) -> bool {
    let end = received
        .iter()
        .position(|&b| b == 0)
        .unwrap_or(received.len());
    received[..end].eq_ignore_ascii_case(BANNER_TEXT)
}

/// Message type (`m_cMsgType`), one byte on the wire.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum MsgType {
    /// `N` publish (C→DB) and mail (DB→C).
    Notify,
    /// `R` subscribe; `double_val` = minimum interval in seconds.
    Register,
    /// `U` unsubscribe.
    Unregister,
    /// `*` pattern subscribe.
    WildcardRegister,
    /// `/` pattern unsubscribe.
    WildcardUnregister,
    /// `T` heartbeat / clock probe and its echo.
    Timing,
    /// `i` handshake (client name).
    Data,
    /// `W` handshake accepted.
    Welcome,
    /// `K` handshake refused.
    Poison,
    /// `Q` server request.
    ServerRequest,
    /// `.` null message (ignored by the DB; first message of replies to synchronous clients).
    Null,
    /// `C` command (ignored by the DB).
    Command,
    /// `A` anonymous (unused).
    Anonymous,
    /// `~` not set.
    NotSet,
    /// `^` client-internal marker, never sent by libMOOS.
    TerminateConnection,
}

impl MsgType {
    /// The wire byte.
    pub const fn code(self) -> u8 {
        match self {
            MsgType::Notify => b'N',
            MsgType::Register => b'R',
            MsgType::Unregister => b'U',
            MsgType::WildcardRegister => b'*',
            MsgType::WildcardUnregister => b'/',
            MsgType::Timing => b'T',
            MsgType::Data => b'i',
            MsgType::Welcome => b'W',
            MsgType::Poison => b'K',
            MsgType::ServerRequest => b'Q',
            MsgType::Null => b'.',
            MsgType::Command => b'C',
            MsgType::Anonymous => b'A',
            MsgType::NotSet => b'~',
            MsgType::TerminateConnection => b'^',
        }
    }

    /// Parse the wire byte.
    pub fn from_code(c: u8) -> Result<Self> {
        Ok(match c {
            b'N' => MsgType::Notify,
            b'R' => MsgType::Register,
            b'U' => MsgType::Unregister,
            b'*' => MsgType::WildcardRegister,
            b'/' => MsgType::WildcardUnregister,
            b'T' => MsgType::Timing,
            b'i' => MsgType::Data,
            b'W' => MsgType::Welcome,
            b'K' => MsgType::Poison,
            b'Q' => MsgType::ServerRequest,
            b'.' => MsgType::Null,
            b'C' => MsgType::Command,
            b'A' => MsgType::Anonymous,
            b'~' => MsgType::NotSet,
            b'^' => MsgType::TerminateConnection,
            other => return Err(MoosError::UnknownMessageType(other)),
        })
    }
}

/// Data type (`m_cDataType`), one byte on the wire; says which value field is meaningful.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DataType {
    /// `D`: value in `double_val`.
    Double,
    /// `S`: value in `string_val`.
    String,
    /// `B`: raw bytes in `string_val`.
    Binary,
    /// `~`: not set (an untyped DB variable).
    NotSet,
}

impl DataType {
    /// The wire byte.
    pub const fn code(self) -> u8 {
        match self {
            DataType::Double => b'D',
            DataType::String => b'S',
            DataType::Binary => b'B',
            DataType::NotSet => b'~',
        }
    }

    /// Parse the wire byte.
    pub fn from_code(c: u8) -> Result<Self> {
        Ok(match c {
            b'D' => DataType::Double,
            b'S' => DataType::String,
            b'B' => DataType::Binary,
            b'~' => DataType::NotSet,
            other => return Err(MoosError::UnknownDataType(other)),
        })
    }
}

/// A MOOS string field. The wire allows arbitrary bytes, so this keeps the bytes (a cheap slice of
/// the received packet) and offers text views; it compares equal to `&str` byte-wise.
#[derive(Clone, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Text(Bytes);

impl Text {
    /// An empty text.
    pub const fn new() -> Self {
        Text(Bytes::new())
    }
    /// A text from a static string, without copying.
    pub const fn from_static(s: &'static str) -> Self {
        Text(Bytes::from_static(s.as_bytes()))
    }
    /// The raw bytes.
    pub fn as_bytes(&self) -> &[u8] {
        &self.0
    }
    /// The text if it is valid UTF-8.
    pub fn to_str(&self) -> Option<&str> {
        std::str::from_utf8(&self.0).ok()
    }
    /// The text, with invalid UTF-8 replaced.
    pub fn to_string_lossy(&self) -> Cow<'_, str> {
        String::from_utf8_lossy(&self.0)
    }
    /// Length in bytes.
    pub fn len(&self) -> usize {
        self.0.len()
    }
    /// Whether the text is empty.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
    /// The underlying bytes.
    pub fn into_bytes(self) -> Bytes {
        self.0
    }
}

impl fmt::Debug for Text {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Debug::fmt(&self.to_string_lossy(), f)
    }
}

impl fmt::Display for Text {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.to_string_lossy())
    }
}

impl From<&str> for Text {
    fn from(s: &str) -> Self {
        Text(Bytes::copy_from_slice(s.as_bytes()))
    }
}

impl From<String> for Text {
    fn from(s: String) -> Self {
        Text(Bytes::from(s))
    }
}

impl From<Bytes> for Text {
    fn from(b: Bytes) -> Self {
        Text(b)
    }
}

impl From<&[u8]> for Text {
    fn from(b: &[u8]) -> Self {
        Text(Bytes::copy_from_slice(b))
    }
}

impl PartialEq<str> for Text {
    fn eq(&self, other: &str) -> bool {
        self.0 == other.as_bytes()
    }
}

impl PartialEq<&str> for Text {
    fn eq(&self, other: &&str) -> bool {
        self.0 == other.as_bytes()
    }
}

impl PartialEq<Text> for &str {
    fn eq(&self, other: &Text) -> bool {
        other.0 == self.as_bytes()
    }
}

/// One `CMOOSMsg`, every wire field kept as sent so that re-encoding reproduces the bytes.
#[derive(Clone, Debug, PartialEq)]
pub struct MoosMessage {
    /// Sequence number the posting client gave it (-1 for handshake/TIMING/DB-built messages).
    pub id: i32,
    /// What the message is.
    pub msg_type: MsgType,
    /// Which value field is meaningful.
    pub data_type: DataType,
    /// Name of the posting client (the DB trusts it).
    pub source: Text,
    /// Free text the poster may add.
    pub source_aux: Text,
    /// Originating community (empty from clients; the DB fills in its own).
    pub community: Text,
    /// Variable name.
    pub key: Text,
    /// MOOS time of the post: Unix seconds × time warp.
    pub time: f64,
    /// The value of a double (-1 by convention otherwise).
    pub double_val: f64,
    /// Auxiliary double (-1 unless used, e.g. TIMING echoes).
    pub double_val2: f64,
    /// The value of a string or binary message (empty for doubles).
    pub string_val: Bytes,
}

/// A borrowed view of a mail value, chosen by the data type.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MoosValue<'a> {
    /// A double.
    Double(f64),
    /// A string (raw bytes; usually UTF-8).
    String(&'a [u8]),
    /// Binary data.
    Binary(&'a [u8]),
    /// No value (data type not set).
    None,
}

impl MoosMessage {
    /// A message with the conventional defaults: id -1, empty strings, doubles -1, time 0.
    pub fn new(msg_type: MsgType, data_type: DataType, key: impl Into<Text>) -> Self {
        MoosMessage {
            id: -1,
            msg_type,
            data_type,
            source: Text::new(),
            source_aux: Text::new(),
            community: Text::new(),
            key: key.into(),
            time: 0.0,
            double_val: -1.0,
            double_val2: -1.0,
            string_val: Bytes::new(),
        }
    }

    /// The value, interpreted by `data_type`.
    pub fn value(&self) -> MoosValue<'_> {
        match self.data_type {
            DataType::Double => MoosValue::Double(self.double_val),
            DataType::String => MoosValue::String(&self.string_val),
            DataType::Binary => MoosValue::Binary(&self.string_val),
            DataType::NotSet => MoosValue::None,
        }
    }

    /// The double value, if this is a double message.
    pub fn as_double(&self) -> Option<f64> {
        (self.data_type == DataType::Double).then_some(self.double_val)
    }

    /// The string value, if this is a string message holding valid UTF-8.
    pub fn as_str(&self) -> Option<&str> {
        if self.data_type == DataType::String {
            std::str::from_utf8(&self.string_val).ok()
        } else {
            None
        }
    }

    /// The raw bytes of a string or binary message.
    pub fn as_binary(&self) -> Option<&[u8]> {
        match self.data_type {
            DataType::String | DataType::Binary => Some(&self.string_val),
            _ => None,
        }
    }

    /// Bytes this message occupies on the wire.
    pub fn encoded_len(&self) -> usize {
        MESSAGE_MIN_LEN
            + self.source.len()
            + self.source_aux.len()
            + self.community.len()
            + self.key.len()
            + self.string_val.len()
    }

    /// Append the wire form to `buf`.
    pub fn encode(&self, buf: &mut BytesMut) -> Result<()> {
        encode_fields(
            buf,
            &Fields {
                id: self.id,
                msg_type: self.msg_type,
                data_type: self.data_type,
                source: self.source.as_bytes(),
                source_aux: self.source_aux.as_bytes(),
                community: self.community.as_bytes(),
                key: self.key.as_bytes(),
                time: self.time,
                double_val: self.double_val,
                double_val2: self.double_val2,
                string_val: &self.string_val,
            },
        )
    }
}

/// A borrowed message, for encoding without building an owned [`MoosMessage`] first.
#[derive(Clone, Copy, Debug)]
pub struct Fields<'a> {
    /// See [`MoosMessage::id`].
    pub id: i32,
    /// See [`MoosMessage::msg_type`].
    pub msg_type: MsgType,
    /// See [`MoosMessage::data_type`].
    pub data_type: DataType,
    /// See [`MoosMessage::source`].
    pub source: &'a [u8],
    /// See [`MoosMessage::source_aux`].
    pub source_aux: &'a [u8],
    /// See [`MoosMessage::community`].
    pub community: &'a [u8],
    /// See [`MoosMessage::key`].
    pub key: &'a [u8],
    /// See [`MoosMessage::time`].
    pub time: f64,
    /// See [`MoosMessage::double_val`].
    pub double_val: f64,
    /// See [`MoosMessage::double_val2`].
    pub double_val2: f64,
    /// See [`MoosMessage::string_val`].
    pub string_val: &'a [u8],
}

impl<'a> Fields<'a> {
    fn client(
        msg_type: MsgType,
        data_type: DataType,
        source: &'a str,
        key: &'a str,
        time: f64,
    ) -> Self {
        Fields {
            id: -1,
            msg_type,
            data_type,
            source: source.as_bytes(),
            source_aux: &[],
            community: &[],
            key: key.as_bytes(),
            time,
            double_val: -1.0,
            double_val2: -1.0,
            string_val: &[],
        }
    }

    /// NOTIFY of a double, laid out as libMOOS sends it (string empty, `double_val2` -1).
    pub fn notify_double(source: &'a str, key: &'a str, value: f64, time: f64) -> Self {
        Fields {
            double_val: value,
            ..Fields::client(MsgType::Notify, DataType::Double, source, key, time)
        }
    }

    /// NOTIFY of a string (`double_val` -1).
    pub fn notify_string(source: &'a str, key: &'a str, value: &'a [u8], time: f64) -> Self {
        Fields {
            string_val: value,
            ..Fields::client(MsgType::Notify, DataType::String, source, key, time)
        }
    }

    /// NOTIFY of binary data (data type `B`, bytes in `string_val`).
    pub fn notify_binary(source: &'a str, key: &'a str, value: &'a [u8], time: f64) -> Self {
        Fields {
            string_val: value,
            ..Fields::client(MsgType::Notify, DataType::Binary, source, key, time)
        }
    }

    /// REGISTER with a minimum interval in seconds (0 = every write).
    pub fn register(source: &'a str, key: &'a str, interval: f64, time: f64) -> Self {
        Fields {
            double_val: interval,
            ..Fields::client(MsgType::Register, DataType::Double, source, key, time)
        }
    }

    /// UNREGISTER (`double_val` 0).
    pub fn unregister(source: &'a str, key: &'a str, time: f64) -> Self {
        Fields {
            double_val: 0.0,
            ..Fields::client(MsgType::Unregister, DataType::Double, source, key, time)
        }
    }

    /// The same message with another id.
    pub fn with_id(self, id: i32) -> Self {
        Fields { id, ..self }
    }

    /// Bytes this message occupies on the wire.
    pub fn encoded_len(&self) -> usize {
        MESSAGE_MIN_LEN
            + self.source.len()
            + self.source_aux.len()
            + self.community.len()
            + self.key.len()
            + self.string_val.len()
    }
}

fn wire_len(len: usize) -> Result<i32> {
    i32::try_from(len).map_err(|_| MoosError::MessageTooLarge {
        len,
        max: i32::MAX as usize,
    })
}

/// Append one message in wire form to `buf`.
pub fn encode_fields(buf: &mut BytesMut, m: &Fields<'_>) -> Result<()> {
    let total = wire_len(m.encoded_len())?;
    buf.reserve(total as usize);
    buf.put_i32_le(total);
    buf.put_i32_le(m.id);
    buf.put_u8(m.msg_type.code());
    buf.put_u8(m.data_type.code());
    for s in [m.source, m.source_aux, m.community, m.key] {
        buf.put_i32_le(s.len() as i32);
        buf.put_slice(s);
    }
    buf.put_f64_le(m.time);
    buf.put_f64_le(m.double_val);
    buf.put_f64_le(m.double_val2);
    buf.put_i32_le(m.string_val.len() as i32);
    buf.put_slice(m.string_val);
    Ok(())
}

/// Start a packet in `buf`: writes a placeholder header and returns where it starts.
pub fn begin_packet(buf: &mut BytesMut) -> usize {
    let start = buf.len();
    buf.put_bytes(0, PACKET_HEADER_LEN);
    start
}

/// Finish the packet begun at `start` holding `count` messages: patches length and count.
pub fn finish_packet(buf: &mut BytesMut, start: usize, count: usize) -> Result<()> {
    let len = wire_len(buf.len() - start)?;
    let count = wire_len(count)?;
    buf[start..start + 4].copy_from_slice(&len.to_le_bytes());
    buf[start + 4..start + 8].copy_from_slice(&count.to_le_bytes());
    buf[start + 8] = 0;
    Ok(())
}

/// Append one packet holding `msgs` to `buf`.
pub fn encode_packet<'m>(
    msgs: impl IntoIterator<Item = &'m MoosMessage>,
    buf: &mut BytesMut,
) -> Result<()> {
    let start = begin_packet(buf);
    let mut n = 0;
    for m in msgs {
        m.encode(buf)?;
        n += 1;
    }
    finish_packet(buf, start, n)
}

/// Read cursor over one frame; every read is bounds-checked.
struct Cursor<'a> {
    frame: &'a Bytes,
    pos: usize,
    end: usize,
}

impl Cursor<'_> {
    fn left(&self) -> usize {
        self.end - self.pos
    }
    fn take(&mut self, n: usize, field: &'static str) -> Result<&[u8]> {
        if n > self.left() {
            return Err(MoosError::BadFieldLength {
                field,
                len: n as i64,
                available: self.left(),
            });
        }
        let s = &self.frame[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }
    fn i32(&mut self, field: &'static str) -> Result<i32> {
        let b = self.take(4, field)?;
        Ok(i32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }
    fn u8(&mut self, field: &'static str) -> Result<u8> {
        Ok(self.take(1, field)?[0])
    }
    fn f64(&mut self, field: &'static str) -> Result<f64> {
        let b = self.take(8, field)?;
        let mut a = [0u8; 8];
        a.copy_from_slice(b);
        Ok(f64::from_le_bytes(a))
    }
    fn string(&mut self, field: &'static str) -> Result<Bytes> {
        let n = self.i32(field)?;
        let available = self.left();
        let len = usize::try_from(n).ok().filter(|&l| l <= available).ok_or(
            MoosError::BadFieldLength {
                field,
                len: n as i64,
                available,
            },
        )?;
        let s = self.frame.slice(self.pos..self.pos + len);
        self.pos += len;
        Ok(s)
    }
}

/// Decode one message starting at `pos` in `frame`, not reading past `end`.
/// Returns the message and the number of bytes it occupied.
fn decode_message_at(frame: &Bytes, pos: usize, end: usize) -> Result<(MoosMessage, usize)> {
    let available = end - pos;
    if available < 4 {
        return Err(MoosError::BadMessageLength { len: -1, available });
    }
    let raw = &frame[pos..pos + 4];
    let mlen = i32::from_le_bytes([raw[0], raw[1], raw[2], raw[3]]);
    let len = usize::try_from(mlen)
        .ok()
        .filter(|&l| (MESSAGE_MIN_LEN..=available).contains(&l))
        .ok_or(MoosError::BadMessageLength {
            len: mlen as i64,
            available,
        })?;
    let mut c = Cursor {
        frame,
        pos: pos + 4,
        end: pos + len,
    };
    let id = c.i32("id")?;
    let msg_type = MsgType::from_code(c.u8("msg_type")?)?;
    let data_type = DataType::from_code(c.u8("data_type")?)?;
    let source = Text(c.string("source")?);
    let source_aux = Text(c.string("source_aux")?);
    let community = Text(c.string("community")?);
    let key = Text(c.string("key")?);
    let time = c.f64("time")?;
    let double_val = c.f64("double_val")?;
    let double_val2 = c.f64("double_val2")?;
    let string_val = c.string("string_val")?;
    if c.pos != pos + len {
        return Err(MoosError::MessageLengthMismatch {
            declared: len,
            used: c.pos - pos,
        });
    }
    let msg = MoosMessage {
        id,
        msg_type,
        data_type,
        source,
        source_aux,
        community,
        key,
        time,
        double_val,
        double_val2,
        string_val,
    };
    Ok((msg, len))
}

/// Decode a single message that fills `bytes` exactly.
pub fn decode_message(bytes: &Bytes) -> Result<MoosMessage> {
    let (m, used) = decode_message_at(bytes, 0, bytes.len())?;
    if used != bytes.len() {
        return Err(MoosError::MessageLengthMismatch {
            declared: used,
            used: bytes.len(),
        });
    }
    Ok(m)
}

/// Check a packet length prefix against the bounds; `None` while fewer than 4 bytes are known.
fn packet_len(prefix: &[u8], max: usize) -> Result<Option<usize>> {
    if prefix.len() < 4 {
        return Ok(None);
    }
    let plen = i32::from_le_bytes([prefix[0], prefix[1], prefix[2], prefix[3]]);
    let len = usize::try_from(plen)
        .ok()
        .filter(|&l| l >= PACKET_HEADER_LEN)
        .ok_or(MoosError::BadPacketLength(plen as i64))?;
    if len > max {
        return Err(MoosError::PacketTooLarge { len, max });
    }
    Ok(Some(len))
}

/// Decode the messages of one whole packet (`frame` = exactly one packet, header included).
pub fn decode_packet(frame: &Bytes) -> Result<Vec<MoosMessage>> {
    let len = match packet_len(frame, usize::MAX)? {
        Some(l) => l,
        None => {
            return Err(MoosError::BadPacketLength(frame.len() as i64));
        }
    };
    if len != frame.len() || frame.len() < PACKET_HEADER_LEN {
        return Err(MoosError::PacketLengthMismatch {
            declared: len,
            used: frame.len(),
        });
    }
    let count = i32::from_le_bytes([frame[4], frame[5], frame[6], frame[7]]);
    // frame[8] is the compression flag: always 0, and the DB itself never looks at it.
    let body = len - PACKET_HEADER_LEN;
    let n = usize::try_from(count)
        .ok()
        .filter(|&n| n.saturating_mul(MESSAGE_MIN_LEN) <= body)
        .ok_or(MoosError::BadMessageCount {
            count: count as i64,
            len,
        })?;
    let mut msgs = Vec::with_capacity(n);
    let mut pos = PACKET_HEADER_LEN;
    for _ in 0..n {
        let (m, used) = decode_message_at(frame, pos, len)?;
        msgs.push(m);
        pos += used;
    }
    if pos != len {
        return Err(MoosError::PacketLengthMismatch {
            declared: len,
            used: pos,
        });
    }
    Ok(msgs)
}

/// Splits a byte stream into packets, refusing any packet longer than a maximum.
#[derive(Clone, Copy, Debug)]
pub struct PacketDecoder {
    max_packet: usize,
}

impl Default for PacketDecoder {
    fn default() -> Self {
        PacketDecoder::new(DEFAULT_MAX_PACKET)
    }
}

impl PacketDecoder {
    /// A decoder that refuses packets longer than `max_packet` bytes.
    pub fn new(max_packet: usize) -> Self {
        PacketDecoder { max_packet }
    }

    /// The configured maximum.
    pub fn max_packet(&self) -> usize {
        self.max_packet
    }

    /// How many more bytes `buf` needs before the next packet is complete (0 if it is).
    /// Errors as soon as the length prefix is known to be bad.
    pub fn bytes_needed(&self, buf: &[u8]) -> Result<usize> {
        Ok(match packet_len(buf, self.max_packet)? {
            None => 4 - buf.len(),
            Some(len) => len.saturating_sub(buf.len()),
        })
    }

    /// Take the next whole packet's bytes off the front of `buf`; `Ok(None)` if incomplete.
    pub fn next_frame(&self, buf: &mut BytesMut) -> Result<Option<Bytes>> {
        match packet_len(buf, self.max_packet)? {
            Some(len) if buf.len() >= len => Ok(Some(buf.split_to(len).freeze())),
            _ => Ok(None),
        }
    }

    /// Take and decode the next whole packet off the front of `buf`; `Ok(None)` if incomplete.
    pub fn decode(&self, buf: &mut BytesMut) -> Result<Option<Vec<MoosMessage>>> {
        match self.next_frame(buf)? {
            Some(frame) => decode_packet(&frame).map(Some),
            None => Ok(None),
        }
    }
}

/// The handshake message: `i`/`S`, key `asynchronous`, value = the client's unique name.
pub fn handshake_message(name: &str, time: f64) -> MoosMessage {
    let mut m = MoosMessage::new(
        MsgType::Data,
        DataType::String,
        Text::from_static(ASYNC_KEY),
    );
    m.time = time;
    m.string_val = Bytes::copy_from_slice(name.as_bytes());
    m
}

/// A client TIMING message as libMOOS sends it: empty strings, id -1, `double_val` 0.
pub fn timing_message(time: f64) -> MoosMessage {
    let mut m = MoosMessage::new(
        MsgType::Timing,
        DataType::Double,
        Text::from_static(TIMING_KEY),
    );
    m.time = time;
    m.double_val = 0.0;
    m
}

/// What a WELCOME tells the client.
#[derive(Clone, Debug, PartialEq)]
pub struct Welcome {
    /// DB time minus the client's handshake time (≈0.1 s on one host: the DB pauses 100 ms).
    pub skew: f64,
    /// The DB's community name.
    pub community: String,
    /// The DB's host name (from `source_aux` = `hostname=<name>`), if given.
    pub db_host: Option<String>,
    /// Whether the DB supports asynchronous clients.
    pub asynchronous: bool,
    /// The DB's MOOS time when it welcomed us.
    pub db_time: f64,
}

/// Interpret the DB's handshake reply: WELCOME → [`Welcome`], POISON → [`MoosError::Poisoned`].
pub fn parse_handshake_reply(msgs: &[MoosMessage]) -> Result<Welcome> {
    let m = match msgs {
        [m] => m,
        _ => {
            return Err(MoosError::UnexpectedHandshake(format!(
                "{} messages in the reply",
                msgs.len()
            )));
        }
    };
    match m.msg_type {
        MsgType::Welcome => {
            let aux = m.source_aux.to_string_lossy();
            let db_host = aux
                .split(',')
                .find_map(|kv| kv.trim().strip_prefix("hostname="))
                .map(str::to_owned);
            Ok(Welcome {
                skew: m.double_val,
                community: m.community.to_string_lossy().into_owned(),
                db_host,
                asynchronous: m.string_val.eq_ignore_ascii_case(ASYNC_KEY.as_bytes()),
                db_time: m.time,
            })
        }
        MsgType::Poison => Err(MoosError::Poisoned(
            String::from_utf8_lossy(&m.string_val).into_owned(),
        )),
        other => Err(MoosError::UnexpectedHandshake(format!(
            "message type {:?}",
            other
        ))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn banner_is_text_plus_nine_nuls() {
        assert_eq!(&BANNER[..23], BANNER_TEXT);
        assert!(BANNER[23..].iter().all(|&b| b == 0));
        assert!(banner_ok(&BANNER));
        assert!(banner_ok(b"elks can't dance 2/8/10\0junk"));
        assert!(!banner_ok(b"NOT THE MOOS BANNER\0\0\0"));
        assert!(!banner_ok(b"ELKS CAN'T DANCE 2/8/1"));
    }

    #[test]
    fn round_trip_and_min_size() {
        let mut m = MoosMessage::new(MsgType::Notify, DataType::Binary, "K");
        m.string_val = Bytes::from_static(&[0, 1, 2]);
        m.source = "me".into();
        let mut buf = BytesMut::new();
        encode_packet([&m], &mut buf).unwrap();
        assert_eq!(buf.len(), PACKET_HEADER_LEN + MESSAGE_MIN_LEN + 1 + 2 + 3);
        let got = PacketDecoder::default().decode(&mut buf).unwrap().unwrap();
        assert_eq!(got, vec![m]);
        assert!(buf.is_empty());
    }

    #[test]
    fn oversized_length_is_refused_before_buffering() {
        let mut buf = BytesMut::from(&(2_000_000i32).to_le_bytes()[..]);
        let d = PacketDecoder::new(1 << 20);
        assert!(matches!(
            d.decode(&mut buf),
            Err(MoosError::PacketTooLarge { len: 2_000_000, .. })
        ));
        assert!(matches!(
            d.bytes_needed(&(-5i32).to_le_bytes()),
            Err(MoosError::BadPacketLength(-5))
        ));
    }

    #[test]
    fn impossible_message_count_is_refused() {
        let mut buf = BytesMut::new();
        buf.put_i32_le(9);
        buf.put_i32_le(1_000_000);
        buf.put_u8(0);
        assert!(matches!(
            PacketDecoder::default().decode(&mut buf),
            Err(MoosError::BadMessageCount { .. })
        ));
    }
}
