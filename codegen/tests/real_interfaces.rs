//! The real `interface_yaml/` compiles, and what it declares comes out as the generated model.

use std::path::PathBuf;

use frontseat_codegen::{Layer, compile, yaml_files};

fn yaml_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../interface_yaml")
}

#[test]
fn real_interface_yaml_compiles() {
    let out = tempfile::tempdir().unwrap();
    let dir = yaml_dir();
    let files = yaml_files(&dir).unwrap();
    for app in [
        "frontseat_interface.yaml",
        "basic_frontseat_simulator.yaml",
        "demo_helm.yaml",
        "chaos.yaml",
        "web.yaml",
    ] {
        assert!(
            files.iter().any(|f| f.ends_with(app)),
            "{app} missing from {files:?}"
        );
    }
    let compiled = match compile(&files, &dir.join("proto"), out.path()) {
        Ok(c) => c,
        Err(e) => panic!("{e}"),
    };
    if std::env::var_os("DUMP_GENERATED").is_some() {
        std::fs::write("/tmp/frontseat_generated.rs", &compiled.rust).unwrap();
    }
    let m = &compiled.model;
    let node_status = m
        .groups
        .iter()
        .find(|g| g.name == "goby::middleware::frontseat::node_status")
        .unwrap();
    assert_eq!(
        node_status.type_name,
        "goby.middleware.frontseat.protobuf.NodeStatus"
    );
    assert_eq!(
        node_status.const_name,
        "GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS"
    );
    assert_eq!(node_status.layer, Layer::Interprocess);
    // The bench's stand-in vehicle publishes node_status with no interface behind it.
    assert_eq!(
        node_status.publishers,
        ["BenchVehicle", "FrontSeatInterface"]
    );
    // helm_state is interthread in demo_helm and interprocess in frontseat_interface: widest wins.
    let helm = m
        .groups
        .iter()
        .find(|g| g.name == "goby::middleware::frontseat::helm_state")
        .unwrap();
    assert_eq!(helm.layer, Layer::Interprocess);
    assert_eq!(
        helm.publishers,
        [
            "BenchHelm",
            "ChaosHelm",
            "DemoHelm",
            "FrontSeatTranslation",
            "OpenCpnHelm",
            "WebCommander"
        ]
    );
    let ground_truth = m
        .groups
        .iter()
        .find(|g| g.name == "frontseat::sim::ground_truth")
        .unwrap();
    assert_eq!(ground_truth.layer, Layer::Interthread);
    let actors: Vec<&str> = m.actors.iter().map(|a| a.name.as_str()).collect();
    assert_eq!(
        actors,
        [
            "AisReporter",
            "ArdupilotPilot",
            "BenchHelm",
            "BenchNavWatch",
            "BenchRawWatch",
            "BenchStatusWatch",
            "BenchVehicle",
            "ChaosHelm",
            "ChaosMonitor",
            "ChaosMonkey",
            "ChaosSimMonkey",
            "ChaosStalled",
            "Coroner",
            "DemoHelm",
            "DriverActor",
            "DriverFaults",
            "FrontSeatInterface",
            "FrontSeatTranslation",
            "HealthInterfaceWatch",
            "HealthReporter",
            "HealthSupervisionWatch",
            "InterfaceFaults",
            "OpenCpnHelm",
            "RootSupervisor",
            "Simulator",
            "SystemdInterfaceWatch",
            "SystemdTranslationWatch",
            "TranslationFaults",
            "WebCommander"
        ]
    );
    assert!(
        compiled
            .rust
            .contains("pub struct FrontSeatTranslationPorts")
    );
    assert!(compiled.rust.contains("pub fn publish_helm_state("));
    assert!(
        compiled
            .resolved_yaml
            .contains("application: frontseat_interface\ninterprocess:\n  publishes:\n")
    );
    // Every input is reported for rerun-if-changed.
    assert!(
        compiled
            .inputs
            .iter()
            .any(|p| p.ends_with("frontseat.proto"))
    );
    assert!(
        compiled
            .inputs
            .iter()
            .any(|p| p.ends_with("demo_helm.yaml"))
    );
}
