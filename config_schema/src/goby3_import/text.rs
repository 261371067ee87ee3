//! Reading a .pb.cfg as Goby3 does: protobuf text format parsed against descriptors of Goby3's
//! own config messages (compiled by build.rs), so a misspelt field or a wrong enum name is an
//! error with its line and column; then every field the file sets, by its dotted Goby3 path,
//! with the enum types to print their names.

use std::collections::BTreeMap;
use std::sync::OnceLock;

use prost_reflect::{DescriptorPool, DynamicMessage, MessageDescriptor, Value};

use crate::ConfigError;

static DESCRIPTORS: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/goby3_config.bin"));

/// Goby3's top-level config message of goby_frontseat_interface.
pub const INTERFACE_MESSAGE: &str = "goby.apps.zeromq.protobuf.FrontSeatInterfaceConfig";
/// Goby3's top-level config message of goby_moos_gateway.
pub const GATEWAY_MESSAGE: &str = "goby.apps.moos.protobuf.GobyMOOSGatewayConfig";

fn pool() -> Result<&'static DescriptorPool, String> {
    static POOL: OnceLock<Result<DescriptorPool, String>> = OnceLock::new();
    POOL.get_or_init(|| DescriptorPool::decode(DESCRIPTORS).map_err(|e| e.to_string()))
        .as_ref()
        .map_err(Clone::clone)
}

fn descriptor(name: &str) -> Result<MessageDescriptor, String> {
    pool()?
        .get_message_by_name(name)
        .ok_or_else(|| format!("no descriptor for {name}"))
}

/// How every parse error of a .pb.cfg starts, after `file:line:column: `.
pub const PARSE_ERROR_PREFIX: &str = "Goby3 config (protobuf text format): ";

/// Parses Goby3 text format against `message` (Goby3's rules: unknown fields and enum names
/// are errors); the error names the file, line and column.
pub fn parse_text(message: &str, text: &str, file: &str) -> Result<DynamicMessage, ConfigError> {
    let internal = |message: String| ConfigError::Parse {
        file: file.to_owned(),
        line: 0,
        column: 0,
        message,
    };
    let desc = descriptor(message).map_err(internal)?;
    DynamicMessage::parse_text_format(desc, text).map_err(|e| {
        use miette::Diagnostic;
        let offset = e
            .labels()
            .and_then(|mut l| l.next())
            .map(|l| l.offset())
            .unwrap_or(0);
        let (line, column) = crate::line_column(text, offset).unwrap_or((0, 0));
        ConfigError::Parse {
            file: file.to_owned(),
            line,
            column,
            message: format!("{PARSE_ERROR_PREFIX}{e}"),
        }
    })
}

/// Every field the message sets, by Goby3 path: scalars and lists of scalars as leaves,
/// singular sub-messages flattened, lists of messages (rpm_table) as one leaf.
pub(super) fn leaves(msg: &DynamicMessage, prefix: &str, out: &mut BTreeMap<String, Value>) {
    let join = |name: &str| {
        if prefix.is_empty() {
            name.to_owned()
        } else {
            format!("{prefix}.{name}")
        }
    };
    for (field, value) in msg.fields() {
        match value {
            Value::Message(m) => leaves(m, &join(field.name()), out),
            v => {
                out.insert(join(field.name()), v.clone());
            }
        }
    }
    for (ext, value) in msg.extensions() {
        let path = join(&format!("[{}]", ext.full_name()));
        match value {
            Value::Message(m) => {
                // A set but empty extension block still selects its driver.
                out.insert(path.clone(), Value::Bool(true));
                leaves(m, &path, out);
            }
            v => {
                out.insert(path, v.clone());
            }
        }
    }
}

/// Goby3's text for a value (notes and comments).
pub(super) fn goby_text(v: &Value, field_enum: Option<&prost_reflect::EnumDescriptor>) -> String {
    match v {
        Value::String(s) => format!("{s:?}"),
        Value::EnumNumber(n) => field_enum
            .and_then(|e| e.get_value(*n))
            .map(|e| e.name().to_owned())
            .unwrap_or_else(|| n.to_string()),
        Value::List(l) => {
            let items: Vec<String> = l.iter().map(|x| goby_text(x, field_enum)).collect();
            format!("[{}]", items.join(", "))
        }
        Value::Message(m) => format!("{{ {} }}", m.to_text_format()),
        Value::Bool(b) => b.to_string(),
        Value::I32(x) => x.to_string(),
        Value::I64(x) => x.to_string(),
        Value::U32(x) => x.to_string(),
        Value::U64(x) => x.to_string(),
        Value::F32(x) => x.to_string(),
        Value::F64(x) => x.to_string(),
        other => format!("{other:?}"),
    }
}

/// The enum type of every enum field, by Goby3 path (extensions included), for printing names.
pub(super) fn enum_fields(
    desc: &MessageDescriptor,
    prefix: &str,
    out: &mut BTreeMap<String, prost_reflect::EnumDescriptor>,
    depth: usize,
) {
    if depth > 8 {
        return;
    }
    let join = |name: &str| {
        if prefix.is_empty() {
            name.to_owned()
        } else {
            format!("{prefix}.{name}")
        }
    };
    for f in desc.fields() {
        match f.kind() {
            prost_reflect::Kind::Enum(e) => {
                out.insert(join(f.name()), e);
            }
            prost_reflect::Kind::Message(m) => enum_fields(&m, &join(f.name()), out, depth + 1),
            _ => {}
        }
    }
    for ext in desc.extensions() {
        let path = join(&format!("[{}]", ext.full_name()));
        match ext.kind() {
            prost_reflect::Kind::Enum(e) => {
                out.insert(path, e);
            }
            prost_reflect::Kind::Message(m) => enum_fields(&m, &path, out, depth + 1),
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn descriptors_decode_and_name_both_applications() {
        assert!(descriptor(INTERFACE_MESSAGE).is_ok());
        assert!(descriptor(GATEWAY_MESSAGE).is_ok());
    }
}
