//! `frontseat log import`: a goby_logger `.goby` file converted to MCAP, self-described the same
//! way our own recordings are. The `.goby` file carries the FileDescriptorProtos of its message
//! types (entries of group `goby::log::ProtobufFileDescriptor`, Goby3's protobuf_log_plugin.h),
//! so types this binary was never compiled with are imported too; a type whose descriptors the
//! file lacks falls back to the types compiled into this binary.
//!
//! Only the PROTOBUF scheme is converted: DCCL payloads need the DCCL codec (Goby3 decodes them
//! with it even though their descriptors are in the file), and CSTR, MAVLink and C++ objects have
//! no protobuf schema; those entries are skipped and counted per scheme and per group, in the
//! command's output and in the MCAP file's [`META_IMPORT_SKIPPED`] metadata.

use std::collections::{BTreeMap, HashMap};
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use prost::Message as _;
use prost_reflect::prost_types::FileDescriptorProto;
use prost_reflect::{DescriptorPool, DynamicMessage, MessageDescriptor};

use crate::goby_log::{GobyLogError, GobyReadStats, GobyReader};
use crate::{CHANNEL_ORIGIN, META_IMPORT_SKIPPED, META_RECORDER, META_RUN, PROFILE};

/// Goby3's MarshallingScheme::PROTOBUF (marshalling/interface.h).
pub const SCHEME_PROTOBUF: u16 = 1;
/// The group goby_logger writes FileDescriptorProtos on (protobuf_log_plugin.h `file_desc_group`).
pub const FILE_DESC_GROUP: &str = "goby::log::ProtobufFileDescriptor";
const FILE_DESC_TYPE: &str = "google.protobuf.FileDescriptorProto";
/// Descriptor files accepted from one file: a real log has tens; more is a hostile file.
const MAX_DESCRIPTOR_FILES: usize = 4096;
/// Channels created in the output (distinct group/type pairs): bounded for the same reason.
const MAX_CHANNELS: usize = 4096;
/// Where skipped entries are counted once [`MAX_CHANNELS`] (scheme, group) pairs are listed.
pub const OTHER_GROUPS: &str = "(other groups)";

#[derive(Debug, thiserror::Error)]
pub enum ImportError {
    #[error(transparent)]
    Goby(#[from] GobyLogError),
    #[error("writing the MCAP file: {0}")]
    Mcap(#[from] mcap::McapError),
}

/// Why [`import_file`] did not write its output.
#[derive(Debug, thiserror::Error)]
pub enum ImportFileError {
    #[error(transparent)]
    Output(#[from] crate::output::OutputError),
    #[error("cannot open {path}: {source}")]
    Open {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: {source}")]
    Import { path: PathBuf, source: ImportError },
}

impl ImportFileError {
    /// Whether the request itself was refused (exit 2) rather than failed.
    pub fn is_usage(&self) -> bool {
        matches!(self, Self::Output(o) if o.is_usage())
    }
}

/// [`import`] from the file `file` into `out` (default: `file` with the extension `.mcap`),
/// refusing to replace an existing output unless `force`, and refusing an output that is the
/// input (same inode). The MCAP is written under a temporary name beside its target
/// ([`crate::output`]: never through a symlink) and renamed at the end: an interrupted import
/// leaves no half-written file under the name a user would open. Returns the output path with
/// the stats.
pub fn import_file(
    file: &Path,
    out: Option<PathBuf>,
    force: bool,
) -> Result<(PathBuf, ImportStats), ImportFileError> {
    let out = out.unwrap_or_else(|| file.with_extension("mcap"));
    let src = std::fs::File::open(file).map_err(|source| ImportFileError::Open {
        path: file.to_path_buf(),
        source,
    })?;
    let mut dst = crate::output::Output::create(&out, force, &[file])?;
    let name = file
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    match import(std::io::BufReader::new(src), &mut dst, &name) {
        Ok(stats) => Ok((dst.commit()?, stats)),
        // Dropping `dst` removes the temporary file.
        Err(source) => Err(ImportFileError::Import {
            path: file.to_path_buf(),
            source,
        }),
    }
}

/// What an import did.
#[derive(Clone, Debug, Default)]
pub struct ImportStats {
    pub read: GobyReadStats,
    pub version: u32,
    pub written: u64,
    pub descriptor_files: u64,
    /// Descriptor entries that did not decode or did not fit the pool (missing dependency,
    /// conflicting redefinition).
    pub bad_descriptors: u64,
    /// Entries of other schemes, by scheme name.
    pub skipped_schemes: BTreeMap<String, u64>,
    /// The same entries by (scheme name, group); at most [`MAX_CHANNELS`] pairs, the rest under
    /// the group [`OTHER_GROUPS`].
    pub skipped_groups: BTreeMap<(String, String), u64>,
    /// PROTOBUF entries whose type no descriptor describes.
    pub no_schema: u64,
    /// PROTOBUF entries whose bytes do not decode as their type.
    pub undecodable: u64,
    /// Entries past [`MAX_CHANNELS`] distinct group/type pairs.
    pub too_many_channels: u64,
    pub first_us: Option<u64>,
    pub last_us: Option<u64>,
}

impl ImportStats {
    pub fn skipped(&self) -> u64 {
        self.skipped_schemes.values().sum::<u64>()
            + self.no_schema
            + self.undecodable
            + self.too_many_channels
    }

    /// One paragraph for the operator.
    pub fn render(&self) -> String {
        let mut s = format!(
            "goby_logger file version {}: {} messages written, {} descriptor files read",
            self.version, self.written, self.descriptor_files
        );
        for (k, v) in &self.skipped_schemes {
            let why = if k == "DCCL" {
                "no DCCL codec here"
            } else {
                "no protobuf schema"
            };
            let by_group: Vec<String> = self
                .skipped_groups
                .iter()
                .filter(|((scheme, _), _)| scheme == k)
                .map(|((_, group), n)| format!("{group} {n}"))
                .collect();
            s += &format!(
                "; {v} {k} entries skipped ({why}; by group: {})",
                by_group.join(", ")
            );
        }
        for (n, what) in [
            (self.no_schema, "without a descriptor for their type"),
            (self.undecodable, "that do not decode as their type"),
            (self.bad_descriptors, "bad descriptor entries"),
            (self.too_many_channels, "past the channel limit"),
            (self.read.crc_errors, "entries with a bad CRC"),
            (self.read.bad_sizes, "entries with an impossible size"),
            (self.read.unresolved, "entries without an index entry"),
        ] {
            if n > 0 {
                s += &format!("; {n} {what}");
            }
        }
        if self.read.skipped_bytes > 0 {
            s += &format!("; {} damaged bytes passed over", self.read.skipped_bytes);
        }
        if self.read.torn_tail {
            s += "; the file ends inside an entry (cut short)";
        }
        if self.version < 3 {
            s += "; this version has no timestamps: messages are numbered 1 ns apart from 0";
        }
        s
    }
}

fn scheme_name(s: u16) -> String {
    // Goby3 marshalling/interface.h MarshallingScheme.
    match s {
        0 => "CSTR".into(),
        1 => "PROTOBUF".into(),
        2 => "DCCL".into(),
        5 => "CXX_OBJECT".into(),
        6 => "MAVLINK".into(),
        n => format!("scheme {n}"),
    }
}

/// Converts the `.goby` stream `src` into an MCAP written to `out`; `source_name` goes into the
/// run metadata.
pub fn import<R: Read, W: Write + std::io::Seek>(
    src: R,
    out: W,
    source_name: &str,
) -> Result<ImportStats, ImportError> {
    let mut reader = GobyReader::new(src);
    let mut stats = ImportStats::default();
    let mut pool = DescriptorPool::new();
    let compiled = crate::schema::compiled_pool();
    let mut writer = mcap::WriteOptions::new()
        .profile(PROFILE)
        .library(format!(
            "frontseat-record {} (log import)",
            env!("CARGO_PKG_VERSION")
        ))
        .compression(Some(mcap::Compression::Zstd))
        .create(out)?;
    // The first entry fixes the version; read it before the run metadata names it.
    let mut pending = reader.next_entry()?;
    stats.version = reader.version().unwrap_or(0);
    let mut run = BTreeMap::new();
    run.insert("source".to_string(), "goby_logger".to_string());
    run.insert("source_file".to_string(), source_name.to_string());
    run.insert("goby_log_version".to_string(), stats.version.to_string());
    run.insert("version".to_string(), env!("CARGO_PKG_VERSION").to_string());
    writer.write_metadata(&mcap::records::Metadata {
        name: META_RUN.into(),
        metadata: run,
    })?;
    // Keyed by the interned names' allocations (GobyReader gives one per distinct name): no
    // work per entry grows with a group's or type's length.
    let mut schemas: HashMap<Interned, u16> = HashMap::new();
    let mut channels: HashMap<(Interned, Interned), u16> = HashMap::new();
    let mut skipped: HashMap<(u16, Interned), u64> = HashMap::new();
    let mut skipped_other: HashMap<u16, u64> = HashMap::new();
    let mut descs: HashMap<Interned, (MessageDescriptor, bool)> = HashMap::new();
    let mut seq = 0u32;
    let mut n = 0u64;
    while let Some(e) = pending.take() {
        n += 1;
        if e.scheme == SCHEME_PROTOBUF
            && *e.group == *FILE_DESC_GROUP
            && *e.type_name == *FILE_DESC_TYPE
        {
            if add_descriptor(&mut pool, &e.data, &mut stats) {
                // A type looked up in the compiled pool may now be in the file's own.
                descs.clear();
            }
        } else if e.scheme != SCHEME_PROTOBUF {
            let key = (e.scheme, Interned(e.group.clone()));
            if let Some(c) = skipped.get_mut(&key) {
                *c += 1;
            } else if skipped.len() >= MAX_CHANNELS {
                *skipped_other.entry(e.scheme).or_default() += 1;
            } else {
                skipped.insert(key, 1);
            }
        } else {
            let ty = Interned(e.type_name.clone());
            let desc = match descs.get(&ty) {
                Some((d, own)) => Some((d.clone(), if *own { &pool } else { compiled_or(&pool) })),
                None => {
                    let found = pool
                        .get_message_by_name(&e.type_name)
                        .map(|d| (d, true))
                        .or_else(|| {
                            compiled.and_then(|c| {
                                c.get_message_by_name(&e.type_name).map(|d| (d, false))
                            })
                        });
                    found.map(|(d, own)| {
                        descs.insert(ty.clone(), (d.clone(), own));
                        (d, if own { &pool } else { compiled_or(&pool) })
                    })
                }
            };
            match desc {
                None => stats.no_schema += 1,
                Some((d, _)) if DynamicMessage::decode(d.clone(), e.data.as_slice()).is_err() => {
                    stats.undecodable += 1;
                }
                Some((_, p)) => {
                    let key = (Interned(e.group.clone()), ty);
                    let channel = match channels.get(&key) {
                        Some(c) => Some(*c),
                        None if channels.len() >= MAX_CHANNELS => None,
                        None => {
                            let schema = match schemas.get(&key.1) {
                                Some(s) => *s,
                                None => {
                                    let data = crate::schema::descriptor_set(p, &e.type_name)
                                        .unwrap_or_default();
                                    let s = writer.add_schema(&e.type_name, "protobuf", &data)?;
                                    schemas.insert(key.1.clone(), s);
                                    s
                                }
                            };
                            let mut meta = BTreeMap::new();
                            meta.insert(CHANNEL_ORIGIN.to_string(), "imported".to_string());
                            let c = writer.add_channel(schema, &e.group, "protobuf", &meta)?;
                            channels.insert(key, c);
                            Some(c)
                        }
                    };
                    match channel {
                        None => stats.too_many_channels += 1,
                        Some(c) => {
                            // Version 3 stamps microseconds; older files are numbered instead.
                            let t = e.time_us.map_or(n, |us| us.saturating_mul(1000));
                            if let Some(us) = e.time_us {
                                stats.first_us.get_or_insert(us);
                                stats.last_us = Some(us);
                            }
                            seq = seq.wrapping_add(1);
                            writer.write_to_known_channel(
                                &mcap::records::MessageHeader {
                                    channel_id: c,
                                    sequence: seq,
                                    log_time: t,
                                    publish_time: t,
                                },
                                &e.data,
                            )?;
                            stats.written += 1;
                        }
                    }
                }
            }
        }
        pending = reader.next_entry()?;
    }
    stats.read = reader.stats().clone();
    for ((scheme, group), count) in skipped {
        let name = scheme_name(scheme);
        *stats
            .skipped_groups
            .entry((name.clone(), group.0.to_string()))
            .or_default() += count;
        *stats.skipped_schemes.entry(name).or_default() += count;
    }
    for (scheme, count) in skipped_other {
        let name = scheme_name(scheme);
        *stats
            .skipped_groups
            .entry((name.clone(), OTHER_GROUPS.to_string()))
            .or_default() += count;
        *stats.skipped_schemes.entry(name).or_default() += count;
    }
    let mut m = BTreeMap::new();
    m.insert("written".into(), stats.written.to_string());
    m.insert("skipped".into(), stats.skipped().to_string());
    m.insert("crc_errors".into(), stats.read.crc_errors.to_string());
    m.insert("damaged_bytes".into(), stats.read.skipped_bytes.to_string());
    // An import drops nothing for lack of time; the recorder's keys say so explicitly.
    m.insert("dropped_queue".into(), "0".into());
    m.insert("dropped_unwritable".into(), "0".into());
    m.insert("run_dropped".into(), "0".into());
    for (scheme, n) in &stats.skipped_schemes {
        m.insert(format!("skipped_{}", scheme.to_lowercase()), n.to_string());
    }
    writer.write_metadata(&mcap::records::Metadata {
        name: META_RECORDER.into(),
        metadata: m,
    })?;
    if !stats.skipped_groups.is_empty() {
        writer.write_metadata(&mcap::records::Metadata {
            name: META_IMPORT_SKIPPED.into(),
            metadata: stats
                .skipped_groups
                .iter()
                .map(|((scheme, group), n)| (format!("{scheme} {group}"), n.to_string()))
                .collect(),
        })?;
    }
    writer.finish()?;
    Ok(stats)
}

/// A name interned by [`GobyReader`]: equal names are one allocation, so the address is the key.
#[derive(Clone)]
struct Interned(Arc<str>);

impl PartialEq for Interned {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.0, &other.0)
    }
}
impl Eq for Interned {}
impl std::hash::Hash for Interned {
    fn hash<H: std::hash::Hasher>(&self, h: &mut H) {
        std::ptr::hash(Arc::as_ptr(&self.0).cast::<u8>(), h)
    }
}

/// The compiled pool when there is one (it is, whenever a descriptor was found in it).
fn compiled_or(own: &DescriptorPool) -> &DescriptorPool {
    crate::schema::compiled_pool().unwrap_or(own)
}

/// Adds one FileDescriptorProto entry to the pool; whether it was added.
fn add_descriptor(pool: &mut DescriptorPool, data: &[u8], stats: &mut ImportStats) -> bool {
    let Ok(fdp) = FileDescriptorProto::decode(data) else {
        stats.bad_descriptors += 1;
        return false;
    };
    // goby_logger writes a file once per log; a repeat (or a file of the same name) is skipped,
    // as Goby3's reader does (`read_file_desc_names_`).
    if pool.get_file_by_name(fdp.name()).is_some() {
        return false;
    }
    if pool.files().len() >= MAX_DESCRIPTOR_FILES {
        stats.bad_descriptors += 1;
        return false;
    }
    // prost-reflect would panic on it (see `schema::known_syntax`).
    if !crate::schema::known_syntax(&fdp) {
        stats.bad_descriptors += 1;
        return false;
    }
    match pool.add_file_descriptor_proto(fdp) {
        Ok(()) => {
            stats.descriptor_files += 1;
            true
        }
        Err(e) => {
            stats.bad_descriptors += 1;
            tracing::debug!(error = %e, "log import: a descriptor entry does not fit");
            false
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `.goby` descriptor entry whose syntax prost-reflect 0.16 panics on (the `mcap_reader`
    /// fuzz finding, FUZZING.md) is counted as bad and skipped, not handed to the pool.
    #[test]
    fn a_descriptor_with_unknown_syntax_is_bad_not_a_panic() {
        let fdp = FileDescriptorProto {
            name: Some("t.proto".into()),
            syntax: Some("prott2".into()),
            ..Default::default()
        };
        let mut pool = DescriptorPool::new();
        let mut stats = ImportStats::default();
        assert!(!add_descriptor(&mut pool, &fdp.encode_to_vec(), &mut stats));
        assert_eq!((stats.bad_descriptors, stats.descriptor_files), (1, 0));
        let fdp = FileDescriptorProto {
            syntax: Some("proto3".into()),
            ..fdp
        };
        assert!(add_descriptor(&mut pool, &fdp.encode_to_vec(), &mut stats));
        assert_eq!((stats.bad_descriptors, stats.descriptor_files), (1, 1));
    }
}
