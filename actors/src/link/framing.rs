//! How a byte link cuts its input into messages, with bounded memory: text lines (NMEA), or the
//! binary frames of a vehicle whose crate supplies the [`FrameCutter`] (Wave Glider SV2, MAVLink),
//! so the runtime names no vehicle protocol. Both resynchronise after bad input instead of closing
//! the link (a serial line cannot be "reconnected" past its noise), and report every problem as a
//! `BadInput` event the driver counts.

use super::DriverIoEvent;

/// A vehicle's binary framing: cuts bytes into whole frames with bounded memory and resynchronises
/// after bad input. Every frame (`Ok`) or problem in words (`Err`) goes to `out`, in order.
pub trait FrameCutter: Send {
    fn feed(&mut self, bytes: &[u8], out: &mut dyn FnMut(Result<Vec<u8>, String>));
}

/// Makes the per-connection state of a binary framing (one per connection: a reconnect starts
/// from a clean buffer).
pub type NewFrameCutter = fn() -> Box<dyn FrameCutter>;

/// How a link's input is cut into messages.
#[derive(Debug, Clone, Copy)]
pub enum Framing {
    /// `\n`-terminated lines (a `\r` before it is dropped); longer than this many bytes is
    /// discarded up to the next `\n`.
    Lines { max_line_bytes: usize },
    /// A vehicle's binary frames (SV2: `frontseat_waveglider_sv2::driver::sv2_frames`; MAVLink:
    /// `frontseat_ardupilot::driver::mavlink_frames`).
    Frames(NewFrameCutter),
}

/// Per-connection state of a [`Framing`].
pub(crate) enum Deframer {
    Lines(LineSplitter),
    Frames(Box<dyn FrameCutter>),
}

impl Deframer {
    pub(crate) fn new(f: Framing) -> Self {
        match f {
            Framing::Lines { max_line_bytes } => Deframer::Lines(LineSplitter::new(max_line_bytes)),
            Framing::Frames(new) => Deframer::Frames(new()),
        }
    }

    /// Feeds bytes; every message or problem becomes an event, in order.
    pub(crate) fn feed(&mut self, bytes: &[u8], out: &mut dyn FnMut(DriverIoEvent)) {
        match self {
            Deframer::Lines(l) => l.feed(bytes, out),
            Deframer::Frames(d) => d.feed(bytes, &mut |r| match r {
                Ok(f) => out(DriverIoEvent::Frame(f)),
                Err(e) => out(DriverIoEvent::BadInput(e)),
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
}
