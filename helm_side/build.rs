//! Compiles Goby3's interprocess manager schema (`proto/goby/zeromq/protobuf/interprocess_zeromq.proto`,
//! gobyd's ManagerRequest/ManagerResponse) with protox + prost-build: no system `protoc`. It is not
//! part of `interface_yaml/` because no actor publishes it: only the Goby3 transport speaks it.

fn main() {
    let file = "goby/zeromq/protobuf/interprocess_zeromq.proto";
    println!("cargo:rerun-if-changed=proto/{file}");
    let fds = match protox::compile([file], ["proto"]) {
        Ok(f) => f,
        Err(e) => panic!("proto/{file}: {e:?}"),
    };
    if let Err(e) = prost_build::Config::new().compile_fds(fds) {
        panic!("prost-build on proto/{file}: {e}");
    }
}
