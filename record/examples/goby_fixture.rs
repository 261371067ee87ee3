//! Writes `record/tests/fixtures/goby3_v3_sample.goby`: a goby_logger file laid out entry for
//! entry as Goby3's `LogEntry::serialize` and the protobuf log plugin's write hook lay it out
//! (see record/tests/fixtures/README.md for the source lines). It is a writer of its own, kept
//! apart from the reader in `src/goby_log.rs`, so the test is not the reader agreeing with
//! itself. Run: `cargo run -p frontseat-record --example goby_fixture -- OUT.goby`.

use std::collections::{HashMap, HashSet};

use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CartesianCoordinate, DesiredCourse, NodeStatus,
};
use prost::Message as _;
use prost_reflect::prost_types::{
    DescriptorProto, FieldDescriptorProto, FileDescriptorProto, field_descriptor_proto,
};
use prost_reflect::{DescriptorPool, DynamicMessage, Value};

const PROTOBUF: u16 = 1;
const CSTR: u16 = 0;
const DCCL: u16 = 2;
const FILE_DESC_GROUP: &str = "goby::log::ProtobufFileDescriptor";
const FILE_DESC_TYPE: &str = "google.protobuf.FileDescriptorProto";

/// Goby3's writer state: static maps in LogEntry (groups_, types_, group_index_, type_index_),
/// and the plugin's written_file_desc_.
struct GobyWriter {
    out: Vec<u8>,
    groups: HashMap<(u16, String), u16>,
    types: HashMap<(u16, String), u16>,
    next_group: u16,
    next_type: u16,
    written_files: HashSet<String>,
    pool: DescriptorPool,
    now_us: u64,
}

impl GobyWriter {
    fn new(pool: DescriptorPool) -> Self {
        // Version 3, written once before the first entry.
        Self {
            out: 3u32.to_be_bytes().to_vec(),
            groups: HashMap::new(),
            types: HashMap::new(),
            next_group: 1,
            next_type: 1,
            written_files: HashSet::new(),
            pool,
            now_us: 0,
        }
    }

    fn raw(&mut self, scheme: u16, group: u16, type_ix: u16, data: &[u8]) {
        let size = 2 + 2 + 2 + 8 + data.len() as u32 + 4;
        let mut e = b"GBY3".to_vec();
        e.extend(size.to_be_bytes());
        e.extend(scheme.to_be_bytes());
        e.extend(group.to_be_bytes());
        e.extend(type_ix.to_be_bytes());
        e.extend(self.now_us.to_be_bytes());
        e.extend(data);
        let mut h = crc32fast::Hasher::new();
        h.update(&e);
        e.extend(h.finalize().to_be_bytes());
        self.out.extend(e);
    }

    fn log(&mut self, scheme: u16, type_name: &str, group: &str, data: &[u8]) {
        let gk = (scheme, group.to_string());
        if !self.groups.contains_key(&gk) {
            let ix = self.next_group;
            self.next_group += 1;
            self.groups.insert(gk.clone(), ix);
            let mut d = scheme.to_be_bytes().to_vec();
            d.extend(group.as_bytes());
            self.raw(0xFFFF, ix, 0, &d);
        }
        let tk = (scheme, type_name.to_string());
        if !self.types.contains_key(&tk) {
            let ix = self.next_type;
            self.next_type += 1;
            self.types.insert(tk.clone(), ix);
            let mut d = scheme.to_be_bytes().to_vec();
            d.extend(type_name.as_bytes());
            self.raw(0xFFFE, 0, ix, &d);
            // new_type_hook[PROTOBUF] and [DCCL] (dccl_log_plugin.h: the same plugin base): the
            // type's file and its dependencies, dependencies first.
            if scheme == PROTOBUF || scheme == DCCL {
                self.add_type(type_name);
            }
        }
        let (g, t) = (self.groups[&gk], self.types[&tk]);
        self.raw(scheme, g, t, data);
    }

    fn add_type(&mut self, type_name: &str) {
        let Some(msg) = self.pool.get_message_by_name(type_name) else {
            // Goby3 warns "Unknown protobuf type" and writes no descriptor.
            return;
        };
        let name = msg.parent_file().name().to_string();
        self.insert_file(&name);
    }

    fn insert_file(&mut self, name: &str) {
        if self.written_files.contains(name) {
            return;
        }
        let Some(f) = self.pool.get_file_by_name(name) else {
            return;
        };
        for d in f.dependencies() {
            self.insert_file(d.name());
        }
        self.written_files.insert(name.to_string());
        let bytes = f.file_descriptor_proto().encode_to_vec();
        self.log(PROTOBUF, FILE_DESC_TYPE, FILE_DESC_GROUP, &bytes);
    }
}

/// A message type no frontseat binary is compiled with: the import must use the file's own
/// descriptors to carry it.
fn salinity_file() -> FileDescriptorProto {
    let field = |name: &str, number: i32, ty: field_descriptor_proto::Type| FieldDescriptorProto {
        name: Some(name.into()),
        number: Some(number),
        label: Some(field_descriptor_proto::Label::Optional as i32),
        r#type: Some(ty as i32),
        json_name: Some(name.into()),
        ..Default::default()
    };
    FileDescriptorProto {
        name: Some("example/science.proto".into()),
        package: Some("example.science".into()),
        syntax: Some("proto2".into()),
        message_type: vec![DescriptorProto {
            name: Some("Salinity".into()),
            field: vec![
                field("time", 1, field_descriptor_proto::Type::Double),
                field("psu", 2, field_descriptor_proto::Type::Double),
            ],
            ..Default::default()
        }],
        ..Default::default()
    }
}

fn main() {
    let out = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "record/tests/fixtures/goby3_v3_sample.goby".into());
    let mut pool = DescriptorPool::decode(frontseat_actors::proto::FILE_DESCRIPTOR_SET)
        .expect("compiled descriptors");
    pool.add_file_descriptor_proto(salinity_file())
        .expect("salinity file");
    let salinity = pool
        .get_message_by_name("example.science.Salinity")
        .expect("salinity type");
    let mut w = GobyWriter::new(pool);
    let t0_us: u64 = 1_764_000_000_000_000; // 2025-11-24T16:00:00Z
    for i in 0..30u64 {
        w.now_us = t0_us + i * 1_000_000;
        let mut n = NodeStatus {
            time: (w.now_us as f64) / 1e6,
            name: Some("goby-auv".into()),
            ..Default::default()
        };
        n.global_fix.lat = 41.5 + i as f64 * 1e-5;
        n.global_fix.lon = -70.7;
        n.local_fix = Some(CartesianCoordinate {
            x: i as f64 * 1.5,
            y: 0.0,
            z: None,
        });
        n.pose.heading = Some(90.0);
        n.speed.over_ground = 1.5;
        w.log(
            PROTOBUF,
            "goby.middleware.frontseat.protobuf.NodeStatus",
            "goby::middleware::frontseat::node_status",
            &n.encode_to_vec(),
        );
        if i % 5 == 0 {
            w.now_us += 100_000;
            let c = DesiredCourse {
                time: (w.now_us as f64) / 1e6,
                heading: Some(90.0),
                speed: Some(1.5),
                ..Default::default()
            };
            w.log(
                PROTOBUF,
                "goby.middleware.frontseat.protobuf.DesiredCourse",
                "goby::middleware::frontseat::desired_course",
                &c.encode_to_vec(),
            );
            let mut s = DynamicMessage::new(salinity.clone());
            s.set_field_by_name("time", Value::F64((w.now_us as f64) / 1e6));
            s.set_field_by_name("psu", Value::F64(34.5 + i as f64 * 0.01));
            w.log(
                PROTOBUF,
                "example.science.Salinity",
                "example::science::salinity",
                &s.encode_to_vec(),
            );
            // A CSTR entry (scheme 0): the import skips it and says so.
            w.log(CSTR, "CSTR", "example::operator_note", b"leg start");
            // DCCL entries (scheme 2) of a type this file has no descriptor for (Goby3 warns
            // "Unknown protobuf type" and writes none): DCCL-encoded bytes the import skips and
            // counts per group.
            w.log(
                DCCL,
                "example.acomms.USBLFix",
                "example::acomms::usbl_fix",
                &[0x7d, i as u8, 0x12, 0x34],
            );
            if i % 10 == 0 {
                w.log(
                    DCCL,
                    "example.acomms.ModemStatus",
                    "example::acomms::modem_status",
                    &[0x7e, i as u8],
                );
            }
        }
    }
    std::fs::write(&out, &w.out).expect("write the fixture");
    eprintln!("wrote {out} ({} bytes)", w.out.len());
}
