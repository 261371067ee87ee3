//! Runs the interface compiler: `interface_yaml/` (yaml + .proto) → `OUT_DIR/frontseat_interfaces.rs`,
//! included by `src/generated.rs`. A bad declaration fails the build with the yaml file and line.

fn main() {
    // At run time, not env!(): a build script compiled for a clone elsewhere is reused from a
    // shared target directory (cargo hashes path packages without their location).
    let manifest_dir =
        std::path::PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").unwrap_or_default());
    frontseat_codegen::run_build_script(&manifest_dir.join("../interface_yaml"));
}
