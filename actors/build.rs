//! Runs the interface compiler: `interface_yaml/` (yaml + .proto) → `OUT_DIR/frontseat_interfaces.rs`,
//! included by `src/generated.rs`. A bad declaration fails the build with the yaml file and line.

fn main() {
    let manifest_dir = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    frontseat_codegen::run_build_script(&manifest_dir.join("../interface_yaml"));
}
