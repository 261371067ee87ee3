//! The composition roots: one file per process kind this binary runs, each the one place that
//! says which children that process starts, in what order, under which policy, and how it
//! starts, runs and drains them. A command (`src/main.rs`, `src/<command>.rs`) parses and
//! validates its arguments and calls its root here; a root calls the crates, never a command.
//!
//! | process | root |
//! |---|---|
//! | `frontseat interface` | [`interface`] |
//! | `frontseat sim` (the basic simulator) | [`simulator`] |
//! | `frontseat sim --vehicle <v>` (a vehicle's emulator) | [`emulators`] |
//! | `frontseat moos-gateway` | [`moos_gateway`] |
//! | `frontseat demo` (simulator + interface under one root; the helm flies on its bus) | [`demo`] |
//! | `frontseat topside` | `frontseat_topside::run` (the whole process is that crate; its children: `frontseat_topside::children`) |
//! | `frontseat launch` | `frontseat_launch::run` (its children are the launch file's processes) |
//!
//! [`supervision_tree`] is what `frontseat interfaces` prints: rendered from the same child
//! lists these roots start.

pub mod demo;
pub mod emulators;
mod gateways;
pub mod interface;
pub mod moos_gateway;
mod recording;
pub mod simulator;

use frontseat_actors::bus::Bus;
use frontseat_actors::supervisor::{ChildSpec, TREE_PREAMBLE, render_tree};
use frontseat_config::InterfaceConfig;

/// The supervision trees `frontseat interfaces` prints, rendered from the child specs that
/// `frontseat interface` (with every optional child on), `frontseat sim` and `frontseat
/// moos-gateway` start: a child added there is a child printed here. Builds, starts nothing.
pub fn supervision_tree() -> String {
    let bus = Bus::new();
    let nodes = |c: Vec<ChildSpec>| c.iter().map(ChildSpec::node).collect::<Vec<_>>();
    let interface = interface::children(
        &interface::with_every_child(InterfaceConfig::default()),
        &bus,
        Default::default(),
    );
    let mut out = TREE_PREAMBLE.to_string();
    out.push_str(&render_tree(
        "frontseat interface",
        "gives up only past a vehicle-side limit: exit 3 (or the child's code)",
        &nodes(interface),
    ));
    out.push_str(&render_tree(
        "frontseat sim (and the demo: these and the interface's under one root)",
        "gives up past the server's limit",
        &nodes(simulator::tree_children()),
    ));
    out.push_str(&render_tree(
        "frontseat moos-gateway",
        "gives up past a child's limit: exit 3",
        &nodes(moos_gateway::tree_children(&bus)),
    ));
    out.push_str(&render_tree(
        "frontseat topside",
        "never gives up on its own: the page server is restarted without end",
        &nodes(frontseat_topside::children(Default::default(), None)),
    ));
    out.push_str(LAUNCH_TREE);
    out
}

/// `frontseat launch`'s children are its file's processes: `frontseat launch --check -c FILE`
/// prints them in start order with their restart policies, from the same plan the launch runs.
const LAUNCH_TREE: &str = "# frontseat launch\n#   root supervisor   gives up when a process fails past its own `restart`\n#   └── one child per process of the launch file, in its order: `frontseat launch --check -c FILE` prints them\n";

#[cfg(test)]
mod tests {
    use std::net::SocketAddr;
    use std::time::Duration;

    use frontseat_actors::supervisor::{SupervisorHandle, tree_names};
    use frontseat_actors::systemd;
    use frontseat_config::{GatewayConfig, SimConfig};

    use super::*;

    /// A loopback port nothing listens on: bound by the system, then let go.
    fn closed_port() -> u16 {
        std::net::TcpListener::bind("127.0.0.1:0")
            .and_then(|l| l.local_addr())
            .map(|a| a.port())
            .unwrap_or(9)
    }

    /// The printed tree of the process whose heading starts with `heading`, as (depth, name).
    fn printed_section(printed: &str, heading: &str) -> Vec<(usize, String)> {
        let section = printed
            .split("# frontseat ")
            .find(|s| s.starts_with(heading))
            .unwrap_or_else(|| panic!("a `frontseat {heading}` tree in {printed}"));
        tree_names(section)
    }

    /// The root's children as printed, in start order.
    fn top_level(names: &[(usize, String)]) -> Vec<&str> {
        names
            .iter()
            .filter(|(depth, _)| *depth == 1)
            .map(|(_, n)| n.as_str())
            .collect()
    }

    /// The names the root supervisor reports for the children it started, in start order.
    async fn started(root: &SupervisorHandle) -> Vec<String> {
        let snap = root
            .snapshot(Duration::from_secs(5))
            .await
            .expect("the root answers");
        snap.children.into_iter().map(|c| c.name).collect()
    }

    /// What `frontseat interfaces` prints for `frontseat interface` is what that service
    /// starts: the printed children (in start order) are the names the root supervisor reports
    /// for the children it started, and each one's nested children are the ones it runs.
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn the_printed_tree_is_the_started_tree() {
        let printed = supervision_tree();
        let names = printed_section(&printed, "interface\n");

        // The same config as printed, every optional child on, its sockets on free loopback ports.
        let mut cfg = interface::with_every_child(InterfaceConfig::default());
        cfg.interprocess.listen = vec!["tcp/127.0.0.1:0".into()];
        cfg.web.listen = "127.0.0.1:0".into();
        cfg.goby3.platform = format!("tree-test-{}", std::process::id());
        cfg.goby3.ip_address = "127.0.0.1".into();
        cfg.goby3.tcp_port = closed_port();
        if let Some(m) = cfg.moos.as_mut() {
            m.port = closed_port();
        }
        cfg.driver.basic_simulator.tcp_port = closed_port();
        if let Some(o) = cfg.opencpn.as_mut() {
            o.ais.udp = vec![format!("127.0.0.1:{}", closed_port())];
            o.helm.listen = "127.0.0.1:0".into();
        }
        let bus = Bus::new();
        let current = systemd::InterfaceRef::default();
        let root = SupervisorHandle::start(
            "root",
            interface::children(&cfg, &bus, current.clone()),
            Some(&bus),
        )
        .await
        .expect("the tree starts");
        assert_eq!(top_level(&names), started(&root).await, "{printed}");

        // The interface runs one nested supervisor, which runs as many children as are printed
        // under it.
        let under_interface = names
            .iter()
            .skip_while(|(_, n)| n != "FrontSeatInterface")
            .skip(1)
            .take_while(|(depth, _)| *depth == 2)
            .count();
        let fsi = current
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .clone()
            .expect("the interface started");
        let nested = fsi.get_children();
        assert_eq!(nested.len(), 1, "the driver's supervisor");
        assert_eq!(nested[0].get_children().len(), under_interface, "{printed}");
        assert_eq!(under_interface, 1, "{printed}");
        root.shutdown(Duration::from_secs(10)).await;
    }

    /// The same for `frontseat sim`: its printed root holds the server `frontseat sim` starts.
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn the_printed_simulator_tree_is_the_started_tree() {
        let printed = supervision_tree();
        let names = printed_section(&printed, "sim ");
        let cfg = SimConfig {
            port: 0,
            ..Default::default()
        };
        let addr = SocketAddr::from(([127, 0, 0, 1], 0));
        let current = Default::default();
        let root =
            SupervisorHandle::start("root", simulator::children(None, addr, &cfg, current), None)
                .await
                .expect("the tree starts");
        assert_eq!(top_level(&names), started(&root).await, "{printed}");
        assert_eq!(top_level(&names), ["SimServer"], "{printed}");
        root.shutdown(Duration::from_secs(10)).await;
    }

    /// The same for `frontseat moos-gateway` with both transports on.
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn the_printed_moos_gateway_tree_is_the_started_tree() {
        let printed = supervision_tree();
        let names = printed_section(&printed, "moos-gateway\n");
        let mut cfg = GatewayConfig::default();
        cfg.interprocess.enabled = true;
        // Its own free loopback port, no interface to reach: the test stands alone.
        cfg.interprocess.listen = vec!["tcp/127.0.0.1:0".into()];
        cfg.interprocess.connect = Vec::new();
        cfg.goby3.enabled = true;
        cfg.goby3.platform = format!("gw-tree-test-{}", std::process::id());
        cfg.goby3.ip_address = "127.0.0.1".into();
        cfg.goby3.tcp_port = closed_port();
        cfg.moos.port = closed_port();
        let bus = Bus::new();
        let root = SupervisorHandle::start(
            "root",
            moos_gateway::children(&cfg, "gw-tree-test", &bus),
            Some(&bus),
        )
        .await
        .expect("the tree starts");
        assert_eq!(top_level(&names), started(&root).await, "{printed}");
        assert_eq!(top_level(&names).len(), 4, "{printed}");
        root.shutdown(Duration::from_secs(10)).await;
    }
}
