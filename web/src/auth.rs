//! Who may do what: reads (the scope) and writes (the commander) by bind address and token, the
//! token compared in constant time, and the Host/Origin checks that keep a web page elsewhere
//! in the operator's browser from reaching a loopback server (DNS rebinding, cross-site POST).
//! The Foxglove WebSocket servers (`frontseat-record`) use the same rules for their upgrade
//! ([`Access::check_upgrade`]): a WebSocket is not subject to CORS, so a page elsewhere could
//! otherwise open one and read what it streams.

use std::net::SocketAddr;

use axum::http::HeaderMap;
use axum::http::header::{AUTHORIZATION, HOST, ORIGIN};
use subtle::ConstantTimeEq;

/// The access rules of one server.
#[derive(Clone, Debug)]
pub struct Access {
    token: Option<String>,
    listen: SocketAddr,
    /// Origins (`scheme://host[:port]`) allowed besides this server's own, e.g. a web
    /// Foxglove at `https://app.foxglove.dev`.
    allowed_origins: Vec<String>,
}

/// Why a request was refused; the HTTP status and the text the client gets.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Refusal {
    /// No token, or the wrong one.
    Unauthorized,
    /// Sends are impossible: a non-loopback bind without a token.
    NoTokenConfigured,
    /// Host or Origin names another site.
    ForeignSite,
}

impl Refusal {
    pub fn status(self) -> axum::http::StatusCode {
        use axum::http::StatusCode;
        match self {
            Self::Unauthorized => StatusCode::UNAUTHORIZED,
            Self::NoTokenConfigured | Self::ForeignSite => StatusCode::FORBIDDEN,
        }
    }
    pub fn text(self) -> &'static str {
        match self {
            Self::Unauthorized => "missing or wrong token",
            Self::NoTokenConfigured => {
                "this server listens beyond loopback without a token: requests that change the \
                 vehicle's state are refused (set [web] token or FRONTSEAT_WEB_TOKEN)"
            }
            Self::ForeignSite => "Host or Origin is not this server",
        }
    }
}

impl Access {
    pub fn new(listen: SocketAddr, token: Option<String>) -> Self {
        Self {
            token,
            listen,
            allowed_origins: Vec::new(),
        }
    }

    /// Also admits requests whose `Origin` is one of `origins` (compared without a trailing
    /// `/`, ASCII case-insensitively); `Host` is checked all the same.
    pub fn with_allowed_origins(mut self, origins: &[String]) -> Self {
        self.allowed_origins = origins
            .iter()
            .map(|o| o.trim_end_matches('/').to_ascii_lowercase())
            .filter(|o| !o.is_empty())
            .collect();
        self
    }

    pub fn token_required(&self) -> bool {
        self.token.is_some()
    }

    /// Whether the commander can ever send on this server.
    pub fn can_send(&self) -> bool {
        self.token.is_some() || self.listen.ip().is_loopback()
    }

    fn token_ok(&self, headers: &HeaderMap, query_token: Option<&str>) -> bool {
        let Some(expected) = &self.token else {
            return true;
        };
        let given = headers
            .get(AUTHORIZATION)
            .and_then(|v| v.to_str().ok())
            .and_then(|v| v.strip_prefix("Bearer "))
            .or(query_token);
        given.is_some_and(|g| bool::from(g.as_bytes().ct_eq(expected.as_bytes())))
    }

    /// On loopback the Host header must name loopback: a page of another site that rebinds
    /// its name to 127.0.0.1 sends its own name.
    fn host_ok(&self, headers: &HeaderMap) -> bool {
        if !self.listen.ip().is_loopback() {
            return true;
        }
        let Some(host) = headers.get(HOST).and_then(|v| v.to_str().ok()) else {
            return false;
        };
        let name = match host.rsplit_once(':') {
            Some((n, port)) if port.chars().all(|c| c.is_ascii_digit()) => n,
            _ => host,
        };
        matches!(name, "localhost" | "[::1]")
            || name
                .parse::<std::net::Ipv4Addr>()
                .is_ok_and(|a| a.is_loopback())
    }

    /// A browser names the page a request comes from; it must be this server, or an origin
    /// configured as allowed. No `Origin` at all: not a browser's cross-site request.
    fn origin_ok(&self, headers: &HeaderMap) -> bool {
        let Some(origin) = headers.get(ORIGIN) else {
            return true;
        };
        let Some(origin) = origin.to_str().ok() else {
            return false;
        };
        let origin = origin.trim_end_matches('/');
        if self
            .allowed_origins
            .iter()
            .any(|a| a.eq_ignore_ascii_case(origin))
        {
            return true;
        }
        let Some(host) = headers.get(HOST).and_then(|v| v.to_str().ok()) else {
            return false;
        };
        origin
            .split_once("://")
            .is_some_and(|(_, rest)| rest == host)
    }

    /// May this request read the scope?
    pub fn check_read(
        &self,
        headers: &HeaderMap,
        query_token: Option<&str>,
    ) -> Result<(), Refusal> {
        if !self.host_ok(headers) {
            return Err(Refusal::ForeignSite);
        }
        if !self.token_ok(headers, query_token) {
            return Err(Refusal::Unauthorized);
        }
        Ok(())
    }

    /// May this request change the vehicle's state? Only with the token in a header (a query
    /// string ends up in logs and browser history), and never from another site.
    pub fn check_write(&self, headers: &HeaderMap) -> Result<(), Refusal> {
        if !self.host_ok(headers) || !self.origin_ok(headers) {
            return Err(Refusal::ForeignSite);
        }
        if !self.can_send() {
            return Err(Refusal::NoTokenConfigured);
        }
        if !self.token_ok(headers, None) {
            return Err(Refusal::Unauthorized);
        }
        Ok(())
    }
}

impl Access {
    /// May this request open a read-only WebSocket (the Foxglove servers)? Host as for every
    /// read, Origin as for a write (a browser sends it with every WebSocket, and nothing like
    /// CORS stops another site's page from reading the socket), the token as for a read (a
    /// WebSocket client in a browser cannot set a header, so `?token=` is accepted).
    pub fn check_upgrade(
        &self,
        headers: &HeaderMap,
        query_token: Option<&str>,
    ) -> Result<(), Refusal> {
        if !self.host_ok(headers) || !self.origin_ok(headers) {
            return Err(Refusal::ForeignSite);
        }
        if !self.token_ok(headers, query_token) {
            return Err(Refusal::Unauthorized);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use axum::http::HeaderValue;

    fn headers(pairs: &[(&'static str, &str)]) -> HeaderMap {
        let mut h = HeaderMap::new();
        for (k, v) in pairs {
            h.insert(*k, HeaderValue::from_str(v).unwrap());
        }
        h
    }

    const TOKEN: &str = "0123456789abcdef-secret";

    #[test]
    fn loopback_without_token_allows_local_pages_only() {
        let a = Access::new("127.0.0.1:50001".parse().unwrap(), None);
        let local = headers(&[("host", "127.0.0.1:50001")]);
        assert_eq!(a.check_read(&local, None), Ok(()));
        assert_eq!(a.check_write(&local), Ok(()));
        let rebound = headers(&[("host", "evil.example:50001")]);
        assert_eq!(a.check_read(&rebound, None), Err(Refusal::ForeignSite));
        let cross = headers(&[
            ("host", "localhost:50001"),
            ("origin", "http://evil.example"),
        ]);
        assert_eq!(a.check_write(&cross), Err(Refusal::ForeignSite));
        let same = headers(&[
            ("host", "localhost:50001"),
            ("origin", "http://localhost:50001"),
        ]);
        assert_eq!(a.check_write(&same), Ok(()));
    }

    #[test]
    fn non_loopback_without_token_is_read_only() {
        let a = Access::new("0.0.0.0:50001".parse().unwrap(), None);
        let h = headers(&[("host", "10.0.0.5:50001")]);
        assert_eq!(a.check_read(&h, None), Ok(()));
        assert_eq!(a.check_write(&h), Err(Refusal::NoTokenConfigured));
    }

    #[test]
    fn token_is_required_in_a_header_to_write() {
        let a = Access::new("0.0.0.0:50001".parse().unwrap(), Some(TOKEN.into()));
        let host = ("host", "10.0.0.5:50001");
        assert_eq!(
            a.check_read(&headers(&[host]), None),
            Err(Refusal::Unauthorized)
        );
        assert_eq!(a.check_read(&headers(&[host]), Some(TOKEN)), Ok(()));
        assert_eq!(a.check_write(&headers(&[host])), Err(Refusal::Unauthorized));
        let bearer = format!("Bearer {TOKEN}");
        let wrong = format!("Bearer {TOKEN}x");
        assert_eq!(
            a.check_write(&headers(&[host, ("authorization", &bearer)])),
            Ok(())
        );
        assert_eq!(
            a.check_write(&headers(&[host, ("authorization", &wrong)])),
            Err(Refusal::Unauthorized)
        );
    }

    #[test]
    fn an_upgrade_needs_this_site_or_an_allowed_origin_and_the_token() {
        let a = Access::new("127.0.0.1:8765".parse().unwrap(), None)
            .with_allowed_origins(&["https://App.Foxglove.dev/".into()]);
        let host = ("host", "127.0.0.1:8765");
        assert_eq!(a.check_upgrade(&headers(&[host]), None), Ok(()));
        let own = headers(&[host, ("origin", "http://127.0.0.1:8765")]);
        assert_eq!(a.check_upgrade(&own, None), Ok(()));
        let allowed = headers(&[host, ("origin", "https://app.foxglove.dev")]);
        assert_eq!(a.check_upgrade(&allowed, None), Ok(()));
        let foreign = headers(&[host, ("origin", "http://evil.example")]);
        assert_eq!(a.check_upgrade(&foreign, None), Err(Refusal::ForeignSite));
        // An allowed origin does not excuse a rebound Host.
        let rebound = headers(&[
            ("host", "evil.example:8765"),
            ("origin", "https://app.foxglove.dev"),
        ]);
        assert_eq!(a.check_upgrade(&rebound, None), Err(Refusal::ForeignSite));
        let t = Access::new("0.0.0.0:8765".parse().unwrap(), Some(TOKEN.into()));
        let h = headers(&[("host", "10.0.0.5:8765")]);
        assert_eq!(t.check_upgrade(&h, None), Err(Refusal::Unauthorized));
        assert_eq!(t.check_upgrade(&h, Some(TOKEN)), Ok(()));
        let evil = headers(&[("host", "10.0.0.5:8765"), ("origin", "http://evil.example")]);
        assert_eq!(
            t.check_upgrade(&evil, Some(TOKEN)),
            Err(Refusal::ForeignSite)
        );
    }
}
