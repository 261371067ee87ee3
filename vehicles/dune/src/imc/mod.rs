//! The IMC wire (LSTS's Inter-Module Communication protocol, 5.4), pure and bounded: the 20-byte
//! header whose sync word tells the sender's byte order, the payload, CRC-16/ARC; u16-prefixed
//! text and raw data, inline messages (u16 id, 65535 = absent) and message lists; the messages a
//! frontseat needs, decoded into typed structs and encoded back byte for byte; and a streaming
//! deframer with a fixed buffer that passes over oversized frames and resynchronises after noise.
//! Every problem is a typed [`ImcError`]. Layouts follow IMC.xml 5.4.31 (identical to imcpy's
//! 5.4.30 for every message here); the fixtures in `../fixtures/` are imcpy's bytes.

/// The sync word as the sender's own u16: a little-endian sender writes `54 FE`.
pub const SYNC: u16 = 0xFE54;
/// Header length.
pub const HEADER_LEN: usize = 20;
/// Header + CRC.
pub const OVERHEAD: usize = HEADER_LEN + 2;
/// Largest frame we take in. IMC allows 65 535 payload bytes; what a frontseat reads is far below
/// 1 KiB, so a larger frame (a PlanDB with a whole plan) is reported and passed over, never
/// buffered.
pub const MAX_FRAME: usize = 4096;
/// Longest message list accepted (a plan's maneuvers, its actions).
pub const MAX_LIST: usize = 64;
/// Deepest nesting of inline messages and lists (PlanControl → PlanSpecification →
/// PlanManeuver → maneuver is 3).
pub const MAX_DEPTH: usize = 4;
/// IMC's "no message" inline id, "no address" and "any entity".
pub const NULL_ID: u16 = 0xFFFF;
pub const NULL_ADDRESS: u16 = 0xFFFF;
pub const ANY_ENTITY: u8 = 0xFF;

const CRC16_ARC: crc::Crc<u16> = crc::Crc::<u16>::new(&crc::CRC_16_ARC);

/// CRC-16/ARC as IMC computes it (DUNE's CRC16: reflected 0x8005, init 0).
pub fn crc16(bytes: &[u8]) -> u16 {
    CRC16_ARC.checksum(bytes)
}

/// What can be wrong with bytes from the other side.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ImcError {
    #[error("{0} bytes of noise outside any IMC packet")]
    Noise(usize),
    #[error("not an IMC sync word")]
    BadSync,
    #[error("packet of {0} bytes is shorter than its header says")]
    Truncated(usize),
    #[error("packet of {0} bytes is larger than {MAX_FRAME}; skipped")]
    Oversized(usize),
    #[error("bad CRC (message id {mgid}); resynchronising")]
    BadCrc { mgid: u16 },
    #[error("unknown message id {0}; skipped")]
    UnknownMessage(u16),
    #[error("message {mgid}: payload of {size} bytes, fields use {used}")]
    PayloadLength { mgid: u16, size: usize, used: usize },
    #[error("message {mgid}: fields run past the payload")]
    ShortPayload { mgid: u16 },
    #[error("message list of {0} entries (at most {MAX_LIST})")]
    ListTooLong(usize),
    #[error("inline messages nested deeper than {MAX_DEPTH}")]
    TooDeep,
    #[error("payload of {0} bytes does not fit a packet")]
    TooLarge(usize),
}

/// The sender's byte order, as its sync word says.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ByteOrder {
    #[default]
    Little,
    Big,
}

/// A packet's header fields (size and sync are implied by the payload and byte order).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Header {
    pub mgid: u16,
    /// Seconds since 1970 UTC.
    pub timestamp: f64,
    pub src: u16,
    pub src_ent: u8,
    pub dst: u16,
    pub dst_ent: u8,
}

impl Header {
    pub fn new(src: u16, dst: u16, timestamp: f64) -> Self {
        Self {
            mgid: 0,
            timestamp,
            src,
            src_ent: ANY_ENTITY,
            dst,
            dst_ent: ANY_ENTITY,
        }
    }
}

// ---------------------------------------------------------------- field encodings

struct Reader<'a> {
    b: &'a [u8],
    pos: usize,
    order: ByteOrder,
    depth: usize,
    mgid: u16,
}

impl Reader<'_> {
    fn take<const N: usize>(&mut self) -> Result<[u8; N], ImcError> {
        let end = self.pos.checked_add(N).filter(|&e| e <= self.b.len());
        let Some(end) = end else {
            return Err(ImcError::ShortPayload { mgid: self.mgid });
        };
        let mut a = [0u8; N];
        a.copy_from_slice(&self.b[self.pos..end]);
        self.pos = end;
        if self.order == ByteOrder::Big {
            a.reverse();
        }
        // Little-endian from here on.
        Ok(a)
    }

    fn bytes(&mut self, n: usize) -> Result<&[u8], ImcError> {
        let end = self.pos.checked_add(n).filter(|&e| e <= self.b.len());
        let Some(end) = end else {
            return Err(ImcError::ShortPayload { mgid: self.mgid });
        };
        let s = &self.b[self.pos..end];
        self.pos = end;
        Ok(s)
    }
}

struct Writer {
    b: Vec<u8>,
    order: ByteOrder,
}

impl Writer {
    fn put<const N: usize>(&mut self, mut le: [u8; N]) {
        if self.order == ByteOrder::Big {
            le.reverse();
        }
        self.b.extend_from_slice(&le);
    }
}

/// One IMC field type: how it reads and writes.
trait Field: Sized {
    fn read(r: &mut Reader<'_>) -> Result<Self, ImcError>;
    fn write(&self, w: &mut Writer);
}

macro_rules! numeric_field {
    ($($t:ty),*) => {$(
        impl Field for $t {
            fn read(r: &mut Reader<'_>) -> Result<Self, ImcError> {
                Ok(<$t>::from_le_bytes(r.take()?))
            }
            fn write(&self, w: &mut Writer) {
                w.put(self.to_le_bytes());
            }
        }
    )*};
}
numeric_field!(u8, u16, u32, i32, f32, f64);

/// `plaintext`: u16 length + bytes, no NUL. Invalid UTF-8 is kept, replaced, not refused (a
/// vehicle's error text must not cost its navigation).
impl Field for String {
    fn read(r: &mut Reader<'_>) -> Result<Self, ImcError> {
        let n = u16::read(r)? as usize;
        Ok(String::from_utf8_lossy(r.bytes(n)?).into_owned())
    }
    fn write(&self, w: &mut Writer) {
        let b = &self.as_bytes()[..self.len().min(u16::MAX as usize)];
        (b.len() as u16).write(w);
        w.b.extend_from_slice(b);
    }
}

/// `rawdata`: u16 length + bytes.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RawData(pub Vec<u8>);

impl Field for RawData {
    fn read(r: &mut Reader<'_>) -> Result<Self, ImcError> {
        let n = u16::read(r)? as usize;
        Ok(RawData(r.bytes(n)?.to_vec()))
    }
    fn write(&self, w: &mut Writer) {
        let b = &self.0[..self.0.len().min(u16::MAX as usize)];
        (b.len() as u16).write(w);
        w.b.extend_from_slice(b);
    }
}

/// An inline `message` field: u16 id + that message's fields; id 65535 = absent.
pub type Inline = Option<Box<Message>>;

impl Field for Inline {
    fn read(r: &mut Reader<'_>) -> Result<Self, ImcError> {
        let id = u16::read(r)?;
        if id == NULL_ID {
            return Ok(None);
        }
        Ok(Some(Box::new(read_nested(r, id)?)))
    }
    fn write(&self, w: &mut Writer) {
        match self {
            None => NULL_ID.write(w),
            Some(m) => {
                m.id().write(w);
                m.write_fields(w);
            }
        }
    }
}

/// A `message-list` field: u16 count + count × (u16 id + fields).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct List(pub Vec<Message>);

impl Field for List {
    fn read(r: &mut Reader<'_>) -> Result<Self, ImcError> {
        let n = u16::read(r)? as usize;
        if n > MAX_LIST {
            return Err(ImcError::ListTooLong(n));
        }
        let mut v = Vec::with_capacity(n);
        for _ in 0..n {
            let id = u16::read(r)?;
            v.push(read_nested(r, id)?);
        }
        Ok(List(v))
    }
    fn write(&self, w: &mut Writer) {
        (self.0.len().min(u16::MAX as usize) as u16).write(w);
        for m in self.0.iter().take(u16::MAX as usize) {
            m.id().write(w);
            m.write_fields(w);
        }
    }
}

fn read_nested(r: &mut Reader<'_>, id: u16) -> Result<Message, ImcError> {
    if r.depth >= MAX_DEPTH {
        return Err(ImcError::TooDeep);
    }
    r.depth += 1;
    let outer = std::mem::replace(&mut r.mgid, id);
    let m = Message::read_fields(id, r);
    r.mgid = outer;
    r.depth -= 1;
    m
}

// ---------------------------------------------------------------- messages

macro_rules! imc_messages {
    ($( $(#[doc = $doc:literal])* $name:ident = $id:literal { $( $(#[doc = $fdoc:literal])* $f:ident : $t:ty ),* $(,)? } )*) => {
        $(
            $(#[doc = $doc])*
            #[derive(Debug, Clone, PartialEq, Default)]
            pub struct $name { $( $(#[doc = $fdoc])* pub $f: $t, )* }

            impl $name {
                pub const ID: u16 = $id;
            }

            impl From<$name> for Message {
                fn from(m: $name) -> Message { Message::$name(m) }
            }
        )*

        /// Every IMC message this codec knows.
        #[derive(Debug, Clone, PartialEq)]
        pub enum Message { $( $name($name), )* }

        impl Message {
            pub fn id(&self) -> u16 {
                match self { $( Message::$name(_) => $id, )* }
            }

            pub fn name(&self) -> &'static str {
                match self { $( Message::$name(_) => stringify!($name), )* }
            }

            /// Whether `id` is one of ours.
            pub fn known(id: u16) -> bool {
                matches!(id, $( $id )|*)
            }

            fn read_fields(id: u16, r: &mut Reader<'_>) -> Result<Message, ImcError> {
                match id {
                    $( $id => Ok(Message::$name($name { $( $f: <$t as Field>::read(r)?, )* })), )*
                    other => Err(ImcError::UnknownMessage(other)),
                }
            }

            #[allow(unused_variables)]
            fn write_fields(&self, w: &mut Writer) {
                match self {
                    $( Message::$name(m) => { $( Field::write(&m.$f, w); )* } )*
                }
            }
        }
    };
}

imc_messages! {
    /// EntityState 1: the health of the entity in the header's `src_ent`.
    EntityState = 1 { state: u8, flags: u8, description: String }
    /// EntityInfo 3: an entity's id and name.
    EntityInfo = 3 { id: u8, label: String, component: String, act_time: u16, deact_time: u16 }
    /// EntityList 5: `Name=id;Name=id`.
    EntityList = 5 { op: u8, list: String }
    /// Heartbeat 150 (DUNE sends one a second).
    Heartbeat = 150 {}
    /// Announce 151: a system's name, type, position and services.
    Announce = 151 {
        sys_name: String, sys_type: u8, owner: u16,
        /// rad
        lat: f64,
        /// rad
        lon: f64, height: f32, services: String,
    }
    /// GpsFix 253.
    GpsFix = 253 {
        validity: u16, fix_type: u8, utc_year: u16, utc_month: u8, utc_day: u8, utc_time: f32,
        lat: f64, lon: f64, height: f32, satellites: u8, cog: f32, sog: f32, hdop: f32,
        vdop: f32, hacc: f32, vacc: f32,
    }
    /// EstimatedState 350: a WGS-84 reference point and the NED offset from it, attitude,
    /// velocities, depth and altitude.
    EstimatedState = 350 {
        lat: f64, lon: f64, height: f32, x: f32, y: f32, z: f32, phi: f32, theta: f32, psi: f32,
        u: f32, v: f32, w: f32, vx: f32, vy: f32, vz: f32, p: f32, q: f32, r: f32, depth: f32,
        alt: f32,
    }
    /// DesiredHeading 400: rad, true north.
    DesiredHeading = 400 { value: f64 }
    /// DesiredZ 401: m, in `z_units` (DEPTH 1).
    DesiredZ = 401 { value: f32, z_units: u8 }
    /// DesiredSpeed 402: in `speed_units` (METERS_PS 0).
    DesiredSpeed = 402 { value: f64, speed_units: u8 }
    /// FollowReference 478: the maneuver that follows a backseat's References.
    FollowReference = 478 {
        control_src: u16, control_ent: u8,
        /// s without a Reference before the maneuver fails; 0 = never.
        timeout: f32, loiter_radius: f32, altitude_interval: f32,
    }
    /// Reference 479: where to go, how fast, how deep.
    Reference = 479 {
        flags: u8, speed: Inline, z: Inline,
        /// rad
        lat: f64,
        /// rad
        lon: f64, radius: f32,
    }
    /// FollowRefState 480: the maneuver's answer to each Reference.
    FollowRefState = 480 {
        control_src: u16, control_ent: u8, reference: Inline, state: u8, proximity: u8,
    }
    /// VehicleState 500: the supervisor's operation mode.
    VehicleState = 500 {
        op_mode: u8, error_count: u8, error_ents: String, maneuver_type: u16,
        maneuver_stime: f64, maneuver_eta: u16, control_loops: u32, flags: u8,
        last_error: String, last_error_time: f64,
    }
    /// ControlLoops 507 (the direct path; see the README for why it is not used).
    ControlLoops = 507 { enable: u8, mask: u32, scope_ref: u32 }
    /// Abort 550: stop everything (dst = the vehicle's id exactly).
    Abort = 550 {}
    /// PlanSpecification 551 (a plan holding maneuvers; lists of actions are kept as given).
    PlanSpecification = 551 {
        plan_id: String, description: String, vnamespace: String, variables: List,
        start_man_id: String, maneuvers: List, transitions: List, start_actions: List,
        end_actions: List,
    }
    /// PlanManeuver 552: one maneuver of a plan.
    PlanManeuver = 552 {
        maneuver_id: String, data: Inline, start_actions: List, end_actions: List,
    }
    /// PlanControl 559: start/stop a plan, and the plan engine's replies.
    PlanControl = 559 {
        kind: u8, op: u8, request_id: u16, plan_id: String, flags: u16, arg: Inline,
        info: String,
    }
    /// PlanControlState 560: the plan engine's state.
    PlanControlState = 560 {
        state: u8, plan_id: String, plan_eta: i32, plan_progress: f32, man_id: String,
        man_type: u16, man_eta: i32, last_outcome: u8,
    }
}

/// Constants of the enumerations and bitfields used here (IMC.xml).
pub mod consts {
    pub mod op_mode {
        pub const SERVICE: u8 = 0;
        pub const CALIBRATION: u8 = 1;
        pub const ERROR: u8 = 2;
        pub const MANEUVER: u8 = 3;
        pub const EXTERNAL: u8 = 4;
        pub const BOOT: u8 = 5;
    }
    pub mod plan_control {
        pub const REQUEST: u8 = 0;
        pub const SUCCESS: u8 = 1;
        pub const FAILURE: u8 = 2;
        pub const IN_PROGRESS: u8 = 3;
        pub const START: u8 = 0;
        pub const STOP: u8 = 1;
    }
    pub mod pcs {
        pub const BLOCKED: u8 = 0;
        pub const READY: u8 = 1;
        pub const INITIALIZING: u8 = 2;
        pub const EXECUTING: u8 = 3;
    }
    pub mod reference {
        pub const LOCATION: u8 = 0x01;
        pub const SPEED: u8 = 0x02;
        pub const Z: u8 = 0x04;
        pub const RADIUS: u8 = 0x08;
        pub const START_POINT: u8 = 0x10;
        pub const DIRECT: u8 = 0x20;
        pub const MANDONE: u8 = 0x80;
    }
    pub mod follow_ref_state {
        pub const WAIT: u8 = 1;
        pub const GOTO: u8 = 2;
        pub const LOITER: u8 = 3;
        pub const HOVER: u8 = 4;
        pub const ELEVATOR: u8 = 5;
        pub const TIMEOUT: u8 = 6;
        pub const FAR: u8 = 0x01;
        pub const XY_NEAR: u8 = 0x02;
        pub const Z_NEAR: u8 = 0x04;
    }
    pub mod entity_state {
        pub const BOOT: u8 = 0;
        pub const NORMAL: u8 = 1;
        pub const FAULT: u8 = 2;
        pub const ERROR: u8 = 3;
        pub const FAILURE: u8 = 4;
    }
    /// DesiredZ.z_units DEPTH, DesiredSpeed.speed_units METERS_PS.
    pub const Z_DEPTH: u8 = 1;
    pub const METERS_PS: u8 = 0;
    /// GpsFix.validity VALID_POS.
    pub const GPS_VALID_POS: u16 = 0x0004;
    /// VehicleState.control_loops bits.
    pub const CL_PATH: u32 = 0x1;
    pub const CL_DEPTH: u32 = 0x8;
    pub const CL_YAW: u32 = 0x40;
    pub const CL_SPEED: u32 = 0x80;
    pub const CL_TORQUE: u32 = 0x400;
    /// VehicleState.flags MANEUVER_DONE.
    pub const VS_MANEUVER_DONE: u8 = 0x01;
}

// ---------------------------------------------------------------- packets

/// A whole packet: header fields, then the message, in `order`, with its CRC.
pub fn encode(h: &Header, msg: &Message, order: ByteOrder) -> Result<Vec<u8>, ImcError> {
    let mut w = Writer {
        b: Vec::with_capacity(128),
        order,
    };
    SYNC.write(&mut w);
    msg.id().write(&mut w);
    0u16.write(&mut w); // size, patched below
    h.timestamp.write(&mut w);
    h.src.write(&mut w);
    h.src_ent.write(&mut w);
    h.dst.write(&mut w);
    h.dst_ent.write(&mut w);
    msg.write_fields(&mut w);
    let size = w.b.len() - HEADER_LEN;
    if size > usize::from(u16::MAX) - OVERHEAD {
        return Err(ImcError::TooLarge(size));
    }
    let s = match order {
        ByteOrder::Little => (size as u16).to_le_bytes(),
        ByteOrder::Big => (size as u16).to_be_bytes(),
    };
    w.b[4..6].copy_from_slice(&s);
    let crc = crc16(&w.b);
    crc.write(&mut w);
    Ok(w.b)
}

/// The byte order a sync word says, if it is one.
fn order_of(b0: u8, b1: u8) -> Option<ByteOrder> {
    match [b0, b1] {
        [0x54, 0xFE] => Some(ByteOrder::Little),
        [0xFE, 0x54] => Some(ByteOrder::Big),
        _ => None,
    }
}

fn u16_in(b: [u8; 2], order: ByteOrder) -> u16 {
    match order {
        ByteOrder::Little => u16::from_le_bytes(b),
        ByteOrder::Big => u16::from_be_bytes(b),
    }
}

/// Header of a whole frame, its byte order and declared payload size, without the CRC check.
pub fn peek(frame: &[u8]) -> Result<(Header, ByteOrder, usize), ImcError> {
    if frame.len() < HEADER_LEN {
        return Err(ImcError::Truncated(frame.len()));
    }
    let order = order_of(frame[0], frame[1]).ok_or(ImcError::BadSync)?;
    let mut r = Reader {
        b: &frame[2..HEADER_LEN],
        pos: 0,
        order,
        depth: 0,
        mgid: 0,
    };
    let mgid = u16::read(&mut r)?;
    let size = u16::read(&mut r)? as usize;
    let h = Header {
        mgid,
        timestamp: f64::read(&mut r)?,
        src: u16::read(&mut r)?,
        src_ent: u8::read(&mut r)?,
        dst: u16::read(&mut r)?,
        dst_ent: u8::read(&mut r)?,
    };
    Ok((h, order, size))
}

/// A whole packet: header checked, CRC checked, message decoded. An unknown id is
/// [`ImcError::UnknownMessage`] (the header is still good: [`peek`] reads it).
pub fn decode(frame: &[u8]) -> Result<(Header, Message), ImcError> {
    let (h, order, size) = peek(frame)?;
    let total = OVERHEAD + size;
    if total > MAX_FRAME {
        return Err(ImcError::Oversized(total));
    }
    if frame.len() < total {
        return Err(ImcError::Truncated(frame.len()));
    }
    if frame.len() > total {
        return Err(ImcError::PayloadLength {
            mgid: h.mgid,
            size,
            used: frame.len() - OVERHEAD,
        });
    }
    let body = &frame[..HEADER_LEN + size];
    let crc = u16_in([frame[total - 2], frame[total - 1]], order);
    if crc16(body) != crc {
        return Err(ImcError::BadCrc { mgid: h.mgid });
    }
    let mut r = Reader {
        b: &body[HEADER_LEN..],
        pos: 0,
        order,
        depth: 0,
        mgid: h.mgid,
    };
    let msg = Message::read_fields(h.mgid, &mut r)?;
    if r.pos != size {
        return Err(ImcError::PayloadLength {
            mgid: h.mgid,
            size,
            used: r.pos,
        });
    }
    Ok((h, msg))
}

// ---------------------------------------------------------------- stream

/// Cuts a byte stream into whole, CRC-checked IMC packets with at most [`MAX_FRAME`] bytes
/// buffered: noise before a sync word is dropped (reported once per run), a bad CRC drops the
/// sync word only and searches again, and so does an oversized packet (never kept).
#[derive(Debug, Default)]
pub struct Deframer {
    buf: Vec<u8>,
    noise: usize,
}

impl Deframer {
    pub fn new() -> Self {
        Self::default()
    }

    /// Bytes held (never more than [`MAX_FRAME`]).
    pub fn buffered(&self) -> usize {
        self.buf.len()
    }

    pub fn feed(&mut self, mut bytes: &[u8], out: &mut dyn FnMut(Result<Vec<u8>, ImcError>)) {
        while !bytes.is_empty() {
            let room = MAX_FRAME - self.buf.len();
            let n = room.min(bytes.len());
            self.buf.extend_from_slice(&bytes[..n]);
            bytes = &bytes[n..];
            self.cut(out);
        }
    }

    fn flush_noise(&mut self, out: &mut dyn FnMut(Result<Vec<u8>, ImcError>)) {
        if self.noise > 0 {
            out(Err(ImcError::Noise(self.noise)));
            self.noise = 0;
        }
    }

    fn cut(&mut self, out: &mut dyn FnMut(Result<Vec<u8>, ImcError>)) {
        loop {
            // Find a sync word (either order).
            let start = self
                .buf
                .windows(2)
                .position(|w| order_of(w[0], w[1]).is_some());
            let drop = match start {
                Some(i) => i,
                // Keep a last byte that may begin a sync word.
                None => self.buf.len().saturating_sub(1),
            };
            if drop > 0 {
                self.noise += drop;
                self.buf.drain(..drop);
            }
            if start.is_none() || self.buf.len() < HEADER_LEN {
                return;
            }
            self.flush_noise(out);
            let order = order_of(self.buf[0], self.buf[1]).unwrap_or_default();
            let size = u16_in([self.buf[4], self.buf[5]], order) as usize;
            let total = OVERHEAD + size;
            if total > MAX_FRAME {
                // Not kept, and not skipped by its declared size either: a false sync in noise
                // declares any size up to 64 KiB, and skipping it would drop that much good
                // data. Only the sync word goes; a real large packet is then scanned through as
                // noise (a false packet inside it would also need a good CRC).
                out(Err(ImcError::Oversized(total)));
                self.buf.drain(..2);
                continue;
            }
            if self.buf.len() < total {
                return;
            }
            let crc = u16_in([self.buf[total - 2], self.buf[total - 1]], order);
            if crc16(&self.buf[..total - 2]) != crc {
                let mgid = u16_in([self.buf[2], self.buf[3]], order);
                out(Err(ImcError::BadCrc { mgid }));
                // Only the sync word goes: a real packet may start inside this one.
                self.buf.drain(..2);
                continue;
            }
            let frame: Vec<u8> = self.buf.drain(..total).collect();
            out(Ok(frame));
        }
    }
}

#[cfg(test)]
mod tests;
