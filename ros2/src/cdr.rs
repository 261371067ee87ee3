//! XCDR1 (plain CDR) as ROS 2's DDS middlewares put it on the wire: a 4-byte encapsulation
//! header, then the fields in .msg order, each primitive aligned to min(size, 8) counted from the
//! first byte after the header (facts file §1). Written little-endian; read in either byte order.
//! Owns only the byte layout: which fields a message has is `msgs.rs`. Reading is bounded — every
//! string and sequence against a limit and against what is left of the input — and every problem
//! is a typed error, never a panic: the input comes from any DDS peer.

/// Encapsulation identifier CDR_LE (XCDR1, little-endian), options 0.
pub const HEADER_LE: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

/// What is wrong with a payload.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum CdrError {
    #[error("payload of {0} bytes is shorter than the 4-byte encapsulation header")]
    NoHeader(usize),
    #[error("encapsulation {0:#06x} is not plain CDR (XCDR1)")]
    Encapsulation(u16),
    #[error("payload ends at byte {at} while reading {what}")]
    Truncated { what: &'static str, at: usize },
    #[error("payload of {len} bytes is larger than {max}")]
    Oversized { len: usize, max: usize },
    #[error("{what}: string of {len} bytes exceeds {max}")]
    StringTooLong {
        what: &'static str,
        len: usize,
        max: usize,
    },
    #[error("{what}: string without its terminating NUL or not UTF-8")]
    BadString { what: &'static str },
    #[error("{what}: sequence of {len} elements exceeds {max}")]
    SequenceTooLong {
        what: &'static str,
        len: usize,
        max: usize,
    },
    #[error("{what}: boolean byte {value} is neither 0 nor 1")]
    BadBool { what: &'static str, value: u8 },
}

/// Serializer. Offsets for alignment count from after the header.
#[derive(Debug)]
pub struct Writer {
    buf: Vec<u8>,
}

impl Default for Writer {
    fn default() -> Self {
        Self::new()
    }
}

impl Writer {
    pub fn new() -> Self {
        let mut buf = Vec::with_capacity(256);
        buf.extend_from_slice(&HEADER_LE);
        Self { buf }
    }
    fn align(&mut self, n: usize) {
        let off = self.buf.len() - HEADER_LE.len();
        let pad = (n - off % n) % n;
        self.buf.resize(self.buf.len() + pad, 0);
    }
    pub fn u8(&mut self, v: u8) {
        self.buf.push(v);
    }
    pub fn i8(&mut self, v: i8) {
        self.buf.extend_from_slice(&v.to_le_bytes());
    }
    pub fn bool(&mut self, v: bool) {
        self.buf.push(u8::from(v));
    }
    pub fn u16(&mut self, v: u16) {
        self.align(2);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }
    pub fn i32(&mut self, v: i32) {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }
    pub fn u32(&mut self, v: u32) {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }
    pub fn f64(&mut self, v: f64) {
        self.align(8);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }
    /// u32 length including the NUL, the bytes, the NUL. A string longer than u32 cannot be
    /// ours (every string we write is bounded upstream), so it is cut rather than wrapped.
    pub fn string(&mut self, s: &str) {
        let bytes = &s.as_bytes()[..s.len().min(u32::MAX as usize - 1)];
        self.u32(bytes.len() as u32 + 1);
        self.buf.extend_from_slice(bytes);
        self.buf.push(0);
    }
    /// A fixed-size array `T[N]`: the elements, no count.
    pub fn f64_array(&mut self, v: &[f64]) {
        for x in v {
            self.f64(*x);
        }
    }
    /// The count of an unbounded sequence `T[]`.
    pub fn seq_len(&mut self, n: usize) {
        self.u32(u32::try_from(n).unwrap_or(u32::MAX));
    }
    pub fn bytes_raw(&mut self, b: &[u8]) {
        self.buf.extend_from_slice(b);
    }
    /// The payload, zero-padded to a multiple of 4 as rmw_cyclonedds sends it.
    pub fn finish(mut self) -> Vec<u8> {
        let pad = (4 - self.buf.len() % 4) % 4;
        self.buf.resize(self.buf.len() + pad, 0);
        self.buf
    }
}

/// Bounded deserializer over one payload, header included.
#[derive(Debug)]
pub struct Reader<'a> {
    data: &'a [u8],
    pos: usize,
    little: bool,
}

impl<'a> Reader<'a> {
    /// Checks the size bound and the header; accepts CDR_LE and CDR_BE, ignores the options.
    pub fn new(payload: &'a [u8], max: usize) -> Result<Self, CdrError> {
        if payload.len() > max {
            return Err(CdrError::Oversized {
                len: payload.len(),
                max,
            });
        }
        if payload.len() < 4 {
            return Err(CdrError::NoHeader(payload.len()));
        }
        let id = u16::from_be_bytes([payload[0], payload[1]]);
        let little = match id {
            0x0001 => true,
            0x0000 => false,
            other => return Err(CdrError::Encapsulation(other)),
        };
        Ok(Self {
            data: &payload[4..],
            pos: 0,
            little,
        })
    }
    fn take(&mut self, n: usize, align: usize, what: &'static str) -> Result<&'a [u8], CdrError> {
        let pad = (align - self.pos % align) % align;
        let start = self.pos + pad;
        let end = start
            .checked_add(n)
            .filter(|e| *e <= self.data.len())
            .ok_or(CdrError::Truncated { what, at: start })?;
        self.pos = end;
        Ok(&self.data[start..end])
    }
    fn arr<const N: usize>(&mut self, what: &'static str) -> Result<[u8; N], CdrError> {
        let s = self.take(N, N.min(8), what)?;
        let mut a = [0u8; N];
        a.copy_from_slice(s);
        if !self.little {
            a.reverse();
        }
        Ok(a)
    }
    pub fn u8(&mut self, what: &'static str) -> Result<u8, CdrError> {
        Ok(self.take(1, 1, what)?[0])
    }
    pub fn bool(&mut self, what: &'static str) -> Result<bool, CdrError> {
        match self.u8(what)? {
            0 => Ok(false),
            1 => Ok(true),
            value => Err(CdrError::BadBool { what, value }),
        }
    }
    pub fn i32(&mut self, what: &'static str) -> Result<i32, CdrError> {
        Ok(i32::from_le_bytes(self.arr::<4>(what)?))
    }
    pub fn u32(&mut self, what: &'static str) -> Result<u32, CdrError> {
        Ok(u32::from_le_bytes(self.arr::<4>(what)?))
    }
    pub fn u16(&mut self, what: &'static str) -> Result<u16, CdrError> {
        Ok(u16::from_le_bytes(self.arr::<2>(what)?))
    }
    pub fn f64(&mut self, what: &'static str) -> Result<f64, CdrError> {
        Ok(f64::from_le_bytes(self.arr::<8>(what)?))
    }
    /// A string of at most `max` bytes (NUL excluded). Length 0 reads as "" (Cyclone does).
    pub fn string(&mut self, what: &'static str, max: usize) -> Result<String, CdrError> {
        let len = self.u32(what)? as usize;
        if len == 0 {
            return Ok(String::new());
        }
        if len - 1 > max {
            return Err(CdrError::StringTooLong {
                what,
                len: len - 1,
                max,
            });
        }
        let raw = self.take(len, 1, what)?;
        match raw.split_last() {
            Some((0, body)) => std::str::from_utf8(body)
                .map(str::to_owned)
                .map_err(|_| CdrError::BadString { what }),
            _ => Err(CdrError::BadString { what }),
        }
    }
    /// The count of a sequence, at most `max` and at most what the rest of the payload can hold
    /// with `min_elem` bytes an element, so a forged count cannot make us allocate.
    pub fn seq_len(
        &mut self,
        what: &'static str,
        max: usize,
        min_elem: usize,
    ) -> Result<usize, CdrError> {
        let n = self.u32(what)? as usize;
        let room = (self.data.len() - self.pos) / min_elem.max(1);
        if n > max || n > room {
            return Err(CdrError::SequenceTooLong {
                what,
                len: n,
                max: max.min(room),
            });
        }
        Ok(n)
    }
    pub fn bytes_raw(&mut self, n: usize, what: &'static str) -> Result<&'a [u8], CdrError> {
        self.take(n, 1, what)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn alignment_counts_from_after_the_header() {
        let mut w = Writer::new();
        w.u8(7);
        w.f64(1.0);
        let b = w.finish();
        assert_eq!(b.len(), 4 + 16);
        assert_eq!(&b[4..6], &[7, 0]);
        assert_eq!(&b[12..20], &1.0f64.to_le_bytes());
    }

    #[test]
    fn strings_carry_their_nul_and_refuse_a_missing_one() {
        let mut w = Writer::new();
        w.string("odom");
        let b = w.finish();
        assert_eq!(&b[4..13], &[5, 0, 0, 0, b'o', b'd', b'o', b'm', 0]);
        let mut r = Reader::new(&b, 64).unwrap();
        assert_eq!(r.string("s", 16).unwrap(), "odom");
        let mut bad = b.clone();
        bad[12] = b'x';
        let mut r = Reader::new(&bad, 64).unwrap();
        assert_eq!(r.string("s", 16), Err(CdrError::BadString { what: "s" }));
        let mut r = Reader::new(&b, 64).unwrap();
        assert!(matches!(
            r.string("s", 3),
            Err(CdrError::StringTooLong { len: 4, max: 3, .. })
        ));
    }

    #[test]
    fn forged_counts_and_sizes_are_refused_without_allocating() {
        let mut w = Writer::new();
        w.u32(u32::MAX);
        let b = w.finish();
        let mut r = Reader::new(&b, 64).unwrap();
        assert!(matches!(
            r.seq_len("seq", 1000, 8),
            Err(CdrError::SequenceTooLong { .. })
        ));
        let mut r = Reader::new(&b, 64).unwrap();
        assert!(matches!(
            r.string("s", 1000),
            Err(CdrError::StringTooLong { .. })
        ));
        assert!(matches!(
            Reader::new(&[0u8; 100], 64),
            Err(CdrError::Oversized { len: 100, max: 64 })
        ));
        assert_eq!(Reader::new(&[0, 1], 64).unwrap_err(), CdrError::NoHeader(2));
        assert_eq!(
            Reader::new(&[0, 7, 0, 0], 64).unwrap_err(),
            CdrError::Encapsulation(7)
        );
        let mut r = Reader::new(&[0, 1, 0, 0, 1, 2], 64).unwrap();
        assert!(matches!(r.f64("x"), Err(CdrError::Truncated { .. })));
    }

    #[test]
    fn big_endian_payloads_read_too() {
        let mut b = vec![0, 0, 0, 0];
        b.extend_from_slice(&2.5f64.to_be_bytes());
        let mut r = Reader::new(&b, 64).unwrap();
        assert_eq!(r.f64("x").unwrap(), 2.5);
    }
}
