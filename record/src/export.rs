//! `frontseat log export`: one group's messages as CSV or JSON Lines, decoded by reflection with
//! the schema stored in the file itself (so old files export even after our .proto files move
//! on). CSV columns are the message's fields flattened by path (`global_fix.lat`); repeated
//! fields and maps go into one cell as JSON.

use std::collections::HashMap;
use std::io::{Read, Write};

use prost_reflect::{DynamicMessage, Kind, MessageDescriptor, SerializeOptions};
use serde_json::Value;

use crate::reader::{ReadError, Recording};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Csv,
    Json,
}

#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    #[error(transparent)]
    Read(#[from] ReadError),
    #[error("writing the export: {0}")]
    Write(std::io::Error),
    #[error(transparent)]
    Output(#[from] crate::output::OutputError),
    #[error("no message of group `{0}` in the file")]
    NoSuchGroup(String),
    #[error(
        "the type {0} has more than {MAX_COLUMNS} fields even unflattened: too wide for CSV (--format json)"
    )]
    TooWide(String),
}

impl ExportError {
    /// Whether the request itself was refused (exit 2) rather than failed.
    pub fn is_usage(&self) -> bool {
        matches!(self, Self::Output(o) if o.is_usage())
    }
}

/// What an export did.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Exported {
    pub rows: u64,
    /// Messages whose schema or bytes did not decode (counted, skipped).
    pub undecodable: u64,
    pub truncated: Option<String>,
    /// The CSV columns (0 for JSON).
    pub columns: usize,
    /// Sub-messages written as one JSON cell rather than flattened: a type that contains
    /// itself, or flattening past [`MAX_COLUMNS`].
    pub json_cells: usize,
    /// What the reader skipped for its limits ([`Recording::limits_note`]).
    pub limits_note: Option<String>,
}

/// Deepest message nesting flattened into columns; deeper goes into a JSON cell.
const MAX_DEPTH: usize = 8;
/// Most CSV columns of one export: a type whose flattening is wider (a chain of types each
/// holding many of the next one) keeps its sub-messages as JSON cells instead, so neither the
/// header nor the work per row grows with what a schema declares.
pub const MAX_COLUMNS: usize = 2048;

/// [`export`] into the file `path`, or standard output when None. The file is written beside
/// its target and renamed at the end ([`crate::output`]); an existing file is replaced only
/// with `force`, and never when it is `input` itself.
pub fn export_to<R: Read>(
    rec: Recording<R>,
    group: &str,
    format: Format,
    path: Option<&std::path::Path>,
    force: bool,
    input: &std::path::Path,
) -> Result<Exported, ExportError> {
    match path {
        Some(p) => {
            let mut out = crate::output::Output::create(p, force, &[input])?;
            let done = export(rec, group, format, &mut out)?;
            out.commit()?;
            Ok(done)
        }
        None => {
            let mut w = std::io::BufWriter::new(std::io::stdout().lock());
            let r = export(rec, group, format, &mut w);
            // A write error at the end (a closed pipe) is the export's error too.
            w.flush().map_err(ExportError::Write).and(r)
        }
    }
}

/// Writes every message of `group` to `out`.
pub fn export<R: Read, W: Write>(
    mut rec: Recording<R>,
    group: &str,
    format: Format,
    out: &mut W,
) -> Result<Exported, ExportError> {
    let mut pools: HashMap<u16, Option<MessageDescriptor>> = HashMap::new();
    // Per channel id: whether it is the group asked for, decided once per channel definition
    // (keyed by the topic's allocation), so a long topic costs nothing per message.
    let mut wanted: HashMap<u16, (std::sync::Arc<str>, bool)> = HashMap::new();
    let mut columns: Option<Vec<Vec<String>>> = None;
    let mut done = Exported::default();
    let opts = SerializeOptions::new()
        .use_proto_field_name(true)
        .stringify_64_bit_integers(false)
        .skip_default_fields(false);
    let w = |e| ExportError::Write(e);
    while let Some(m) = rec.next_message()? {
        let Some(ch) = rec.channel(m.channel_id) else {
            continue;
        };
        let is_group = match wanted.get(&m.channel_id) {
            Some((t, w)) if std::sync::Arc::ptr_eq(t, &ch.topic) => *w,
            _ => {
                let w = &*ch.topic == group;
                wanted.insert(m.channel_id, (ch.topic.clone(), w));
                w
            }
        };
        if !is_group {
            continue;
        }
        let schema_id = ch.schema_id;
        let desc = pools
            .entry(schema_id)
            .or_insert_with(|| {
                let s = rec.schema(schema_id)?;
                let pool = crate::schema::decode_untrusted_pool(&s.data)?;
                pool.get_message_by_name(&s.name)
            })
            .clone();
        let Some(desc) = desc else {
            done.undecodable += 1;
            continue;
        };
        let Ok(msg) = DynamicMessage::decode(desc.clone(), m.data.as_slice()) else {
            done.undecodable += 1;
            continue;
        };
        let Ok(json) = msg.serialize_with_options(serde_json::value::Serializer, &opts) else {
            done.undecodable += 1;
            continue;
        };
        let t = m.log_time as f64 / 1e9;
        match format {
            Format::Json => {
                let line = serde_json::json!({ "log_time": t, "group": group, "msg": json });
                writeln!(out, "{line}").map_err(w)?;
            }
            Format::Csv => {
                let cols = match &columns {
                    Some(c) => c,
                    None => {
                        let (c, cells) = csv_columns(&desc)?;
                        done.columns = c.len();
                        done.json_cells = cells;
                        let header: Vec<String> = std::iter::once("log_time".to_string())
                            .chain(c.iter().map(|p| p.join(".")))
                            .collect();
                        writeln!(out, "{}", csv_row(&header)).map_err(w)?;
                        columns.insert(c)
                    }
                };
                let row: Vec<String> = std::iter::once(format!("{t:.9}"))
                    .chain(cols.iter().map(|c| cell(lookup(&json, c))))
                    .collect();
                writeln!(out, "{}", csv_row(&row)).map_err(w)?;
            }
        }
        done.rows += 1;
    }
    done.truncated = rec.truncated().map(str::to_string);
    done.limits_note = rec.limits_note();
    if done.rows == 0 && done.undecodable == 0 {
        return Err(ExportError::NoSuchGroup(group.to_string()));
    }
    Ok(done)
}

/// The CSV columns of `desc`, each a field path: singular sub-messages are walked (at most
/// [`MAX_DEPTH`] deep, never into a type already on the path: a type containing itself is one
/// JSON cell), everything else is one column. Past [`MAX_COLUMNS`] the walk starts again with no
/// sub-message flattened; a type with more top-level fields than that is refused.
fn csv_columns(desc: &MessageDescriptor) -> Result<(Vec<Vec<String>>, usize), ExportError> {
    for max_depth in [MAX_DEPTH, 0] {
        let mut out = Vec::new();
        let mut cells = 0;
        let mut path = Vec::new();
        let mut on_path = vec![desc.full_name().to_string()];
        if field_columns(
            desc,
            &mut path,
            &mut on_path,
            max_depth,
            &mut out,
            &mut cells,
        ) {
            return Ok((out, cells));
        }
    }
    Err(ExportError::TooWide(desc.full_name().to_string()))
}

/// Appends `desc`'s columns under `path`; false once past [`MAX_COLUMNS`].
fn field_columns(
    desc: &MessageDescriptor,
    path: &mut Vec<String>,
    on_path: &mut Vec<String>,
    max_depth: usize,
    out: &mut Vec<Vec<String>>,
    cells: &mut usize,
) -> bool {
    for f in desc.fields() {
        path.push(f.name().to_string());
        let ok = match f.kind() {
            Kind::Message(sub)
                if !f.is_list()
                    && !f.is_map()
                    && path.len() <= max_depth
                    && !on_path.iter().any(|t| t == sub.full_name()) =>
            {
                on_path.push(sub.full_name().to_string());
                let ok = field_columns(&sub, path, on_path, max_depth, out, cells);
                on_path.pop();
                ok
            }
            k => {
                if matches!(k, Kind::Message(_)) && !f.is_list() && !f.is_map() {
                    *cells += 1;
                }
                out.push(path.clone());
                out.len() <= MAX_COLUMNS
            }
        };
        path.pop();
        if !ok {
            return false;
        }
    }
    true
}

/// The value at `path` in a message's JSON (absent fields: None).
fn lookup<'a>(v: &'a Value, path: &[String]) -> Option<&'a Value> {
    path.iter().try_fold(v, |v, k| v.as_object()?.get(k))
}

fn cell(v: Option<&Value>) -> String {
    match v {
        None | Some(Value::Null) => String::new(),
        Some(Value::String(s)) => s.clone(),
        Some(v) => v.to_string(),
    }
}

fn csv_row(cells: &[String]) -> String {
    cells
        .iter()
        .map(|c| {
            if c.contains([',', '"', '\n', '\r']) {
                format!("\"{}\"", c.replace('"', "\"\""))
            } else {
                c.clone()
            }
        })
        .collect::<Vec<_>>()
        .join(",")
}
