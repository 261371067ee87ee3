//! Web clients of the commander: the requests a browser, a client without the token or a broken
//! one sends (also `tests/hostile_web.rs`' requests), one exchange on its own connection, and
//! the commander the harness starts for them to flood.

use std::net::SocketAddr;
use std::time::Duration;

use frontseat_actors::bus::Bus;
use frontseat_config::InterfaceConfig;

use crate::options::ChaosHarnessError;

/// Concurrent clients of the web flood.
pub(crate) const WEB_FLOODERS: u64 = 8;
/// The token the harness's web commander requires.
pub(crate) const WEB_TOKEN: &str = "chaos-web-token-0123456789";

/// A web commander send of a desired_course (`time` set, as the commander requires), with the
/// heading and speed as written: the flood's and `tests/hostile_web.rs`' body.
pub fn course_body(heading: &str, speed: &str) -> String {
    format!(
        r#"{{"group":"goby::middleware::frontseat::desired_course","message":{{"time":1,"heading":{heading},"speed":{speed},"depth":0}}}}"#
    )
}

/// A POST of `body` to the web commander's `/api/send` on its own connection, with the bearer
/// `token` and the `Origin` header when given.
pub fn send_request(
    addr: SocketAddr,
    token: Option<&str>,
    origin: Option<&str>,
    body: &str,
) -> String {
    let mut req = format!(
        "POST /api/send HTTP/1.1\r\nHost: {addr}\r\nContent-Type: application/json\r\nConnection: close\r\nContent-Length: {}\r\n",
        body.len()
    );
    if let Some(t) = token {
        req.push_str(&format!("Authorization: Bearer {t}\r\n"));
    }
    if let Some(o) = origin {
        req.push_str(&format!("Origin: {o}\r\n"));
    }
    req.push_str("\r\n");
    req.push_str(body);
    req
}

/// The `n`th request of the flood: mostly hostile setpoints with the right token, and sends a
/// browser of another site, a client without the token, or a broken client would make.
pub(crate) fn web_flood_request(addr: SocketAddr, n: u64) -> String {
    let course = course_body;
    let (auth, origin, body) = match n % 6 {
        0 => (true, None, course("1e308", "1.5")),
        1 => (true, None, course("90", "1e308")),
        2 => (true, None, course("-5.1e307", "-1e20")),
        3 => (false, None, course("90", "1.5")),
        4 => (true, Some("http://evil.example"), course("90", "1.5")),
        _ => (true, None, "{\"group\": [1, 2, {".to_string()),
    };
    send_request(addr, auth.then_some(WEB_TOKEN), origin, &body)
}

/// One request on its own connection; true when an HTTP answer came within a second.
pub(crate) async fn web_exchange(addr: SocketAddr, req: &str) -> bool {
    use tokio::io::{AsyncReadExt, AsyncWriteExt};
    let go = async {
        let mut s = tokio::net::TcpStream::connect(addr).await.ok()?;
        s.write_all(req.as_bytes()).await.ok()?;
        let mut buf = Vec::new();
        let mut chunk = [0u8; 1024];
        // Bounded: an answer is a status line and a short JSON error.
        while buf.len() < 64 * 1024 {
            match s.read(&mut chunk).await {
                Ok(0) | Err(_) => break,
                Ok(n) => buf.extend_from_slice(&chunk[..n]),
            }
        }
        Some(buf.starts_with(b"HTTP/1.1 "))
    };
    matches!(
        tokio::time::timeout(Duration::from_secs(1), go).await,
        Ok(Some(true))
    )
}

/// The web commander, for the flood: loopback, with a token (without one it refuses sends).
pub(crate) async fn start_commander(
    config: &InterfaceConfig,
    bus: &Bus,
) -> Result<frontseat_web::WebService, ChaosHarnessError> {
    let web_cfg = frontseat_config::WebConfig {
        enabled: true,
        listen: "127.0.0.1:0".into(),
        token: Some(WEB_TOKEN.into()),
        ..Default::default()
    };
    frontseat_web::WebService::start_with(
        &web_cfg,
        &config.limits,
        Some(WEB_TOKEN.into()),
        bus,
        &config.name,
    )
    .await
    .map_err(|e| ChaosHarnessError::Web(e.to_string()))
}
