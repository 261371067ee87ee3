//! Messages as JSON, by reflection over the compiled descriptors (`proto::FILE_DESCRIPTOR_SET`):
//! any group's bytes → JSON for the scope, a message type → the commander's form schema, and
//! the commander's JSON → checked protobuf bytes. No message type is named here, so a group
//! added to `interface_yaml/` shows up with no web code.

use std::sync::OnceLock;

use prost::Message as _;
use prost_reflect::{
    Cardinality, DescriptorPool, DeserializeOptions, DynamicMessage, FieldDescriptor, Kind,
    MessageDescriptor, ReflectMessage, SerializeOptions, Value,
};
use serde_json::{Map, Value as Json, json};

use crate::WebError;

/// Deepest nesting the form schema describes (Goby3's messages nest three deep).
const MAX_FORM_DEPTH: usize = 6;

/// The descriptor pool of every compiled message; `None` if the embedded set does not decode,
/// which would be a build defect (logged once; the scope then shows raw sizes only).
pub fn pool() -> Option<&'static DescriptorPool> {
    static POOL: OnceLock<Option<DescriptorPool>> = OnceLock::new();
    POOL.get_or_init(|| {
        match DescriptorPool::decode(frontseat_actors::proto::FILE_DESCRIPTOR_SET) {
            Ok(p) => Some(p),
            Err(e) => {
                tracing::error!(error = %e, "the compiled descriptor set does not decode");
                None
            }
        }
    })
    .as_ref()
}

fn descriptor(type_name: &str) -> Result<MessageDescriptor, WebError> {
    pool()
        .and_then(|p| p.get_message_by_name(type_name))
        .ok_or_else(|| WebError::UnknownType(type_name.to_string()))
}

fn json_options() -> SerializeOptions {
    SerializeOptions::new()
        .use_proto_field_name(true)
        .stringify_64_bit_integers(false)
}

/// The message as JSON (proto field names, enums by name, set fields only).
pub fn to_json(type_name: &str, bytes: &[u8]) -> Result<Json, WebError> {
    let desc = descriptor(type_name)?;
    let msg = DynamicMessage::decode(desc, bytes).map_err(|e| WebError::Decode(e.to_string()))?;
    msg.serialize_with_options(serde_json::value::Serializer, &json_options())
        .map_err(|e| WebError::Decode(e.to_string()))
}

/// [`to_json`] written straight to JSON text, without the `Json` value in between: the hub's
/// events are text, so building the value only to print it cost every event a second pass
/// (W1's path, issue 49).
pub fn to_json_text(type_name: &str, bytes: &[u8]) -> Result<String, WebError> {
    let desc = descriptor(type_name)?;
    let msg = DynamicMessage::decode(desc, bytes).map_err(|e| WebError::Decode(e.to_string()))?;
    let mut out = Vec::with_capacity(256);
    msg.serialize_with_options(&mut serde_json::Serializer::new(&mut out), &json_options())
        .map_err(|e| WebError::Decode(e.to_string()))?;
    String::from_utf8(out).map_err(|e| WebError::Decode(e.to_string()))
}

/// The commander's JSON → protobuf bytes of `type_name`: unknown fields and missing required
/// fields are refused, like a malformed message from any other helm would be.
pub fn from_json(type_name: &str, value: &Json) -> Result<Vec<u8>, WebError> {
    let desc = descriptor(type_name)?;
    let msg = DynamicMessage::deserialize_with_options(
        desc,
        value,
        &DeserializeOptions::new().deny_unknown_fields(true),
    )
    .map_err(|e| WebError::Invalid(e.to_string()))?;
    let mut missing = Vec::new();
    missing_required(&msg, "", &mut missing);
    if !missing.is_empty() {
        return Err(WebError::Invalid(format!(
            "missing required field(s): {}",
            missing.join(", ")
        )));
    }
    Ok(msg.encode_to_vec())
}

fn missing_required(msg: &DynamicMessage, prefix: &str, out: &mut Vec<String>) {
    for f in msg.descriptor().fields() {
        let path = if prefix.is_empty() {
            f.name().to_string()
        } else {
            format!("{prefix}.{}", f.name())
        };
        if f.is_required() && !msg.has_field(&f) {
            out.push(path);
            continue;
        }
        if msg.has_field(&f)
            && let Value::Message(m) = msg.get_field(&f).as_ref()
        {
            missing_required(m, &path, out);
        }
    }
}

/// Units of Goby3's fields, as its DCCL options give them (the .proto files here leave the
/// DCCL options out). Keyed by field name, which Goby3 uses consistently.
fn unit(field: &str) -> Option<&'static str> {
    Some(match field {
        "time" => "s (UNIX)",
        "heading" | "pitch" | "roll" | "course_over_ground" => "deg",
        "speed" | "z_rate" | "over_ground" | "over_water" => "m/s",
        "depth" | "altitude" | "x" | "y" | "z" => "m",
        "lat" | "lon" => "deg",
        "heading_rate" | "pitch_rate" | "roll_rate" => "deg/s",
        _ => return None,
    })
}

fn kind_name(k: &Kind) -> &'static str {
    match k {
        Kind::Double => "double",
        Kind::Float => "float",
        Kind::Int32 | Kind::Sint32 | Kind::Sfixed32 => "int32",
        Kind::Int64 | Kind::Sint64 | Kind::Sfixed64 => "int64",
        Kind::Uint32 | Kind::Fixed32 => "uint32",
        Kind::Uint64 | Kind::Fixed64 => "uint64",
        Kind::Bool => "bool",
        Kind::String => "string",
        Kind::Bytes => "bytes",
        Kind::Message(_) => "message",
        Kind::Enum(_) => "enum",
    }
}

fn default_json(f: &FieldDescriptor) -> Json {
    if f.is_list() || matches!(f.kind(), Kind::Message(_)) {
        return Json::Null;
    }
    match f.default_value() {
        Value::Bool(b) => json!(b),
        Value::I32(v) => json!(v),
        Value::I64(v) => json!(v),
        Value::U32(v) => json!(v),
        Value::U64(v) => json!(v),
        Value::F32(v) if v.is_finite() => json!(v),
        Value::F64(v) if v.is_finite() => json!(v),
        Value::F32(v) => json!(v.to_string()),
        Value::F64(v) => json!(v.to_string()),
        Value::String(s) => json!(s),
        Value::Bytes(b) => json!(String::from_utf8_lossy(&b)),
        Value::EnumNumber(n) => match f.kind() {
            Kind::Enum(e) => e
                .get_value(n)
                .map_or(json!(n), |v| json!(v.name().to_string())),
            _ => json!(n),
        },
        _ => Json::Null,
    }
}

fn field_schema(f: &FieldDescriptor, depth: usize) -> Json {
    let kind = f.kind();
    let mut o = Map::new();
    o.insert("name".into(), json!(f.name()));
    o.insert("number".into(), json!(f.number()));
    o.insert("type".into(), json!(kind_name(&kind)));
    o.insert(
        "label".into(),
        json!(match f.cardinality() {
            Cardinality::Required => "required",
            Cardinality::Repeated => "repeated",
            Cardinality::Optional => "optional",
        }),
    );
    o.insert("default".into(), default_json(f));
    if let Some(u) = unit(f.name()) {
        o.insert("unit".into(), json!(u));
    }
    match &kind {
        Kind::Enum(e) => {
            let values: Vec<Json> = e
                .values()
                .map(|v| json!({"name": v.name(), "number": v.number()}))
                .collect();
            o.insert("enum".into(), Json::Array(values));
        }
        Kind::Message(m) if depth < MAX_FORM_DEPTH => {
            o.insert("message".into(), message_schema_at(m, depth + 1));
        }
        _ => {}
    }
    Json::Object(o)
}

fn message_schema_at(m: &MessageDescriptor, depth: usize) -> Json {
    let fields: Vec<Json> = m.fields().map(|f| field_schema(&f, depth)).collect();
    json!({"type": m.full_name(), "fields": fields})
}

/// The form schema of a message type: every field with its kind, label, default, unit, enum
/// choices, and nested messages.
pub fn message_schema(type_name: &str) -> Result<Json, WebError> {
    Ok(message_schema_at(&descriptor(type_name)?, 0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
        DesiredCourse, HelmState, HelmStateReport,
    };

    const DC: &str = "goby.middleware.frontseat.protobuf.DesiredCourse";

    #[test]
    fn bytes_become_json_with_proto_names_and_enum_names() {
        let bytes = HelmStateReport {
            state: HelmState::HelmDrive as i32,
        }
        .encode_to_vec();
        let j = to_json("goby.middleware.frontseat.protobuf.HelmStateReport", &bytes).unwrap();
        assert_eq!(j, json!({"state": "HELM_DRIVE"}));
    }

    #[test]
    fn json_round_trips_to_the_prost_type() {
        let bytes = from_json(DC, &json!({"time": 12.5, "heading": 90, "speed": 1.5})).unwrap();
        let dc = DesiredCourse::decode(bytes.as_slice()).unwrap();
        assert_eq!((dc.time, dc.heading(), dc.speed()), (12.5, 90.0, 1.5));
    }

    #[test]
    fn missing_required_and_unknown_fields_are_refused() {
        let e = from_json(DC, &json!({"heading": 90})).unwrap_err();
        assert!(e.to_string().contains("time"), "{e}");
        assert!(from_json(DC, &json!({"time": 1, "headng": 90})).is_err());
        assert!(from_json(DC, &json!({"time": "soon"})).is_err());
        assert!(from_json("no.such.Type", &json!({})).is_err());
    }

    #[test]
    fn schema_has_defaults_units_and_enums() {
        let s = message_schema(DC).unwrap();
        let alt = s["fields"]
            .as_array()
            .unwrap()
            .iter()
            .find(|f| f["name"] == "altitude")
            .unwrap();
        assert_eq!(alt["default"], json!(10.0));
        assert_eq!(alt["unit"], json!("m"));
        let raw = message_schema("goby.middleware.frontseat.protobuf.Raw").unwrap();
        let ty = raw["fields"]
            .as_array()
            .unwrap()
            .iter()
            .find(|f| f["name"] == "type")
            .unwrap();
        assert_eq!(ty["default"], json!("RAW_ASCII"));
        assert_eq!(ty["enum"][1]["name"], json!("RAW_BINARY"));
        let time = &s["fields"][0];
        assert_eq!(
            (time["name"].clone(), time["label"].clone()),
            (json!("time"), json!("required"))
        );
    }
}
