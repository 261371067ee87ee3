//! The ports a launch file's processes will bind, and two of them given the same one: found by
//! `--check` and before anything starts, instead of the second process failing to bind at run
//! time (a launch that ended with exit 10 + its position). Each vehicle's interface binds its
//! Zenoh `listen` endpoints (in peer mode), its web page, its Foxglove server and an ArduPilot
//! `udpin:` link; a `frontseat` process binds what its config and flags say (`sim`, `interface`,
//! `moos-gateway`, `topside`); a MOOSDB (or pAntler's) binds its `.moos` file's ServerPort or
//! `--moos_port`; any process waited for with `ready = { kind = "tcp" }` binds that address.
//! Connections (`sim_port`, a MOOS client's port, Zenoh `connect`) bind nothing: several vehicles
//! may share one simulator.

use std::net::IpAddr;
use std::path::{Path, PathBuf};

use frontseat_config::{GatewayConfig, InterfaceConfig, InterprocessConfig, InterprocessMode};

use crate::config::ReadyKind;
use crate::spec::ProcSpec;

/// TCP and UDP ports are separate: `tcp/…:7447` and `udp/…:7447` do not clash.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Proto {
    Tcp,
    Udp,
}

impl std::fmt::Display for Proto {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Proto::Tcp => "TCP",
            Proto::Udp => "UDP",
        })
    }
}

/// One address a process will bind.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Binding {
    pub proto: Proto,
    /// The address as written (`127.0.0.1`, `0.0.0.0`, `localhost`, `[::1]`).
    pub host: String,
    pub port: u16,
    /// Whose it is: `vehicle auv1`, `process sim`, `process helm-auv2`.
    pub owner: String,
    /// Where the launch file (or the config it names) sets it: `interprocess.listen
    /// "tcp/127.0.0.1:7447"`, `--port 54321`.
    pub what: String,
}

/// Whether two hosts can be the same socket address: equal, or either is a wildcard (0.0.0.0,
/// ::, empty) that takes the port on every address. A name other than localhost is compared as
/// written.
fn hosts_overlap(a: &str, b: &str) -> bool {
    let norm = |h: &str| -> String {
        let h = h.trim_start_matches('[').trim_end_matches(']');
        match h {
            "localhost" => "127.0.0.1".into(),
            _ => h.to_ascii_lowercase(),
        }
    };
    let (a, b) = (norm(a), norm(b));
    let wildcard =
        |h: &str| h.is_empty() || h.parse::<IpAddr>().is_ok_and(|ip| ip.is_unspecified());
    a == b || wildcard(&a) || wildcard(&b)
}

/// The first two bindings of different owners on one port (protocol and overlapping address).
pub fn first_clash(bindings: &[Binding]) -> Option<(&Binding, &Binding)> {
    for (i, a) in bindings.iter().enumerate() {
        for b in &bindings[..i] {
            if a.port == b.port
                && a.proto == b.proto
                && a.owner != b.owner
                && hosts_overlap(&a.host, &b.host)
            {
                return Some((b, a));
            }
        }
    }
    None
}

/// `host:port` or `[v6]:port` → (host, port); port 0 (the system picks one) binds nothing fixed.
fn host_port(addr: &str) -> Option<(String, u16)> {
    let (host, port) = addr.rsplit_once(':')?;
    // A Zenoh locator may carry `#iface=…` or `?…` metadata after the port.
    let port = port.split(['#', '?']).next().unwrap_or(port);
    let port: u16 = port.parse().ok()?;
    (port != 0).then(|| (host.to_string(), port))
}

/// A Zenoh endpoint's transport and address (`tcp/127.0.0.1:7447`); unix sockets bind no port.
fn zenoh_endpoint(ep: &str) -> Option<(Proto, String, u16)> {
    let (proto, addr) = ep.split_once('/')?;
    let proto = match proto {
        "tcp" | "tls" | "ws" => Proto::Tcp,
        "udp" | "quic" => Proto::Udp,
        _ => return None,
    };
    let (host, port) = host_port(addr)?;
    Some((proto, host, port))
}

fn zenoh_listen(cfg: &InterprocessConfig, owner: &str, prefix: &str, out: &mut Vec<Binding>) {
    if !cfg.enabled || cfg.mode == InterprocessMode::Client {
        return;
    }
    for ep in &cfg.listen {
        if let Some((proto, host, port)) = zenoh_endpoint(ep) {
            out.push(Binding {
                proto,
                host,
                port,
                owner: owner.to_string(),
                what: format!("{prefix}.listen {ep:?}"),
            });
        }
    }
}

fn tcp(addr: &str, owner: &str, what: String, out: &mut Vec<Binding>) {
    if let Some((host, port)) = host_port(addr) {
        out.push(Binding {
            proto: Proto::Tcp,
            host,
            port,
            owner: owner.to_string(),
            what,
        });
    }
}

fn foxglove(r: &frontseat_config::RecordConfig, owner: &str, out: &mut Vec<Binding>) {
    if r.enabled && r.foxglove.enabled {
        let b = &r.foxglove.bind;
        tcp(b, owner, format!("record.foxglove.bind {b:?}"), out);
    }
}

/// What one interface binds.
pub fn of_interface(ic: &InterfaceConfig, owner: &str, out: &mut Vec<Binding>) {
    zenoh_listen(&ic.interprocess, owner, "interprocess", out);
    if ic.web.enabled {
        let l = &ic.web.listen;
        tcp(l, owner, format!("web.listen {l:?}"), out);
    }
    foxglove(&ic.record, owner, out);
    if ic.driver.name == frontseat_config::ARDUPILOT {
        let a = &ic.driver.ardupilot.address;
        if let Some(addr) = a.strip_prefix("udpin:")
            && let Some((host, port)) = host_port(addr)
        {
            out.push(Binding {
                proto: Proto::Udp,
                host,
                port,
                owner: owner.to_string(),
                what: format!("driver.ardupilot.address {a:?}"),
            });
        }
    }
}

/// The value after `--flag` or in `--flag=value`.
fn flag<'a>(args: &'a [String], name: &str) -> Option<&'a str> {
    let eq = format!("{name}=");
    args.iter().enumerate().find_map(|(i, a)| {
        if a == name {
            args.get(i + 1).map(String::as_str)
        } else {
            a.strip_prefix(&eq)
        }
    })
}

/// A `frontseat` service's config file: `-c FILE`, `--config FILE` or Goby3's positional file.
fn config_file(p: &ProcSpec) -> Option<PathBuf> {
    let rest = p.args.get(1..).unwrap_or_default();
    // Positional: a word not after a flag (`--port 54321` is not a file).
    let positional = || {
        rest.iter().enumerate().find_map(|(i, a)| {
            let after_flag = i > 0 && rest[i - 1].starts_with('-') && !rest[i - 1].contains('=');
            (!a.starts_with('-') && !after_flag).then_some(a.as_str())
        })
    };
    let file = flag(rest, "-c")
        .or_else(|| flag(rest, "--config"))
        .or_else(positional)?;
    Some(resolve(&p.cwd, file))
}

fn resolve(base: &Path, p: &str) -> PathBuf {
    let p = Path::new(p);
    if p.is_absolute() {
        p.to_path_buf()
    } else {
        base.join(p)
    }
}

/// A small text file, or nothing (a file that cannot be read is the process's own error, at run
/// time; the check does not guess).
fn read_small(path: &Path) -> Option<String> {
    // Bounded as it reads (a FIFO or a device reports no size), like every config file.
    frontseat_config::read_text(path).ok()
}

/// `ServerPort = N` of a MOOS mission file (MOOSDB's default is 9000).
fn moos_server_port(text: &str) -> Option<u16> {
    text.lines().find_map(|l| {
        let l = l.split("//").next().unwrap_or_default();
        let (k, v) = l.split_once('=')?;
        k.trim()
            .eq_ignore_ascii_case("ServerPort")
            .then(|| v.trim().parse().ok())
            .flatten()
    })
}

/// What one `[[process]]` binds, as far as its command says: a `frontseat` service by its
/// config and flags, a MOOSDB or pAntler by its mission file, and its `ready` TCP address.
/// `frontseat` is the binary `frontseat` commands run.
pub fn of_process(p: &ProcSpec, frontseat: &Path, out: &mut Vec<Binding>) {
    let owner = format!("process {}", p.name);
    let start = out.len();
    let program = p.program.file_name().and_then(|n| n.to_str()).unwrap_or("");
    if p.program == frontseat {
        let sub = p.args.first().map(String::as_str).unwrap_or("");
        let file = config_file(p);
        match sub {
            "sim" => {
                let cfg = match &file {
                    Some(f) => frontseat_config::load::<frontseat_config::SimConfig>(f).ok(),
                    None => Some(frontseat_config::SimConfig::default()),
                };
                let emulator = flag(&p.args, "--vehicle").unwrap_or("basic");
                let port_flag = flag(&p.args, "--port").and_then(|v| v.parse::<u16>().ok());
                let tcp_flag = flag(&p.args, "--tcp").and_then(|v| v.parse::<u16>().ok());
                let bind = flag(&p.args, "--bind")
                    .map(str::to_string)
                    .or_else(|| cfg.as_ref().map(|c| c.bind.clone()))
                    .unwrap_or_else(|| "127.0.0.1".into());
                // The basic simulator and the Bluefin emulator listen on --port (or the
                // config's); the other emulators on --tcp.
                let (port, what) = match emulator {
                    "basic" | "bluefin" => match port_flag {
                        Some(v) => (Some(v), format!("--port {v}")),
                        None => (cfg.as_ref().map(|c| c.port), "port (its config)".into()),
                    },
                    _ => (tcp_flag, format!("--tcp {}", tcp_flag.unwrap_or(0))),
                };
                if let Some(port) = port.filter(|&p| p != 0) {
                    out.push(Binding {
                        proto: Proto::Tcp,
                        host: bind,
                        port,
                        owner: owner.clone(),
                        what,
                    });
                }
            }
            "interface" => {
                if let Some(ic) =
                    file.and_then(|f| frontseat_config::load::<InterfaceConfig>(&f).ok())
                {
                    of_interface(&ic, &owner, out);
                }
            }
            "moos-gateway" => {
                if let Some(g) = file.and_then(|f| frontseat_config::load::<GatewayConfig>(&f).ok())
                {
                    zenoh_listen(&g.interprocess, &owner, "interprocess", out);
                    foxglove(&g.record, &owner, out);
                }
            }
            "topside" => {
                // Read as TOML, not as the topside's own type (which lives above this crate);
                // no file: the defaults.
                let table = match file.as_deref() {
                    Some(f) => read_small(f).and_then(|s| s.parse::<toml::Table>().ok()),
                    None => Some(toml::Table::new()),
                };
                if let Some(t) = table {
                    let get = |table: &str, key: &str| {
                        t.get(table)
                            .and_then(|v| v.get(key))
                            .and_then(|v| v.as_str())
                            .map(str::to_string)
                    };
                    let web = get("web", "listen").unwrap_or_else(|| "127.0.0.1:50080".into());
                    tcp(&web, &owner, format!("web.listen {web:?}"), out);
                    let fox_on = t
                        .get("foxglove")
                        .and_then(|f| f.get("enabled"))
                        .and_then(|v| v.as_bool())
                        .unwrap_or(false);
                    if fox_on {
                        let b = get("foxglove", "bind").unwrap_or_else(|| "127.0.0.1:8765".into());
                        tcp(&b, &owner, format!("foxglove.bind {b:?}"), out);
                    }
                    if let Some(l) = t
                        .get("zenoh")
                        .and_then(|z| z.get("listen"))
                        .and_then(|v| v.as_array())
                    {
                        for ep in l.iter().filter_map(|v| v.as_str()) {
                            if let Some((proto, host, port)) = zenoh_endpoint(ep) {
                                out.push(Binding {
                                    proto,
                                    host,
                                    port,
                                    owner: owner.clone(),
                                    what: format!("zenoh.listen {ep:?}"),
                                });
                            }
                        }
                    }
                }
            }
            _ => {}
        }
    } else if program == "MOOSDB" || program == "pAntler" {
        let port = flag(&p.args, "--moos_port")
            .and_then(|v| v.parse::<u16>().ok())
            .map(|v| (v, format!("--moos_port={v}")))
            .or_else(|| {
                let mission = p.args.iter().find(|a| a.ends_with(".moos"))?;
                let text = read_small(&resolve(&p.cwd, mission))?;
                let v = moos_server_port(&text)?;
                Some((v, format!("ServerPort = {v} ({mission})")))
            })
            .or_else(|| (program == "MOOSDB").then(|| (9000, "MOOSDB's default port".into())));
        if let Some((port, what)) = port {
            out.push(Binding {
                proto: Proto::Tcp,
                host: "0.0.0.0".into(),
                port,
                owner: owner.clone(),
                what,
            });
        }
    }
    if p.ready.kind == ReadyKind::Tcp
        && let Some((host, port)) = host_port(&p.ready.address)
        && !out[start..]
            .iter()
            .any(|b| b.port == port && b.proto == Proto::Tcp)
    {
        out.push(Binding {
            proto: Proto::Tcp,
            host,
            port,
            owner,
            what: format!("ready.address {:?}", p.ready.address),
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn b(proto: Proto, host: &str, port: u16, owner: &str) -> Binding {
        Binding {
            proto,
            host: host.into(),
            port,
            owner: owner.into(),
            what: String::new(),
        }
    }

    #[test]
    fn a_clash_is_one_port_one_protocol_overlapping_addresses_two_owners() {
        let t = Proto::Tcp;
        for (x, y, clash) in [
            (
                b(t, "127.0.0.1", 7447, "a"),
                b(t, "127.0.0.1", 7447, "b"),
                true,
            ),
            (
                b(t, "127.0.0.1", 7447, "a"),
                b(t, "0.0.0.0", 7447, "b"),
                true,
            ),
            (
                b(t, "localhost", 7447, "a"),
                b(t, "127.0.0.1", 7447, "b"),
                true,
            ),
            (b(t, "[::]", 7447, "a"), b(t, "127.0.0.1", 7447, "b"), true),
            (
                b(t, "127.0.0.1", 7447, "a"),
                b(t, "127.0.0.2", 7447, "b"),
                false,
            ),
            (
                b(t, "127.0.0.1", 7447, "a"),
                b(Proto::Udp, "127.0.0.1", 7447, "b"),
                false,
            ),
            (
                b(t, "127.0.0.1", 7447, "a"),
                b(t, "127.0.0.1", 7448, "b"),
                false,
            ),
            (
                b(t, "127.0.0.1", 7447, "a"),
                b(t, "127.0.0.1", 7447, "a"),
                false,
            ),
        ] {
            assert_eq!(
                first_clash(&[x.clone(), y.clone()]).is_some(),
                clash,
                "{x:?} {y:?}"
            );
        }
    }

    #[test]
    fn endpoints_and_mission_files_give_their_ports() {
        assert_eq!(
            zenoh_endpoint("tcp/127.0.0.1:7447"),
            Some((Proto::Tcp, "127.0.0.1".into(), 7447))
        );
        assert_eq!(
            zenoh_endpoint("quic/[::1]:7447#iface=lo"),
            Some((Proto::Udp, "[::1]".into(), 7447))
        );
        assert_eq!(zenoh_endpoint("tcp/127.0.0.1:0"), None);
        assert_eq!(zenoh_endpoint("unixsock-stream//tmp/z.sock"), None);
        assert_eq!(zenoh_endpoint("tcp127.0.0.1:1"), None);
        assert_eq!(
            moos_server_port("ServerHost = localhost\n  serverport= 9001 // x\n"),
            Some(9001)
        );
        assert_eq!(moos_server_port("// ServerPort = 9\nCommunity = a\n"), None);
    }
}
