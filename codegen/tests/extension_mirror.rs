//! The documented way to carry Goby3 extension fields (interface_yaml/README.md): a mirror message
//! with the base fields and explicit 1000+ fields reads and writes the same bytes as Goby3's
//! `extend`ed message.

use std::path::PathBuf;

use prost::Message;
use prost_reflect::{DynamicMessage, Value};

#[test]
fn a_mirror_message_reads_and_writes_goby_extension_bytes() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let pool = protox::Compiler::new([
        root.join("tests/fixtures/proto_ext"),
        root.join("../interface_yaml/proto"),
    ])
    .unwrap()
    .open_file("example_driver/example_driver.proto")
    .unwrap()
    .descriptor_pool();

    let base = pool
        .get_message_by_name("goby.middleware.frontseat.protobuf.CommandRequest")
        .unwrap();
    let mirror = pool
        .get_message_by_name("frontseat.protobuf.example_driver.CommandRequest")
        .unwrap();
    let rudder = pool
        .get_extension_by_name("frontseat.protobuf.example_driver.rudder_trim")
        .unwrap();
    let leg = pool
        .get_extension_by_name("frontseat.protobuf.example_driver.mission_leg")
        .unwrap();

    // What a Goby3 driver puts on the wire.
    let mut goby = DynamicMessage::new(base.clone());
    goby.set_field_by_name("request_id", Value::I32(7));
    goby.set_field_by_name("response_requested", Value::Bool(true));
    goby.set_extension(&rudder, Value::F64(-2.5));
    goby.set_extension(&leg, Value::String("leg-3".into()));
    let bytes = goby.encode_to_vec();

    // The mirror sees every field, the extension ones as plain fields.
    let read = DynamicMessage::decode(mirror.clone(), bytes.as_slice()).unwrap();
    assert_eq!(
        read.get_field_by_name("request_id").unwrap().as_i32(),
        Some(7)
    );
    assert_eq!(
        read.get_field_by_name("rudder_trim").unwrap().as_f64(),
        Some(-2.5)
    );
    assert_eq!(
        read.get_field_by_name("mission_leg").unwrap().as_str(),
        Some("leg-3")
    );
    // And writes the same bytes back, which Goby3 reads as its extensions.
    assert_eq!(read.encode_to_vec(), bytes);
    let back = DynamicMessage::decode(base, read.encode_to_vec().as_slice()).unwrap();
    assert_eq!(back.get_extension(&rudder).as_f64(), Some(-2.5));
    assert_eq!(back, goby);
}
