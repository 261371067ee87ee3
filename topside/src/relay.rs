//! Commanding one vehicle from the topside page: the command is relayed to that vehicle's own
//! web commander (`POST /api/send` of the page linked in `[[vehicle]]`) with the vehicle's token
//! the operator typed, so the vehicle's interface decides with exactly its usual gates. Only to
//! vehicles whose page requires a token (the topside never becomes a way around one), only to the
//! `http://host:port/` links of the config, with the request, the answer and the time bounded.

use std::time::Duration;

use tokio::io::{AsyncReadExt, AsyncWriteExt};

/// Largest command relayed, and largest answer read. Unit: bytes.
pub const MAX_BODY: usize = 64 * 1024;
/// The vehicle must answer within this.
const DEADLINE: Duration = Duration::from_secs(5);

#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Target {
    /// `host:port`, also the Host header the vehicle's page checks.
    pub authority: String,
}

/// Why a command was not relayed.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum RelayError {
    #[error("the vehicle's page does not require a token: command it on its own page")]
    NoVehicleToken,
    #[error("the vehicle's page cannot be reached: {0}")]
    Unreachable(String),
    #[error("the vehicle's page answered something that is not HTTP")]
    BadAnswer,
}

/// `http://host:port/…` → the target; anything else (https, no port, user info) → None.
pub fn parse_page(url: &str) -> Option<Target> {
    let rest = url.strip_prefix("http://")?;
    let authority = rest.split('/').next()?;
    if authority.is_empty() || authority.contains('@') {
        return None;
    }
    let (host, port) = authority.rsplit_once(':')?;
    port.parse::<u16>().ok().filter(|p| *p != 0)?;
    if host.is_empty() {
        return None;
    }
    Some(Target {
        authority: authority.to_string(),
    })
}

async fn request(t: &Target, head: &str, body: &[u8]) -> Result<(u16, Vec<u8>), RelayError> {
    let io = async {
        let mut s = tokio::net::TcpStream::connect(&t.authority).await?;
        s.write_all(head.as_bytes()).await?;
        s.write_all(body).await?;
        let mut buf = Vec::new();
        // Headers and a bounded body: anything past that is cut, never buffered.
        (&mut s)
            .take((MAX_BODY + 16 * 1024) as u64)
            .read_to_end(&mut buf)
            .await?;
        Ok::<_, std::io::Error>(buf)
    };
    let buf = tokio::time::timeout(DEADLINE, io)
        .await
        .map_err(|_| RelayError::Unreachable("no answer in time".into()))?
        .map_err(|e| RelayError::Unreachable(e.to_string()))?;
    let text_end = buf
        .windows(4)
        .position(|w| w == b"\r\n\r\n")
        .ok_or(RelayError::BadAnswer)?;
    let status = std::str::from_utf8(&buf[..text_end])
        .ok()
        .and_then(|h| h.strip_prefix("HTTP/1.1 "))
        .and_then(|h| h.get(..3))
        .and_then(|c| c.parse::<u16>().ok())
        .ok_or(RelayError::BadAnswer)?;
    Ok((status, buf[text_end + 4..].to_vec()))
}

/// Relays `body` (the commander's JSON) to the vehicle with `token`: its status and answer.
pub async fn relay(t: &Target, token: &str, body: &[u8]) -> Result<(u16, Vec<u8>), RelayError> {
    let info = format!(
        "GET /api/info HTTP/1.1\r\nHost: {}\r\nConnection: close\r\n\r\n",
        t.authority
    );
    let (_, answer) = request(t, &info, &[]).await?;
    let required = serde_json::from_slice::<serde_json::Value>(&answer)
        .ok()
        .and_then(|v| v["token_required"].as_bool())
        .ok_or(RelayError::BadAnswer)?;
    if !required {
        return Err(RelayError::NoVehicleToken);
    }
    let head = format!(
        "POST /api/send HTTP/1.1\r\nHost: {}\r\nAuthorization: Bearer {token}\r\nContent-Type: application/json\r\nContent-Length: {}\r\nConnection: close\r\n\r\n",
        t.authority,
        body.len()
    );
    request(t, &head, body).await
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_plain_http_links_with_a_port_are_targets() {
        assert_eq!(
            parse_page("http://127.0.0.1:50002/").map(|t| t.authority),
            Some("127.0.0.1:50002".into())
        );
        for bad in [
            "https://127.0.0.1:50002/",
            "http://127.0.0.1/",
            "http://user@127.0.0.1:1/",
            "http://:80/",
            "http://127.0.0.1:0/",
            "ftp://x:1/",
        ] {
            assert_eq!(parse_page(bad), None, "{bad}");
        }
    }
}
