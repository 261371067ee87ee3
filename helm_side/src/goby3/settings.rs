//! Resolving `[goby3]` and the vehicle name into what the link needs: the platform (Goby3's
//! default rules), the transport and manager endpoint, timeouts and the reconnect backoff.

use std::time::Duration;

use frontseat_config::{Goby3Config, Goby3Transport};

use super::manager::Transport;
use crate::{DEFAULT_PLATFORM, GatewayError};

/// Everything the link needs, resolved from `[goby3]` and the vehicle name.
#[derive(Clone, Debug, PartialEq)]
pub struct Goby3Settings {
    pub platform: String,
    pub transport: Transport,
    pub client_name: String,
    pub manager_timeout: Duration,
    pub settle: Duration,
    pub reconnect_initial: Duration,
    pub reconnect_max: Duration,
    /// Largest frame or message accepted from gobyd (the length guard's limit); 0 = no guard.
    pub max_message_bytes: u64,
}

impl Goby3Settings {
    /// The platform is `[goby3] platform`, else the vehicle `name`, else Goby3's default.
    pub fn from_config(cfg: &Goby3Config, name: &str) -> Result<Self, GatewayError> {
        let platform = match (cfg.platform.as_str(), name) {
            ("", "") => DEFAULT_PLATFORM,
            ("", n) => n,
            (p, _) => p,
        };
        if platform.contains(['/', '\0']) {
            return Err(GatewayError::BadPlatform(platform.to_string()));
        }
        let transport = match cfg.transport {
            Goby3Transport::Ipc => Transport::ipc_for_platform(platform, &cfg.socket_name),
            Goby3Transport::Tcp => Transport::Tcp {
                address: cfg.ip_address.clone(),
                port: cfg.tcp_port,
            },
        };
        let secs = |s: f64| Duration::try_from_secs_f64(s).unwrap_or(Duration::from_secs(5));
        Ok(Self {
            platform: platform.to_string(),
            transport,
            // Unresolved (see Goby3Config::with_client_name_for): the interface's Goby3 name.
            client_name: if cfg.client_name.is_empty() {
                cfg.health_name(crate::GOBY3_INTERFACE_APP).to_string()
            } else {
                cfg.client_name.clone()
            },
            manager_timeout: secs(cfg.manager_timeout_seconds),
            settle: Duration::from_millis(cfg.settle_ms),
            reconnect_initial: Duration::from_millis(cfg.reconnect_initial_ms.max(1)),
            reconnect_max: Duration::from_millis(cfg.reconnect_max_ms.max(1)),
            max_message_bytes: cfg.max_message_bytes,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_resolve_platform_and_transport_like_goby3() {
        let mut cfg = Goby3Config::default();
        let s = Goby3Settings::from_config(&cfg, "").unwrap();
        assert_eq!(s.platform, DEFAULT_PLATFORM);
        assert_eq!(
            s.transport.manager_endpoint(),
            "ipc:///tmp/goby_default_goby_platform.manager"
        );
        let s = Goby3Settings::from_config(&cfg, "auv1").unwrap();
        assert_eq!(s.platform, "auv1");
        cfg.platform = "zp3".into();
        cfg.transport = Goby3Transport::Tcp;
        cfg.tcp_port = 11150;
        let s = Goby3Settings::from_config(&cfg, "auv1").unwrap();
        assert_eq!(s.transport.manager_endpoint(), "tcp://127.0.0.1:11150");
        cfg.platform = "a/b".into();
        assert!(Goby3Settings::from_config(&cfg, "").is_err());
    }
}
