//! Which groups a process exports and imports, derived from the generated interface alone: a
//! process hosts some actors; every `interprocess` group one of them publishes is exported and
//! every one they subscribe is imported. Also the mapping group → Zenoh key expression. Pure.

use frontseat_actors::bus::Layer;
use frontseat_actors::groups::GroupInfo;

use crate::GatewayError;

/// One group crossing the process boundary, in one direction.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Route {
    /// Goby3 group name, e.g. `goby::middleware::frontseat::node_status`.
    pub group: &'static str,
    /// Proto full name of the message; also the schema of the Zenoh encoding.
    pub type_name: &'static str,
    /// `<platform>/<group with "::" → "/">`.
    pub key: String,
}

/// What a gateway does for one set of hosted actors.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Plan {
    pub exports: Vec<Route>,
    pub imports: Vec<Route>,
}

/// `auv1` + `goby::middleware::frontseat::node_status` → `auv1/goby/middleware/frontseat/node_status`.
pub fn key_for(platform: &str, group: &str) -> String {
    format!("{platform}/{}", group.replace("::", "/"))
}

/// A platform becomes the first chunk of every key expression, so it must be one valid chunk.
pub fn check_platform(platform: &str) -> Result<(), GatewayError> {
    if platform.is_empty() {
        return Err(GatewayError::EmptyPlatform);
    }
    if platform.contains(['/', '*', '$', '?', '#']) || platform.trim() != platform {
        return Err(GatewayError::BadPlatform(platform.to_string()));
    }
    Ok(())
}

/// The routes of a process hosting `hosted` actors, with Zenoh keys under `platform`.
pub fn plan(groups: &[GroupInfo], platform: &str, hosted: &[&str]) -> Result<Plan, GatewayError> {
    check_platform(platform)?;
    let mut out = routes(groups, hosted)?;
    for r in out.exports.iter_mut().chain(out.imports.iter_mut()) {
        r.key = key_for(platform, r.group);
    }
    Ok(out)
}

/// The routes of a process hosting `hosted` actors, for a transport that needs no Zenoh key
/// (`key` is left empty). A hosted name that no group mentions is an error: a typo would
/// otherwise silently export nothing.
pub fn routes(groups: &[GroupInfo], hosted: &[&str]) -> Result<Plan, GatewayError> {
    for actor in hosted {
        let known = groups
            .iter()
            .any(|g| g.publishers.contains(actor) || g.subscribers.contains(actor));
        if !known {
            return Err(GatewayError::UnknownActor(actor.to_string()));
        }
    }
    let mut out = Plan::default();
    for g in groups.iter().filter(|g| g.layer == Layer::Interprocess) {
        let route = || Route {
            group: g.name,
            type_name: g.type_name,
            key: String::new(),
        };
        if g.publishers.iter().any(|p| hosted.contains(p)) {
            out.exports.push(route());
        }
        if g.subscribers.iter().any(|s| hosted.contains(s)) {
            out.imports.push(route());
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use frontseat_actors::groups::ALL;

    fn groups(routes: &[Route]) -> Vec<&'static str> {
        let mut v: Vec<_> = routes.iter().map(|r| r.group).collect();
        v.sort();
        v
    }

    #[test]
    fn key_expression_replaces_every_separator() {
        assert_eq!(
            key_for("auv1", "goby::middleware::frontseat::node_status"),
            "auv1/goby/middleware/frontseat/node_status"
        );
    }

    #[test]
    fn interface_exports_what_it_publishes_and_imports_what_it_subscribes() {
        let p = plan(ALL, "auv1", &["FrontSeatInterface"]).unwrap();
        // Derived from the yaml, checked against the generated table rather than a copy of it.
        for g in ALL {
            let exported = p.exports.iter().any(|r| r.group == g.name);
            let imported = p.imports.iter().any(|r| r.group == g.name);
            let ip = g.layer == Layer::Interprocess;
            assert_eq!(
                exported,
                ip && g.publishers.contains(&"FrontSeatInterface"),
                "{}",
                g.name
            );
            assert_eq!(
                imported,
                ip && g.subscribers.contains(&"FrontSeatInterface"),
                "{}",
                g.name
            );
        }
        assert!(groups(&p.exports).contains(&"goby::middleware::frontseat::node_status"));
        assert!(groups(&p.exports).contains(&"goby::middleware::frontseat::status"));
        assert!(groups(&p.imports).contains(&"goby::middleware::frontseat::desired_course"));
        assert!(groups(&p.imports).contains(&"goby::middleware::frontseat::helm_state"));
        assert!(
            !groups(&p.exports)
                .iter()
                .any(|g| g.starts_with("frontseat::driver")),
            "interthread groups never leave the process"
        );
        let ns = p
            .exports
            .iter()
            .find(|r| r.group == "goby::middleware::frontseat::node_status")
            .unwrap();
        assert_eq!(ns.key, "auv1/goby/middleware/frontseat/node_status");
        assert_eq!(
            ns.type_name,
            "goby.middleware.frontseat.protobuf.NodeStatus"
        );
    }

    #[test]
    fn translation_alone_is_the_mirror_of_the_interface() {
        let p = plan(ALL, "auv1", &["FrontSeatTranslation"]).unwrap();
        assert!(groups(&p.exports).contains(&"goby::middleware::frontseat::desired_course"));
        assert!(groups(&p.exports).contains(&"goby::middleware::frontseat::helm_state"));
        assert!(groups(&p.imports).contains(&"goby::middleware::frontseat::node_status"));
        assert!(!groups(&p.imports).contains(&"goby::middleware::frontseat::desired_course"));
    }

    #[test]
    fn both_in_one_process_still_import_from_outside_helms() {
        let p = plan(ALL, "auv1", &["FrontSeatInterface", "FrontSeatTranslation"]).unwrap();
        let dc = "goby::middleware::frontseat::desired_course";
        assert!(groups(&p.exports).contains(&dc));
        assert!(groups(&p.imports).contains(&dc));
    }

    #[test]
    fn unknown_actor_and_bad_platforms_are_refused() {
        assert!(matches!(
            plan(ALL, "auv1", &["FrontSeatInterfase"]),
            Err(GatewayError::UnknownActor(a)) if a == "FrontSeatInterfase"
        ));
        assert!(matches!(
            plan(ALL, "", &["FrontSeatInterface"]),
            Err(GatewayError::EmptyPlatform)
        ));
        for bad in ["a/b", "*", "auv$1", "x?", "#", " auv1"] {
            assert!(
                matches!(
                    plan(ALL, bad, &["FrontSeatInterface"]),
                    Err(GatewayError::BadPlatform(_))
                ),
                "{bad:?}"
            );
        }
    }
}
