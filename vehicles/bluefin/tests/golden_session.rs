//! The constructed golden session (`fixtures/golden_session.txt`) through the codec alone: every
//! sentence line of both directions parses (its checksum holds), formats back to the same bytes,
//! and decodes as the typed sentence of its side — `$BP…` as [`FromPayload`], `$BF…` as
//! [`FromHuxley`], none of them unknown. The driver replays the same file against its own state
//! (`tests/driver_golden.rs`), so the wire facts and the behaviour share one transcript.

use frontseat_bluefin::codec::{FromHuxley, FromPayload, Sentence};

const SESSION: &str = include_str!("../fixtures/golden_session.txt");

/// The sentence of a `>`/`<` line, without its trailing `# note`.
fn sentence(rest: &str) -> &str {
    rest.split_once(" #").map_or(rest, |(s, _)| s).trim()
}

#[test]
fn every_golden_line_parses_formats_back_and_is_typed() {
    let (mut to_huxley, mut from_huxley) = (0, 0);
    for (n, raw) in SESSION.lines().enumerate() {
        let (dir, rest) = match raw.split_at_checked(1) {
            Some((d @ (">" | "<"), rest)) => (d, sentence(rest)),
            _ => continue,
        };
        let s = Sentence::parse(rest).unwrap_or_else(|e| panic!("line {}: {rest}: {e}", n + 1));
        assert_eq!(s.format(), rest, "line {}: not byte-identical", n + 1);
        if dir == ">" {
            to_huxley += 1;
            let t = FromPayload::from_sentence(&s)
                .unwrap_or_else(|e| panic!("line {}: {rest}: {e}", n + 1));
            assert!(
                !matches!(t, FromPayload::Other(_)),
                "line {}: {rest}",
                n + 1
            );
            assert_eq!(t.to_sentence().format(), rest, "line {}: typed", n + 1);
        } else {
            from_huxley += 1;
            let t = FromHuxley::from_sentence(&s)
                .unwrap_or_else(|e| panic!("line {}: {rest}: {e}", n + 1));
            assert!(!matches!(t, FromHuxley::Other(_)), "line {}: {rest}", n + 1);
        }
    }
    // Every sentence line of the transcript was read (a comment or directive format that hid
    // lines from this loop would show here): 19 payload lines, 24 Huxley lines.
    assert_eq!((to_huxley, from_huxley), (19, 24));
}

#[test]
fn a_flipped_byte_breaks_the_checksum_of_every_golden_line() {
    for raw in SESSION.lines() {
        let Some((">" | "<", rest)) = raw.split_at_checked(1) else {
            continue;
        };
        let line = sentence(rest);
        // Flip a bit of the first field's last letter (inside the checksummed body).
        let mut bytes = line.as_bytes().to_vec();
        bytes[5] ^= 0x01;
        let bad = String::from_utf8(bytes).expect("ASCII stays ASCII");
        assert!(Sentence::parse(&bad).is_err(), "{bad} still parses");
    }
}
