//! A minimal OTLP/HTTP trace sink on loopback for row T1: answers `200 OK` (an empty
//! ExportTraceServiceResponse) to every `POST /v1/traces` and counts requests and body bytes, so
//! the interface child exports for real without a collector installed. Bodies are read and
//! dropped, never decoded: the bench measures the exporter's cost, not what it exports.

use std::net::Ipv4Addr;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};

/// A request head bigger than this is not an OTLP exporter talking.
const MAX_HEAD: usize = 64 * 1024;
/// The SDK's batches are far smaller; a bigger body is refused, so memory stays bounded.
const MAX_BODY: usize = 32 * 1024 * 1024;

#[derive(Default)]
struct Counters {
    exports: AtomicU64,
    bytes: AtomicU64,
    refused: AtomicU64,
}

/// What the sink received so far.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SinkStats {
    /// `POST /v1/traces` answered 200.
    pub exports: u64,
    /// Body bytes of those requests.
    pub bytes: u64,
    /// Requests answered with an error (wrong route, no or too large content-length).
    pub refused: u64,
}

pub struct Sink {
    port: u16,
    counters: Arc<Counters>,
    task: tokio::task::JoinHandle<()>,
}

impl Sink {
    pub async fn start() -> std::io::Result<Self> {
        let listener = TcpListener::bind((Ipv4Addr::LOCALHOST, 0)).await?;
        let port = listener.local_addr()?.port();
        let counters = Arc::new(Counters::default());
        let c = counters.clone();
        let task = tokio::spawn(async move {
            let mut conns = tokio::task::JoinSet::new();
            while let Ok((sock, _)) = listener.accept().await {
                conns.spawn(serve(sock, c.clone()));
                // Reap finished connections so a long run does not accumulate handles.
                while conns.try_join_next().is_some() {}
            }
        });
        Ok(Self {
            port,
            counters,
            task,
        })
    }

    /// The base URL for `[telemetry] endpoint` (the exporter appends `/v1/traces`).
    pub fn url(&self) -> String {
        format!("http://127.0.0.1:{}", self.port)
    }

    pub fn stats(&self) -> SinkStats {
        SinkStats {
            exports: self.counters.exports.load(Ordering::Relaxed),
            bytes: self.counters.bytes.load(Ordering::Relaxed),
            refused: self.counters.refused.load(Ordering::Relaxed),
        }
    }
}

impl Drop for Sink {
    fn drop(&mut self) {
        // Aborting the accept loop drops its JoinSet, which aborts every connection.
        self.task.abort();
    }
}

/// The `content-length` of a request head, if it has a usable one.
fn content_length(head: &str) -> Option<usize> {
    head.split("\r\n").skip(1).find_map(|l| {
        let (k, v) = l.split_once(':')?;
        k.trim()
            .eq_ignore_ascii_case("content-length")
            .then(|| v.trim().parse().ok())?
    })
}

async fn respond(sock: &mut TcpStream, status: &str) -> bool {
    let head = format!(
        "HTTP/1.1 {status}\r\nContent-Type: application/x-protobuf\r\nContent-Length: 0\r\n\r\n"
    );
    sock.write_all(head.as_bytes()).await.is_ok()
}

/// Serves one keep-alive connection until the peer closes it or sends something unusable.
async fn serve(mut sock: TcpStream, c: Arc<Counters>) {
    let mut buf: Vec<u8> = Vec::with_capacity(8192);
    let mut chunk = vec![0u8; 64 * 1024];
    loop {
        let head_end = loop {
            if let Some(i) = buf.windows(4).position(|w| w == b"\r\n\r\n") {
                break i + 4;
            }
            if buf.len() > MAX_HEAD {
                c.refused.fetch_add(1, Ordering::Relaxed);
                return;
            }
            match sock.read(&mut chunk).await {
                Ok(0) | Err(_) => return,
                Ok(n) => buf.extend_from_slice(&chunk[..n]),
            }
        };
        let head = String::from_utf8_lossy(&buf[..head_end]).into_owned();
        let Some(len) = content_length(&head).filter(|&l| l <= MAX_BODY) else {
            c.refused.fetch_add(1, Ordering::Relaxed);
            let _ = respond(&mut sock, "411 Length Required").await;
            return;
        };
        while buf.len() < head_end + len {
            match sock.read(&mut chunk).await {
                Ok(0) | Err(_) => return,
                Ok(n) => buf.extend_from_slice(&chunk[..n]),
            }
        }
        buf.drain(..head_end + len);
        let status = if head.starts_with("POST /v1/traces ") {
            c.exports.fetch_add(1, Ordering::Relaxed);
            c.bytes.fetch_add(len as u64, Ordering::Relaxed);
            "200 OK"
        } else {
            c.refused.fetch_add(1, Ordering::Relaxed);
            "404 Not Found"
        };
        if !respond(&mut sock, status).await {
            return;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    async fn exchange(port: u16, req: &[u8]) -> String {
        let mut s = TcpStream::connect((Ipv4Addr::LOCALHOST, port))
            .await
            .unwrap();
        s.write_all(req).await.unwrap();
        let mut got = Vec::new();
        let mut b = [0u8; 1024];
        // One response per request; the head ends the response (Content-Length: 0).
        while !got.windows(4).any(|w| w == b"\r\n\r\n") {
            let n = s.read(&mut b).await.unwrap();
            assert!(n > 0, "closed early: {}", String::from_utf8_lossy(&got));
            got.extend_from_slice(&b[..n]);
        }
        String::from_utf8_lossy(&got).into_owned()
    }

    #[tokio::test]
    async fn counts_trace_exports_and_refuses_the_rest() {
        let sink = Sink::start().await.unwrap();
        let port = sink.port;
        let ok = tokio::time::timeout(
            std::time::Duration::from_secs(10),
            exchange(
                port,
                b"POST /v1/traces HTTP/1.1\r\nHost: x\r\nContent-Length: 5\r\n\r\nhello",
            ),
        )
        .await
        .unwrap();
        assert!(ok.starts_with("HTTP/1.1 200 OK"), "{ok}");
        let bad = tokio::time::timeout(
            std::time::Duration::from_secs(10),
            exchange(port, b"POST /v1/traces HTTP/1.1\r\nHost: x\r\n\r\n"),
        )
        .await
        .unwrap();
        assert!(bad.starts_with("HTTP/1.1 411"), "{bad}");
        assert_eq!(
            sink.stats(),
            SinkStats {
                exports: 1,
                bytes: 5,
                refused: 1
            }
        );
        assert!(sink.url().ends_with(&format!(":{port}")));
    }

    #[test]
    fn content_length_is_case_insensitive_and_must_parse() {
        assert_eq!(
            content_length("POST / HTTP/1.1\r\ncontent-LENGTH: 12\r\n\r\n"),
            Some(12)
        );
        assert_eq!(
            content_length("POST / HTTP/1.1\r\nContent-Length: x\r\n\r\n"),
            None
        );
        assert_eq!(content_length("POST / HTTP/1.1\r\n\r\n"), None);
    }
}
