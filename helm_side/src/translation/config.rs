//! Config glue: the MOOS client's configuration from `[moos]` (address, name, time warp) and
//! the bound on what it queues while the MOOSDB is away.

use frontseat_config::MoosConfig;
use frontseat_moos::MoosClientConfig;

/// Notifications kept while the MOOSDB is away (about 2 s of 10 Hz navigation): only fresh
/// navigation is of use to the helm, and a long backlog would be flushed at it on reconnect.
const MOOS_QUEUE_LIMIT: usize = 256;

/// The MOOS client configuration for `cfg`: its name, the DB address and the community's
/// MOOSTimeWarp (every time stamp we send is Unix time × warp).
pub fn client_config(cfg: &MoosConfig) -> MoosClientConfig {
    // An IPv6 literal needs brackets in host:port.
    let server = if cfg.server.contains(':') && !cfg.server.starts_with('[') {
        format!("[{}]:{}", cfg.server, cfg.port)
    } else {
        format!("{}:{}", cfg.server, cfg.port)
    };
    MoosClientConfig {
        server,
        // 0 = the service's warp; a config not resolved by the service (with_warp) runs unwarped.
        time_warp: if cfg.time_warp > 0.0 {
            cfg.time_warp
        } else {
            1.0
        },
        queue_limit: MOOS_QUEUE_LIMIT,
        mail_by_packet: true,
        ..MoosClientConfig::new(cfg.app_name.clone())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn client_config_carries_address_name_and_time_warp() {
        let cfg = MoosConfig {
            server: "10.0.0.2".into(),
            port: 9001,
            community: "auv".into(),
            app_name: "iFrontSeat".into(),
            time_warp: 5.0,
            desired_timeout_s: 1.0,
        };
        let c = client_config(&cfg);
        assert_eq!(c.server, "10.0.0.2:9001");
        assert_eq!(c.name, "iFrontSeat");
        assert_eq!(c.time_warp, 5.0);
        assert!(c.validate().is_ok());
        let v6 = client_config(&MoosConfig {
            server: "::1".into(),
            ..cfg
        });
        assert_eq!(v6.server, "[::1]:9001");
    }
}
