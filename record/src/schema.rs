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

/// Whether prost-reflect can be handed this file: 0.16 panics (an index out of bounds in
/// `Label::new`, while reporting the error) on a `syntax` other than proto2 or proto3, because it
/// labels the error with a file it has not stored yet. Found by the `mcap_reader` fuzz target.
pub fn known_syntax(f: &prost_reflect::prost_types::FileDescriptorProto) -> bool {
    matches!(f.syntax.as_deref(), None | Some("proto2" | "proto3"))
}

/// `DescriptorPool::decode` for a set read from a file (an MCAP schema, untrusted): `None` when it
/// does not decode, or holds a file prost-reflect would panic on ([`known_syntax`]).
pub fn decode_untrusted_pool(bytes: &[u8]) -> Option<DescriptorPool> {
    let set = FileDescriptorSet::decode(bytes).ok()?;
    if !set.file.iter().all(known_syntax) {
        return None;
    }
    DescriptorPool::decode(bytes).ok()
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

    /// The `mcap_reader` fuzz finding (fuzz/corpus/mcap_reader/found_unknown_syntax.mcap): a
    /// schema whose file says `syntax = "prott2"` made prost-reflect panic; it is refused instead.
    #[test]
    fn unknown_syntax_is_refused_not_a_panic() {
        use prost_reflect::prost_types::FileDescriptorProto;
        for syntax in ["prott2", "", "editions"] {
            let set = FileDescriptorSet {
                file: vec![FileDescriptorProto {
                    name: Some("t.proto".into()),
                    syntax: Some(syntax.into()),
                    ..Default::default()
                }],
            }
            .encode_to_vec();
            assert!(decode_untrusted_pool(&set).is_none(), "{syntax:?}");
        }
        let ok = FileDescriptorSet {
            file: vec![FileDescriptorProto {
                name: Some("t.proto".into()),
                syntax: Some("proto3".into()),
                ..Default::default()
            }],
        }
        .encode_to_vec();
        assert!(decode_untrusted_pool(&ok).is_some());
    }

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
