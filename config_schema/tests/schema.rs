//! The JSON Schema is valid JSON, documents every field, and carries the defaults and ranges.

use frontseat_config::{GatewayConfig, InterfaceConfig, ServiceConfig, SimConfig, schema};
use serde_json::Value;

/// Every property of every object schema (root and $defs) has a non-empty description.
fn assert_all_described<T: ServiceConfig>() -> Value {
    let v: Value = serde_json::from_str(&schema::<T>()).expect("schema is JSON");
    let mut objects = vec![("<root>".to_owned(), &v)];
    if let Some(defs) = v.get("$defs").and_then(Value::as_object) {
        objects.extend(defs.iter().map(|(k, d)| (k.clone(), d)));
    }
    let mut checked = 0;
    for (name, obj) in objects {
        let Some(props) = obj.get("properties").and_then(Value::as_object) else {
            continue;
        };
        for (key, p) in props {
            let d = p.get("description").and_then(Value::as_str).unwrap_or("");
            assert!(
                !d.trim().is_empty(),
                "{}: {name}.{key} has no description",
                T::SERVICE
            );
            checked += 1;
        }
    }
    assert!(checked > 5, "walked the schema");
    v
}

#[test]
fn interface_schema_documents_every_field() {
    let v = assert_all_described::<InterfaceConfig>();
    assert_eq!(v["title"], "InterfaceConfig");
    let timeout = &v["properties"]["helm_running_timeout"];
    assert!(timeout["description"].as_str().unwrap().contains("Unit: s"));
    assert_eq!(timeout["default"], 10.0);
    assert_eq!(v["additionalProperties"], false);
    let lat = &v["$defs"]["LatLonConfig"]["properties"]["lat"];
    assert_eq!(
        (lat["minimum"].as_f64(), lat["maximum"].as_f64()),
        (Some(-90.0), Some(90.0))
    );
    let vt = &v["$defs"]["VehicleType"]["enum"];
    assert_eq!(vt.as_array().unwrap().len(), 14);
    assert!(
        vt.as_array()
            .unwrap()
            .contains(&Value::from("MOORING_SUBSURFACE"))
    );
}

#[test]
fn sim_schema_documents_every_field() {
    let v = assert_all_described::<SimConfig>();
    assert_eq!(v["properties"]["port"]["default"], 54321);
    let kinds = v["$defs"]["FaultKind"]["oneOf"].as_array().unwrap();
    assert_eq!(kinds.len(), 7);
}

#[test]
fn gateway_schema_requires_moos() {
    let v = assert_all_described::<GatewayConfig>();
    assert_eq!(v["required"], serde_json::json!(["moos"]));
}
