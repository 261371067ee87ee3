//! How a byte link cuts its input into messages, with bounded memory: text lines (NMEA) or
//! Wave Glider SV2 binary frames. Both resynchronise after bad input instead of closing the
//! link (a serial line cannot be "reconnected" past its noise), and report every problem as a
//! `BadInput` event the driver counts. Also the rate limiter drivers use for those warnings.

use std::time::{Duration, Instant};

use frontseat_sim::waveglider_sv2::codec::FrameDecoder;

use crate::driver::DriverIoEvent;

/// How a link's input is cut into messages.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Framing {
    /// `\n`-terminated lines (a `\r` before it is dropped); longer than this many bytes is
    /// discarded up to the next `\n`.
    Lines { max_line_bytes: usize },
    /// SV2 frames: start byte 0x7E, escaping, size field, CRC-16/ARC.
    Sv2Frames,
}

/// Per-connection state of a [`Framing`].
pub(crate) enum Deframer {
    Lines(LineSplitter),
    Sv2(FrameDecoder),
}

impl Deframer {
    pub(crate) fn new(f: Framing) -> Self {
        match f {
            Framing::Lines { max_line_bytes } => Deframer::Lines(LineSplitter::new(max_line_bytes)),
            Framing::Sv2Frames => Deframer::Sv2(FrameDecoder::new()),
        }
    }

    /// Feeds bytes; every message or problem becomes an event, in order.
    pub(crate) fn feed(&mut self, bytes: &[u8], out: &mut dyn FnMut(DriverIoEvent)) {
        match self {
            Deframer::Lines(l) => l.feed(bytes, out),
            Deframer::Sv2(d) => d.feed(bytes, &mut |r| match r {
                Ok(f) => match f.unescaped() {
                    Ok(b) => out(DriverIoEvent::Frame(b)),
                    Err(e) => out(DriverIoEvent::BadInput(e.to_string())),
                },
                Err(e) => out(DriverIoEvent::BadInput(format!("SV2 framing: {e}"))),
            }),
        }
    }
}

/// Bounded line splitter.
pub(crate) struct LineSplitter {
    buf: Vec<u8>,
    max: usize,
    discarding: bool,
}

impl LineSplitter {
    pub(crate) fn new(max: usize) -> Self {
        Self {
            buf: Vec::with_capacity(256.min(max)),
            max,
            discarding: false,
        }
    }

    pub(crate) fn feed(&mut self, bytes: &[u8], out: &mut dyn FnMut(DriverIoEvent)) {
        for &b in bytes {
            if b == b'\n' {
                if !self.discarding {
                    if self.buf.last() == Some(&b'\r') {
                        self.buf.pop();
                    }
                    match std::str::from_utf8(&self.buf) {
                        Ok(l) => out(DriverIoEvent::Line(l.to_string())),
                        Err(_) => out(DriverIoEvent::BadInput(format!(
                            "invalid UTF-8 in a {}-byte line",
                            self.buf.len()
                        ))),
                    }
                }
                self.buf.clear();
                self.discarding = false;
            } else if !self.discarding {
                // +1: the `\r` of a maximal line.
                if self.buf.len() > self.max {
                    out(DriverIoEvent::BadInput(format!(
                        "line over {} bytes; discarded up to the next newline",
                        self.max
                    )));
                    self.buf.clear();
                    self.discarding = true;
                } else {
                    self.buf.push(b);
                }
            }
        }
    }
}

/// At most `burst` warnings per `period`; the rest are counted and summarised in the next
/// allowed one, so a noisy line cannot flood the log.
#[derive(Debug)]
pub struct RateLimit {
    period: Duration,
    burst: u32,
    window_start: Option<Instant>,
    in_window: u32,
    suppressed: u64,
}

impl RateLimit {
    pub fn new(period: Duration, burst: u32) -> Self {
        Self {
            period,
            burst,
            window_start: None,
            in_window: 0,
            suppressed: 0,
        }
    }

    /// `Some(n)` when a line may be logged now, n = how many were suppressed before it.
    pub fn allow(&mut self) -> Option<u64> {
        let now = Instant::now();
        match self.window_start {
            Some(t) if now.duration_since(t) < self.period => {}
            _ => {
                self.window_start = Some(now);
                self.in_window = 0;
            }
        }
        if self.in_window < self.burst {
            self.in_window += 1;
            Some(std::mem::take(&mut self.suppressed))
        } else {
            self.suppressed += 1;
            None
        }
    }
}

impl Default for RateLimit {
    fn default() -> Self {
        Self::new(Duration::from_secs(10), 5)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(f: Framing, bytes: &[u8]) -> Vec<String> {
        let mut d = Deframer::new(f);
        let mut v = Vec::new();
        d.feed(bytes, &mut |e| {
            v.push(match e {
                DriverIoEvent::Line(l) => format!("line:{l}"),
                DriverIoEvent::Frame(b) => format!("frame:{}", b.len()),
                DriverIoEvent::BadInput(w) => format!("bad:{w}"),
                other => format!("{other:?}"),
            })
        });
        v
    }

    #[test]
    fn lines_resynchronise_after_oversize_and_bad_utf8() {
        let mut input = b"ok\r\n".to_vec();
        input.extend(std::iter::repeat_n(b'x', 100));
        input.extend_from_slice(b"\r\n\xff\r\n$A*41\n");
        assert_eq!(
            run(Framing::Lines { max_line_bytes: 10 }, &input),
            vec![
                "line:ok",
                "bad:line over 10 bytes; discarded up to the next newline",
                "bad:invalid UTF-8 in a 1-byte line",
                "line:$A*41"
            ]
        );
    }

    #[test]
    fn rate_limit_counts_what_it_suppresses() {
        let mut r = RateLimit::new(Duration::from_secs(3600), 2);
        assert_eq!(r.allow(), Some(0));
        assert_eq!(r.allow(), Some(0));
        assert_eq!(r.allow(), None);
        assert_eq!(r.allow(), None);
        r.window_start = Some(Instant::now() - Duration::from_secs(7200));
        assert_eq!(r.allow(), Some(2));
    }
}
