//! Zenoh session configuration from `[interprocess]` (and the topside's `[zenoh]`, which goes
//! through the same function): mode, listen and connect endpoints, TLS and access by certificate
//! common name, and the settings that keep the default on loopback (no multicast scouting, which
//! would otherwise announce us on every interface) and bound what one peer can make us buffer.

use frontseat_config::{InterprocessConfig, InterprocessMode, ZenohAccessConfig, ZenohTlsConfig};
use serde_json::json;

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
    if let Some(tls) = &ip.tls {
        set_tls(&mut cfg, tls)?;
    }
    if let Some(access) = &ip.access {
        set(&mut cfg, "access_control", access_control(access))?;
    }
    Ok(cfg)
}

/// `transport/link/tls`: one certificate for both directions, since a vehicle both listens (for
/// the topside) and connects (to other vehicles or a router).
fn set_tls(cfg: &mut zenoh::Config, tls: &ZenohTlsConfig) -> Result<(), GatewayError> {
    let files = [
        ("root_ca_certificate", &tls.root_ca_certificate),
        ("listen_certificate", &tls.certificate),
        ("listen_private_key", &tls.private_key),
        ("connect_certificate", &tls.certificate),
        ("connect_private_key", &tls.private_key),
    ];
    for (key, file) in files {
        if let Some(f) = file {
            set(cfg, &format!("transport/link/tls/{key}"), f.as_str().into())?;
        }
    }
    set(cfg, "transport/link/tls/enable_mtls", tls.mutual.into())?;
    set(
        cfg,
        "transport/link/tls/verify_name_on_connect",
        tls.verify_name_on_connect.into(),
    )?;
    // A fleet certificate that expires must end the link, not leave it open until restart.
    set(
        cfg,
        "transport/link/tls/close_link_on_expiration",
        true.into(),
    )
}

/// Every message type Zenoh's access control knows: a listed peer may do all, others nothing.
const ACL_MESSAGES: [&str; 9] = [
    "put",
    "delete",
    "declare_subscriber",
    "query",
    "reply",
    "declare_queryable",
    "liveliness_token",
    "liveliness_query",
    "declare_liveliness_subscriber",
];

/// Name of the loopback interface, as Zenoh's access control sees a link's interface.
const LOOPBACK_INTERFACE: &str = if cfg!(target_os = "linux") {
    "lo"
} else {
    "lo0"
};

/// Zenoh's `access_control`: default deny; allow all to the listed certificate common names
/// (and, when asked, to plain tcp links on the loopback interface). A subject's properties are
/// and-ed, subjects or-ed.
fn access_control(access: &ZenohAccessConfig) -> serde_json::Value {
    let mut subjects = vec![json!({
        "id": "fleet",
        "cert_common_names": access.allow_common_names,
    })];
    if access.allow_local_tcp {
        subjects.push(json!({
            "id": "local_tcp",
            "interfaces": [LOOPBACK_INTERFACE],
            "link_protocols": ["tcp"],
        }));
    }
    let ids: Vec<String> = subjects
        .iter()
        .filter_map(|s| s.get("id").and_then(|v| v.as_str()).map(str::to_owned))
        .collect();
    json!({
        "enabled": true,
        "default_permission": "deny",
        "rules": [{
            "id": "allow_all",
            "messages": ACL_MESSAGES,
            "flows": ["ingress", "egress"],
            "permission": "allow",
            "key_exprs": ["**"],
        }],
        "subjects": subjects,
        "policies": [{ "rules": ["allow_all"], "subjects": ids }],
    })
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
        tls: None,
        access: None,
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
    fn tls_and_access_map_onto_zenoh_keys() {
        let ip = InterprocessConfig {
            listen: vec!["tls/127.0.0.1:7447".into()],
            tls: Some(ZenohTlsConfig {
                root_ca_certificate: Some("/ca.pem".into()),
                certificate: Some("/me.pem".into()),
                private_key: Some("/me.key".into()),
                ..Default::default()
            }),
            access: Some(ZenohAccessConfig {
                allow_common_names: vec!["topside".into()],
                allow_local_tcp: false,
            }),
            ..Default::default()
        };
        let cfg = zenoh_config(&ip, 1000).unwrap();
        let tls = |k: &str| get(&cfg, &format!("transport/link/tls/{k}"));
        assert_eq!(tls("root_ca_certificate"), "\"/ca.pem\"");
        assert_eq!(tls("listen_certificate"), "\"/me.pem\"");
        assert_eq!(tls("connect_private_key"), "\"/me.key\"");
        assert_eq!(tls("enable_mtls"), "true");
        assert_eq!(tls("verify_name_on_connect"), "true");
        assert_eq!(get(&cfg, "access_control/enabled"), "true");
        assert_eq!(get(&cfg, "access_control/default_permission"), "\"deny\"");
        let subjects: serde_json::Value =
            serde_json::from_str(&get(&cfg, "access_control/subjects")).unwrap();
        assert_eq!(subjects[0]["cert_common_names"], json!(["topside"]));
        assert_eq!(subjects.as_array().map(Vec::len), Some(1));
    }

    #[test]
    fn without_the_sections_there_is_no_tls_and_no_acl() {
        let cfg = zenoh_config(&InterprocessConfig::default(), 1000).unwrap();
        assert_eq!(get(&cfg, "access_control/enabled"), "false");
        assert_eq!(get(&cfg, "transport/link/tls/root_ca_certificate"), "null");
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
