//! One Goby3 interprocess publication as gobyd's proxy carries it: a single ZeroMQ part holding
//! `"/" GROUP "/" SCHEME "/" TYPE "/" PID "/" THREAD "/"`, one NUL, then the protobuf bytes. Also
//! the ZeroMQ prefix a subscriber sets. Pure: encode, decode (untrusted bytes → typed error) and
//! prefix building, table-tested against the frames recorded from gobyd 3.1.5a.

/// The only marshalling scheme the frontseat groups use (Goby3's `MarshallingScheme::PROTOBUF`,
/// written by name on the wire).
pub const SCHEME_PROTOBUF: &str = "PROTOBUF";
/// Longest thread id Goby3 accepts: `std::stoull(s, 0, 16)` of a 64-bit hash.
const MAX_THREAD_DIGITS: usize = 16;

/// A decoded frame, borrowing from the received bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Frame<'a> {
    pub group: &'a str,
    pub scheme: &'a str,
    pub type_name: &'a str,
    pub pid: i32,
    pub thread: u64,
    pub payload: &'a [u8],
}

/// Why received bytes are not a frame. Each one would make a Goby3 subscriber call
/// `std::terminate()` (or silently mis-deliver); here it is counted and dropped.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum FrameError {
    #[error("{len} bytes, more than the {max} accepted")]
    Oversized { len: usize, max: usize },
    #[error("no NUL between identifier and payload")]
    NoNul,
    #[error("identifier does not start with '/'")]
    NoLeadingSlash,
    #[error("identifier is not UTF-8")]
    NotUtf8,
    #[error("identifier has {0} fields, not group/scheme/type/pid/thread")]
    FieldCount(usize),
    #[error("empty {0}")]
    Empty(&'static str),
    #[error("pid {0:?} is not a decimal 32-bit integer")]
    BadPid(String),
    #[error("thread {0:?} is not 1 to 16 hex digits")]
    BadThread(String),
}

/// The identifier of a publication, without the NUL.
pub fn identifier(group: &str, type_name: &str, pid: i32, thread: u64) -> String {
    format!("/{group}/{SCHEME_PROTOBUF}/{type_name}/{pid}/{thread:x}/")
}

/// A complete frame: identifier, NUL, payload, in one buffer (one ZeroMQ part).
pub fn encode(group: &str, type_name: &str, pid: i32, thread: u64, payload: &[u8]) -> Vec<u8> {
    let id = identifier(group, type_name, pid, thread);
    let mut out = Vec::with_capacity(id.len() + 1 + payload.len());
    out.extend_from_slice(id.as_bytes());
    out.push(0);
    out.extend_from_slice(payload);
    out
}

/// The ZeroMQ subscription prefix for one (group, type): every publisher process and thread.
/// The trailing `/` keeps `…::status/` from also matching `…::status_x/`.
pub fn subscription_prefix(group: &str, type_name: &str) -> String {
    format!("/{group}/{SCHEME_PROTOBUF}/{type_name}/")
}

/// Parses one received part. Stricter than Goby3 where Goby3 would abort or mis-parse (a pid
/// with trailing letters, a thread id that is not hex); as lenient where Goby3 delivers (upper-
/// case hex, pid 0, no trailing `/` after the thread).
pub fn decode(bytes: &[u8], max: usize) -> Result<Frame<'_>, FrameError> {
    if bytes.len() > max {
        return Err(FrameError::Oversized {
            len: bytes.len(),
            max,
        });
    }
    let nul = bytes
        .iter()
        .position(|b| *b == 0)
        .ok_or(FrameError::NoNul)?;
    let (id, payload) = (&bytes[..nul], &bytes[nul + 1..]);
    let id = std::str::from_utf8(id).map_err(|_| FrameError::NotUtf8)?;
    let id = id.strip_prefix('/').ok_or(FrameError::NoLeadingSlash)?;
    let id = id.strip_suffix('/').unwrap_or(id);
    let fields: Vec<&str> = id.split('/').collect();
    let [group, scheme, type_name, pid, thread] = fields[..] else {
        return Err(FrameError::FieldCount(fields.len()));
    };
    for (what, v) in [("group", group), ("scheme", scheme), ("type", type_name)] {
        if v.is_empty() {
            return Err(FrameError::Empty(what));
        }
    }
    let pid_ok = {
        let digits = pid.strip_prefix('-').unwrap_or(pid);
        !digits.is_empty() && digits.bytes().all(|b| b.is_ascii_digit())
    };
    let pid = pid_ok
        .then(|| pid.parse::<i32>().ok())
        .flatten()
        .ok_or_else(|| FrameError::BadPid(pid.chars().take(32).collect()))?;
    let thread_ok = !thread.is_empty()
        && thread.len() <= MAX_THREAD_DIGITS
        && thread.bytes().all(|b| b.is_ascii_hexdigit());
    let thread = thread_ok
        .then(|| u64::from_str_radix(thread, 16).ok())
        .flatten()
        .ok_or_else(|| FrameError::BadThread(thread.chars().take(32).collect()))?;
    Ok(Frame {
        group,
        scheme,
        type_name,
        pid,
        thread,
        payload,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const RAW: &str = "goby.middleware.frontseat.protobuf.Raw";
    const G: &str = "goby::middleware::frontseat::raw_send_request";

    #[test]
    fn encode_then_decode_is_identity() {
        let f = encode(G, RAW, 1390, 0x790d258c6961c06e, b"\x0a\x01x");
        let d = decode(&f, 1000).unwrap();
        assert_eq!(
            d,
            Frame {
                group: G,
                scheme: SCHEME_PROTOBUF,
                type_name: RAW,
                pid: 1390,
                thread: 0x790d258c6961c06e,
                payload: b"\x0a\x01x"
            }
        );
        assert!(f.starts_with(subscription_prefix(G, RAW).as_bytes()));
    }

    #[test]
    fn prefix_of_one_group_does_not_match_a_longer_name() {
        let p = subscription_prefix("a::status", RAW);
        let other = encode("a::status_x", RAW, 1, 1, b"");
        assert!(!other.starts_with(p.as_bytes()));
    }

    #[test]
    fn a_nul_inside_the_payload_is_payload() {
        let f = encode(G, RAW, 1, 1, &[0, 0, 1]);
        assert_eq!(decode(&f, 1000).unwrap().payload, &[0, 0, 1]);
    }

    #[test]
    fn malformed_identifiers_table() {
        let p = |s: &str| {
            let mut v = s.as_bytes().to_vec();
            v.push(0);
            v.push(8);
            v
        };
        let rows: Vec<(Vec<u8>, FrameError)> = vec![
            (b"/g/PROTOBUF/T/1/a/".to_vec(), FrameError::NoNul),
            (p("g/PROTOBUF/T/1/a/"), FrameError::NoLeadingSlash),
            (p("/g/PROTOBUF/T/"), FrameError::FieldCount(3)),
            (p("/g/x/PROTOBUF/T/1/a/"), FrameError::FieldCount(6)),
            (p("//PROTOBUF/T/1/a/"), FrameError::Empty("group")),
            (p("/g/PROTOBUF//1/a/"), FrameError::Empty("type")),
            (
                p("/g/PROTOBUF/T/python/a/"),
                FrameError::BadPid("python".into()),
            ),
            (p("/g/PROTOBUF/T/12x/a/"), FrameError::BadPid("12x".into())),
            (
                p("/g/PROTOBUF/T/99999999999/a/"),
                FrameError::BadPid("99999999999".into()),
            ),
            (
                p("/g/PROTOBUF/T/1/main/"),
                FrameError::BadThread("main".into()),
            ),
            (p("/g/PROTOBUF/T/1//"), FrameError::BadThread(String::new())),
            (
                p("/g/PROTOBUF/T/1/11111111111111111/"),
                FrameError::BadThread("11111111111111111".into()),
            ),
            (
                {
                    let mut v = b"/g/PROTOBUF/T/1/".to_vec();
                    v.push(0xff);
                    v.extend_from_slice(b"/\0");
                    v
                },
                FrameError::NotUtf8,
            ),
        ];
        for (bytes, want) in rows {
            assert_eq!(
                decode(&bytes, 1000),
                Err(want.clone()),
                "{:?}",
                String::from_utf8_lossy(&bytes)
            );
        }
        assert_eq!(
            decode(&p("/g/PROTOBUF/T/1/a/"), 5),
            Err(FrameError::Oversized { len: 20, max: 5 })
        );
    }

    #[test]
    fn what_goby3_delivers_is_accepted() {
        for id in [
            "/g/PROTOBUF/T/0/0/",
            "/g/PROTOBUF/T/-1/ABCDEF/",
            "/g/PROTOBUF/T/5305/1f16fb7f9fd52474",
            "/g;3/PROTOBUF/T/1/ffffffffffffffff/",
        ] {
            let mut v = id.as_bytes().to_vec();
            v.push(0);
            assert!(decode(&v, 1000).is_ok(), "{id}");
        }
    }
}
