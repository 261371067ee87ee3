//! The rules: from located yaml declarations and the compiled protos to the resolved model (groups
//! with one type and one layer, actors with their publications and subscriptions), or to the list
//! of every rule the declarations break.

use std::collections::{BTreeMap, HashMap};
use std::path::PathBuf;

use heck::{ToSnakeCase, ToUpperCamelCase};
use prost_reflect::DescriptorPool;

use crate::error::{Diagnostic, Rule};
use crate::protos::rust_path;
use crate::yaml::{Direction, Entry, InterfaceFile, Layer, Pos};

/// A resolved group.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct GroupModel {
    /// Goby3's full name, `goby::middleware::frontseat::node_status`.
    pub name: String,
    /// The proto full name, `goby.middleware.frontseat.protobuf.NodeStatus`.
    pub type_name: String,
    /// The Rust path under `proto`, one segment per element.
    pub rust_type: Vec<String>,
    /// The widest layer any declaration gives it.
    pub layer: Layer,
    pub publishers: Vec<String>,
    pub subscribers: Vec<String>,
    /// `GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS`.
    pub const_name: String,
}

/// One publication or subscription of an actor.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Port {
    /// Index into `Model::groups`.
    pub group: usize,
    /// `node_status` (publish method suffix) or `NodeStatus` (inbox variant).
    pub ident: String,
    /// Index into `Model::extensions` when this port is a vehicle extension: a subscription is
    /// then delivered in the actor's one `VehicleExtension` variant, encoded, with its spec.
    pub extension: Option<usize>,
}

/// How the interface treats a vehicle's extension group (`extension:` in the vehicle's yaml).
/// The type is a mirror of the Goby3 message it extends (same base fields and numbers, plus
/// the vehicle's own), so the interface gates it by its base fields alone.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExtensionKind {
    /// A CommandRequest from a helm: in command state only, its course through the safety envelope.
    Command,
    /// A CommandRequest that changes the vehicle's mode (how command is reached): in listen or
    /// command; a course riding along is gated as `command`.
    Mode,
    /// An InterfaceData from a helm: in listen or command.
    Data,
    /// An InterfaceData from the vehicle to the helms: its node_status crosses the navigation gate.
    Navigation,
    /// As `navigation`, for a second copy of navigation the driver also sent plainly (gated the
    /// same, counted once).
    NavigationCopy,
}

impl ExtensionKind {
    pub const ALL: [ExtensionKind; 5] = [
        ExtensionKind::Command,
        ExtensionKind::Mode,
        ExtensionKind::Data,
        ExtensionKind::Navigation,
        ExtensionKind::NavigationCopy,
    ];

    pub fn key(self) -> &'static str {
        match self {
            ExtensionKind::Command => "command",
            ExtensionKind::Mode => "mode",
            ExtensionKind::Data => "data",
            ExtensionKind::Navigation => "navigation",
            ExtensionKind::NavigationCopy => "navigation_copy",
        }
    }

    /// The Goby3 message a mirror of this kind extends.
    pub fn base(self) -> &'static str {
        match self {
            ExtensionKind::Command | ExtensionKind::Mode => {
                "goby.middleware.frontseat.protobuf.CommandRequest"
            }
            _ => "goby.middleware.frontseat.protobuf.InterfaceData",
        }
    }

    /// Toward the vehicle (the interface subscribes) or toward the helms (it publishes).
    pub fn direction(self) -> Direction {
        match self {
            ExtensionKind::Navigation | ExtensionKind::NavigationCopy => Direction::Publishes,
            _ => Direction::Subscribes,
        }
    }
}

/// One vehicle extension group.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ExtensionModel {
    /// Index into `Model::groups`.
    pub group: usize,
    pub kind: ExtensionKind,
    /// The file's `vehicle:`.
    pub vehicle: String,
    /// The actor that gates it.
    pub actor: String,
    /// The field numbers of the base message (the rest of a mirror's fields are the vehicle's).
    pub base_fields: Vec<u32>,
}

/// A resolved actor.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ActorModel {
    pub name: String,
    pub publishes: Vec<Port>,
    pub subscribes: Vec<Port>,
}

/// One application's declarations with types normalised and layers resolved.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ApplicationModel {
    pub name: String,
    pub file: PathBuf,
    /// (resolved layer, direction, group, type, actor), in declaration order.
    pub entries: Vec<(Layer, Direction, String, String, String)>,
}

/// Everything the generator needs.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Model {
    pub applications: Vec<ApplicationModel>,
    pub groups: Vec<GroupModel>,
    pub actors: Vec<ActorModel>,
    /// Every vehicle extension group, sorted by group name.
    pub extensions: Vec<ExtensionModel>,
}

struct Diags<'a> {
    out: &'a mut Vec<Diagnostic>,
}

impl Diags<'_> {
    fn push(&mut self, file: &std::path::Path, pos: Pos, rule: Rule, message: String) {
        self.out.push(Diagnostic {
            file: file.to_path_buf(),
            line: pos.line,
            column: pos.column,
            rule,
            message,
        });
    }
}

/// Where another declaration is, as seen from a diagnostic in `here`: just the line when it is in
/// the same file.
fn at(here: &std::path::Path, file: &std::path::Path, pos: Pos) -> String {
    if here == file {
        format!("line {}", pos.line)
    } else {
        format!("{}:{}:{}", file.display(), pos.line, pos.column)
    }
}

fn valid_group_name(name: &str) -> bool {
    name.split("::").all(|seg| {
        let mut chars = seg.chars();
        chars
            .next()
            .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
            && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
    })
}

fn valid_actor_name(name: &str) -> bool {
    let mut chars = name.chars();
    chars.next().is_some_and(|c| c.is_ascii_uppercase()) && chars.all(|c| c.is_ascii_alphanumeric())
}

fn last_segment(group: &str) -> &str {
    group.rsplit("::").next().unwrap_or(group)
}

/// Applies every rule to the parsed files. `diags` receives every violation; the model is only
/// meaningful when no diagnostic was added.
pub fn resolve(files: &[InterfaceFile], pool: &DescriptorPool, out: &mut Vec<Diagnostic>) -> Model {
    let mut diags = Diags { out };

    // One application per file name; two files claiming the same application are a duplicate.
    let mut apps_seen: HashMap<&str, (&PathBuf, Pos)> = HashMap::new();
    for f in files {
        if let Some((file, pos)) = apps_seen.get(f.application.value.as_str()) {
            diags.push(
                &f.path,
                f.application.pos,
                Rule::Duplicate,
                format!(
                    "application `{}` is already declared at {}",
                    f.application.value,
                    at(&f.path, file, *pos)
                ),
            );
        } else {
            apps_seen.insert(&f.application.value, (&f.path, f.application.pos));
        }
    }

    // Entries that pass the per-entry rules, with their normalised type and Rust path.
    struct Good<'a> {
        file: &'a PathBuf,
        app: &'a str,
        entry: &'a Entry,
        type_name: String,
        rust_type: Vec<String>,
        /// The entry's `extension:` (kind, vehicle, base field numbers), checked.
        extension: Option<(ExtensionKind, String, Vec<u32>)>,
    }
    let mut good: Vec<Good> = Vec::new();
    let mut seen: HashMap<(&str, Layer, Direction, &str, &str), Pos> = HashMap::new();
    for f in files {
        for e in &f.entries {
            let mut ok = true;
            if !valid_group_name(&e.group.value) {
                diags.push(
                    &f.path,
                    e.group.pos,
                    Rule::InvalidName,
                    format!(
                        "invalid group name `{}`: expected `::`-separated segments of letters, digits and `_`",
                        e.group.value
                    ),
                );
                ok = false;
            }
            if !valid_actor_name(&e.actor.value) {
                diags.push(
                    &f.path,
                    e.actor.pos,
                    Rule::InvalidName,
                    format!(
                        "invalid actor name `{}`: expected UpperCamelCase letters and digits",
                        e.actor.value
                    ),
                );
                ok = false;
            }
            let type_name = e.type_name.value.trim_start_matches('.').to_string();
            let rust_type = match pool.get_message_by_name(&type_name) {
                Some(msg) => rust_path(&msg),
                None => {
                    let hint = if pool.get_enum_by_name(&type_name).is_some() {
                        " (it is an enum; a group carries a message)".to_string()
                    } else {
                        let similar = similar_messages(pool, &type_name);
                        if similar.is_empty() {
                            " (not defined by any .proto under interface_yaml/proto)".to_string()
                        } else {
                            format!(" (did you mean {}?)", similar.join(" or "))
                        }
                    };
                    diags.push(
                        &f.path,
                        e.type_name.pos,
                        Rule::UnknownType,
                        format!("unknown message type `{}`{hint}", e.type_name.value),
                    );
                    ok = false;
                    Vec::new()
                }
            };
            let key = (
                f.application.value.as_str(),
                e.layer,
                e.direction,
                e.group.value.as_str(),
                e.actor.value.as_str(),
            );
            if let Some(first) = seen.get(&key) {
                diags.push(
                    &f.path,
                    e.pos,
                    Rule::Duplicate,
                    format!(
                        "duplicate declaration: actor `{}` already {} `{}` in layer `{}` of application `{}` (line {})",
                        e.actor.value,
                        e.direction.key(),
                        e.group.value,
                        e.layer.key(),
                        f.application.value,
                        first.line
                    ),
                );
                continue;
            }
            seen.insert(key, e.pos);
            let extension = match &e.extension {
                None => None,
                Some(x) => match check_extension(f, e, x, &type_name, pool) {
                    Ok(ext) => Some(ext),
                    Err(message) => {
                        diags.push(&f.path, x.pos, Rule::Extension, message);
                        ok = false;
                        None
                    }
                },
            };
            if ok {
                good.push(Good {
                    file: &f.path,
                    app: &f.application.value,
                    entry: e,
                    type_name,
                    rust_type,
                    extension,
                });
            }
        }
    }

    // One type per group: the first publication fixes it; without publisher, the first subscription.
    struct Decided<'a> {
        type_name: String,
        rust_type: Vec<String>,
        file: &'a PathBuf,
        pos: Pos,
        actor: &'a str,
        by_publisher: bool,
    }
    let mut decided: BTreeMap<&str, Decided> = BTreeMap::new();
    let mut consistent = vec![true; good.len()];
    for direction in [Direction::Publishes, Direction::Subscribes] {
        for (i, g) in good.iter().enumerate() {
            if g.entry.direction != direction {
                continue;
            }
            let group = g.entry.group.value.as_str();
            match decided.get(group) {
                None => {
                    decided.insert(
                        group,
                        Decided {
                            type_name: g.type_name.clone(),
                            rust_type: g.rust_type.clone(),
                            file: g.file,
                            pos: g.entry.type_name.pos,
                            actor: &g.entry.actor.value,
                            by_publisher: direction == Direction::Publishes,
                        },
                    );
                }
                Some(d) if d.type_name != g.type_name => {
                    consistent[i] = false;
                    if direction == Direction::Subscribes && d.by_publisher {
                        diags.push(
                            g.file,
                            g.entry.type_name.pos,
                            Rule::TypeMismatch,
                            format!(
                                "actor `{}` subscribes `{group}` as `{}`, but its publisher `{}` publishes `{}` ({})",
                                g.entry.actor.value,
                                g.type_name,
                                d.actor,
                                d.type_name,
                                at(g.file, d.file, d.pos)
                            ),
                        );
                    } else {
                        diags.push(
                            g.file,
                            g.entry.type_name.pos,
                            Rule::TwoTypes,
                            format!(
                                "group `{group}` carries two types: `{}` here and `{}` ({})",
                                g.type_name,
                                d.type_name,
                                at(g.file, d.file, d.pos)
                            ),
                        );
                    }
                }
                Some(_) => {}
            }
        }
    }

    // Groups: widest layer, publishers and subscribers in declaration order, no repeats.
    let mut groups: Vec<GroupModel> = Vec::new();
    let mut group_index: HashMap<&str, usize> = HashMap::new();
    for (name, d) in &decided {
        group_index.insert(name, groups.len());
        groups.push(GroupModel {
            name: name.to_string(),
            type_name: d.type_name.clone(),
            rust_type: d.rust_type.clone(),
            layer: Layer::Interthread,
            publishers: Vec::new(),
            subscribers: Vec::new(),
            const_name: name.replace("::", "_").to_uppercase(),
        });
    }
    let mut const_names: HashMap<String, usize> = HashMap::new();
    for (i, g) in groups.iter().enumerate() {
        if let Some(&j) = const_names.get(&g.const_name) {
            let d = &decided[groups[j].name.as_str()];
            diags.push(
                d.file,
                d.pos,
                Rule::NameCollision,
                format!(
                    "groups `{}` and `{}` both generate the constant `{}`",
                    groups[j].name, g.name, g.const_name
                ),
            );
        } else {
            const_names.insert(g.const_name.clone(), i);
        }
    }

    let mut actors: BTreeMap<&str, ActorModel> = BTreeMap::new();
    let mut extensions: Vec<ExtensionModel> = Vec::new();
    // Where each actor's generated identifier came from, to name both sides of a collision.
    let mut idents: HashMap<(&str, Direction, String), (usize, &PathBuf, Pos)> = HashMap::new();
    for (i, g) in good.iter().enumerate() {
        if !consistent[i] {
            continue;
        }
        let e = g.entry;
        let Some(&gi) = group_index.get(e.group.value.as_str()) else {
            continue;
        };
        let group = &mut groups[gi];
        group.layer = group.layer.max(e.layer);
        let list = match e.direction {
            Direction::Publishes => &mut group.publishers,
            Direction::Subscribes => &mut group.subscribers,
        };
        if !list.contains(&e.actor.value) {
            list.push(e.actor.value.clone());
        }
        let actor = actors.entry(&e.actor.value).or_insert_with(|| ActorModel {
            name: e.actor.value.clone(),
            publishes: Vec::new(),
            subscribes: Vec::new(),
        });
        let seg = last_segment(&e.group.value);
        let (ports, ident, what) = match e.direction {
            Direction::Publishes => (
                &mut actor.publishes,
                seg.to_snake_case(),
                "publish method `publish_",
            ),
            Direction::Subscribes => (
                &mut actor.subscribes,
                seg.to_upper_camel_case(),
                "inbox variant `",
            ),
        };
        if ports.iter().any(|p| p.group == gi) {
            continue;
        }
        match idents.get(&(e.actor.value.as_str(), e.direction, ident.clone())) {
            Some((other, file, pos)) => {
                diags.push(
                    g.file,
                    e.group.pos,
                    Rule::NameCollision,
                    format!(
                        "actor `{}`: groups `{}` and `{}` ({}) both generate the {what}{ident}`; rename one group's last segment",
                        e.actor.value,
                        e.group.value,
                        good_group_name(&groups, *other),
                        at(g.file, file, *pos)
                    ),
                );
            }
            None => {
                idents.insert(
                    (e.actor.value.as_str(), e.direction, ident.clone()),
                    (gi, g.file, e.group.pos),
                );
                let extension = g.extension.as_ref().map(|(kind, vehicle, base_fields)| {
                    extensions.push(ExtensionModel {
                        group: gi,
                        kind: *kind,
                        vehicle: vehicle.clone(),
                        actor: e.actor.value.clone(),
                        base_fields: base_fields.clone(),
                    });
                    extensions.len() - 1
                });
                ports.push(Port {
                    group: gi,
                    ident,
                    extension,
                });
            }
        }
    }

    let mut applications: Vec<ApplicationModel> = files
        .iter()
        .map(|f| ApplicationModel {
            name: f.application.value.clone(),
            file: f.path.clone(),
            entries: Vec::new(),
        })
        .collect();
    for g in &good {
        let Some(app) = applications.iter_mut().find(|a| a.name == g.app) else {
            continue;
        };
        let layer = group_index
            .get(g.entry.group.value.as_str())
            .map_or(g.entry.layer, |&i| groups[i].layer);
        app.entries.push((
            layer,
            g.entry.direction,
            g.entry.group.value.clone(),
            g.type_name.clone(),
            g.entry.actor.value.clone(),
        ));
    }
    applications.sort_by(|a, b| a.name.cmp(&b.name));

    // Sorted by group, and the ports' indices with them.
    let mut order: Vec<usize> = (0..extensions.len()).collect();
    order.sort_by(|&a, &b| {
        (&groups[extensions[a].group].name, &extensions[a].actor)
            .cmp(&(&groups[extensions[b].group].name, &extensions[b].actor))
    });
    let mut new_index = vec![0; extensions.len()];
    for (new, &old) in order.iter().enumerate() {
        new_index[old] = new;
    }
    let extensions: Vec<ExtensionModel> = order.iter().map(|&i| extensions[i].clone()).collect();
    let mut actors: Vec<ActorModel> = actors.into_values().collect();
    for a in &mut actors {
        for p in a.publishes.iter_mut().chain(a.subscribes.iter_mut()) {
            if let Some(x) = p.extension.as_mut() {
                *x = new_index[*x];
            }
        }
    }

    Model {
        applications,
        groups,
        actors,
        extensions,
    }
}

/// The rules of an `extension:` entry: a known kind, in the direction and layer it implies, in a
/// file that names its `vehicle:`, on a type that mirrors the message the kind extends (every
/// base field present with its number, type and label). The kind, the vehicle and the base's
/// field numbers, or the message saying what is wrong.
fn check_extension(
    f: &InterfaceFile,
    e: &Entry,
    x: &crate::yaml::Located,
    type_name: &str,
    pool: &DescriptorPool,
) -> Result<(ExtensionKind, String, Vec<u32>), String> {
    let Some(kind) = ExtensionKind::ALL.into_iter().find(|k| k.key() == x.value) else {
        let known: Vec<String> = ExtensionKind::ALL
            .iter()
            .map(|k| format!("`{}`", k.key()))
            .collect();
        return Err(format!(
            "unknown extension kind `{}` (expected one of {})",
            x.value,
            known.join(", ")
        ));
    };
    if e.direction != kind.direction() {
        return Err(format!(
            "extension `{}` is declared under `{}`, but the interface {} it",
            kind.key(),
            e.direction.key(),
            if kind.direction() == Direction::Publishes {
                "publishes"
            } else {
                "subscribes to"
            }
        ));
    }
    if e.layer != Layer::Interprocess {
        return Err(format!(
            "extension `{}` must be `interprocess`: a helm in another process uses it",
            kind.key()
        ));
    }
    let Some(vehicle) = f.vehicle.as_ref().filter(|v| !v.value.is_empty()) else {
        return Err(
            "an `extension:` entry needs the file's `vehicle:` (the vehicle's name in refusals)"
                .to_string(),
        );
    };
    let base = pool
        .get_message_by_name(kind.base())
        .ok_or_else(|| format!("the base message `{}` is not compiled", kind.base()))?;
    // An unknown type was reported already; no second message about it.
    let Some(mirror) = pool.get_message_by_name(type_name) else {
        return Ok((kind, vehicle.value.clone(), Vec::new()));
    };
    let mut base_fields = Vec::new();
    for bf in base.fields() {
        let same = mirror.get_field(bf.number()).is_some_and(|mf| {
            mf.name() == bf.name()
                && mf.cardinality() == bf.cardinality()
                && kind_name(&mf.kind()) == kind_name(&bf.kind())
        });
        if !same {
            return Err(format!(
                "`{type_name}` is not a mirror of `{}`: field {} `{}` must be there with the same \
                 number, name, type and label (a mirror has every base field and adds its own)",
                kind.base(),
                bf.number(),
                bf.name()
            ));
        }
        base_fields.push(bf.number());
    }
    Ok((kind, vehicle.value.clone(), base_fields))
}

fn kind_name(k: &prost_reflect::Kind) -> String {
    match k {
        prost_reflect::Kind::Message(m) => m.full_name().to_string(),
        prost_reflect::Kind::Enum(en) => en.full_name().to_string(),
        other => format!("{other:?}"),
    }
}

fn good_group_name(groups: &[GroupModel], i: usize) -> &str {
    groups.get(i).map_or("?", |g| g.name.as_str())
}

/// Messages the user may have meant: same short name in another package, or a full name within a
/// few typos.
fn similar_messages(pool: &DescriptorPool, wanted: &str) -> Vec<String> {
    let short = wanted.rsplit('.').next().unwrap_or(wanted);
    let mut similar: Vec<String> = pool
        .all_messages()
        .filter(|m| m.name() == short || edit_distance(m.full_name(), wanted) <= 3)
        .map(|m| format!("`{}`", m.full_name()))
        .collect();
    similar.sort();
    similar.dedup();
    similar
}

fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut cur = vec![i + 1; b.len() + 1];
        for (j, cb) in b.iter().enumerate() {
            let cost = usize::from(ca != *cb);
            cur[j + 1] = (prev[j] + cost).min(prev[j + 1] + 1).min(cur[j] + 1);
        }
        prev = cur;
    }
    prev[b.len()]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn edit_distance_counts_typos() {
        assert_eq!(edit_distance("NodeStatus", "NodeStatus"), 0);
        assert_eq!(edit_distance("NodeStatus", "NodeStatsu"), 2);
        assert_eq!(edit_distance("abc", ""), 3);
    }

    #[test]
    fn names() {
        assert!(valid_group_name("goby::middleware::frontseat::node_status"));
        assert!(!valid_group_name("frontseat::sim::ground-truth"));
        assert!(!valid_group_name("a::::b"));
        assert!(valid_actor_name("FrontSeatInterface"));
        assert!(!valid_actor_name("front_seat"));
        assert_eq!(last_segment("a::b::c"), "c");
    }
}
