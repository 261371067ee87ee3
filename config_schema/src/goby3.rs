//! The `[goby3]` section: joining an existing Goby3 system as a client of its gobyd, with the
//! settings of Goby3's `InterProcessPortalConfig` (platform, transport, socket name or manager
//! address and port, client name, manager timeout) plus our reconnect policy.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::FieldError;
use crate::check::{Checker, at};

/// How gobyd is reached (Goby3's `interprocess.transport`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum Goby3Transport {
    /// Unix-domain sockets `/tmp/goby_<platform>.manager|.xsub|.xpub` (or `<socket_name>.*`).
    #[default]
    #[serde(alias = "IPC")]
    Ipc,
    /// TCP: gobyd's manager on `ip_address:tcp_port`; the publish/subscribe ports come from it.
    #[serde(alias = "TCP")]
    Tcp,
}

/// A client of gobyd (Goby3's interprocess layer), beside or instead of Zenoh.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct Goby3Config {
    /// Export and import the interprocess groups through gobyd, in Goby3's PROTOBUF framing.
    pub enabled: bool,
    /// Goby3 platform name (gobyd's `interprocess.platform`); empty = the top-level `name`, or
    /// Goby3's "default_goby_platform" when that is empty too.
    pub platform: String,
    /// "ipc" or "tcp", as gobyd is configured.
    pub transport: Goby3Transport,
    /// IPC only: base path of gobyd's sockets (Goby3's `socket_name`); empty = /tmp/goby_<platform>.
    pub socket_name: String,
    /// TCP only: address of gobyd's manager (Goby3's `ip_address` / `ipv4_address`).
    #[serde(alias = "ipv4_address")]
    pub ip_address: String,
    /// TCP only: port of gobyd's manager (Goby3's `tcp_port`, default 11144).
    #[schemars(range(min = 1))]
    pub tcp_port: u16,
    /// Name we give gobyd's manager (Goby3's `client_name`; gobyd's hold list names clients by
    /// it); empty = as in Goby3, the application name (`app_name`, else the Goby3 application
    /// this service replaces: `goby_frontseat_interface`, `goby_moos_gateway`), so a vehicle's
    /// existing `hold { required_client: "goby_frontseat_interface" }` is released by us.
    pub client_name: String,
    /// How long to wait for each manager answer before giving up on this attempt. Unit: s.
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub manager_timeout_seconds: f64,
    /// Wait after the sockets are connected and the hold is released before the first
    /// publication, so gobyd has forwarded our peers' subscriptions (Goby3 waits 1 s). Unit: ms.
    pub settle_ms: u64,
    /// First delay before trying gobyd again after it was unreachable or went away; doubles up
    /// to reconnect_max_ms. Unit: ms.
    #[schemars(range(min = 1))]
    pub reconnect_initial_ms: u64,
    /// Cap of the reconnect delay. Unit: ms.
    #[schemars(range(min = 1))]
    pub reconnect_max_ms: u64,
    /// Largest frame or message accepted from gobyd. ZeroMQ has no limit of its own here: a
    /// bigger one closes the connection (counted as `oversized`, then the link joins again). The
    /// guard costs one loopback hop each way; 0 turns it off and trusts gobyd with any size.
    /// Unit: bytes (0, or at least 1024).
    pub max_message_bytes: u64,
    /// The name this process answers goby_coroner's health requests with (its
    /// `--expected_name`); empty = the Goby3 application it replaces: `goby_frontseat_interface`
    /// for `frontseat interface`, `goby_moos_gateway` for `frontseat moos-gateway`.
    pub app_name: String,
}

impl Goby3Config {
    /// This config with an empty `client_name` resolved as Goby3 does: to the application name
    /// (`app_name`, else `default`, the Goby3 application replaced).
    pub fn with_client_name_for(&self, default: &str) -> Self {
        let mut c = self.clone();
        if c.client_name.is_empty() {
            c.client_name = self.health_name(default).to_string();
        }
        c
    }

    /// The name in health answers: `app_name`, else `default` (the Goby3 application replaced).
    pub fn health_name<'a>(&'a self, default: &'a str) -> &'a str {
        if self.app_name.is_empty() {
            default
        } else {
            &self.app_name
        }
    }
}

impl Default for Goby3Config {
    fn default() -> Self {
        Self {
            enabled: false,
            platform: String::new(),
            transport: Goby3Transport::Ipc,
            socket_name: String::new(),
            ip_address: "127.0.0.1".into(),
            tcp_port: 11144,
            client_name: String::new(),
            manager_timeout_seconds: 5.0,
            settle_ms: 1000,
            reconnect_initial_ms: 100,
            reconnect_max_ms: 2000,
            max_message_bytes: 4 * 1024 * 1024,
            app_name: String::new(),
        }
    }
}

impl Goby3Config {
    pub(crate) fn check(&self, prefix: &str, c: &mut Checker) {
        if self.platform.contains(['/', '\0']) {
            c.push(FieldError::new(
                at(prefix, "platform"),
                format!("{:?}", self.platform),
                "must not contain '/' or NUL (it becomes part of a socket path)",
            ));
        }
        if self.transport == Goby3Transport::Tcp {
            c.non_empty(&at(prefix, "ip_address"), &self.ip_address);
            c.port(&at(prefix, "tcp_port"), self.tcp_port);
        }
        if self.socket_name.contains('\0') {
            c.push(FieldError::new(
                at(prefix, "socket_name"),
                format!("{:?}", self.socket_name),
                "must not contain NUL",
            ));
        }
        if (1..1024).contains(&self.max_message_bytes) {
            c.push(FieldError::new(
                at(prefix, "max_message_bytes"),
                self.max_message_bytes.to_string(),
                "must be 0 (no length guard) or at least 1024 (a Goby3 frame's header alone can \
                 take hundreds of bytes)",
            ));
        }
        if self.client_name == "gobyd" || self.app_name == "gobyd" {
            c.push(FieldError::new(
                at(prefix, "client_name"),
                "\"gobyd\"",
                "is gobyd's own name: a ready report under it would release gobyd's hold for it",
            ));
        }
        c.positive_up_to(
            &at(prefix, "manager_timeout_seconds"),
            self.manager_timeout_seconds,
            3600.0,
        );
        let initial = at(prefix, "reconnect_initial_ms");
        let max = at(prefix, "reconnect_max_ms");
        c.at_least(&initial, self.reconnect_initial_ms, 1);
        c.at_least(&max, self.reconnect_max_ms, 1);
        c.ordered(
            &initial,
            self.reconnect_initial_ms,
            &max,
            self.reconnect_max_ms,
        );
        c.count(&at(prefix, "settle_ms"), self.settle_ms, 0, 60_000);
    }
}
