//! Shared pieces of the web tests: a plain HTTP/1.1 client over a real loopback socket (so a
//! test can send exactly the bytes it means, headers and bodies the server must refuse
//! included) and a Server-Sent Events reader.
#![allow(dead_code)]

pub mod browser;

use std::net::SocketAddr;
use std::time::Duration;

use serde_json::Value;
use tokio::io::{AsyncBufReadExt, AsyncReadExt, AsyncWriteExt, BufReader};
use tokio::net::TcpStream;

pub const TIMEOUT: Duration = Duration::from_secs(20);

#[derive(Debug)]
pub struct Reply {
    pub status: u16,
    pub head: String,
    pub body: String,
}

impl Reply {
    pub fn json(&self) -> Value {
        serde_json::from_str(&self.body).unwrap_or_else(|e| panic!("not JSON ({e}): {}", self.body))
    }
}

/// One request on a fresh connection (`Connection: close`); `Host` is the server's address
/// unless `headers` gives one.
pub async fn request(
    addr: SocketAddr,
    method: &str,
    path: &str,
    headers: &[(&str, &str)],
    body: &[u8],
) -> Reply {
    let mut s = tokio::time::timeout(TIMEOUT, TcpStream::connect(addr))
        .await
        .expect("connect in time")
        .expect("connect");
    let mut req = format!("{method} {path} HTTP/1.1\r\nConnection: close\r\n");
    if !headers.iter().any(|(k, _)| k.eq_ignore_ascii_case("host")) {
        req.push_str(&format!("Host: {addr}\r\n"));
    }
    for (k, v) in headers {
        req.push_str(&format!("{k}: {v}\r\n"));
    }
    req.push_str(&format!("Content-Length: {}\r\n\r\n", body.len()));
    s.write_all(req.as_bytes()).await.expect("write head");
    // The server may answer (413) before reading a large body; a reset then is fine.
    let _ = s.write_all(body).await;
    let raw = tokio::time::timeout(TIMEOUT, read_reply(&mut s))
        .await
        .expect("reply in time");
    let text = String::from_utf8_lossy(&raw).to_string();
    let (head, body) = text.split_once("\r\n\r\n").unwrap_or((&text, ""));
    let status = head
        .split(' ')
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(0);
    let body = if head
        .to_ascii_lowercase()
        .contains("transfer-encoding: chunked")
    {
        dechunk(body)
    } else {
        body.to_string()
    };
    Reply {
        status,
        head: head.to_string(),
        body,
    }
}

/// Reads one reply: to its Content-Length when it gives one (some servers keep the connection
/// open whatever the request said), else to the end of the stream.
async fn read_reply(s: &mut TcpStream) -> Vec<u8> {
    let mut raw = Vec::new();
    let mut buf = [0u8; 8192];
    loop {
        if let Some(end) = raw.windows(4).position(|w| w == b"\r\n\r\n") {
            let head = String::from_utf8_lossy(&raw[..end]).to_ascii_lowercase();
            let len = head
                .lines()
                .find_map(|l| l.strip_prefix("content-length:"))
                .and_then(|v| v.trim().parse::<usize>().ok());
            if let Some(len) = len
                && raw.len() >= end + 4 + len
            {
                return raw;
            }
        }
        match s.read(&mut buf).await {
            Ok(0) | Err(_) => return raw,
            Ok(n) => raw.extend_from_slice(&buf[..n]),
        }
    }
}

fn dechunk(mut s: &str) -> String {
    let mut out = String::new();
    while let Some((size, rest)) = s.split_once("\r\n") {
        let Ok(n) = usize::from_str_radix(size.trim(), 16) else {
            break;
        };
        if n == 0 || rest.len() < n {
            break;
        }
        out.push_str(&rest[..n]);
        s = rest[n..].trim_start_matches("\r\n");
    }
    out
}

pub async fn get(addr: SocketAddr, path: &str) -> Reply {
    request(addr, "GET", path, &[], b"").await
}

pub async fn post_json(
    addr: SocketAddr,
    path: &str,
    extra: &[(&str, &str)],
    body: &Value,
) -> Reply {
    let mut h = vec![("Content-Type", "application/json")];
    h.extend_from_slice(extra);
    request(addr, "POST", path, &h, body.to_string().as_bytes()).await
}

/// A tab's event stream.
pub struct Sse {
    reader: BufReader<TcpStream>,
    pub status: u16,
}

impl Sse {
    pub async fn open(addr: SocketAddr, path: &str) -> Sse {
        let mut s = TcpStream::connect(addr).await.expect("connect");
        let req =
            format!("GET {path} HTTP/1.1\r\nHost: {addr}\r\nAccept: text/event-stream\r\n\r\n");
        s.write_all(req.as_bytes()).await.expect("write");
        let mut reader = BufReader::new(s);
        let mut status = 0;
        loop {
            let mut line = String::new();
            let n = tokio::time::timeout(TIMEOUT, reader.read_line(&mut line))
                .await
                .expect("head in time")
                .expect("read head");
            if n == 0 {
                break;
            }
            if status == 0 {
                status = line
                    .split(' ')
                    .nth(1)
                    .and_then(|s| s.parse().ok())
                    .unwrap_or(0);
            }
            if line == "\r\n" {
                break;
            }
        }
        Sse { reader, status }
    }

    /// The next event's JSON data (keep-alive comments and chunk sizes skipped); None at the
    /// end of the stream.
    pub async fn next(&mut self) -> Option<Value> {
        loop {
            let mut line = String::new();
            let n = tokio::time::timeout(TIMEOUT, self.reader.read_line(&mut line))
                .await
                .expect("event in time")
                .ok()?;
            // End of stream, or the last chunk of the chunked body (the connection stays open).
            if n == 0 || line == "0\r\n" {
                return None;
            }
            if let Some(data) = line.trim_end().strip_prefix("data: ") {
                return Some(serde_json::from_str(data).expect("event data is JSON"));
            }
        }
    }

    /// The next event of kind `msg` on `group`.
    pub async fn next_on(&mut self, group: &str) -> Value {
        loop {
            let ev = self.next().await.expect("stream open");
            if ev["kind"] == "msg" && ev["group"] == group {
                return ev;
            }
        }
    }
}

/// Sockets that each hold a connection without finishing a request, as anyone on the host can
/// open: every other one connects and stays silent, the rest send one byte and then one more
/// each second for as long as the socket stays open (a request head that never ends). Dropping
/// it closes them all.
pub struct Flood {
    _idle: Vec<TcpStream>,
    _trickling: tokio::task::JoinSet<()>,
}

pub async fn flood(addr: SocketAddr, n: usize) -> Flood {
    let mut idle = Vec::new();
    let mut trickling = tokio::task::JoinSet::new();
    for i in 0..n {
        let mut s = tokio::time::timeout(TIMEOUT, TcpStream::connect(addr))
            .await
            .expect("connect in time")
            .expect("connect");
        if i % 2 == 0 {
            idle.push(s);
            continue;
        }
        trickling.spawn(async move {
            if s.write_all(b"G").await.is_err() {
                return;
            }
            let mut rest = b"ET /api/info HTTP/1.1\r\nX-Slow: ".iter().copied();
            let mut buf = [0u8; 256];
            loop {
                tokio::select! {
                    r = s.read(&mut buf) => match r {
                        Ok(0) | Err(_) => return,
                        // Whatever the server says (nothing, or an error status), the flood goes on.
                        Ok(_) => {}
                    },
                    () = tokio::time::sleep(Duration::from_secs(1)) => {
                        if s.write_all(&[rest.next().unwrap_or(b'a')]).await.is_err() {
                            return;
                        }
                    }
                }
            }
        });
    }
    Flood {
        _idle: idle,
        _trickling: trickling,
    }
}
