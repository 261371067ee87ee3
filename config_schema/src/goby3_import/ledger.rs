//! The bookkeeping of one import: every field the file sets starts out to be placed, and each
//! rule moves it to a TOML setting (with the Goby3 field it came from), names it in an
//! "ignored" [`Note`], or refuses it; then the TOML text, every line commented with its origin
//! and the ignored fields listed at the end. Which field goes where is the rules' business.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use prost_reflect::{DynamicMessage, ReflectMessage, Value};

use super::text::{enum_fields, goby_text, leaves};
use crate::FieldError;

/// What became of one field of the .pb.cfg that has no setting of ours.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Note {
    /// Goby3's dotted path, extensions in brackets (`app.glog_config.tty_verbosity`).
    pub path: String,
    /// The value as the file gave it.
    pub value: String,
    /// Why it has no setting here.
    pub why: String,
}

/// One TOML setting and the Goby3 field it came from.
pub(super) struct Setting {
    pub(super) key: String,
    pub(super) value: toml::Value,
    pub(super) from: String,
}

/// The import in progress: the fields still to place, the settings by table, the notes.
pub(super) struct Import {
    pub(super) left: BTreeMap<String, Value>,
    /// Enum descriptors by path, for printing enum names.
    pub(super) enums: BTreeMap<String, prost_reflect::EnumDescriptor>,
    pub(super) tables: Vec<(String, Vec<Setting>)>,
    pub(super) ignored: Vec<Note>,
    pub(super) refused: Vec<FieldError>,
}

impl Import {
    pub(super) fn new(msg: &DynamicMessage) -> Self {
        let mut left = BTreeMap::new();
        leaves(msg, "", &mut left);
        let mut enums = BTreeMap::new();
        enum_fields(&msg.descriptor(), "", &mut enums, 0);
        Self {
            left,
            enums,
            tables: Vec::new(),
            ignored: Vec::new(),
            refused: Vec::new(),
        }
    }

    pub(super) fn text(&self, path: &str, v: &Value) -> String {
        goby_text(v, self.enums.get(path))
    }

    /// Takes a field out of the ones still to place.
    pub(super) fn take(&mut self, path: &str) -> Option<Value> {
        self.left.remove(path)
    }

    pub(super) fn set(
        &mut self,
        table: &str,
        key: &str,
        value: toml::Value,
        from: impl Into<String>,
    ) {
        let s = Setting {
            key: key.to_owned(),
            value,
            from: from.into(),
        };
        match self.tables.iter_mut().find(|(t, _)| t == table) {
            Some((_, list)) => {
                list.retain(|x| x.key != key);
                list.push(s);
            }
            None => self.tables.push((table.to_owned(), vec![s])),
        }
    }

    /// Moves `goby` (when the file sets it) to `key` in `table`, converted by [`to_toml`].
    pub(super) fn map(&mut self, goby: &str, table: &str, key: &str) {
        if let Some(v) = self.take(goby) {
            match self.to_toml(goby, &v) {
                Ok(t) => self.set(table, key, t, goby),
                Err(why) => self.refuse(goby, &v, why),
            }
        }
    }

    /// Every field still to place under `goby_prefix.` moved to the same name in `table`
    /// (Goby3's names are ours in the vehicle sections), sub-messages to sub-tables.
    pub(super) fn map_same_names(&mut self, goby_prefix: &str, table: &str) {
        let p = format!("{goby_prefix}.");
        let paths: Vec<String> = self
            .left
            .keys()
            .filter(|k| k.starts_with(&p))
            .cloned()
            .collect();
        for path in paths {
            let rest = &path[p.len()..];
            let (sub, key) = match rest.rsplit_once('.') {
                Some((sub, key)) => (format!("{table}.{sub}"), key.to_owned()),
                None => (table.to_owned(), rest.to_owned()),
            };
            self.map(&path, &sub, &key);
        }
    }

    pub(super) fn ignore(&mut self, goby: &str, why: &str) {
        if let Some(v) = self.take(goby) {
            let value = self.text(goby, &v);
            self.ignored.push(Note {
                path: goby.to_owned(),
                value,
                why: why.to_owned(),
            });
        }
    }

    /// Every field still to place under `goby_prefix` ignored for `why`.
    pub(super) fn ignore_all(&mut self, goby_prefix: &str, why: &str) {
        let paths: Vec<String> = self
            .left
            .keys()
            .filter(|k| *k == goby_prefix || k.starts_with(&format!("{goby_prefix}.")))
            .cloned()
            .collect();
        for p in paths {
            self.ignore(&p, why);
        }
    }

    pub(super) fn refuse(&mut self, goby: &str, v: &Value, why: String) {
        let value = self.text(goby, v);
        self.refused
            .push(FieldError::new(format!("(Goby3) {goby}"), value, why));
    }

    pub(super) fn to_toml(&self, path: &str, v: &Value) -> Result<toml::Value, String> {
        Ok(match v {
            Value::Bool(b) => toml::Value::Boolean(*b),
            Value::I32(x) => toml::Value::Integer(i64::from(*x)),
            Value::I64(x) => toml::Value::Integer(*x),
            Value::U32(x) => toml::Value::Integer(i64::from(*x)),
            Value::U64(x) => toml::Value::Integer(
                i64::try_from(*x).map_err(|_| "too large for a TOML integer".to_owned())?,
            ),
            Value::F32(x) => float(f64::from(*x))?,
            Value::F64(x) => float(*x)?,
            Value::String(s) => toml::Value::String(s.clone()),
            Value::EnumNumber(_) => toml::Value::String(self.text(path, v)),
            Value::List(items) => toml::Value::Array(
                items
                    .iter()
                    .map(|x| self.to_toml(path, x))
                    .collect::<Result<_, _>>()?,
            ),
            Value::Message(m) => {
                let mut t = toml::map::Map::new();
                for (f, fv) in m.fields() {
                    t.insert(f.name().to_owned(), self.to_toml(path, fv)?);
                }
                toml::Value::Table(t)
            }
            other => return Err(format!("unsupported value {other:?}")),
        })
    }

    /// The TOML text: top-level settings first, then each table, every line commented with
    /// its Goby3 field; the ignored fields listed at the end.
    pub(super) fn render(&self, header: &str) -> String {
        let mut out = String::new();
        let _ = writeln!(out, "{header}");
        let mut tables: Vec<&(String, Vec<Setting>)> = self.tables.iter().collect();
        // Top level first (TOML: keys after a [table] header belong to it).
        tables.sort_by_key(|(t, _)| !t.is_empty());
        for (table, settings) in tables {
            if !table.is_empty() {
                let _ = writeln!(out, "\n[{table}]");
            }
            for s in settings {
                let _ = writeln!(out, "{} = {}  # {}", s.key, inline(&s.value), s.from);
            }
        }
        if !self.ignored.is_empty() {
            let _ = writeln!(
                out,
                "\n# Set in the Goby3 file, with no setting here (ignored, named so nothing is \
                 dropped silently):"
            );
            for n in &self.ignored {
                let _ = writeln!(out, "#   {} = {}: {}", n.path, n.value, n.why);
            }
        }
        out
    }
}

fn float(x: f64) -> Result<toml::Value, String> {
    if x.is_finite() {
        Ok(toml::Value::Float(x))
    } else {
        Err("not a finite number".to_owned())
    }
}

/// A TOML value on one line (tables inline).
fn inline(v: &toml::Value) -> String {
    match v {
        toml::Value::Table(t) => {
            let items: Vec<String> = t
                .iter()
                .map(|(k, v)| format!("{k} = {}", inline(v)))
                .collect();
            format!("{{ {} }}", items.join(", "))
        }
        toml::Value::Array(a) => {
            let items: Vec<String> = a.iter().map(inline).collect();
            format!("[{}]", items.join(", "))
        }
        other => other.to_string(),
    }
}
