//! One bad-yaml fixture per rule: each must fail with its rule, its message, and the fixture's
//! file name and line.

use std::path::PathBuf;

use frontseat_codegen::{Diagnostic, Rule, compile, yaml_files};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn proto_dir() -> PathBuf {
    root().join("../interface_yaml/proto")
}

fn diagnostics(files: &[PathBuf]) -> Vec<Diagnostic> {
    let out = tempfile::tempdir().unwrap();
    match compile(files, &proto_dir(), out.path()) {
        Ok(_) => panic!("{files:?} compiled, but must not"),
        Err(e) => {
            assert!(!e.diagnostics().is_empty(), "not a yaml diagnostic: {e}");
            e.diagnostics().to_vec()
        }
    }
}

/// (fixture, rule, line, fragment of the message)
const CASES: &[(&str, Rule, u64, &str)] = &[
    (
        "unknown_type.yaml",
        Rule::UnknownType,
        6,
        "unknown message type `goby.middleware.frontseat.protobuf.NodeStatsu`",
    ),
    (
        "two_types.yaml",
        Rule::TwoTypes,
        11,
        "group `goby::middleware::frontseat::status` carries two types: `frontseat.protobuf.DriverStatus` here and `goby.middleware.frontseat.protobuf.InterfaceStatus` (line 6)",
    ),
    (
        "duplicate.yaml",
        Rule::Duplicate,
        8,
        "duplicate declaration: actor `Simulator` already subscribes `frontseat::sim::fault` in layer `interthread` of application `bad_duplicate` (line 5)",
    ),
    (
        "unknown_layer.yaml",
        Rule::UnknownLayer,
        8,
        "unknown layer `intervehicle` (expected `interprocess` or `interthread`)",
    ),
    (
        "type_mismatch.yaml",
        Rule::TypeMismatch,
        10,
        "actor `FrontSeatInterface` subscribes `goby::middleware::frontseat::desired_course` as `goby.middleware.frontseat.protobuf.CommandRequest`, but its publisher `FrontSeatTranslation` publishes `goby.middleware.frontseat.protobuf.DesiredCourse`",
    ),
    (
        "unknown_key.yaml",
        Rule::UnknownKey,
        3,
        "unknown key `version` (expected `application`, `vehicle`, `interprocess` or `interthread`)",
    ),
    (
        "missing_field.yaml",
        Rule::MissingField,
        5,
        "missing field `actor` in a `publishes` entry of layer `interthread`",
    ),
    (
        "missing_application.yaml",
        Rule::MissingField,
        2,
        "missing `application:`",
    ),
    (
        "name_collision.yaml",
        Rule::NameCollision,
        8,
        "actor `FrontSeatInterface`: groups `frontseat::interface::status` and `goby::middleware::frontseat::status`",
    ),
    (
        "invalid_name.yaml",
        Rule::InvalidName,
        5,
        "invalid group name `frontseat::sim::ground-truth`",
    ),
    (
        "wrong_shape.yaml",
        Rule::Syntax,
        6,
        "expected string scalar",
    ),
    ("syntax.yaml", Rule::Syntax, 7, ""),
    (
        "extension_unknown_kind.yaml",
        Rule::Extension,
        9,
        "unknown extension kind `steer_anywhere` (expected one of `command`, `mode`, `data`, `navigation`, `navigation_copy`)",
    ),
    (
        "extension_direction.yaml",
        Rule::Extension,
        9,
        "extension `command` is declared under `publishes`, but the interface subscribes to it",
    ),
    (
        "extension_no_vehicle.yaml",
        Rule::Extension,
        8,
        "an `extension:` entry needs the file's `vehicle:`",
    ),
    (
        "extension_not_mirror.yaml",
        Rule::Extension,
        9,
        "`frontseat.protobuf.bluefin.InterfaceData` is not a mirror of `goby.middleware.frontseat.protobuf.CommandRequest`: field 1 `desired_course`",
    ),
    (
        "extension_interthread.yaml",
        Rule::Extension,
        9,
        "extension `data` must be `interprocess`",
    ),
];

#[test]
fn every_rule_fails_with_file_line_and_message() {
    for &(fixture, rule, line, fragment) in CASES {
        let path = root().join("tests/fixtures").join(fixture);
        let diags = diagnostics(std::slice::from_ref(&path));
        assert_eq!(
            diags.len(),
            1,
            "{fixture}: expected one diagnostic, got {diags:#?}"
        );
        let d = &diags[0];
        assert_eq!(d.rule, rule, "{fixture}: {d}");
        assert_eq!(d.line, line, "{fixture}: {d}");
        assert_eq!(d.file, path, "{fixture}: {d}");
        let text = d.to_string();
        eprintln!("{text}");
        assert!(
            text.starts_with(&format!("{}:{line}:", path.display())),
            "{fixture}: `{text}` does not start with file:line"
        );
        assert!(
            text.contains(fragment),
            "{fixture}: `{text}` lacks `{fragment}`"
        );
    }
}

#[test]
fn every_fixture_is_in_the_table() {
    let dir = root().join("tests/fixtures");
    for f in yaml_files(&dir).unwrap() {
        let name = f.file_name().unwrap().to_str().unwrap();
        assert!(
            CASES.iter().any(|c| c.0 == name) || name == "cross_file_mismatch.yaml",
            "fixture {name} is not tested"
        );
    }
}

#[test]
fn a_mismatch_across_files_names_both_files() {
    let mut files = yaml_files(&root().join("../interface_yaml")).unwrap();
    let bad = root().join("tests/fixtures/cross_file_mismatch.yaml");
    files.push(bad.clone());
    let diags = diagnostics(&files);
    assert_eq!(diags.len(), 1, "{diags:#?}");
    let d = &diags[0];
    assert_eq!(
        (d.rule, &d.file, d.line),
        (Rule::TypeMismatch, &bad, 7),
        "{d}"
    );
    // The other side is whichever real file declares a node_status publisher first (today
    // bench.yaml's BenchVehicle, before frontseat_interface.yaml's FrontSeatInterface).
    assert!(
        d.message.contains("interface_yaml/") && d.message.contains(".yaml:"),
        "{d}"
    );
}

#[test]
fn all_violations_of_a_run_are_reported_together() {
    let dir = root().join("tests/fixtures");
    let files: Vec<PathBuf> = ["unknown_type.yaml", "duplicate.yaml", "unknown_key.yaml"]
        .iter()
        .map(|f| dir.join(f))
        .collect();
    let diags = diagnostics(&files);
    let rules: Vec<Rule> = diags.iter().map(|d| d.rule).collect();
    assert_eq!(
        rules,
        [Rule::Duplicate, Rule::UnknownKey, Rule::UnknownType]
    );
}

#[test]
fn the_error_display_lists_every_diagnostic() {
    let path = root().join("tests/fixtures/unknown_type.yaml");
    let out = tempfile::tempdir().unwrap();
    let err = compile(std::slice::from_ref(&path), &proto_dir(), out.path())
        .err()
        .unwrap();
    let text = err.to_string();
    assert!(text.starts_with("invalid interface yaml:\n"), "{text}");
    assert!(
        text.contains("unknown_type.yaml:6:13: unknown message type"),
        "{text}"
    );
    assert!(
        text.contains("(did you mean"),
        "suggestion expected: {text}"
    );
}
