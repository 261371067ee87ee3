//! Zenoh session configuration from `[interprocess]`: mode, listen and connect endpoints, and the
//! settings that keep the default on loopback (no multicast scouting, which would otherwise
//! announce us on every interface) and bound what one peer can make us buffer.

use frontseat_config::{InterprocessConfig, InterprocessMode};

use crate::GatewayError;

/// Zenoh refuses (and drops the link of) any message bigger than this; the gateway's own,
/// smaller `max_payload` then refuses and counts what gets through.
fn link_limit(max_payload: usize) -> usize {
    max_payload.saturating_mul(4).max(64 * 1024)
}

fn set(cfg: &mut zenoh::Config, field: &str, value: serde_json::Value) -> Result<(), GatewayError> {
    cfg.insert_json5(field, &value.to_string())
        .map_err(|e| GatewayError::Config {
            field: field.to_string(),
            reason: e.to_string(),
        })
}

/// The session config for the gateway.
pub fn zenoh_config(
    ip: &InterprocessConfig,
    max_payload: usize,
) -> Result<zenoh::Config, GatewayError> {
    let mut cfg = zenoh::Config::default();
    let (mode, listen) = match ip.mode {
        InterprocessMode::Peer => ("peer", ip.listen.clone()),
        // A client reaches everything through its router and listens nowhere.
        InterprocessMode::Client => ("client", Vec::new()),
    };
    set(&mut cfg, "mode", mode.into())?;
    set(&mut cfg, "listen/endpoints", listen.into())?;
    set(&mut cfg, "connect/endpoints", ip.connect.clone().into())?;
    set(&mut cfg, "scouting/multicast/enabled", false.into())?;
    set(
        &mut cfg,
        "transport/link/rx/max_message_size",
        link_limit(max_payload).into(),
    )?;
    Ok(cfg)
}

/// A client session to `connect` endpoints, listening nowhere and not scouting: what a helm or
/// test tool uses to reach `frontseat interface` on this host.
pub fn client_config(connect: &[String]) -> Result<zenoh::Config, GatewayError> {
    let ip = InterprocessConfig {
        enabled: true,
        mode: InterprocessMode::Client,
        listen: Vec::new(),
        connect: connect.to_vec(),
        platform: String::new(),
    };
    zenoh_config(&ip, crate::DEFAULT_MAX_PAYLOAD)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn get(cfg: &zenoh::Config, key: &str) -> String {
        cfg.get_json(key).unwrap()
    }

    #[test]
    fn default_peer_listens_on_loopback_only_and_does_not_scout() {
        let cfg = zenoh_config(&InterprocessConfig::default(), 1000).unwrap();
        assert_eq!(get(&cfg, "mode"), "\"peer\"");
        assert_eq!(get(&cfg, "listen/endpoints"), r#"["tcp/127.0.0.1:7447"]"#);
        assert_eq!(get(&cfg, "connect/endpoints"), "[]");
        assert_eq!(get(&cfg, "scouting/multicast/enabled"), "false");
        assert_eq!(get(&cfg, "transport/link/rx/max_message_size"), "65536");
    }

    #[test]
    fn client_listens_nowhere() {
        let cfg = client_config(&["tcp/127.0.0.1:9".into()]).unwrap();
        assert_eq!(get(&cfg, "mode"), "\"client\"");
        assert_eq!(get(&cfg, "listen/endpoints"), "[]");
        assert_eq!(get(&cfg, "connect/endpoints"), r#"["tcp/127.0.0.1:9"]"#);
    }

    #[test]
    fn a_bad_endpoint_is_a_typed_error() {
        let ip = InterprocessConfig {
            listen: vec!["not an endpoint".into()],
            ..Default::default()
        };
        match zenoh_config(&ip, 1000) {
            Err(GatewayError::Config { field, .. }) => assert_eq!(field, "listen/endpoints"),
            other => panic!("{other:?}"),
        }
    }
}
