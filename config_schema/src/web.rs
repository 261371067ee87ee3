//! The `[web]` section of `frontseat interface`: the live scope and commander served by the
//! interface process itself (crate `frontseat-web`), its bind address, token and bounds.

use std::net::SocketAddr;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::FieldError;
use crate::check::{Checker, at};

/// Environment variable that gives the web token (it wins over `web.token`).
pub const WEB_TOKEN_ENV: &str = "FRONTSEAT_WEB_TOKEN";

/// Shortest token accepted: shorter ones are guessable over a few thousand requests.
pub const MIN_TOKEN_CHARS: usize = 16;

/// The web scope and commander.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct WebConfig {
    /// Serve the scope/commander page from this process.
    pub enabled: bool,
    /// Address and port to listen on. Loopback by default; any other address needs a token for
    /// every request that can change the vehicle's state (without one, sends are refused).
    pub listen: String,
    /// Shared secret that API requests must carry (`Authorization: Bearer <token>`, or
    /// `?token=` for the event stream); FRONTSEAT_WEB_TOKEN in the environment wins over this.
    /// At least 16 characters.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[schemars(example = &"change-me-to-a-long-random-string")]
    pub token: Option<String>,
    /// Open TCP connections served at once; more are closed on accept and counted.
    #[schemars(range(min = 1, max = 4096))]
    pub max_connections: usize,
    /// Event streams (browser tabs) served at once; more get 503.
    #[schemars(range(min = 1, max = 1024))]
    pub max_clients: usize,
    /// Events queued per browser tab; a slower tab misses newer ones (dropped and counted),
    /// never slowing the bus. Unit: messages.
    #[schemars(range(min = 1, max = 65536))]
    pub client_queue: usize,
    /// Messages kept per group for its history. Unit: messages.
    #[schemars(range(min = 1, max = 100000))]
    pub history: usize,
    /// Largest request body (a commander send). Unit: bytes.
    #[schemars(range(min = 256, max = 1048576))]
    pub max_body_bytes: usize,
    /// A connection that neither sends nor receives for this long is closed (an open scope tab
    /// receives a keep-alive every 5 s, so only idle or stalled sockets are); a request not
    /// answered within this long of its first byte (trickled, slowloris) is closed too. Unit: s,
    /// 1 to 3600.
    #[schemars(range(min = 1, max = 3600))]
    pub idle_timeout_s: u64,
    /// Longest a connection may take to send a complete request head, from its start (or the
    /// end of its previous answer); then it is closed. Besides, when every one of
    /// `max_connections` is held, a new connection closes the oldest one that is not being
    /// answered (a socket that sent nothing or a partial request, or a keep-alive between
    /// requests); open event streams are never closed for it. Unit: s, 1 to 300.
    #[schemars(range(min = 1, max = 300))]
    pub header_timeout_s: u64,
}

impl Default for WebConfig {
    fn default() -> Self {
        Self {
            enabled: false,
            listen: "127.0.0.1:50001".into(),
            token: None,
            max_connections: 64,
            max_clients: 16,
            client_queue: 512,
            history: 200,
            max_body_bytes: 16 * 1024,
            idle_timeout_s: 30,
            header_timeout_s: 5,
        }
    }
}

impl WebConfig {
    /// The listen address, if it parses.
    pub fn listen_addr(&self) -> Option<SocketAddr> {
        self.listen.parse().ok()
    }

    pub(crate) fn check(&self, prefix: &str, c: &mut Checker) {
        if self.listen_addr().is_none() {
            c.push(FieldError::new(
                at(prefix, "listen"),
                format!("{:?}", self.listen),
                "not an address and port like \"127.0.0.1:50001\"",
            ));
        }
        if let Some(t) = &self.token
            && t.chars().count() < MIN_TOKEN_CHARS
        {
            c.push(FieldError::new(
                at(prefix, "token"),
                "\"…\"",
                format!("shorter than {MIN_TOKEN_CHARS} characters"),
            ));
        }
        c.count(
            &at(prefix, "max_connections"),
            self.max_connections as u64,
            1,
            4096,
        );
        c.count(&at(prefix, "max_clients"), self.max_clients as u64, 1, 1024);
        c.count(
            &at(prefix, "client_queue"),
            self.client_queue as u64,
            1,
            65536,
        );
        c.count(&at(prefix, "history"), self.history as u64, 1, 100_000);
        c.count(
            &at(prefix, "max_body_bytes"),
            self.max_body_bytes as u64,
            256,
            1 << 20,
        );
        c.count(&at(prefix, "idle_timeout_s"), self.idle_timeout_s, 1, 3600);
        c.count(
            &at(prefix, "header_timeout_s"),
            self.header_timeout_s,
            1,
            300,
        );
    }

    /// Advice that does not make the config invalid (printed by `--check`).
    pub fn warnings(&self, prefix: &str) -> Vec<String> {
        let mut out = Vec::new();
        if self.enabled
            && self.token.is_none()
            && self.listen_addr().is_some_and(|a| !a.ip().is_loopback())
        {
            out.push(format!(
                "{}: {} is not a loopback address and no token is set: every request that can \
                 change the vehicle's state will be refused unless {WEB_TOKEN_ENV} is set",
                at(prefix, "listen"),
                self.listen
            ));
        }
        out
    }
}
