//! The topside's page and its Foxglove server stay reachable while anyone on the host holds
//! hundreds of sockets that never finish a request (silent, or a byte a second), and the
//! Foxglove server refuses another site's page (foreign Origin, or foreign Host: DNS
//! rebinding) as the page does. Real loopback sockets, bounded waits.

use std::net::SocketAddr;
use std::time::Duration;

use frontseat_topside::{Topside, TopsideConfig};
use futures_util::StreamExt;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;
use tokio_tungstenite::tungstenite::Message;
use tokio_tungstenite::tungstenite::client::IntoClientRequest;

const BOUND: Duration = Duration::from_secs(10);

/// `n` sockets holding a connection without finishing a request: every other one silent, the
/// rest trickling `head` a byte a second while open. Dropping the set closes them.
async fn flood(addr: SocketAddr, n: usize, head: &'static [u8]) -> tokio::task::JoinSet<()> {
    let mut set = tokio::task::JoinSet::new();
    for i in 0..n {
        let mut s = tokio::time::timeout(BOUND, TcpStream::connect(addr))
            .await
            .expect("connect in time")
            .expect("connect");
        set.spawn(async move {
            let mut bytes = head.iter().copied();
            let mut buf = [0u8; 256];
            loop {
                tokio::select! {
                    r = s.read(&mut buf) => match r {
                        Ok(0) | Err(_) => return,
                        // Whatever the server says (nothing, or an error status), the flood goes on.
                        Ok(_) => {}
                    },
                    () = tokio::time::sleep(Duration::from_secs(1)), if i % 2 == 1 => {
                        if s.write_all(&[bytes.next().unwrap_or(b'a')]).await.is_err() {
                            return;
                        }
                    }
                }
            }
        });
    }
    set
}

async fn get(addr: SocketAddr, path: &str) -> (u16, String) {
    let mut s = TcpStream::connect(addr).await.unwrap();
    let req = format!("GET {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n");
    let _ = s.write_all(req.as_bytes()).await;
    let mut buf = Vec::new();
    let _ = s.read_to_end(&mut buf).await;
    let text = String::from_utf8_lossy(&buf).into_owned();
    let code = text.get(9..12).and_then(|c| c.parse().ok()).unwrap_or(0);
    let body = text
        .split_once("\r\n\r\n")
        .map(|(_, b)| b.to_string())
        .unwrap_or_default();
    (code, body)
}

fn config() -> TopsideConfig {
    let mut cfg = TopsideConfig::default();
    cfg.web.listen = "127.0.0.1:0".into();
    cfg.foxglove.enabled = true;
    cfg.foxglove.bind = "127.0.0.1:0".into();
    cfg
}

type Ws = tokio_tungstenite::WebSocketStream<tokio_tungstenite::MaybeTlsStream<TcpStream>>;

async fn connect(
    url: &str,
    headers: &[(&'static str, &str)],
) -> Result<Ws, tokio_tungstenite::tungstenite::Error> {
    let mut req = url.into_client_request().unwrap();
    req.headers_mut().insert(
        "Sec-WebSocket-Protocol",
        "foxglove.websocket.v1".parse().unwrap(),
    );
    for (k, v) in headers {
        req.headers_mut().insert(*k, v.parse().unwrap());
    }
    Ok(tokio_tungstenite::connect_async(req).await?.0)
}

async fn first_op(ws: &mut Ws) -> serde_json::Value {
    loop {
        let m = tokio::time::timeout(BOUND, ws.next())
            .await
            .expect("a message in time")
            .expect("open")
            .expect("no error");
        if let Message::Text(t) = m {
            return serde_json::from_str(&t).unwrap();
        }
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_topside_page_serves_a_new_client_through_hundreds_of_idle_sockets() {
    let top = Topside::start(&config()).await.unwrap();
    let addr = top.local_addr();
    let _flood = flood(addr, 300, b"GET /api/fleet HTTP/1.1\r\nX-Slow: ").await;
    let (code, body) = tokio::time::timeout(BOUND, get(addr, "/api/fleet"))
        .await
        .expect("the fleet within the bound");
    assert_eq!(code, 200, "{body}");
    assert!(body.contains("vehicles"), "{body}");
    let (code, body) = tokio::time::timeout(BOUND, get(addr, "/"))
        .await
        .expect("the page within the bound");
    assert_eq!(code, 200);
    assert!(body.contains("frontseat topside"));
    top.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_topside_foxglove_serves_a_new_client_through_hundreds_of_idle_sockets() {
    let top = Topside::start(&config()).await.unwrap();
    let addr = top.foxglove_addr().unwrap();
    let _flood = flood(
        addr,
        300,
        b"GET / HTTP/1.1\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n",
    )
    .await;
    let mut ws = tokio::time::timeout(BOUND, connect(&format!("ws://{addr}/"), &[]))
        .await
        .expect("a client connects within the bound")
        .expect("upgraded");
    assert_eq!(first_op(&mut ws).await["op"], "serverInfo");
    // A second flood does not take the connected client: it still hears the server (pings).
    let _second = flood(addr, 300, b"GET / HTTP/1.1\r\n").await;
    let m = tokio::time::timeout(BOUND, ws.next())
        .await
        .expect("a message in time")
        .expect("still open");
    assert!(m.is_ok(), "{m:?}");
    top.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_topside_foxglove_refuses_a_foreign_origin_or_host() {
    let top = Topside::start(&config()).await.unwrap();
    let addr = top.foxglove_addr().unwrap();
    let url = format!("ws://{addr}/");
    let rebound = format!("evil.example:{}", addr.port());
    for headers in [
        vec![("Origin", "https://evil.example")],
        vec![("Host", rebound.as_str())],
    ] {
        match connect(&url, &headers).await {
            Err(tokio_tungstenite::tungstenite::Error::Http(r)) => {
                assert_eq!(r.status().as_u16(), 403, "{headers:?}")
            }
            other => panic!("{headers:?}: expected 403, got {:?}", other.map(|_| ())),
        }
    }
    let own = format!("http://{addr}");
    let mut ws = connect(&url, &[("Origin", own.as_str())]).await.unwrap();
    assert_eq!(first_op(&mut ws).await["op"], "serverInfo");
    top.shutdown().await;
}

/// `web.idle_timeout_s` bounds a request whose body trickles in a byte at a time (each byte
/// resets the idle timer, the head is complete, so the header timeout is past): closed once
/// that long has gone by since its first byte with no answer. Was a fixed 30 s.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_trickled_request_is_closed_after_the_configured_idle_timeout() {
    let mut cfg = config();
    cfg.foxglove.enabled = false;
    cfg.web.idle_timeout_s = 1;
    let top = Topside::start(&cfg).await.unwrap();
    let addr = top.local_addr();
    let mut s = TcpStream::connect(addr).await.unwrap();
    let head = format!(
        "POST /api/vehicle/auv1/send HTTP/1.1\r\nHost: {addr}\r\nContent-Type: application/json\r\nContent-Length: 4096\r\n\r\n{{"
    );
    s.write_all(head.as_bytes()).await.unwrap();
    let (mut rd, mut wr) = s.into_split();
    let trickle = tokio::spawn(async move {
        let mut tick = tokio::time::interval(Duration::from_millis(200));
        loop {
            tick.tick().await;
            if wr.write_all(b" ").await.is_err() {
                return;
            }
        }
    });
    // Closed (end of stream or reset) well before the 30 s it used to take; an answer, if the
    // server sends one before closing, is read through.
    let mut buf = Vec::new();
    let closed = tokio::time::timeout(BOUND, rd.read_to_end(&mut buf)).await;
    trickle.abort();
    assert!(
        closed.is_ok(),
        "the trickled request was still open after {BOUND:?}"
    );
    top.shutdown().await;
}
