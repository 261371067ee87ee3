//! Per message type, the protobuf FileDescriptorSet an MCAP `protobuf` schema carries: the file
//! declaring the type and every file it imports, dependencies first (the order the reference
//! readers build their pools in). Built from the descriptors compiled into the binary, so a
//! recording needs no .proto files to be read anywhere.

use std::collections::HashSet;
use std::sync::OnceLock;

use prost::Message as _;
use prost_reflect::prost_types::FileDescriptorSet;
use prost_reflect::{DescriptorPool, FileDescriptor};

/// The pool of every message compiled into this binary; `None` if the embedded set does not
/// decode (a build defect, reported by the recorder as an error at start).
pub fn compiled_pool() -> Option<&'static DescriptorPool> {
    static POOL: OnceLock<Option<DescriptorPool>> = OnceLock::new();
    POOL.get_or_init(|| DescriptorPool::decode(frontseat_actors::proto::FILE_DESCRIPTOR_SET).ok())
        .as_ref()
}

/// The encoded FileDescriptorSet describing `type_name` (a proto full name), or `None` when the
/// pool has no such message.
pub fn descriptor_set(pool: &DescriptorPool, type_name: &str) -> Option<Vec<u8>> {
    let msg = pool.get_message_by_name(type_name)?;
    let mut seen = HashSet::new();
    let mut files = Vec::new();
    push_with_deps(msg.parent_file(), &mut seen, &mut files);
    Some(FileDescriptorSet { file: files }.encode_to_vec())
}

fn push_with_deps(
    f: FileDescriptor,
    seen: &mut HashSet<String>,
    out: &mut Vec<prost_reflect::prost_types::FileDescriptorProto>,
) {
    if !seen.insert(f.name().to_string()) {
        return;
    }
    for d in f.dependencies() {
        push_with_deps(d, seen, out);
    }
    out.push(f.file_descriptor_proto().clone());
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn node_status_schema_stands_alone() {
        let pool = compiled_pool().expect("compiled descriptors decode");
        let bytes = descriptor_set(pool, "goby.middleware.frontseat.protobuf.NodeStatus")
            .expect("NodeStatus is compiled");
        // A fresh pool built from the schema alone knows the type: nothing else is needed.
        let alone = DescriptorPool::decode(bytes.as_slice()).expect("self-contained set");
        assert!(
            alone
                .get_message_by_name("goby.middleware.frontseat.protobuf.NodeStatus")
                .is_some()
        );
        assert!(descriptor_set(pool, "no.such.Type").is_none());
    }
}
