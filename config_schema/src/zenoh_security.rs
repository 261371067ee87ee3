//! Who may join a Zenoh session and how its links are protected: the TLS certificate files, mutual
//! TLS, and access by certificate common name. One pair of types serves every service that opens a
//! session (`[interprocess.tls]`/`[interprocess.access]` of the interface and moos-gateway,
//! `[zenoh.tls]`/`[zenoh.access]` of the topside), with the checks on them: the files exist and
//! hold PEM, `tls/` endpoints have a section, and advice when traffic leaves loopback unprotected.

use std::io::Read;
use std::net::{IpAddr, SocketAddr};

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::FieldError;
use crate::check::at;

/// A certificate or key bigger than this is the wrong file; it is not read whole.
const MAX_PEM_BYTES: u64 = 1 << 20;

/// TLS for the session's `tls/…` endpoints (Zenoh's `transport/link/tls`). Every file is PEM.
/// The same certificate serves both directions: presented to peers that connect here and to peers
/// this session connects to, so it needs both the serverAuth and clientAuth extended key usages and,
/// for a host others connect to, that host's address as a subject alternative name.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct ZenohTlsConfig {
    /// The fleet's certificate authority: peers' certificates must be signed by it. Required.
    /// (Zenoh also trusts the public Web PKI roots for the servers it connects to; a name check
    /// still applies, see verify_name_on_connect.)
    #[serde(skip_serializing_if = "Option::is_none")]
    #[schemars(example = "/etc/frontseat/tls/ca.pem")]
    pub root_ca_certificate: Option<String>,
    /// This host's certificate, signed by the fleet's CA. Required to listen on a `tls/`
    /// endpoint, and with `mutual`.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[schemars(example = "/etc/frontseat/tls/auv1.pem")]
    pub certificate: Option<String>,
    /// The private key of `certificate` (PKCS#8, SEC1 or PKCS#1). Readable by the service's user
    /// only: a key readable by group or others is reported by `--check`.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[schemars(example = "/etc/frontseat/tls/auv1.key")]
    pub private_key: Option<String>,
    /// Mutual TLS: a peer that connects here must present a certificate signed by the CA, and
    /// this session presents `certificate` when it connects. Off, anyone who reaches a `tls/`
    /// listener joins the session (encrypted, but unauthenticated).
    pub mutual: bool,
    /// Check that the certificate of a peer this session connects to names the address in the
    /// connect endpoint (a subject alternative name). Turn off only for a CA that signs nothing
    /// but the fleet.
    pub verify_name_on_connect: bool,
}

impl Default for ZenohTlsConfig {
    fn default() -> Self {
        Self {
            root_ca_certificate: None,
            certificate: None,
            private_key: None,
            mutual: true,
            verify_name_on_connect: true,
        }
    }
}

/// Access control by certificate common name (Zenoh's `access_control`, generated from this
/// section): when it is present every peer is denied everything except what its certificate's
/// common name (CN) is given here. A fleet vehicle's CN is its platform name (the vehicle's
/// `name`), so a vehicle may publish only under its own keys; only commanders may publish a
/// helm state or a course to another platform. Needs `tls` with `mutual`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct ZenohAccessConfig {
    /// Common names of the fleet's vehicles, each its own platform name, e.g. ["auv1", "auv2"].
    /// Such a peer may publish (put, delete, queryable, liveliness token) only under
    /// `<its name>/**` — its own node_status, status, and its helm's course to itself — and may
    /// subscribe to anything (another vehicle's node_status, to trail it). It cannot steer
    /// another vehicle nor speak for one. This vehicle's own name may be listed (one list can
    /// serve the whole fleet).
    pub vehicles: Vec<String>,
    /// Common names that may command: publish and subscribe under every platform, including
    /// helm_state and desired_course to this vehicle — the topside, an operator's station,
    /// e.g. ["topside"]. Anyone holding such a certificate can steer the vehicle: keep the list
    /// short.
    pub commanders: Vec<String>,
    /// Also allow everything to plain `tcp/` links over the loopback interface: the vehicle's
    /// own helm and tools on this host, which present no certificate.
    pub allow_local_tcp: bool,
    /// Replaced by `vehicles` and `commanders` (a name listed here could steer the vehicle):
    /// refused with a message that says which list each name belongs in.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    #[schemars(skip)]
    pub allow_common_names: Vec<String>,
}

impl Default for ZenohAccessConfig {
    fn default() -> Self {
        Self {
            vehicles: Vec::new(),
            commanders: Vec::new(),
            allow_local_tcp: true,
            allow_common_names: Vec::new(),
        }
    }
}

/// Most names in one of the lists: a fleet of hundreds, each a Zenoh ACL subject and rule.
pub const MAX_ACCESS_NAMES: usize = 256;
/// Longest common name accepted (X.509 allows 64 characters; 256 bytes leaves room for UTF-8).
const MAX_CN_BYTES: usize = 256;

/// Whether `name` can be the first chunk of a key expression (`<name>/**`): Zenoh's wildcard and
/// verbatim characters and `/` would widen or break it.
pub fn is_key_chunk(name: &str) -> bool {
    !name.is_empty() && !name.contains(['/', '*', '$', '?', '#']) && name.trim() == name
}

impl ZenohAccessConfig {
    /// Every broken rule of this section at `path` (`interprocess.access`, `zenoh.access`).
    pub fn check(&self, path: &str) -> Vec<FieldError> {
        let mut e = Vec::new();
        let p = |k| at(path, k);
        if !self.allow_common_names.is_empty() {
            e.push(FieldError::new(
                p("allow_common_names"),
                format!("{:?}", self.allow_common_names),
                "replaced, because every name listed here could steer this vehicle: put the \
                 fleet's vehicles in `vehicles = [...]` (each may publish only under its own \
                 platform) and the topside and operators that may command in \
                 `commanders = [...]`",
            ));
        }
        if self.vehicles.is_empty()
            && self.commanders.is_empty()
            && self.allow_common_names.is_empty()
        {
            e.push(FieldError::new(
                path.to_string(),
                "vehicles = [], commanders = []",
                "every peer would be denied; list the fleet's names or leave the section out",
            ));
        }
        for (field, list) in [
            ("vehicles", &self.vehicles),
            ("commanders", &self.commanders),
        ] {
            if list.len() > MAX_ACCESS_NAMES {
                e.push(FieldError::new(
                    p(field),
                    list.len(),
                    format!("more than {MAX_ACCESS_NAMES} names"),
                ));
                continue;
            }
            for (i, cn) in list.iter().enumerate() {
                let bad = if cn.trim().is_empty() || cn.len() > MAX_CN_BYTES {
                    Some("not a common name (1 to 256 bytes)")
                } else if field == "vehicles" && !is_key_chunk(cn) {
                    Some(
                        "a vehicle's common name is its platform, the first chunk of its keys: \
                         no '/', '*', '$', '?', '#' or surrounding spaces",
                    )
                } else if field == "commanders" && self.vehicles.contains(cn) {
                    Some("also in `vehicles`: a name is either a vehicle or a commander")
                } else {
                    None
                };
                if let Some(why) = bad {
                    e.push(FieldError::new(
                        format!("{}[{i}]", p(field)),
                        format!("{cn:?}"),
                        why,
                    ));
                }
            }
        }
        e
    }
}

/// A session's endpoints and security sections, as every service that opens one has them.
#[derive(Debug, Clone, Copy)]
pub struct ZenohSecurity<'a> {
    /// Endpoints listened on.
    pub listen: &'a [String],
    /// Endpoints connected to.
    pub connect: &'a [String],
    /// The `tls` section, if present.
    pub tls: Option<&'a ZenohTlsConfig>,
    /// The `access` section, if present.
    pub access: Option<&'a ZenohAccessConfig>,
    /// The session is opened at all (the certificate files are only read then).
    pub in_use: bool,
}

/// Protocol of a Zenoh endpoint (`tls` of `tls/10.0.0.1:7447`), if it has one.
pub fn endpoint_protocol(ep: &str) -> Option<&str> {
    ep.split_once('/').map(|(p, _)| p)
}

/// Whether an endpoint's address is on loopback; `None` for a host name other than localhost, or
/// an address that is not one.
fn endpoint_is_loopback(ep: &str) -> Option<bool> {
    let (_, rest) = ep.split_once('/')?;
    // Zenoh appends `?metadata` and `#config` to the address.
    let addr = rest.split(['?', '#']).next().unwrap_or(rest);
    if let Ok(a) = addr.parse::<SocketAddr>() {
        return Some(a.ip().is_loopback());
    }
    let host = addr.rsplit_once(':').map_or(addr, |(h, _)| h);
    if host.eq_ignore_ascii_case("localhost") {
        return Some(true);
    }
    host.trim_matches(['[', ']'])
        .parse::<IpAddr>()
        .ok()
        .map(|ip| ip.is_loopback())
}

impl ZenohSecurity<'_> {
    fn endpoints(&self) -> impl Iterator<Item = (&'static str, usize, &str)> {
        let l = self
            .listen
            .iter()
            .enumerate()
            .map(|(i, e)| ("listen", i, e.as_str()));
        let c = self
            .connect
            .iter()
            .enumerate()
            .map(|(i, e)| ("connect", i, e.as_str()));
        l.chain(c)
    }

    fn any_tls(&self, field: &str) -> bool {
        self.endpoints()
            .any(|(f, _, e)| f == field && endpoint_protocol(e) == Some("tls"))
    }

    /// Every broken rule, with paths under `prefix` (`interprocess`, `zenoh`).
    pub fn check(&self, prefix: &str) -> Vec<FieldError> {
        let mut e = Vec::new();
        let (tls_listen, tls_connect) = (self.any_tls("listen"), self.any_tls("connect"));
        if self.tls.is_none() {
            for (field, i, ep) in self.endpoints() {
                if endpoint_protocol(ep) == Some("tls") {
                    e.push(FieldError::new(
                        format!("{}[{i}]", at(prefix, field)),
                        format!("{ep:?}"),
                        format!("a tls/ endpoint needs a [{}] section", at(prefix, "tls")),
                    ));
                }
            }
        }
        if let Some(tls) = self.tls
            && self.in_use
            && (tls_listen || tls_connect)
        {
            let p = |k| at(&at(prefix, "tls"), k);
            match &tls.root_ca_certificate {
                Some(f) => check_pem(&p("root_ca_certificate"), f, "CERTIFICATE", &mut e),
                None => e.push(FieldError::new(
                    p("root_ca_certificate"),
                    "(unset)",
                    "required: the fleet's CA that signs the peers' certificates",
                )),
            }
            let own_needed = tls_listen || tls.mutual;
            let why = if tls_listen {
                "required to listen on a tls/ endpoint"
            } else {
                "required with mutual = true (it is presented to the peers this connects to)"
            };
            match &tls.certificate {
                Some(f) => check_pem(&p("certificate"), f, "CERTIFICATE", &mut e),
                None if own_needed => e.push(FieldError::new(p("certificate"), "(unset)", why)),
                None => {}
            }
            match &tls.private_key {
                Some(f) => check_pem(&p("private_key"), f, "PRIVATE KEY", &mut e),
                None if own_needed => e.push(FieldError::new(p("private_key"), "(unset)", why)),
                None => {}
            }
        }
        if let Some(access) = self.access.filter(|_| self.in_use) {
            match self.tls {
                None => e.push(FieldError::new(
                    at(prefix, "access"),
                    "(set)",
                    format!(
                        "access by certificate common name needs a [{}] section",
                        at(prefix, "tls")
                    ),
                )),
                Some(t) if !t.mutual => e.push(FieldError::new(
                    at(&at(prefix, "tls"), "mutual"),
                    false,
                    format!(
                        "[{}] needs mutual = true: peers that connect here present no certificate \
                         to check",
                        at(prefix, "access")
                    ),
                )),
                Some(_) => {}
            }
            e.extend(access.check(&at(prefix, "access")));
        }
        e
    }

    /// Advice (printed by `--check`, logged at start-up): traffic beyond loopback that is not
    /// protected, and a private key others can read.
    pub fn warnings(&self, prefix: &str) -> Vec<String> {
        let mut w = Vec::new();
        if !self.in_use {
            return w;
        }
        for (field, i, ep) in self.endpoints() {
            let proto = endpoint_protocol(ep).unwrap_or("");
            if proto != "tls" && endpoint_is_loopback(ep) != Some(true) {
                w.push(format!(
                    "{}[{i}] = {ep:?} is not a loopback address and not tls/: Zenoh traffic on it \
                     is neither encrypted nor authenticated, and whoever reaches it can publish to \
                     the vehicle (use a tls/ endpoint with [{}])",
                    at(prefix, field),
                    at(prefix, "tls")
                ));
            }
        }
        if let Some(tls) = self.tls {
            if !tls.mutual && self.any_tls("listen") {
                w.push(format!(
                    "{} = false: anyone who reaches a tls/ listen endpoint joins the session and \
                     can publish to the vehicle",
                    at(&at(prefix, "tls"), "mutual")
                ));
            }
            if !tls.verify_name_on_connect && self.any_tls("connect") {
                w.push(format!(
                    "{} = false: any certificate the CA (or a public Web PKI root) signed is \
                     accepted from the peers this connects to, whatever address it names",
                    at(&at(prefix, "tls"), "verify_name_on_connect")
                ));
            }
            if let Some(key) = &tls.private_key
                && let Some(mode) = loose_permissions(key)
            {
                w.push(format!(
                    "{}: {key} has mode {mode:o}: readable by group or others; chmod 600 it",
                    at(&at(prefix, "tls"), "private_key")
                ));
            }
        }
        w
    }
}

/// `path` is a readable file of at most [`MAX_PEM_BYTES`] with a `-----BEGIN …{label}-----` block.
fn check_pem(path: &str, file: &str, label: &str, e: &mut Vec<FieldError>) {
    let mut text = String::new();
    let read = std::fs::File::open(file).and_then(|f| {
        if !f.metadata()?.is_file() {
            return Err(std::io::Error::other("not a regular file"));
        }
        f.take(MAX_PEM_BYTES + 1).read_to_string(&mut text)
    });
    let reason = match read {
        Err(err) => format!("cannot be read: {err}"),
        Ok(n) if n as u64 > MAX_PEM_BYTES => format!("larger than {MAX_PEM_BYTES} bytes"),
        Ok(_) if !pem_has(&text, label) => format!("holds no PEM \"{label}\" block"),
        Ok(_) => return,
    };
    e.push(FieldError::new(path, format!("{file:?}"), reason));
}

/// A `BEGIN` line whose label ends with `label` (`PRIVATE KEY` matches `EC PRIVATE KEY`).
fn pem_has(text: &str, label: &str) -> bool {
    text.lines().any(|l| {
        l.trim()
            .strip_prefix("-----BEGIN ")
            .and_then(|r| r.strip_suffix("-----"))
            .is_some_and(|l| l.ends_with(label))
    })
}

#[cfg(unix)]
fn loose_permissions(file: &str) -> Option<u32> {
    use std::os::unix::fs::PermissionsExt;
    let mode = std::fs::metadata(file).ok()?.permissions().mode() & 0o777;
    (mode & 0o077 != 0).then_some(mode)
}

#[cfg(not(unix))]
fn loose_permissions(_file: &str) -> Option<u32> {
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn loopback_is_told_from_the_rest() {
        for (ep, want) in [
            ("tcp/127.0.0.1:7447", Some(true)),
            ("tcp/[::1]:7447", Some(true)),
            ("tcp/localhost:7447", Some(true)),
            ("tcp/0.0.0.0:7447", Some(false)),
            ("tcp/10.0.0.2:7447#iface=eth0", Some(false)),
            ("tcp/boat.example:7447", None),
        ] {
            assert_eq!(endpoint_is_loopback(ep), want, "{ep}");
        }
    }

    #[test]
    fn pem_labels() {
        assert!(pem_has(
            "x\n-----BEGIN EC PRIVATE KEY-----\n",
            "PRIVATE KEY"
        ));
        assert!(pem_has("-----BEGIN CERTIFICATE-----", "CERTIFICATE"));
        assert!(!pem_has("-----BEGIN CERTIFICATE-----", "PRIVATE KEY"));
    }

    fn access(vehicles: &[&str], commanders: &[&str]) -> ZenohAccessConfig {
        ZenohAccessConfig {
            vehicles: vehicles.iter().map(|s| s.to_string()).collect(),
            commanders: commanders.iter().map(|s| s.to_string()).collect(),
            ..Default::default()
        }
    }

    fn paths(e: Vec<FieldError>) -> Vec<String> {
        e.into_iter().map(|e| e.path).collect()
    }

    #[test]
    fn access_lists_are_checked() {
        assert_eq!(
            paths(access(&["auv1", "auv2"], &["topside"]).check("a")),
            Vec::<String>::new()
        );
        assert_eq!(
            paths(access(&[], &["topside"]).check("a")),
            Vec::<String>::new()
        );
        assert_eq!(paths(access(&[], &[]).check("a")), vec!["a"]);
        assert_eq!(
            paths(access(&["auv/1", "*", " auv2", "a$b", "ok"], &["op/1"]).check("a")),
            vec![
                "a.vehicles[0]",
                "a.vehicles[1]",
                "a.vehicles[2]",
                "a.vehicles[3]"
            ],
            "a commander's name is never a key chunk, so it may hold '/'"
        );
        assert_eq!(
            paths(access(&["auv1"], &["auv1", ""]).check("a")),
            vec!["a.commanders[0]", "a.commanders[1]"]
        );
        let many: Vec<String> = (0..=MAX_ACCESS_NAMES).map(|i| format!("v{i}")).collect();
        let big = ZenohAccessConfig {
            vehicles: many,
            ..Default::default()
        };
        assert_eq!(paths(big.check("a")), vec!["a.vehicles"]);
    }

    #[test]
    fn the_old_all_or_nothing_list_is_refused_naming_the_new_fields() {
        let old: ZenohAccessConfig =
            toml::from_str("allow_common_names = [\"topside\", \"auv2\"]").unwrap();
        let e = old.check("interprocess.access");
        assert_eq!(e.len(), 1, "{e:?}");
        assert_eq!(e[0].path, "interprocess.access.allow_common_names");
        let why = &e[0].message;
        assert!(
            why.contains("vehicles = [") && why.contains("commanders = ["),
            "{why}"
        );
    }
}
