//! Compiles the descriptors of Goby3's config messages (proto/goby3/) into OUT_DIR, so that a
//! Goby3 .pb.cfg is read with Goby3's own names and types (see src/goby3_import/text.rs).

use prost::Message;

fn main() {
    println!("cargo:rerun-if-changed=proto/goby3");
    println!("cargo:rerun-if-changed=../interface_yaml/proto");
    let files = [
        "app_config.proto",
        "middleware_app.proto",
        "interprocess.proto",
        "frontseat_config.proto",
        "apps.proto",
        "moos.proto",
        "moos_helm.proto",
    ];
    let fds = match protox::compile(files, ["proto/goby3", "../interface_yaml/proto"]) {
        Ok(f) => f,
        Err(e) => panic!("proto/goby3 does not compile: {e}"),
    };
    let out = std::path::PathBuf::from(std::env::var("OUT_DIR").unwrap_or_else(|_| ".".into()));
    if let Err(e) = std::fs::write(out.join("goby3_config.bin"), fds.encode_to_vec()) {
        panic!("cannot write the Goby3 config descriptors: {e}");
    }
}
