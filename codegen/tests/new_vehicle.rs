//! Adding a vehicle adds a file: the real `interface_yaml/` plus one new vehicle yaml compiles, the
//! new groups join the generated extension table with their kind, vehicle and base fields, and
//! the FrontSeatInterface's inbox still has exactly one variant for every vehicle's extensions.

use std::path::PathBuf;

use frontseat_codegen::{ExtensionKind, compile, yaml_files};

#[test]
fn a_new_vehicle_yaml_joins_the_extension_table_without_a_new_inbox_variant() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let dir = root.join("../interface_yaml");
    let mut files = yaml_files(&dir).unwrap();
    let before = compile(
        &files,
        &dir.join("proto"),
        tempfile::tempdir().unwrap().path(),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    files.push(root.join("tests/fixtures/new_vehicle/example.yaml"));
    let out = tempfile::tempdir().unwrap();
    let after = compile(&files, &dir.join("proto"), out.path()).unwrap_or_else(|e| panic!("{e}"));

    let m = &after.model;
    assert_eq!(m.extensions.len(), before.model.extensions.len() + 2);
    let find = |name: &str| {
        m.extensions
            .iter()
            .find(|x| m.groups[x.group].name == name)
            .unwrap_or_else(|| panic!("{name} not in {:?}", m.extensions))
    };
    let cmd = find("frontseat::example::example_command_request");
    assert_eq!(cmd.kind, ExtensionKind::Command);
    assert_eq!(cmd.vehicle, "Example");
    assert_eq!(cmd.actor, "FrontSeatInterface");
    // CommandRequest's own fields: desired_course, response_requested, request_id, cancel_request_id.
    assert_eq!(cmd.base_fields, [1, 10, 11, 20]);
    let nav = find("frontseat::example::example_data_from_frontseat");
    assert_eq!(nav.kind, ExtensionKind::Navigation);

    // The table is sorted by group, and each port points at its own row.
    let names: Vec<&str> = m
        .extensions
        .iter()
        .map(|x| m.groups[x.group].name.as_str())
        .collect();
    let mut sorted = names.clone();
    sorted.sort();
    assert_eq!(names, sorted);
    let fsi = m
        .actors
        .iter()
        .find(|a| a.name == "FrontSeatInterface")
        .unwrap();
    for p in fsi.subscribes.iter().chain(fsi.publishes.iter()) {
        if let Some(i) = p.extension {
            assert_eq!(m.extensions[i].group, p.group);
        }
    }

    // One `VehicleExtension` variant before and after; the new groups are data, not code.
    let variant = "VehicleExtension(Envelope<super::extensions::Encoded>)";
    assert_eq!(before.rust.matches(variant).count(), 1);
    assert_eq!(after.rust.matches(variant).count(), 1);
    assert!(
        after
            .rust
            .contains("group: \"frontseat::example::example_command_request\"")
    );
    assert!(!before.rust.contains("example_command_request"));

    // `frontseat interfaces` prints the vehicle file as it was written.
    let app = after
        .resolved_yaml
        .split("---\n")
        .find(|a| a.starts_with("application: vehicle_example\n"))
        .unwrap_or_else(|| panic!("{}", after.resolved_yaml));
    assert!(app.contains("vehicle: Example\n"), "{app}");
    assert!(
        app.contains(
            "    - group: frontseat::example::example_command_request\n      \
             type: frontseat.protobuf.iver.CommandRequest\n      actor: FrontSeatInterface\n      \
             extension: command\n"
        ),
        "{app}"
    );
}
