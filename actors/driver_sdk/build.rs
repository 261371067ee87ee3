//! Generates the Rust types of Goby3's frontseat messages (the ones that cross the driver ABI)
//! from the repository's .proto files, with protox (no system `protoc`), and tells the tests
//! which target they build C plugins for.

use std::path::PathBuf;

fn main() {
    // At run time, not env!(): a build script compiled for a clone elsewhere is reused from a
    // shared target directory (cargo hashes path packages without their location).
    let manifest = PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").unwrap_or_default());
    let proto_dir = manifest.join("../../interface_yaml/proto");
    let main_proto = "goby/middleware/frontseat/frontseat.proto";
    println!(
        "cargo:rerun-if-changed={}",
        proto_dir.join("goby").display()
    );
    let mut compiler = match protox::Compiler::new([&proto_dir]) {
        Ok(c) => c,
        Err(e) => panic!("cannot read {}: {e}", proto_dir.display()),
    };
    compiler.include_imports(true);
    if let Err(e) = compiler.open_files([main_proto]) {
        panic!("cannot compile {main_proto}: {e:?}");
    }
    let out = PathBuf::from(std::env::var_os("OUT_DIR").unwrap_or_default());
    if let Err(e) = prost_build::Config::new()
        .out_dir(&out)
        .compile_fds(compiler.file_descriptor_set())
    {
        panic!("prost-build: {e}");
    }
    println!(
        "cargo:rustc-env=FRONTSEAT_SDK_TARGET={}",
        std::env::var("TARGET").unwrap_or_default()
    );
}
