//! NMEA 0183 framing as OpenCPN reads and writes it: `$` or `!`, a 2-character talker, a
//! 3-character type, comma fields, `*hh` (the XOR of every byte between the start character and
//! `*`, two uppercase hex digits), CR LF. Input is untrusted: a line is bounded
//! ([`MAX_LINE`]), its checksum is required and checked, and every problem is a typed error.

use std::fmt::Write as _;

/// Longest sentence read: OpenCPN's AIS decoder refuses longer ones (ais_decoder.cpp:1680), and
/// its autopilot sentences keep to NMEA's 82.
pub const MAX_LINE: usize = 128;
/// NMEA's own limit, CR LF included: everything we write keeps to it.
pub const MAX_WRITTEN: usize = 82;
/// Most fields one sentence may have.
const MAX_FIELDS: usize = 32;

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum NmeaError {
    #[error("longer than {MAX_LINE} characters")]
    TooLong,
    #[error("does not start with `$` or `!`")]
    NoStart,
    #[error("no `*hh` checksum")]
    NoChecksum,
    #[error("checksum `{got}` does not match the computed {computed:02X}")]
    BadChecksum { got: String, computed: u8 },
    #[error("not printable ASCII")]
    NotAscii,
    #[error("the address is not a 2-character talker and 3-character type")]
    BadAddress,
    #[error("more than {MAX_FIELDS} fields")]
    TooManyFields,
}

/// XOR of the bytes of `body` (what lies between the start character and `*`).
pub fn checksum(body: &str) -> u8 {
    body.bytes().fold(0, |a, b| a ^ b)
}

/// `start` + `body` + `*hh` + CR LF.
pub fn frame(start: char, body: &str) -> String {
    let mut s = String::with_capacity(body.len() + 6);
    s.push(start);
    s.push_str(body);
    let _ = write!(s, "*{:02X}\r\n", checksum(body));
    s
}

/// One sentence read and checked: its talker (`EC`), type (`APB`) and fields after the address.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Sentence<'a> {
    pub talker: &'a str,
    pub kind: &'a str,
    pub fields: Vec<&'a str>,
}

/// Reads one sentence (CR LF or not), checking its checksum.
pub fn parse(line: &str) -> Result<Sentence<'_>, NmeaError> {
    let line = line.trim_end_matches(['\r', '\n']);
    if line.len() > MAX_LINE {
        return Err(NmeaError::TooLong);
    }
    if !line.bytes().all(|b| (0x20..0x7f).contains(&b)) {
        return Err(NmeaError::NotAscii);
    }
    let rest = line
        .strip_prefix('$')
        .or_else(|| line.strip_prefix('!'))
        .ok_or(NmeaError::NoStart)?;
    let (body, sum) = rest.rsplit_once('*').ok_or(NmeaError::NoChecksum)?;
    let computed = checksum(body);
    match u8::from_str_radix(sum, 16) {
        Ok(v) if sum.len() == 2 && v == computed => {}
        Ok(_) if sum.len() == 2 => {
            return Err(NmeaError::BadChecksum {
                got: sum.to_string(),
                computed,
            });
        }
        _ => return Err(NmeaError::NoChecksum),
    }
    let mut parts = body.split(',');
    let address = parts.next().unwrap_or_default();
    if address.len() != 5 || !address.bytes().all(|b| b.is_ascii_alphanumeric()) {
        return Err(NmeaError::BadAddress);
    }
    let fields: Vec<&str> = parts.by_ref().take(MAX_FIELDS + 1).collect();
    if fields.len() > MAX_FIELDS {
        return Err(NmeaError::TooManyFields);
    }
    Ok(Sentence {
        talker: &address[..2],
        kind: &address[2..],
        fields,
    })
}

/// Cuts a datagram or a stream chunk into sentence candidates as OpenCPN's network reader does
/// (comm_drv_n0183_net.cpp:445-503): a sentence starts at the last `$`/`!` before its end, and
/// ends at CR/LF or two characters after `*`. Garbage between sentences is skipped; a candidate
/// longer than [`MAX_LINE`] is returned as is, to be refused (and counted) by [`parse`].
pub fn split(chunk: &str) -> Vec<&str> {
    let mut out = Vec::new();
    for line in chunk.split(['\r', '\n']) {
        let mut rest = line;
        while let Some(star) = rest.find('*') {
            let end = (star + 3).min(rest.len());
            let head = &rest[..end];
            if let Some(start) = head.rfind(['$', '!']) {
                out.push(&head[start..]);
            }
            rest = &rest[end..];
        }
        // A sentence without `*hh` is still offered (and refused for its missing checksum).
        if let Some(start) = rest.rfind(['$', '!']) {
            out.push(&rest[start..]);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checksums_of_the_captured_sentences() {
        // Captured from OpenCPN 5.10.2 (shared protocol facts, §5).
        for s in [
            "$ECRMB,A,0.004,L,WPA,WPB,4221.600,N,07105.100,W,0.014,19.026,23.846,A,A*7B",
            "$ECAPB,A,A,0.004,L,N,A,V,36.463,T,WPB,19.026,T,19.026,T*61",
            "$ECXTE,A,A,0.004,L,N*4B",
            "!AIVDM,1,1,,A,B4M9Ph@03vfaHsV3kJ9DI3g40000,0*05",
        ] {
            let p = parse(s).unwrap();
            assert_eq!(p.talker.len(), 2);
        }
    }

    #[test]
    fn refusals_are_typed() {
        assert_eq!(
            parse("$ECXTE,A,A,0.004,L,N*4C").unwrap_err(),
            NmeaError::BadChecksum {
                got: "4C".into(),
                computed: 0x4B
            }
        );
        assert_eq!(
            parse("$ECXTE,A,A,0.004,L,N").unwrap_err(),
            NmeaError::NoChecksum
        );
        assert_eq!(parse("ECXTE,A*00").unwrap_err(), NmeaError::NoStart);
        assert_eq!(
            parse(&format!("${}*00", "A".repeat(200))).unwrap_err(),
            NmeaError::TooLong
        );
        assert_eq!(parse("$ECXTE,\u{e9}*00").unwrap_err(), NmeaError::NotAscii);
        let body = "ECX";
        assert_eq!(
            parse(frame('$', body).as_str()).unwrap_err(),
            NmeaError::BadAddress
        );
    }

    #[test]
    fn frame_round_trips() {
        let f = frame('$', "ECXTE,A,A,0.004,L,N");
        assert_eq!(f, "$ECXTE,A,A,0.004,L,N*4B\r\n");
        assert_eq!(parse(&f).unwrap().fields, vec!["A", "A", "0.004", "L", "N"]);
    }

    #[test]
    fn split_finds_sentences_among_garbage() {
        let d = "junk$ECXTE,A,A,0.004,L,N*4B$$!AIVDM,1*00garbage\r\n$GP";
        assert_eq!(
            split(d),
            vec!["$ECXTE,A,A,0.004,L,N*4B", "!AIVDM,1*00", "$GP"]
        );
    }
}
