//! The raw gate: what `raw_send_request` (Goby3's debugging backdoor, which bypasses the safety
//! envelope) may put on the vehicle link. One request is one line of a line protocol, or one
//! frame of a binary one, from a source `[raw_send] sources` names, within `max_bytes` — so a
//! request can never carry a second command behind an embedded terminator. Pure: the interface
//! counts and logs what this refuses.

use frontseat_config::{InterfaceConfig, RawSource};

use crate::bus::Origin;
use crate::proto::goby::middleware::frontseat::protobuf::Raw;

/// How the selected driver delimits its messages on the wire.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RawFraming {
    /// ASCII lines ended by CR/LF (the basic simulator, Bluefin Huxley, Iver3 UVC): one request
    /// may not carry a second line.
    Lines,
    /// Binary frames the driver delimits itself (plugins, binary protocols): only the size and
    /// the source are checked here.
    Frames,
}

/// `[raw_send]` resolved for one interface.
#[derive(Clone, Debug, PartialEq)]
pub struct RawPolicy {
    pub sources: Vec<RawSource>,
    pub max_bytes: usize,
    pub framing: RawFraming,
}

impl RawPolicy {
    /// `[raw_send]` for a driver whose wire is delimited by `framing` (the driver's own word:
    /// [`crate::drivers::BuiltIn::raw_framing`]).
    pub fn from_config(cfg: &InterfaceConfig, framing: RawFraming) -> Self {
        Self {
            sources: cfg.raw_send.sources.clone(),
            max_bytes: cfg.raw_send.max_bytes,
            framing,
        }
    }
}

impl Default for RawPolicy {
    /// The defaults, for a line protocol (the stricter check: one request is one line).
    fn default() -> Self {
        Self::from_config(&InterfaceConfig::default(), RawFraming::Lines)
    }
}

/// The door a bus message came through, in `[raw_send] sources`' words.
pub fn source_of(origin: Origin) -> RawSource {
    match origin {
        Origin::Local => RawSource::Local,
        Origin::Imported => RawSource::Zenoh,
        Origin::Goby3 => RawSource::Goby3,
        Origin::Web => RawSource::Web,
        // A replay never publishes raw_send_request and never shares a bus with a driver
        // (`Bus::claim`); should one arrive anyway, it counts as an opt-in outside source.
        Origin::Replayed => RawSource::Zenoh,
    }
}

pub fn source_name(s: RawSource) -> &'static str {
    match s {
        RawSource::Local => "local",
        RawSource::Goby3 => "goby3",
        RawSource::Zenoh => "zenoh",
        RawSource::Web => "web",
    }
}

/// The raw message that may go to the driver (one trailing terminator removed: the driver adds
/// its own), or why not.
pub fn check_raw(raw: &Raw, source: RawSource, policy: &RawPolicy) -> Result<Raw, String> {
    if !policy.sources.contains(&source) {
        return Err(format!(
            "raw sends from {} are not accepted ([raw_send] sources)",
            source_name(source)
        ));
    }
    let bytes = raw.raw.as_deref().unwrap_or_default();
    let body = match policy.framing {
        RawFraming::Lines => {
            let body = bytes
                .strip_suffix(b"\r\n")
                .or_else(|| bytes.strip_suffix(b"\n"))
                .or_else(|| bytes.strip_suffix(b"\r"))
                .unwrap_or(bytes);
            if let Some(i) = body.iter().position(|b| *b == b'\r' || *b == b'\n') {
                return Err(format!(
                    "embedded line terminator at byte {i}: one raw message is one line"
                ));
            }
            if let Some(i) = body
                .iter()
                .position(|b| !(b.is_ascii_graphic() || *b == b' ' || *b == b'\t'))
            {
                return Err(format!(
                    "byte {i} (0x{:02x}) is not printable ASCII: the vehicle's protocol is ASCII lines",
                    body[i]
                ));
            }
            body
        }
        RawFraming::Frames => bytes,
    };
    if body.is_empty() {
        return Err("empty".into());
    }
    if body.len() > policy.max_bytes {
        return Err(format!(
            "{} bytes, over [raw_send] max_bytes = {}",
            body.len(),
            policy.max_bytes
        ));
    }
    Ok(Raw {
        raw: Some(body.to_vec()),
        ..raw.clone()
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn raw(b: &[u8]) -> Raw {
        Raw {
            raw: Some(b.to_vec()),
            ..Default::default()
        }
    }

    fn lines() -> RawPolicy {
        RawPolicy {
            sources: vec![RawSource::Local, RawSource::Goby3],
            max_bytes: 16,
            framing: RawFraming::Lines,
        }
    }

    #[test]
    fn one_line_passes_without_its_terminator() {
        for (input, out) in [
            (&b"CMD,SPEED:1"[..], &b"CMD,SPEED:1"[..]),
            (b"CMD,SPEED:1\r\n", b"CMD,SPEED:1"),
            (b"CMD,SPEED:1\n", b"CMD,SPEED:1"),
            (b"$OMSTOP,0*0F\r", b"$OMSTOP,0*0F"),
            (b"A B\tC", b"A B\tC"),
        ] {
            let ok = check_raw(&raw(input), RawSource::Local, &lines());
            let ok = ok.unwrap_or_else(|e| panic!("{input:?}: {e}"));
            assert_eq!(ok.raw.as_deref(), Some(out), "{input:?}");
        }
    }

    #[test]
    fn refusals_table() {
        let long = [b'A'; 17];
        for (name, input, source, why) in [
            (
                "embedded newline: two commands",
                &b"CMD,HEADING:1\nCMD,HEADING:inf"[..],
                RawSource::Local,
                "embedded line terminator",
            ),
            ("embedded CR", b"A\rB", RawSource::Local, "embedded"),
            (
                "two terminators",
                b"A\r\n\r\n",
                RawSource::Local,
                "embedded",
            ),
            ("NUL", b"A\0B", RawSource::Local, "not printable"),
            ("escape", b"\x1b[2J", RawSource::Local, "not printable"),
            (
                "non-ASCII",
                "é".as_bytes(),
                RawSource::Local,
                "not printable",
            ),
            ("empty", b"", RawSource::Local, "empty"),
            ("only a terminator", b"\r\n", RawSource::Local, "empty"),
            ("over max_bytes", &long[..], RawSource::Local, "max_bytes"),
            ("from zenoh", b"A", RawSource::Zenoh, "not accepted"),
            ("from the web", b"A", RawSource::Web, "not accepted"),
        ] {
            let e = check_raw(&raw(input), source, &lines()).expect_err(name);
            assert!(e.contains(why), "{name}: {e}");
        }
    }

    #[test]
    fn nobody_when_no_source_is_named() {
        let p = RawPolicy {
            sources: vec![],
            ..lines()
        };
        for s in [
            RawSource::Local,
            RawSource::Goby3,
            RawSource::Zenoh,
            RawSource::Web,
        ] {
            assert!(check_raw(&raw(b"A"), s, &p).is_err());
        }
    }

    #[test]
    fn frames_are_bounded_but_not_split() {
        let p = RawPolicy {
            framing: RawFraming::Frames,
            ..lines()
        };
        let frame = b"\xfe\x09\n\r\x00\x01";
        let ok = check_raw(&raw(frame), RawSource::Goby3, &p).unwrap();
        assert_eq!(ok.raw.as_deref(), Some(&frame[..]));
        assert!(check_raw(&raw(&[0; 17]), RawSource::Goby3, &p).is_err());
        assert!(check_raw(&raw(b""), RawSource::Goby3, &p).is_err());
    }

    #[test]
    fn the_defaults_take_local_and_goby3_lines_for_the_basic_simulator() {
        let p = RawPolicy::default();
        assert_eq!(p.framing, RawFraming::Lines);
        assert_eq!(p.sources, vec![RawSource::Local, RawSource::Goby3]);
        assert_eq!(p.max_bytes, 512);
        assert_eq!(source_of(Origin::Imported), RawSource::Zenoh);
        assert_eq!(source_of(Origin::Goby3), RawSource::Goby3);
        assert_eq!(source_of(Origin::Web), RawSource::Web);
    }
}
