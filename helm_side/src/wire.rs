//! The gateway's wire conventions, as pure functions: the Zenoh encoding that names the message
//! type, the W3C traceparent carried in the attachment, and the checks an imported sample must
//! pass before its bytes are decoded. Everything here is about untrusted input from the network.

/// The MIME part of the encoding the gateway publishes with (Zenoh's `APPLICATION_PROTOBUF`).
pub const PROTOBUF_MIME: &str = "application/protobuf";
/// Zenoh's default encoding: what a publisher that names nothing sends.
pub const DEFAULT_MIME: &str = "zenoh/bytes";
/// Longest traceparent accepted (the W3C version-00 form is 55 characters; later versions may
/// append fields).
pub const MAX_TRACEPARENT: usize = 256;

/// Why an imported sample is refused before decoding.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Refusal {
    Oversized { len: usize, max: usize },
    WrongType { encoding: String },
}

/// The encoding string of an exported message, e.g.
/// `application/protobuf;goby.middleware.frontseat.protobuf.NodeStatus`.
pub fn encoding_for(type_name: &str) -> String {
    format!("{PROTOBUF_MIME};{type_name}")
}

/// Accepts a sample whose encoding names `type_name`, or names no type at all (Zenoh's default,
/// or protobuf without a schema), since a hand-written tool may not set one; the bytes are still
/// decoded and checked. Anything naming another type or another format is refused.
pub fn check_sample(
    encoding: &str,
    len: usize,
    max: usize,
    type_name: &str,
) -> Result<(), Refusal> {
    if len > max {
        return Err(Refusal::Oversized { len, max });
    }
    let (mime, schema) = match encoding.split_once(';') {
        Some((m, s)) => (m, s),
        None => (encoding, ""),
    };
    let ok = match (mime, schema) {
        (DEFAULT_MIME, "") => true,
        (PROTOBUF_MIME, "") => true,
        (PROTOBUF_MIME, s) => s == type_name,
        _ => false,
    };
    if ok {
        Ok(())
    } else {
        Err(Refusal::WrongType {
            encoding: encoding.chars().take(120).collect(),
        })
    }
}

/// Parses an attachment as a W3C traceparent (`vv-<32 hex>-<16 hex>-<2 hex>[-...]`). `None` for
/// anything else, including the all-zero trace and span ids the spec declares invalid.
pub fn parse_traceparent(bytes: &[u8]) -> Option<String> {
    if bytes.len() > MAX_TRACEPARENT {
        return None;
    }
    let s = std::str::from_utf8(bytes).ok()?.trim();
    let mut parts = s.split('-');
    let version = parts.next()?;
    let trace_id = parts.next()?;
    let span_id = parts.next()?;
    let flags = parts.next()?;
    let lower_hex = |p: &str, n: usize| {
        p.len() == n
            && p.bytes()
                .all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b))
    };
    let fields_ok = lower_hex(version, 2)
        && version != "ff"
        && lower_hex(trace_id, 32)
        && lower_hex(span_id, 16)
        && lower_hex(flags, 2);
    // Version 00 has exactly four fields; later versions may add more.
    let extra_ok = version != "00" || parts.next().is_none();
    let nonzero = trace_id.bytes().any(|b| b != b'0') && span_id.bytes().any(|b| b != b'0');
    (fields_ok && extra_ok && nonzero).then(|| s.to_string())
}

/// Logs the first few occurrences of a bad input and then every power of two, so a flood of
/// garbage cannot flood the log while the counter still tells the whole story.
pub fn worth_logging(count: u64) -> bool {
    count <= 10 || count.is_power_of_two()
}

#[cfg(test)]
mod tests {
    use super::*;

    const NS: &str = "goby.middleware.frontseat.protobuf.NodeStatus";
    const TP: &str = "00-0af7651916cd43dd8448eb211c80319c-b7ad6b7169203331-01";

    #[test]
    fn encodings_table() {
        let rows: &[(&str, bool)] = &[
            (
                "application/protobuf;goby.middleware.frontseat.protobuf.NodeStatus",
                true,
            ),
            ("application/protobuf", true),
            ("zenoh/bytes", true),
            (
                "application/protobuf;goby.middleware.frontseat.protobuf.DesiredCourse",
                false,
            ),
            ("text/plain", false),
            ("text/plain;utf-8", false),
            ("application/json", false),
            ("zenoh/bytes;x", false),
            ("", false),
        ];
        for (enc, ok) in rows {
            assert_eq!(check_sample(enc, 10, 100, NS).is_ok(), *ok, "{enc:?}");
        }
        assert_eq!(
            encoding_for(NS),
            "application/protobuf;goby.middleware.frontseat.protobuf.NodeStatus"
        );
        assert!(check_sample(&encoding_for(NS), 0, 0, NS).is_ok());
    }

    #[test]
    fn size_is_checked_before_anything_else() {
        assert_eq!(
            check_sample("text/plain", 101, 100, NS),
            Err(Refusal::Oversized { len: 101, max: 100 })
        );
        assert!(check_sample("zenoh/bytes", 100, 100, NS).is_ok());
    }

    #[test]
    fn traceparent_table() {
        assert_eq!(parse_traceparent(TP.as_bytes()).as_deref(), Some(TP));
        let bad: &[&[u8]] = &[
            b"",
            b"garbage",
            b"00-0af7651916cd43dd8448eb211c80319c-b7ad6b7169203331",
            b"00-0AF7651916CD43DD8448EB211C80319C-b7ad6b7169203331-01",
            b"00-00000000000000000000000000000000-b7ad6b7169203331-01",
            b"00-0af7651916cd43dd8448eb211c80319c-0000000000000000-01",
            b"ff-0af7651916cd43dd8448eb211c80319c-b7ad6b7169203331-01",
            b"00-0af7651916cd43dd8448eb211c80319c-b7ad6b7169203331-01-xx",
            b"\xff\xfe",
        ];
        for b in bad {
            assert_eq!(
                parse_traceparent(b),
                None,
                "{:?}",
                String::from_utf8_lossy(b)
            );
        }
        let future = b"01-0af7651916cd43dd8448eb211c80319c-b7ad6b7169203331-01-abcd";
        assert!(parse_traceparent(future).is_some());
        assert_eq!(parse_traceparent(&vec![b'0'; MAX_TRACEPARENT + 1]), None);
    }

    #[test]
    fn log_sampling_keeps_the_first_and_then_thins_out() {
        let logged: Vec<u64> = (1..=100).filter(|n| worth_logging(*n)).collect();
        assert_eq!(logged, vec![1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 16, 32, 64]);
    }
}
