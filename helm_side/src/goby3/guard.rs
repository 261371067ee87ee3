//! A ZMTP length guard in front of each ZeroMQ socket we connect to gobyd. The `zeromq` crate
//! (0.7, the newest) has no maximum message size: a frame header claiming 2^40 bytes makes its
//! decoder reserve that much, and the process aborts. So each of our sockets connects to a
//! loopback listener of ours instead, and the bytes coming from gobyd pass through a [`Meter`]
//! that reads the ZMTP 3 framing (the 64-byte greeting, then flags, a 1- or 8-byte size and the
//! body of each frame) and closes the connection *before* forwarding a frame, or a multi-frame
//! message, larger than `[goby3] max_message_bytes`. Bytes towards gobyd pass unchanged. The
//! zeromq socket then sees its peer gone, and the link joins gobyd again as after any loss.
//!
//! The price is one more loopback hop each way on the Goby3 path (rows G1/G2 of `frontseat
//! bench`); `max_message_bytes = 0` removes the guard for a gobyd that is trusted with any size.

use std::net::Ipv4Addr;
use std::path::PathBuf;
use std::sync::Arc;

use tokio::io::{AsyncRead, AsyncReadExt, AsyncWrite, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream, UnixStream};
use tokio::task::JoinSet;

use super::traffic::{Counters, bump};
use crate::wire;

/// ZMTP 3's greeting: signature, version, mechanism, as-server, filler.
const GREETING_LEN: usize = 64;
const FLAG_MORE: u8 = 0b001;
const FLAG_LONG: u8 = 0b010;
const FLAG_COMMAND: u8 = 0b100;
const READ_CHUNK: usize = 16 * 1024;

/// A frame or message from gobyd over the limit.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{what} of {size} bytes from gobyd is over max_message_bytes ({limit})")]
pub struct Oversized {
    pub what: &'static str,
    pub size: u64,
    pub limit: u64,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum State {
    Greeting { left: usize },
    Flags,
    Size { flags: u8, left: u8, size: u64 },
    Body { left: u64 },
}

/// Follows the ZMTP 3 framing of one direction of a connection, byte by byte across reads.
#[derive(Debug)]
pub struct Meter {
    limit: u64,
    state: State,
    /// Bytes of the message whose frames are still coming (MORE set on the last one).
    message: u64,
}

impl Meter {
    pub fn new(limit: u64) -> Self {
        Self {
            limit,
            state: State::Greeting { left: GREETING_LEN },
            message: 0,
        }
    }

    /// Takes the next bytes of the stream; an error at the first frame header whose size, or whose
    /// message's running size, is over the limit (before any of its body).
    pub fn feed(&mut self, mut bytes: &[u8]) -> Result<(), Oversized> {
        while let Some((&b, rest)) = bytes.split_first() {
            match self.state {
                State::Greeting { left } => {
                    let k = left.min(bytes.len());
                    bytes = &bytes[k..];
                    self.state = if k == left {
                        State::Flags
                    } else {
                        State::Greeting { left: left - k }
                    };
                }
                State::Flags => {
                    bytes = rest;
                    self.state = State::Size {
                        flags: b,
                        left: if b & FLAG_LONG != 0 { 8 } else { 1 },
                        size: 0,
                    };
                }
                State::Size { flags, left, size } => {
                    bytes = rest;
                    let size = (size << 8) | u64::from(b);
                    if left > 1 {
                        self.state = State::Size {
                            flags,
                            left: left - 1,
                            size,
                        };
                        continue;
                    }
                    self.header(flags, size)?;
                    self.state = if size == 0 {
                        State::Flags
                    } else {
                        State::Body { left: size }
                    };
                }
                State::Body { left } => {
                    let k = left.min(bytes.len() as u64);
                    bytes = &bytes[k as usize..];
                    self.state = if k == left {
                        State::Flags
                    } else {
                        State::Body { left: left - k }
                    };
                }
            }
        }
        Ok(())
    }

    fn header(&mut self, flags: u8, size: u64) -> Result<(), Oversized> {
        let over = |what, size| Oversized {
            what,
            size,
            limit: self.limit,
        };
        if size > self.limit {
            return Err(over("a frame", size));
        }
        if flags & FLAG_COMMAND != 0 {
            return Ok(());
        }
        self.message = self.message.saturating_add(size);
        if self.message > self.limit {
            return Err(over("a message", self.message));
        }
        if flags & FLAG_MORE == 0 {
            self.message = 0;
        }
        Ok(())
    }
}

/// Where gobyd listens.
#[derive(Clone, Debug, PartialEq, Eq)]
enum Upstream {
    Tcp(String),
    Ipc(PathBuf),
}

trait Io: AsyncRead + AsyncWrite + Unpin + Send {}
impl<T: AsyncRead + AsyncWrite + Unpin + Send> Io for T {}

impl Upstream {
    fn parse(endpoint: &str) -> Option<Self> {
        if let Some(addr) = endpoint.strip_prefix("tcp://") {
            Some(Self::Tcp(addr.to_string()))
        } else {
            endpoint
                .strip_prefix("ipc://")
                .map(|p| Self::Ipc(PathBuf::from(p)))
        }
    }

    async fn connect(&self) -> std::io::Result<Box<dyn Io>> {
        Ok(match self {
            Self::Tcp(addr) => {
                let s = TcpStream::connect(addr.as_str()).await?;
                let _ = s.set_nodelay(true);
                Box::new(s)
            }
            Self::Ipc(path) => Box::new(UnixStream::connect(path).await?),
        })
    }
}

/// A running guard: connect the zeromq socket to `endpoint`. Dropping it closes every relayed
/// connection.
pub struct Guard {
    pub endpoint: String,
    task: Option<tokio::task::JoinHandle<()>>,
}

impl Drop for Guard {
    fn drop(&mut self) {
        if let Some(t) = &self.task {
            t.abort();
        }
    }
}

/// Puts a guard in front of gobyd's `upstream` endpoint. gobyd is reached once here, so that an
/// absent gobyd fails the join at once, as a direct connect would. A `limit` of 0 is no guard:
/// the socket connects to gobyd itself.
pub(crate) async fn front(
    upstream: &str,
    limit: u64,
    counters: Arc<Counters>,
) -> std::io::Result<Guard> {
    if limit == 0 {
        return Ok(Guard {
            endpoint: upstream.to_string(),
            task: None,
        });
    }
    let up = Upstream::parse(upstream).ok_or_else(|| {
        std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            format!("not a tcp:// or ipc:// endpoint: {upstream}"),
        )
    })?;
    let first = up.connect().await?;
    let listener = TcpListener::bind((Ipv4Addr::LOCALHOST, 0)).await?;
    let endpoint = format!("tcp://{}", listener.local_addr()?);
    let task = Some(tokio::spawn(serve(listener, up, first, limit, counters)));
    Ok(Guard { endpoint, task })
}

async fn serve(
    listener: TcpListener,
    up: Upstream,
    first: Box<dyn Io>,
    limit: u64,
    counters: Arc<Counters>,
) {
    let mut first = Some(first);
    let mut relays = JoinSet::new();
    while let Ok((down, _)) = listener.accept().await {
        while relays.try_join_next().is_some() {}
        let upstream = match first.take() {
            Some(s) => s,
            None => match up.connect().await {
                Ok(s) => s,
                // gobyd gone: closing `down` tells the socket so.
                Err(_) => continue,
            },
        };
        relays.spawn(relay(down, upstream, limit, counters.clone()));
    }
}

async fn relay(down: TcpStream, up: Box<dyn Io>, limit: u64, counters: Arc<Counters>) {
    let _ = down.set_nodelay(true);
    let (mut down_rd, mut down_wr) = down.into_split();
    let (mut up_rd, mut up_wr) = tokio::io::split(up);
    tokio::select! {
        _ = tokio::io::copy(&mut down_rd, &mut up_wr) => {}
        r = metered_copy(&mut up_rd, &mut down_wr, limit) => {
            if let Err(o) = r {
                let n = bump(&counters.oversized);
                if wire::worth_logging(n) {
                    tracing::warn!(count = n, "{o}; connection to gobyd closed");
                }
            }
        }
    }
}

/// Copies until either side closes; stops before forwarding anything of an oversized frame.
async fn metered_copy(
    from: &mut (impl AsyncRead + Unpin),
    to: &mut (impl AsyncWrite + Unpin),
    limit: u64,
) -> Result<(), Oversized> {
    let mut meter = Meter::new(limit);
    let mut buf = vec![0u8; READ_CHUNK];
    loop {
        let n = match from.read(&mut buf).await {
            Ok(0) | Err(_) => return Ok(()),
            Ok(n) => n,
        };
        crate::hops::hop("goby3.guard.in", "");
        meter.feed(&buf[..n])?;
        if to.write_all(&buf[..n]).await.is_err() {
            return Ok(());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn greeting() -> Vec<u8> {
        let mut g = vec![0xff, 0, 0, 0, 0, 0, 0, 0, 0, 0x7f, 3, 0];
        g.extend_from_slice(b"NULL");
        g.resize(GREETING_LEN, 0);
        g
    }

    fn frame(flags: u8, body: &[u8]) -> Vec<u8> {
        let mut f = Vec::new();
        if body.len() > 255 {
            f.push(flags | FLAG_LONG);
            f.extend_from_slice(&(body.len() as u64).to_be_bytes());
        } else {
            f.push(flags);
            f.push(body.len() as u8);
        }
        f.extend_from_slice(body);
        f
    }

    /// Fed whole and fed one byte at a time, the same verdict.
    fn verdict(limit: u64, stream: &[u8]) -> Result<(), Oversized> {
        let whole = Meter::new(limit).feed(stream);
        let mut m = Meter::new(limit);
        let bytewise = stream
            .iter()
            .try_for_each(|b| m.feed(std::slice::from_ref(b)));
        assert_eq!(whole, bytewise);
        whole
    }

    #[test]
    fn frames_and_messages_within_the_limit_pass() {
        let mut s = greeting();
        s.extend(frame(FLAG_COMMAND, b"\x05READY"));
        s.extend(frame(FLAG_MORE, &[1; 300]));
        s.extend(frame(0, &[2; 700]));
        s.extend(frame(0, &[]));
        s.extend(frame(0, &[3; 1000]));
        assert_eq!(verdict(1000, &s), Ok(()));
    }

    #[test]
    fn a_frame_over_the_limit_is_refused_at_its_header() {
        let mut s = greeting();
        s.extend(frame(0, &[1; 10]));
        s.push(FLAG_LONG);
        s.extend_from_slice(&(1u64 << 40).to_be_bytes());
        assert_eq!(
            verdict(4096, &s),
            Err(Oversized {
                what: "a frame",
                size: 1 << 40,
                limit: 4096
            })
        );
    }

    #[test]
    fn a_message_of_small_frames_over_the_limit_is_refused() {
        let mut s = greeting();
        for _ in 0..4 {
            s.extend(frame(FLAG_MORE, &[0; 300]));
        }
        assert_eq!(
            verdict(1000, &s),
            Err(Oversized {
                what: "a message",
                size: 1200,
                limit: 1000
            })
        );
        // Commands are frames of their own, never part of a message.
        let mut s = greeting();
        s.extend(frame(FLAG_MORE, &[0; 600]));
        s.extend(frame(FLAG_COMMAND, &[0; 600]));
        s.extend(frame(0, &[0; 400]));
        assert_eq!(verdict(1000, &s), Ok(()));
    }

    #[test]
    fn endpoints_parse() {
        assert_eq!(
            Upstream::parse("tcp://127.0.0.1:11144"),
            Some(Upstream::Tcp("127.0.0.1:11144".into()))
        );
        assert_eq!(
            Upstream::parse("ipc:///tmp/goby_auv1.manager"),
            Some(Upstream::Ipc("/tmp/goby_auv1.manager".into()))
        );
        assert_eq!(Upstream::parse("inproc://x"), None);
    }
}
