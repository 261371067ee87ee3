//! The supervision tree as `frontseat interfaces` prints it: rendered from the [`Node`]s of the
//! very child specs a service starts, each with its side and policy in words, and read back
//! ([`tree_names`]) by the tests that hold the printed tree to the started one.

use std::time::Duration;

use frontseat_config::RestartPolicy;

use super::policy::{Policy, Side};
use super::spec::Node;

/// What the printed tree says before the trees of the services.
pub const TREE_PREAMBLE: &str = "\
# supervision tree (every restart is logged, counted, and published on frontseat::supervision::status)
# two sides, two policies: only the vehicle side can end the process; a helm-side child is
# restarted without end (backoff doubling to backoff_max_ms, jittered), and while it is down the
# process is degraded (supervision status: degraded, the child's down_since; goby_coroner health:
# DEGRADED; metric frontseat.supervision.helm_side_down), never dead; a vehicle-side child is
# restarted at most max_restarts within restart_window_s, then its supervisor gives up (exit 3, or
# the child's own code); a helm-side `never` child that fails is left down, degraded; children
# stop in reverse start order
";

/// "100 ms", "2 s", "1.5 s".
fn span(d: Duration) -> String {
    if d.subsec_millis() == 0 && d.as_secs() > 0 {
        format!("{} s", d.as_secs())
    } else if d < Duration::from_secs(1) {
        format!("{} ms", d.as_millis())
    } else {
        format!("{} s", d.as_secs_f64())
    }
}

fn policy_words(p: &Policy) -> String {
    let restart = match p.restart {
        RestartPolicy::Never => "never",
        RestartPolicy::OnFailure => "on-failure",
        RestartPolicy::Always => "always",
    };
    let backoff = format!(
        "after {} doubling to {}",
        span(p.backoff_initial),
        span(p.backoff_max)
    );
    match p.side {
        Side::Vehicle => format!(
            "{restart}, {backoff}, at most {} in {}",
            p.max_restarts,
            span(p.window)
        ),
        Side::Helm => format!("{restart}, {backoff}, jittered, without end"),
    }
}

fn render_nodes(out: &mut String, nodes: &[Node], indent: &str) {
    for (i, n) in nodes.iter().enumerate() {
        let last = i + 1 == nodes.len();
        let (branch, more) = if last {
            ("└── ", "    ")
        } else {
            ("├── ", "│   ")
        };
        let side = match n.policy.side {
            Side::Vehicle => "VEHICLE",
            Side::Helm => "helm",
        };
        let width = 26usize.saturating_sub(indent.chars().count());
        out.push_str(&format!(
            "#   {indent}{branch}{:<width$}{side:<8} {}\n",
            n.name,
            policy_words(&n.policy)
        ));
        let below = format!("{indent}{more}");
        let bar = if n.about.nested.is_empty() {
            " "
        } else {
            "│"
        };
        if !n.about.note.is_empty() {
            out.push_str(&format!("#   {below}{bar}   {}\n", n.about.note));
        }
        render_nodes(out, &n.about.nested, &below);
    }
}

/// One service's tree under its root supervisor, from the nodes of the very
/// [`ChildSpec`](super::ChildSpec)s it
/// starts (in start order), as `frontseat interfaces` prints it.
pub fn render_tree(title: &str, root_note: &str, children: &[Node]) -> String {
    let mut out = format!("# {title}\n#   root supervisor   {root_note}\n");
    render_nodes(&mut out, children, "");
    out
}

/// The names in a tree [`render_tree`] printed, each with its depth (1: a root's child).
pub fn tree_names(tree: &str) -> Vec<(usize, String)> {
    tree.lines()
        .filter_map(|l| {
            let at = l.find("── ")?;
            let depth = l[..at].chars().count().saturating_sub(4) / 4 + 1;
            let name = l[at + "── ".len()..].split_whitespace().next()?;
            Some((depth, name.to_string()))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::supervisor::policy::tests::policy;

    #[test]
    fn the_tree_is_rendered_from_the_nodes_and_read_back() {
        let mut scope = Node::new(
            "Scope",
            policy(RestartPolicy::OnFailure, 3).helm_side(),
            "a",
        );
        scope.about.nested = vec![Node::new("Inner", policy(RestartPolicy::Always, 5), "")];
        let nodes = vec![
            Node::new("First", policy(RestartPolicy::Never, 2), "first note"),
            scope,
            Node::new("Last", policy(RestartPolicy::OnFailure, 4), ""),
        ];
        let tree = render_tree("svc", "root note", &nodes);
        assert_eq!(
            tree_names(&tree),
            vec![
                (1, "First".to_string()),
                (1, "Scope".to_string()),
                (2, "Inner".to_string()),
                (1, "Last".to_string()),
            ],
            "{tree}"
        );
        assert!(
            tree.contains("First                     VEHICLE  never, after 100 ms doubling to 1 s, at most 2 in 60 s"),
            "{tree}"
        );
        assert!(
            tree.contains(
                "helm     on-failure, after 100 ms doubling to 1 s, jittered, without end"
            ),
            "{tree}"
        );
        assert!(tree.contains("│   └── Inner"), "{tree}");
        assert!(tree.contains("first note"), "{tree}");
    }
}
