//! Reading one interface yaml file into located declarations.
//!
//! The shape is Goby3's: `application:`, then layers (`interprocess:` / `interthread:`), each with
//! `publishes:` / `subscribes:` lists of `{group, type, actor}`. A vehicle's own file
//! (`interface_yaml/vehicles/`) adds `vehicle:` (its name in refusals) and marks its extension
//! groups with `extension:` (how the interface gates them, see model.rs). Every map is read with a
//! hand-written visitor that records unknown keys with their position instead of failing on the
//! first one, so that one build reports every mistake in the file with its line.

use std::fmt;
use std::path::{Path, PathBuf};

use serde::Deserialize;
use serde::de::{self, IgnoredAny, MapAccess, Visitor};
use serde_saphyr::Spanned;

use crate::error::{Diagnostic, Rule};

/// A line/column in a yaml file (1-based).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct Pos {
    pub line: u64,
    pub column: u64,
}

/// A string value and where it is.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Located {
    pub value: String,
    pub pos: Pos,
}

/// The two layers we implement; Goby3's `intervehicle` is not one of them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Layer {
    Interthread,
    Interprocess,
}

impl Layer {
    pub fn key(self) -> &'static str {
        match self {
            Layer::Interthread => "interthread",
            Layer::Interprocess => "interprocess",
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Direction {
    Publishes,
    Subscribes,
}

impl Direction {
    pub fn key(self) -> &'static str {
        match self {
            Direction::Publishes => "publishes",
            Direction::Subscribes => "subscribes",
        }
    }
}

/// One `{group, type, actor}` entry, all three present.
#[derive(Clone, Debug)]
pub struct Entry {
    pub pos: Pos,
    pub layer: Layer,
    pub direction: Direction,
    pub group: Located,
    pub type_name: Located,
    pub actor: Located,
    /// `extension:` — a vehicle extension group and how it is gated.
    pub extension: Option<Located>,
}

/// One yaml file, after the shape checks.
#[derive(Clone, Debug)]
pub struct InterfaceFile {
    pub path: PathBuf,
    pub application: Located,
    /// `vehicle:` — the vehicle a file of extension groups belongs to.
    pub vehicle: Option<Located>,
    pub entries: Vec<Entry>,
}

/// Reads and shape-checks one file. Shape problems are pushed to `diags`; the file is returned when
/// it has an application name (possibly with fewer entries than written, if some were malformed).
pub fn read_file(path: &Path, text: &str, diags: &mut Vec<Diagnostic>) -> Option<InterfaceFile> {
    let mut diag = |pos: Pos, rule: Rule, message: String| {
        diags.push(Diagnostic {
            file: path.to_path_buf(),
            line: pos.line,
            column: pos.column,
            rule,
            message,
        })
    };
    let start = Pos { line: 1, column: 1 };
    if text.lines().all(|l| {
        let l = l.trim();
        l.is_empty() || l.starts_with('#') || l == "---"
    }) {
        diag(
            start,
            Rule::MissingField,
            "missing `application:` (the file declares nothing)".into(),
        );
        return None;
    }
    let top: TopLevel = match serde_saphyr::from_str(text) {
        Ok(top) => top,
        Err(e) => {
            let pos = e
                .location()
                .map(|l| Pos {
                    line: l.line(),
                    column: l.column(),
                })
                .unwrap_or(start);
            diag(pos, Rule::Syntax, e.without_snippet().to_string());
            return None;
        }
    };
    for key in &top.unknown {
        if key.value.starts_with("inter") {
            diag(
                key.pos,
                Rule::UnknownLayer,
                format!(
                    "unknown layer `{}` (expected `interprocess` or `interthread`)",
                    key.value
                ),
            );
        } else {
            diag(
                key.pos,
                Rule::UnknownKey,
                format!(
                    "unknown key `{}` (expected `application`, `vehicle`, `interprocess` or `interthread`)",
                    key.value
                ),
            );
        }
    }
    let mut entries = Vec::new();
    let mut seen_layers: Vec<(Layer, Pos)> = Vec::new();
    for (layer, key_pos, body) in top.layers {
        if let Some((_, first)) = seen_layers.iter().find(|(l, _)| *l == layer) {
            diag(
                key_pos,
                Rule::Duplicate,
                format!(
                    "layer `{}` declared twice in this file (first at line {})",
                    layer.key(),
                    first.line
                ),
            );
            continue;
        }
        seen_layers.push((layer, key_pos));
        for key in &body.unknown {
            diag(
                key.pos,
                Rule::UnknownKey,
                format!(
                    "unknown key `{}` in layer `{}` (expected `publishes` or `subscribes`)",
                    key.value,
                    layer.key()
                ),
            );
        }
        for (direction, list) in [
            (Direction::Publishes, body.publishes),
            (Direction::Subscribes, body.subscribes),
        ] {
            for raw in list {
                let pos = pos_of(&raw.referenced);
                let raw = raw.value;
                for key in &raw.unknown {
                    diag(
                        key.pos,
                        Rule::UnknownKey,
                        format!(
                            "unknown key `{}` in a `{}` entry (expected `group`, `type`, `actor`, `extension`)",
                            key.value,
                            direction.key()
                        ),
                    );
                }
                let mut missing = Vec::new();
                for (name, field) in [
                    ("group", &raw.group),
                    ("type", &raw.type_name),
                    ("actor", &raw.actor),
                ] {
                    if field.as_ref().is_none_or(|f| f.value.trim().is_empty()) {
                        missing.push(name);
                    }
                }
                if !missing.is_empty() {
                    let list = missing
                        .iter()
                        .map(|m| format!("`{m}`"))
                        .collect::<Vec<_>>()
                        .join(", ");
                    diag(
                        pos,
                        Rule::MissingField,
                        format!(
                            "missing field {list} in a `{}` entry of layer `{}`",
                            direction.key(),
                            layer.key()
                        ),
                    );
                    continue;
                }
                if let (Some(group), Some(type_name), Some(actor)) =
                    (raw.group, raw.type_name, raw.actor)
                {
                    entries.push(Entry {
                        pos,
                        layer,
                        direction,
                        group: trimmed(group),
                        type_name: trimmed(type_name),
                        actor: trimmed(actor),
                        extension: raw.extension.map(trimmed),
                    });
                }
            }
        }
    }
    match top.application {
        Some(app) if !app.value.trim().is_empty() => Some(InterfaceFile {
            path: path.to_path_buf(),
            application: trimmed(app),
            vehicle: top.vehicle.map(trimmed),
            entries,
        }),
        Some(app) => {
            diag(
                app.pos,
                Rule::MissingField,
                "`application:` is empty".into(),
            );
            None
        }
        None => {
            diag(
                top.first_key.unwrap_or(start),
                Rule::MissingField,
                "missing `application:` (every interface file names its application)".into(),
            );
            None
        }
    }
}

fn trimmed(l: Located) -> Located {
    Located {
        value: l.value.trim().to_string(),
        pos: l.pos,
    }
}

fn pos_of(loc: &serde_saphyr::Location) -> Pos {
    Pos {
        line: loc.line(),
        column: loc.column(),
    }
}

fn located(s: Spanned<String>) -> Located {
    Located {
        pos: pos_of(&s.referenced),
        value: s.value,
    }
}

struct TopLevel {
    application: Option<Located>,
    vehicle: Option<Located>,
    layers: Vec<(Layer, Pos, LayerBody)>,
    unknown: Vec<Located>,
    first_key: Option<Pos>,
}

impl<'de> Deserialize<'de> for TopLevel {
    fn deserialize<D: de::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_map(TopVisitor)
    }
}

struct TopVisitor;

impl<'de> Visitor<'de> for TopVisitor {
    type Value = TopLevel;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a map with `application` and layers `interprocess` / `interthread`")
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<TopLevel, A::Error> {
        let mut top = TopLevel {
            application: None,
            vehicle: None,
            layers: Vec::new(),
            unknown: Vec::new(),
            first_key: None,
        };
        while let Some(key) = map.next_key::<Spanned<String>>()? {
            let key = located(key);
            top.first_key.get_or_insert(key.pos);
            match key.value.as_str() {
                "application" => {
                    top.application = Some(located(map.next_value::<Spanned<String>>()?));
                }
                "vehicle" => {
                    top.vehicle = Some(located(map.next_value::<Spanned<String>>()?));
                }
                "interprocess" | "interthread" => {
                    let layer = if key.value == "interprocess" {
                        Layer::Interprocess
                    } else {
                        Layer::Interthread
                    };
                    let body = map.next_value::<Option<LayerBody>>()?.unwrap_or_default();
                    top.layers.push((layer, key.pos, body));
                }
                _ => {
                    map.next_value::<IgnoredAny>()?;
                    top.unknown.push(key);
                }
            }
        }
        Ok(top)
    }
}

#[derive(Default)]
struct LayerBody {
    publishes: Vec<Spanned<RawEntry>>,
    subscribes: Vec<Spanned<RawEntry>>,
    unknown: Vec<Located>,
}

impl<'de> Deserialize<'de> for LayerBody {
    fn deserialize<D: de::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_map(LayerVisitor)
    }
}

struct LayerVisitor;

impl<'de> Visitor<'de> for LayerVisitor {
    type Value = LayerBody;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a map with `publishes` and/or `subscribes` lists")
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<LayerBody, A::Error> {
        let mut body = LayerBody::default();
        while let Some(key) = map.next_key::<Spanned<String>>()? {
            let key = located(key);
            let list = match key.value.as_str() {
                "publishes" => &mut body.publishes,
                "subscribes" => &mut body.subscribes,
                _ => {
                    map.next_value::<IgnoredAny>()?;
                    body.unknown.push(key);
                    continue;
                }
            };
            let entries = map
                .next_value::<Option<Vec<Spanned<RawEntry>>>>()?
                .unwrap_or_default();
            list.extend(entries);
        }
        Ok(body)
    }
}

struct RawEntry {
    group: Option<Located>,
    type_name: Option<Located>,
    actor: Option<Located>,
    extension: Option<Located>,
    unknown: Vec<Located>,
}

impl<'de> Deserialize<'de> for RawEntry {
    fn deserialize<D: de::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_map(EntryVisitor)
    }
}

struct EntryVisitor;

impl<'de> Visitor<'de> for EntryVisitor {
    type Value = RawEntry;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a map with `group`, `type` and `actor`")
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<RawEntry, A::Error> {
        let mut entry = RawEntry {
            group: None,
            type_name: None,
            actor: None,
            extension: None,
            unknown: Vec::new(),
        };
        while let Some(key) = map.next_key::<Spanned<String>>()? {
            let key = located(key);
            let slot = match key.value.as_str() {
                "group" => &mut entry.group,
                "type" => &mut entry.type_name,
                "actor" => &mut entry.actor,
                "extension" => &mut entry.extension,
                _ => {
                    map.next_value::<IgnoredAny>()?;
                    entry.unknown.push(key);
                    continue;
                }
            };
            let value = map.next_value::<Option<Spanned<String>>>()?.map(located);
            *slot = value;
        }
        Ok(entry)
    }
}
