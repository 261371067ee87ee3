//! Wire compatibility with Goby3: for every case of the recorded golden messages, our prost types
//! decode the reference bytes to the values of the case's text format, and encode those values to
//! the same bytes. The text format is parsed with prost-reflect against the descriptor set the
//! interface compiler compiled, so schema and generated types are checked together.

use std::fmt::Debug;

use frontseat_actors::proto::{
    self, goby::middleware::frontseat::protobuf as fs, goby::middleware::protobuf as gm,
};
use prost::Message;
use prost_reflect::{DescriptorPool, DynamicMessage};

const GOLDEN: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/tests/fixtures/goby3/golden_messages.json"
);

fn hex_decode(hex: &str) -> Vec<u8> {
    hex.as_bytes()
        .chunks(2)
        .map(|pair| {
            let pair = std::str::from_utf8(pair).unwrap();
            assert_eq!(pair.len(), 2, "odd hex length");
            u8::from_str_radix(pair, 16).unwrap()
        })
        .collect()
}

fn hex_encode(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// Checks one case with the typed message `T`.
fn check<T: Message + Default + PartialEq + Debug>(
    pool: &DescriptorPool,
    case: &str,
    message: &str,
    text: &str,
    hex: &str,
) {
    let bytes = hex_decode(hex);
    let typed = T::decode(bytes.as_slice()).unwrap_or_else(|e| panic!("{case}: decode: {e}"));
    // Encoding the decoded values gives the reference bytes back.
    assert_eq!(hex_encode(&typed.encode_to_vec()), hex, "{case}: re-encode");

    let desc = pool
        .get_message_by_name(message)
        .unwrap_or_else(|| panic!("{case}: {message} not in the descriptor set"));
    let from_text = DynamicMessage::parse_text_format(desc.clone(), text)
        .unwrap_or_else(|e| panic!("{case}: text format: {e}"));
    // The text format's values, carried into our type, equal what we decoded from the bytes.
    let text_typed = T::decode(from_text.encode_to_vec().as_slice()).unwrap();
    assert_eq!(
        typed, text_typed,
        "{case}: decoded values differ from the text format"
    );
    // And the reference runtime's bytes, read by reflection, are the text format's values too.
    let from_bytes = DynamicMessage::decode(desc, bytes.as_slice()).unwrap();
    assert_eq!(
        from_bytes, from_text,
        "{case}: reflection decode differs from text format"
    );
    // Encoding the text format's values gives the reference bytes.
    assert_eq!(
        hex_encode(&text_typed.encode_to_vec()),
        hex,
        "{case}: encode of text values"
    );
}

#[test]
fn every_golden_case_decodes_to_its_text_format_and_encodes_to_its_bytes() {
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(GOLDEN).unwrap()).unwrap();
    let pool = DescriptorPool::decode(proto::FILE_DESCRIPTOR_SET).unwrap();
    let cases = json["cases"].as_array().unwrap();
    assert!(!cases.is_empty(), "no golden cases");
    for c in cases {
        let case = c["case"].as_str().unwrap();
        let message = c["message"].as_str().unwrap();
        let text = c["text_format"].as_str().unwrap();
        let hex = c["hex"].as_str().unwrap();
        let checker: fn(&DescriptorPool, &str, &str, &str, &str) = match message {
            "goby.middleware.frontseat.protobuf.NodeStatus" => check::<fs::NodeStatus>,
            "goby.middleware.frontseat.protobuf.DesiredCourse" => check::<fs::DesiredCourse>,
            "goby.middleware.frontseat.protobuf.HelmStateReport" => check::<fs::HelmStateReport>,
            "goby.middleware.frontseat.protobuf.InterfaceStatus" => check::<fs::InterfaceStatus>,
            "goby.middleware.frontseat.protobuf.CommandRequest" => check::<fs::CommandRequest>,
            "goby.middleware.frontseat.protobuf.CommandResponse" => check::<fs::CommandResponse>,
            "goby.middleware.frontseat.protobuf.InterfaceData" => check::<fs::InterfaceData>,
            "goby.middleware.frontseat.protobuf.Raw" => check::<fs::Raw>,
            "goby.middleware.frontseat.protobuf.CtdSample"
            | "goby.middleware.frontseat.protobuf.CTDSample" => check::<fs::CtdSample>,
            "goby.middleware.protobuf.DatumUpdate" => check::<gm::DatumUpdate>,
            "goby.middleware.protobuf.LatLonPoint" => check::<gm::LatLonPoint>,
            other => panic!("{case}: no typed check for {other}; add it here"),
        };
        checker(&pool, case, message, text, hex);
    }
}

#[test]
fn typed_values_are_the_golden_ones() {
    // A spot check that the typed fields carry the values, not just the same bytes.
    let pool = DescriptorPool::decode(proto::FILE_DESCRIPTOR_SET).unwrap();
    assert!(
        pool.get_message_by_name("frontseat.protobuf.SimFault")
            .is_some()
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(GOLDEN).unwrap()).unwrap();
    let case = json["cases"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["case"] == "desired_course_heading_speed")
        .unwrap();
    let dc =
        fs::DesiredCourse::decode(hex_decode(case["hex"].as_str().unwrap()).as_slice()).unwrap();
    assert_eq!(dc.time, 1_700_000_001.5);
    assert_eq!(dc.heading, Some(90.0));
    assert_eq!(dc.speed, Some(1.5));
    assert_eq!(dc.depth, None);
    // proto2 defaults are kept: altitude defaults to 10.
    assert_eq!(dc.altitude(), 10.0);
}
