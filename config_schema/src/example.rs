//! Renders the example config by walking the schemars schema (for structure, descriptions,
//! enum values and examples) alongside the serialized `T::default()` (for the values).
//!
//! Walking the schema rather than the value is what lets unset optional fields and sections
//! still appear, commented out, with their descriptions.

use std::collections::BTreeSet;

use serde_json::{Map, Value};

use crate::ServiceConfig;

const WIDTH: usize = 98;

pub(crate) fn render<T: ServiceConfig>() -> String {
    let schema = schemars::schema_for!(T);
    let root = schema.as_value();
    let defaults = serde_json::to_value(T::default()).unwrap_or(Value::Null);
    let mut w = Writer {
        out: String::new(),
        defs: root.get("$defs").and_then(Value::as_object),
    };
    let service = T::SERVICE;
    w.comment(&format!("frontseat {service} configuration (TOML)."), "");
    if let Some(d) = root.get("description").and_then(Value::as_str) {
        w.comment(d, "");
    }
    w.out.push_str("#\n");
    w.comment(
        "Every setting is shown with its default value, after its description and unit. \
         Settings and sections that are off by default are commented out with a '#' directly \
         before the key or [table] header: remove that '#' (from the header and each key) to turn \
         them on.",
        "",
    );
    w.comment(
        &format!(
            "Check a file with `frontseat {service} --check -c FILE`; \
             the JSON Schema is printed by `frontseat {service} --schema`."
        ),
        "",
    );
    w.table(&[], root, defaults.as_object(), false, None);
    w.out
}

struct Writer<'a> {
    out: String,
    defs: Option<&'a Map<String, Value>>,
}

enum Sub<'a> {
    Table(&'a Value),
    Array(&'a Value),
}

impl<'a> Writer<'a> {
    /// Follows `$ref` and unwraps `Option<T>` (anyOf/oneOf with a null branch).
    fn resolve(&self, s: &'a Value) -> &'a Value {
        let target = s
            .get("$ref")
            .and_then(Value::as_str)
            .and_then(|r| r.strip_prefix("#/$defs/"))
            .and_then(|name| self.defs?.get(name));
        if let Some(d) = target {
            return self.resolve(d);
        }
        for key in ["anyOf", "oneOf"] {
            if let Some(branches) = s.get(key).and_then(Value::as_array) {
                let non_null: Vec<&Value> = branches
                    .iter()
                    .filter(|b| b.get("type").and_then(Value::as_str) != Some("null"))
                    .collect();
                if non_null.len() == 1 && branches.len() == 2 {
                    return self.resolve(non_null[0]);
                }
            }
        }
        s
    }

    fn is_table(s: &Value) -> bool {
        s.get("properties").is_some_and(Value::is_object)
    }

    fn sub_kind(&self, s: &'a Value) -> Option<Sub<'a>> {
        if Self::is_table(s) {
            return Some(Sub::Table(s));
        }
        let items = self.resolve(s.get("items")?);
        Self::is_table(items).then_some(Sub::Array(items))
    }

    /// Description of a property: its own doc comment, else its type's.
    fn describe(prop: &Value, resolved: &Value) -> String {
        let text = |v: &Value, k: &str| v.get(k).and_then(Value::as_str).map(str::to_owned);
        let title = text(prop, "title").or_else(|| text(resolved, "title"));
        let desc = text(prop, "description").or_else(|| text(resolved, "description"));
        match (title, desc) {
            (Some(t), Some(d)) => format!("{t}. {d}"),
            (Some(t), None) => t,
            (None, Some(d)) => d,
            (None, None) => String::new(),
        }
    }

    /// "One of: …" for enums, one line per variant when the variants are documented.
    fn enum_values(resolved: &Value) -> Option<String> {
        if let Some(values) = resolved.get("enum").and_then(Value::as_array) {
            let names: Vec<String> = values.iter().map(plain).collect();
            return Some(format!("One of: {}.", names.join(", ")));
        }
        let branches = resolved.get("oneOf").and_then(Value::as_array)?;
        let mut lines = vec!["One of:".to_owned()];
        for b in branches {
            let value = b
                .get("const")
                .or_else(|| b.get("enum").and_then(|e| e.get(0)))?;
            match b.get("description").and_then(Value::as_str) {
                Some(d) => lines.push(format!("  {}: {d}", plain(value))),
                None => lines.push(format!("  {}", plain(value))),
            }
        }
        Some(lines.join("\n"))
    }

    /// Writes `text` as `# ` comment lines, wrapped; `\n` in `text` starts a new line.
    fn comment(&mut self, text: &str, indent: &str) {
        for para in text.split("\n\n") {
            let mut any = false;
            for raw in para.split('\n') {
                // Doc-comment lines are soft-wrapped; only indented lines (enum lists) keep
                // their own line.
                let keep = raw.starts_with("  ");
                let words = glue_units(raw);
                let words: Vec<&str> = words.iter().map(String::as_str).collect();
                if words.is_empty() {
                    continue;
                }
                if any && !keep {
                    self.rewrap_append(&words, indent);
                } else {
                    let lead = if keep { "  " } else { "" };
                    self.out.push_str(&format!("{indent}# {lead}"));
                    self.put_words(&words, indent, lead.len());
                }
                any = true;
            }
        }
    }

    fn put_words(&mut self, words: &[&str], indent: &str, used: usize) {
        let mut len = indent.len() + 2 + used;
        let mut first = true;
        for w in words {
            if !first && len + 1 + w.chars().count() > WIDTH {
                self.out.push('\n');
                self.out.push_str(&format!("{indent}# "));
                len = indent.len() + 2;
                first = true;
            }
            if !first {
                self.out.push(' ');
                len += 1;
            }
            self.out.push_str(w);
            len += w.chars().count();
            first = false;
        }
        self.out.push('\n');
    }

    /// Continues the previous comment line (a soft-wrapped doc line).
    fn rewrap_append(&mut self, words: &[&str], indent: &str) {
        if self.out.ends_with('\n') {
            self.out.pop();
        }
        let line_start = self.out.rfind('\n').map_or(0, |i| i + 1);
        let used = self.out[line_start..].chars().count();
        let mut len = used;
        for w in words {
            if len + 1 + w.chars().count() > WIDTH {
                self.out.push('\n');
                self.out.push_str(&format!("{indent}# "));
                len = indent.len() + 2;
            } else {
                self.out.push(' ');
                len += 1;
            }
            self.out.push_str(w);
            len += w.chars().count();
        }
        self.out.push('\n');
    }

    fn setting(&mut self, off: bool, text: &str) {
        if off {
            self.out.push('#');
        }
        self.out.push_str(text);
        self.out.push('\n');
    }

    /// One table's scalar keys, then its sub-tables and arrays of tables (TOML requires keys
    /// before sub-tables).
    fn table(
        &mut self,
        path: &[String],
        schema: &'a Value,
        values: Option<&Map<String, Value>>,
        off: bool,
        mut entry: Option<&mut BTreeSet<String>>,
    ) {
        let Some(props) = schema.get("properties").and_then(Value::as_object) else {
            return;
        };
        let mut subs = Vec::new();
        for (name, prop) in props {
            let resolved = self.resolve(prop);
            let value = values.and_then(|m| m.get(name)).filter(|v| !v.is_null());
            if let Some(kind) = self.sub_kind(resolved) {
                subs.push((name, prop, kind, value));
                continue;
            }
            // Array entries are examples: they show only the keys they set, and describe each
            // key once per array.
            let describe = match entry.as_deref_mut() {
                None => true,
                Some(seen) => {
                    if value.is_none() {
                        continue;
                    }
                    seen.insert(name.clone())
                }
            };
            if describe {
                self.out.push('\n');
                let mut text = Self::describe(prop, resolved);
                if let Some(e) = Self::enum_values(resolved) {
                    text = format!("{text}\n{e}");
                }
                match value {
                    Some(_) => self.comment(&text, ""),
                    None => self.comment(&format!("{text}\nUnset by default."), ""),
                }
            }
            match value {
                Some(v) => self.setting(off, &format!("{name} = {}", toml_value(v))),
                None => {
                    let ex = prop
                        .get("examples")
                        .and_then(|e| e.get(0))
                        .map_or_else(String::new, toml_value);
                    self.setting(true, &format!("{name} = {ex}"));
                }
            }
        }
        for (name, prop, kind, value) in subs {
            let mut full = path.to_vec();
            full.push(name.clone());
            let dotted = full.join(".");
            self.out.push('\n');
            match kind {
                Sub::Table(res) => {
                    let owned;
                    let (sub_off, sub_values) = match value {
                        Some(v) => (off, v.as_object()),
                        None => {
                            owned = defaults_of(res);
                            (true, Some(&owned))
                        }
                    };
                    let mut text = Self::describe(prop, res);
                    if sub_off && !off {
                        text.push_str(
                            "\nOff by default; remove the '#' before the lines below to turn it on.",
                        );
                    }
                    self.comment(&text, "");
                    self.setting(sub_off, &format!("[{dotted}]"));
                    self.table(&full, res, sub_values, sub_off, None);
                }
                Sub::Array(items) => {
                    let present = value.and_then(Value::as_array).filter(|a| !a.is_empty());
                    let (entries, entries_off) = match present {
                        Some(a) => (a.clone(), off),
                        None => (
                            prop.get("examples")
                                .and_then(|e| e.get(0))
                                .and_then(Value::as_array)
                                .cloned()
                                .unwrap_or_default(),
                            true,
                        ),
                    };
                    let mut text = Self::describe(prop, items);
                    if present.is_none() {
                        text.push_str("\nExample entries (remove the '#' to use them):");
                    }
                    self.comment(&text, "");
                    let mut seen = BTreeSet::new();
                    for (i, e) in entries.iter().enumerate() {
                        if i > 0 {
                            self.out.push('\n');
                        }
                        self.setting(entries_off, &format!("[[{dotted}]]"));
                        self.table(&full, items, e.as_object(), entries_off, Some(&mut seen));
                    }
                }
            }
        }
    }
}

/// The defaults schemars recorded per property, for a section that is absent by default.
fn defaults_of(schema: &Value) -> Map<String, Value> {
    schema
        .get("properties")
        .and_then(Value::as_object)
        .map(|props| {
            props
                .iter()
                .filter_map(|(k, p)| Some((k.clone(), p.get("default")?.clone())))
                .collect()
        })
        .unwrap_or_default()
}

/// A JSON value as a TOML value literal.
fn toml_value(v: &Value) -> String {
    match toml::Value::try_from(v) {
        Ok(t) => t.to_string(),
        Err(_) => v.to_string(),
    }
}

/// Enum values as written in TOML (quoted strings).
fn plain(v: &Value) -> String {
    toml_value(v)
}

/// Splits a line into words, keeping "Unit:" with the unit after it so a wrap never leaves a
/// dangling "Unit:" at a line end.
fn glue_units(line: &str) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for w in line.split_whitespace() {
        match out.last_mut() {
            Some(prev) if prev == "Unit:" => {
                prev.push(' ');
                prev.push_str(w);
            }
            _ => out.push(w.to_owned()),
        }
    }
    out
}
