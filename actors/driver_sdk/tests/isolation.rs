//! The driver-host child process: the pre-flight check's exit codes and errors, and a C driver
//! that segfaults on its 5th command ending only the child, with the signal reported.

mod common;

use std::sync::Arc;
use std::time::Duration;

use common::*;
use frontseat_driver_sdk::driver::SignalKind;
use frontseat_driver_sdk::frame::to_host::Op;
use frontseat_driver_sdk::isolate::{self, HostEvent, HostProcess};
use frontseat_driver_sdk::loader::Signal;
use frontseat_driver_sdk::proto::goby::middleware::frontseat::protobuf::DesiredCourse;
use frontseat_driver_sdk::{CommandRequest, CommandResponse, Error, abi};
use prost::Message;
use tokio::sync::mpsc;

#[test]
fn check_of_an_abi_mismatch_exits_5_with_the_documented_error() {
    let lib = build_c_plugin("iso_abi99", &["-DFSD_EXAMPLE_ABI_VERSION=99"]);
    let out = std::process::Command::new(driver_host())
        .args(["driver-host", "--check", "--library"])
        .arg(&lib)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(5));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("ABI version mismatch: the library is built for driver ABI version 99"),
        "{stderr}"
    );
    let e = isolate::probe(&driver_host(), &lib, Duration::from_secs(10))
        .err()
        .unwrap();
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
}

#[test]
fn check_passes_for_good_libraries_and_tells_a_missing_file() {
    isolate::probe(&driver_host(), &rust_plugin(), Duration::from_secs(10)).unwrap();
    let ok = build_c_plugin("iso_ok", &[]);
    isolate::probe(&driver_host(), &ok, Duration::from_secs(10)).unwrap();
    let missing = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("nope.so");
    let e = isolate::probe(&driver_host(), &missing, Duration::from_secs(10))
        .err()
        .unwrap();
    assert!(matches!(e, Error::LibraryMissing { .. }), "{e}");
}

fn command(id: i32) -> Op {
    Op::Command(
        CommandRequest {
            desired_course: Some(DesiredCourse {
                time: 0.0,
                heading: Some(10.0 * f64::from(id)),
                speed: Some(1.0),
                ..Default::default()
            }),
            response_requested: Some(true),
            request_id: Some(id),
            ..Default::default()
        }
        .encode_to_vec(),
    )
}

async fn next(rx: &mut mpsc::UnboundedReceiver<HostEvent>) -> HostEvent {
    tokio::time::timeout(Duration::from_secs(10), rx.recv())
        .await
        .expect("an event within 10 s")
        .expect("events until Exited")
}

/// Skips what the driver emits while loading (its log line, its state).
async fn until_loaded(rx: &mut mpsc::UnboundedReceiver<HostEvent>) {
    loop {
        match next(rx).await {
            HostEvent::Loaded => return,
            HostEvent::Signal(_) => {}
            other => panic!("expected Loaded, got {other:?}"),
        }
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn segfault_on_the_fifth_command_ends_only_the_child() {
    let lib = build_c_plugin("iso_crash5", &["-DFSD_EXAMPLE_CRASH_ON_COMMAND=5"]);
    let (tx, mut rx) = mpsc::unbounded_channel();
    let host = HostProcess::spawn(
        &driver_host(),
        &lib,
        b"{}".to_vec(),
        Arc::new(move |ev| tx.send(ev).is_ok()),
    )
    .unwrap();
    until_loaded(&mut rx).await;
    for id in 1..=5 {
        host.send(command(id)).unwrap();
    }
    let mut answered = Vec::new();
    let exited = loop {
        match next(&mut rx).await {
            HostEvent::Signal(Signal::Bytes(SignalKind::CommandResponse, b)) => {
                answered.push(CommandResponse::decode(&b[..]).unwrap().request_id())
            }
            HostEvent::Exited(how) => break how,
            _ => {}
        }
    };
    assert_eq!(answered, vec![1, 2, 3, 4], "four answers, then the crash");
    assert!(exited.contains("SIGSEGV"), "{exited}");
    // This process (the "interface") is still here and can start a fresh host.
    let (tx, mut rx) = mpsc::unbounded_channel();
    let _again = HostProcess::spawn(
        &driver_host(),
        &lib,
        b"{}".to_vec(),
        Arc::new(move |ev| tx.send(ev).is_ok()),
    )
    .unwrap();
    until_loaded(&mut rx).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn rejected_config_and_clean_unload_over_the_pipe() {
    let lib = build_c_plugin("iso_ok2", &[]);
    let (tx, mut rx) = mpsc::unbounded_channel();
    let _h = HostProcess::spawn(
        &driver_host(),
        &lib,
        b"[]".to_vec(),
        Arc::new(move |ev| tx.send(ev).is_ok()),
    )
    .unwrap();
    match next(&mut rx).await {
        HostEvent::LoadFailed(Error::ConfigRejected { reason }) => {
            assert_eq!(reason, "config must be a JSON object")
        }
        other => panic!("expected the config to be rejected, got {other:?}"),
    }
    match next(&mut rx).await {
        HostEvent::Exited(how) => assert!(how.contains("exit status: 7"), "{how}"),
        other => panic!("expected the exit, got {other:?}"),
    }

    let (tx, mut rx) = mpsc::unbounded_channel();
    let h = HostProcess::spawn(
        &driver_host(),
        &lib,
        b"{}".to_vec(),
        Arc::new(move |ev| tx.send(ev).is_ok()),
    )
    .unwrap();
    until_loaded(&mut rx).await;
    h.send(Op::Tick(100_000)).unwrap();
    h.send(Op::Unload(true)).unwrap();
    let mut ticked = false;
    let how = loop {
        match next(&mut rx).await {
            HostEvent::TickDone(100_000) => ticked = true,
            HostEvent::Exited(how) => break how,
            _ => {}
        }
    };
    assert!(ticked);
    assert!(how.contains("exit status: 0"), "{how}");
}
