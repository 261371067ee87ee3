//! `frontseat log export`: one group's messages as CSV or JSON Lines, decoded by reflection with
//! the schema stored in the file itself (so old files export even after our .proto files move
//! on). CSV columns are the message's fields flattened by path (`global_fix.lat`); repeated
//! fields and maps go into one cell as JSON.

use std::collections::HashMap;
use std::io::{Read, Write};

use prost_reflect::{DescriptorPool, DynamicMessage, Kind, MessageDescriptor, SerializeOptions};
use serde_json::{Map, Value};

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
    #[error("cannot create {path}: {source}")]
    Create {
        path: String,
        source: std::io::Error,
    },
    #[error("no message of group `{0}` in the file")]
    NoSuchGroup(String),
}

/// What an export did.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Exported {
    pub rows: u64,
    /// Messages whose schema or bytes did not decode (counted, skipped).
    pub undecodable: u64,
    pub truncated: Option<String>,
}

/// Deepest message nesting flattened into columns; deeper goes into a JSON cell.
const MAX_DEPTH: usize = 8;

/// [`export`] into the file `path` (created or replaced), or standard output when None.
pub fn export_to<R: Read>(
    rec: Recording<R>,
    group: &str,
    format: Format,
    path: Option<&std::path::Path>,
) -> Result<Exported, ExportError> {
    fn to<R: Read, W: Write>(
        rec: Recording<R>,
        group: &str,
        format: Format,
        w: W,
    ) -> Result<Exported, ExportError> {
        let mut w = std::io::BufWriter::new(w);
        let r = export(rec, group, format, &mut w);
        // A write error at the end (a full disk) is the export's error too.
        w.flush().map_err(ExportError::Write).and(r)
    }
    match path {
        Some(p) => {
            let f = std::fs::File::create(p).map_err(|e| ExportError::Create {
                path: p.display().to_string(),
                source: e,
            })?;
            to(rec, group, format, f)
        }
        None => to(rec, group, format, std::io::stdout().lock()),
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
    let mut columns: Option<Vec<String>> = None;
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
        if &*ch.topic != group {
            continue;
        }
        let schema_id = ch.schema_id;
        let desc = pools
            .entry(schema_id)
            .or_insert_with(|| {
                let s = rec.schema(schema_id)?;
                let pool = DescriptorPool::decode(&*s.data).ok()?;
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
                let cols = columns.get_or_insert_with(|| {
                    let mut c = Vec::new();
                    field_columns(&desc, "", 0, &mut c);
                    c
                });
                if done.rows == 0 {
                    let header: Vec<String> = std::iter::once("log_time".to_string())
                        .chain(cols.iter().cloned())
                        .collect();
                    writeln!(out, "{}", csv_row(&header)).map_err(w)?;
                }
                let mut flat = Map::new();
                flatten("", &json, 0, &mut flat);
                let row: Vec<String> = std::iter::once(format!("{t:.9}"))
                    .chain(cols.iter().map(|c| cell(flat.get(c))))
                    .collect();
                writeln!(out, "{}", csv_row(&row)).map_err(w)?;
            }
        }
        done.rows += 1;
    }
    done.truncated = rec.truncated().map(str::to_string);
    if done.rows == 0 && done.undecodable == 0 {
        return Err(ExportError::NoSuchGroup(group.to_string()));
    }
    Ok(done)
}

/// Column names of a message: singular sub-messages are walked, everything else is one column.
fn field_columns(desc: &MessageDescriptor, prefix: &str, depth: usize, out: &mut Vec<String>) {
    for f in desc.fields() {
        let name = if prefix.is_empty() {
            f.name().to_string()
        } else {
            format!("{prefix}.{}", f.name())
        };
        match f.kind() {
            Kind::Message(sub) if !f.is_list() && !f.is_map() && depth < MAX_DEPTH => {
                field_columns(&sub, &name, depth + 1, out)
            }
            _ => out.push(name),
        }
    }
}

fn flatten(prefix: &str, v: &Value, depth: usize, out: &mut Map<String, Value>) {
    match v {
        Value::Object(o) if depth < MAX_DEPTH => {
            for (k, v) in o {
                let key = if prefix.is_empty() {
                    k.clone()
                } else {
                    format!("{prefix}.{k}")
                };
                flatten(&key, v, depth + 1, out);
            }
        }
        v => {
            out.insert(prefix.to_string(), v.clone());
        }
    }
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
