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

/// Every message type Zenoh's access control knows.
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

/// What a fleet vehicle may send us about any key: asking (subscriptions, queries), which makes
/// us send it what it asked for — the fleet's status, for a trail. Reading is not steering.
const ACL_READ: [&str; 4] = [
    "declare_subscriber",
    "query",
    "liveliness_query",
    "declare_liveliness_subscriber",
];

/// What a fleet vehicle may send us only under its own platform: data and the declarations that
/// answer or announce data. A helm_state or desired_course put is one of these, so a vehicle's
/// certificate steers no vehicle but its own.
const ACL_SPEAK: [&str; 5] = [
    "put",
    "delete",
    "reply",
    "declare_queryable",
    "liveliness_token",
];

/// Name of the loopback interface, as Zenoh's access control sees a link's interface.
const LOOPBACK_INTERFACE: &str = if cfg!(target_os = "linux") {
    "lo"
} else {
    "lo0"
};

/// Zenoh's `access_control`, generated from `[…access]`: default deny, checked by Zenoh on every
/// message crossing a link, per link, by the common name of the certificate that link presented.
/// - a commander (and, when asked, a plain tcp link on the loopback interface): every message
///   on every key, both ways;
/// - a vehicle: ingress, subscriptions and queries on every key, data and declarations only
///   under `<its name>/**`; egress, everything it asked for.
///
/// Zenoh allows a message when any subject the link matches allows it, and a subject's
/// properties (common name, interface, protocol) are and-ed.
pub fn access_control(access: &ZenohAccessConfig) -> serde_json::Value {
    let mut rules = vec![
        json!({
            "id": "everything",
            "messages": ACL_MESSAGES,
            "flows": ["ingress", "egress"],
            "permission": "allow",
            "key_exprs": ["**"],
        }),
        json!({
            "id": "fleet_send",
            "messages": ACL_MESSAGES,
            "flows": ["egress"],
            "permission": "allow",
            "key_exprs": ["**"],
        }),
        json!({
            "id": "fleet_read",
            "messages": ACL_READ,
            "flows": ["ingress"],
            "permission": "allow",
            "key_exprs": ["**"],
        }),
    ];
    let mut subjects = Vec::new();
    let mut policies = Vec::new();
    for (i, name) in access.vehicles.iter().enumerate() {
        let (rule, subject) = (format!("own_keys_{i}"), format!("vehicle_{i}"));
        rules.push(json!({
            "id": rule,
            "messages": ACL_SPEAK,
            "flows": ["ingress"],
            "permission": "allow",
            "key_exprs": [format!("{name}/**")],
        }));
        subjects.push(json!({ "id": subject, "cert_common_names": [name] }));
        policies.push(json!({
            "id": format!("vehicle_{i}"),
            "rules": ["fleet_read", rule, "fleet_send"],
            "subjects": [subject],
        }));
    }
    let mut trusted = Vec::new();
    if !access.commanders.is_empty() {
        subjects.push(json!({ "id": "commanders", "cert_common_names": access.commanders }));
        trusted.push("commanders");
    }
    if access.allow_local_tcp {
        subjects.push(json!({
            "id": "local_tcp",
            "interfaces": [LOOPBACK_INTERFACE],
            "link_protocols": ["tcp"],
        }));
        trusted.push("local_tcp");
    }
    if !trusted.is_empty() {
        policies.push(json!({ "id": "trusted", "rules": ["everything"], "subjects": trusted }));
    }
    json!({
        "enabled": true,
        "default_permission": "deny",
        "rules": rules,
        "subjects": subjects,
        "policies": policies,
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
                commanders: vec!["topside".into()],
                allow_local_tcp: false,
                ..Default::default()
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

    fn fleet_access() -> ZenohAccessConfig {
        ZenohAccessConfig {
            vehicles: vec!["auv1".into(), "auv2".into()],
            commanders: vec!["topside".into(), "ops".into()],
            ..Default::default()
        }
    }

    #[test]
    fn a_vehicle_may_speak_only_under_its_own_platform_and_a_commander_everywhere() {
        let acl = access_control(&fleet_access());
        let rule = |id: &str| {
            acl["rules"]
                .as_array()
                .unwrap()
                .iter()
                .find(|r| r["id"] == id)
                .unwrap_or_else(|| panic!("no rule {id}: {acl:#}"))
                .clone()
        };
        let policy = |subject: &str| {
            acl["policies"]
                .as_array()
                .unwrap()
                .iter()
                .find(|p| {
                    p["subjects"]
                        .as_array()
                        .unwrap()
                        .iter()
                        .any(|s| s == subject)
                })
                .unwrap_or_else(|| panic!("no policy for {subject}: {acl:#}"))
                .clone()
        };
        let subject = |id: &str| {
            acl["subjects"]
                .as_array()
                .unwrap()
                .iter()
                .find(|s| s["id"] == id)
                .unwrap_or_else(|| panic!("no subject {id}: {acl:#}"))
                .clone()
        };
        assert_eq!(acl["default_permission"], "deny");
        assert_eq!(subject("vehicle_1")["cert_common_names"], json!(["auv2"]));
        assert_eq!(
            policy("vehicle_1")["rules"],
            json!(["fleet_read", "own_keys_1", "fleet_send"])
        );
        let own = rule("own_keys_1");
        assert_eq!(own["key_exprs"], json!(["auv2/**"]));
        assert_eq!(own["flows"], json!(["ingress"]));
        assert!(own["messages"].as_array().unwrap().contains(&json!("put")));
        let read = rule("fleet_read");
        assert!(
            !read["messages"].as_array().unwrap().contains(&json!("put")),
            "reading is not putting"
        );
        assert_eq!(read["flows"], json!(["ingress"]));
        assert_eq!(
            subject("commanders")["cert_common_names"],
            json!(["topside", "ops"])
        );
        assert_eq!(subject("local_tcp")["link_protocols"], json!(["tcp"]));
        assert_eq!(policy("commanders")["rules"], json!(["everything"]));
        assert_eq!(policy("local_tcp")["rules"], json!(["everything"]));
        assert_eq!(rule("everything")["key_exprs"], json!(["**"]));
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn zenoh_accepts_the_generated_access_control() {
        for access in [
            fleet_access(),
            ZenohAccessConfig {
                vehicles: vec!["auv1".into()],
                allow_local_tcp: false,
                ..Default::default()
            },
            ZenohAccessConfig {
                commanders: vec!["topside".into()],
                allow_local_tcp: false,
                ..Default::default()
            },
        ] {
            let ip = InterprocessConfig {
                listen: Vec::new(),
                access: Some(access.clone()),
                ..Default::default()
            };
            // Zenoh checks the rules, subjects and policies only when the session opens.
            let s = zenoh::open(zenoh_config(&ip, 1000).unwrap())
                .await
                .unwrap_or_else(|e| panic!("{access:?}: {e}"));
            s.close().await.unwrap();
        }
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
