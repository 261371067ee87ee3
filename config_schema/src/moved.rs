//! A config from an older version: a key this version does not know where it stands, but has
//! under another table (a field that moved between versions, or a flat Goby3-style key) gets the
//! path where it lives now added to the "unknown field" error. The paths come from the config's
//! own JSON Schema, so a field that moves later is found without a table kept by hand.

use schemars::JsonSchema;

use crate::ConfigError;

/// Deepest nesting searched (the interface's deepest table is 4 levels; refs may cycle).
const MAX_DEPTH: usize = 8;
/// At most this many places are named.
const MAX_PLACES: usize = 3;

/// Adds "now at `a.b.key`" to an unknown-field parse error of `T` when `key` exists elsewhere.
pub(crate) fn explain<T: JsonSchema>(err: &mut ConfigError, text: &str, offset: Option<usize>) {
    let ConfigError::Parse { message, .. } = err else {
        return;
    };
    let Some(key) = unknown_key(message) else {
        return;
    };
    let here = offset.and_then(|o| table_at(text, o)).unwrap_or_default();
    let schema = serde_json::to_value(schemars::schema_for!(T)).unwrap_or_default();
    let mut places = Vec::new();
    walk(&schema, &schema, "", &key, 0, &mut places);
    let here_path = if here.is_empty() {
        key.clone()
    } else {
        format!("{here}.{key}")
    };
    places.retain(|p| *p != here_path);
    places.sort();
    places.dedup();
    // Nearest first: the place sharing most tables with where the key stands, then the shallowest
    // (a key written under [driver] most likely belongs under [driver.basic_simulator]).
    let shared = |p: &str| {
        p.split('.')
            .zip(here.split('.'))
            .take_while(|(a, b)| a == b)
            .count()
    };
    places.sort_by_key(|p| (std::cmp::Reverse(shared(p)), p.matches('.').count()));
    if places.is_empty() {
        return;
    }
    places.truncate(MAX_PLACES);
    let at = places
        .iter()
        .map(|p| format!("`{p}`"))
        .collect::<Vec<_>>()
        .join(" or ");
    let table = |p: &str| match p.rsplit_once('.') {
        Some((t, _)) => format!("[{t}]"),
        None => "the top level".to_string(),
    };
    message.push_str(&format!(
        ". This version has `{key}` at {at}: a config from an older version? Move it to {}",
        table(&places[0])
    ));
}

/// `key` of serde's "unknown field `key`, expected …".
fn unknown_key(message: &str) -> Option<String> {
    let rest = message.split("unknown field `").nth(1)?;
    let key = rest.split('`').next()?;
    (!key.is_empty()).then(|| key.to_string())
}

/// The `[table]` (or `[[table]]`) header in force at byte `offset`; "" at the top level.
fn table_at(text: &str, offset: usize) -> Option<String> {
    let before = text.get(..offset)?;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    // A header line itself (an unknown table) belongs to the table above it.
    Some(
        before[..line_start]
            .lines()
            .rev()
            .find_map(|l| {
                let l = l.trim();
                let inner = l.strip_prefix("[[").and_then(|r| r.split_once("]]"));
                let inner = inner.or_else(|| l.strip_prefix('[').and_then(|r| r.split_once(']')));
                inner.map(|(name, _)| name.trim().to_owned())
            })
            .unwrap_or_default(),
    )
}

/// Every dotted path under `node` whose last part is `key`.
fn walk(
    root: &serde_json::Value,
    node: &serde_json::Value,
    prefix: &str,
    key: &str,
    depth: usize,
    out: &mut Vec<String>,
) {
    if depth > MAX_DEPTH {
        return;
    }
    let node = resolve(root, node);
    if let Some(props) = node.get("properties").and_then(|p| p.as_object()) {
        for (name, sub) in props {
            let path = if prefix.is_empty() {
                name.clone()
            } else {
                format!("{prefix}.{name}")
            };
            if name == key {
                out.push(path.clone());
            }
            walk(root, sub, &path, key, depth + 1, out);
        }
    }
    for combinator in ["anyOf", "oneOf", "allOf"] {
        if let Some(alts) = node.get(combinator).and_then(|a| a.as_array()) {
            for alt in alts {
                walk(root, alt, prefix, key, depth + 1, out);
            }
        }
    }
    if let Some(items) = node.get("items") {
        walk(root, items, prefix, key, depth + 1, out);
    }
}

/// Follows a local `$ref` (`#/$defs/Name`).
fn resolve<'a>(root: &'a serde_json::Value, node: &'a serde_json::Value) -> &'a serde_json::Value {
    match node.get("$ref").and_then(|r| r.as_str()) {
        Some(r) => r
            .strip_prefix('#')
            .and_then(|ptr| root.pointer(ptr))
            .unwrap_or(node),
        None => node,
    }
}
