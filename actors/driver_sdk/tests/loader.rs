//! The host side of the ABI in-process: the C example driver (built here with `cc`) proves the
//! ABI from C; each load error is told apart with its documented wording.

mod common;

use std::sync::{Arc, Mutex};

use common::*;
use frontseat_driver_sdk::driver::SignalKind;
use frontseat_driver_sdk::loader::{Plugin, Signal, SignalSink};
use frontseat_driver_sdk::proto::goby::middleware::frontseat::protobuf::DesiredCourse;
use frontseat_driver_sdk::{
    CommandRequest, CommandResponse, Error, FrontSeatState, InterfaceData, Raw, abi,
};
use prost::Message;

type Collected = Arc<Mutex<Vec<Signal>>>;

fn collector() -> (Collected, SignalSink) {
    let got = Arc::new(Mutex::new(Vec::new()));
    let g = got.clone();
    (got, Arc::new(move |s| g.lock().unwrap().push(s)))
}

fn bytes_of(got: &Mutex<Vec<Signal>>, kind: SignalKind) -> Vec<Vec<u8>> {
    got.lock()
        .unwrap()
        .iter()
        .filter_map(|s| match s {
            Signal::Bytes(k, b) if *k == kind => Some(b.clone()),
            _ => None,
        })
        .collect()
}

#[test]
fn c_driver_speaks_the_abi_both_ways() {
    let lib = build_c_plugin("example_ok", &[]);
    let plugin = Plugin::open(&lib).unwrap();
    let (got, sink) = collector();
    let mut d = plugin.load(b"{}", sink).unwrap();
    assert_eq!(
        d.frontseat_state(),
        FrontSeatState::FrontseatAcceptingCommands as i32
    );
    assert!(!d.frontseat_providing_data());

    let req = CommandRequest {
        desired_course: Some(DesiredCourse {
            time: 0.0,
            heading: Some(90.0),
            speed: Some(2.0),
            depth: Some(5.0),
            ..Default::default()
        }),
        response_requested: Some(true),
        request_id: Some(41),
        ..Default::default()
    };
    assert_eq!(d.send_command(&req.encode_to_vec()), abi::OK);
    let responses = bytes_of(&got, SignalKind::CommandResponse);
    assert_eq!(responses.len(), 1);
    let r = CommandResponse::decode(&responses[0][..]).unwrap();
    assert_eq!((r.request_successful, r.request_id), (Some(true), Some(41)));
    let raw = Raw::decode(&bytes_of(&got, SignalKind::RawToFrontseat)[0][..]).unwrap();
    assert_eq!(raw.raw(), b"CMD,HEADING:90,SPEED:2,DEPTH:5");

    // Two loops 1 s apart at 2 m/s east: the longitude grows, the latitude stays.
    assert_eq!(d.do_loop(1_000_000), abi::OK);
    assert_eq!(d.do_loop(2_000_000), abi::OK);
    assert!(d.frontseat_providing_data());
    let data = bytes_of(&got, SignalKind::DataFromFrontseat);
    assert_eq!(data.len(), 2);
    let a = InterfaceData::decode(&data[0][..])
        .unwrap()
        .node_status
        .unwrap();
    let b = InterfaceData::decode(&data[1][..])
        .unwrap()
        .node_status
        .unwrap();
    assert_eq!(b.time, 2.0);
    assert_eq!(b.pose.heading, Some(90.0));
    assert_eq!(b.speed.over_ground, 2.0);
    assert!(b.global_fix.lon > a.global_fix.lon);
    assert!((b.global_fix.lat - a.global_fix.lat).abs() < 1e-9);

    assert_eq!(d.send_command(&[0xff, 0xff]), abi::ERR_BAD_MESSAGE);
    assert!(
        got.lock()
            .unwrap()
            .iter()
            .any(|s| matches!(s, Signal::State { state: 2, .. }))
    );
    assert!(got.lock().unwrap().iter().any(|s| matches!(
        s,
        Signal::Log { message, .. } if message.contains("C example driver loaded")
    )));
}

#[test]
fn config_rejected_by_the_driver_is_typed() {
    let lib = build_c_plugin("example_reject", &[]);
    let (_, sink) = collector();
    let e = Plugin::open(&lib)
        .unwrap()
        .load(b"not json", sink)
        .err()
        .unwrap();
    assert!(
        matches!(&e, Error::ConfigRejected { reason } if reason == "config must be a JSON object"),
        "{e}"
    );
    assert_eq!(
        e.to_string(),
        "driver config rejected by the driver: config must be a JSON object"
    );
}

#[test]
fn abi_mismatch_is_refused_before_any_other_symbol() {
    let lib = build_c_plugin("example_abi99", &["-DFSD_EXAMPLE_ABI_VERSION=99"]);
    let e = Plugin::open(&lib).err().unwrap();
    assert!(
        matches!(
            e,
            Error::AbiMismatch {
                found: 99,
                expected: abi::ABI_VERSION,
                ..
            }
        ),
        "{e}"
    );
    let msg = e.to_string();
    assert!(msg.contains("ABI version mismatch"), "{msg}");
    assert!(msg.contains("version 99"), "{msg}");
    assert_eq!(e.exit_code(), 5);
}

#[test]
fn missing_symbol_file_and_garbage_library_are_told_apart() {
    let lib = build_c_plugin(
        "example_noloop",
        &["-DFSD_EXAMPLE_OMIT_LOOP", "-Wno-unused-function"],
    );
    let e = Plugin::open(&lib).err().unwrap();
    assert!(
        matches!(&e, Error::SymbolMissing { symbol, .. } if symbol == "frontseat_driver_loop"),
        "{e}"
    );

    let missing = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("no_such_driver.so");
    let e = Plugin::open(&missing).err().unwrap();
    assert!(matches!(e, Error::LibraryMissing { .. }), "{e}");
    assert!(e.to_string().ends_with("file not found"));

    let garbage = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("libgarbage.so");
    std::fs::write(&garbage, b"this is not an ELF file").unwrap();
    let e = Plugin::open(&garbage).err().unwrap();
    assert!(matches!(e, Error::LibraryNotLoadable { .. }), "{e}");
}

#[test]
fn rust_plugin_rejects_a_config_that_is_not_the_interface_config() {
    let plugin = Plugin::open(&rust_plugin()).unwrap();
    let (_, sink) = collector();
    let e = plugin.load(b"{\"nope\": 1}", sink).err().unwrap();
    assert!(
        matches!(&e, Error::ConfigRejected { reason } if reason.starts_with("config is not valid")),
        "{e}"
    );
}
