//! Compiling the .proto files: protox parses them (no system `protoc`), prost-build turns the
//! descriptors into Rust, and the descriptor pool is kept to resolve the yaml's `type:` names.

use std::path::{Path, PathBuf};

use heck::{ToSnakeCase, ToUpperCamelCase};
use prost_reflect::{DescriptorPool, MessageDescriptor};

use crate::error::Error;

/// The compiled protos.
pub struct Protos {
    pub pool: DescriptorPool,
    /// The encoded `FileDescriptorSet` (with imports), for reflection at run time.
    pub descriptor_set: Vec<u8>,
    /// Every .proto file read, for `rerun-if-changed`.
    pub files: Vec<PathBuf>,
    /// prost's output, one entry per proto package: (package, Rust source).
    pub packages: Vec<(String, String)>,
}

/// Compiles every `.proto` under `proto_dir`; prost-build writes into `scratch_dir`.
pub fn compile(proto_dir: &Path, scratch_dir: &Path) -> Result<Protos, Error> {
    let mut files = Vec::new();
    collect_protos(proto_dir, &mut files)?;
    files.sort();
    if files.is_empty() {
        return Err(Error::Proto(format!(
            "no .proto files under {}",
            proto_dir.display()
        )));
    }
    let relative: Vec<PathBuf> = files
        .iter()
        .map(|f| f.strip_prefix(proto_dir).unwrap_or(f).to_path_buf())
        .collect();
    let mut compiler =
        protox::Compiler::new([proto_dir]).map_err(|e| Error::Proto(e.to_string()))?;
    compiler.include_imports(true).include_source_info(true);
    compiler
        .open_files(&relative)
        .map_err(|e| Error::Proto(format!("{e:?}")))?;
    let pool = compiler.descriptor_pool();
    let fds = compiler.file_descriptor_set();
    let descriptor_set = compiler.encode_file_descriptor_set();

    std::fs::create_dir_all(scratch_dir).map_err(|source| Error::Io {
        path: scratch_dir.to_path_buf(),
        source,
    })?;
    prost_build::Config::new()
        .out_dir(scratch_dir)
        .compile_fds(fds)
        .map_err(Error::ProstBuild)?;

    let mut packages = Vec::new();
    for file in pool.files() {
        let package = file.package_name().to_string();
        if packages.iter().any(|(p, _)| *p == package) {
            continue;
        }
        let name = if package.is_empty() {
            "_".to_string()
        } else {
            package.clone()
        };
        let path = scratch_dir.join(format!("{name}.rs"));
        let code = std::fs::read_to_string(&path).map_err(|source| Error::Io { path, source })?;
        packages.push((package, code));
    }
    packages.sort();
    Ok(Protos {
        pool,
        descriptor_set,
        files,
        packages,
    })
}

fn collect_protos(dir: &Path, out: &mut Vec<PathBuf>) -> Result<(), Error> {
    let io = |source| Error::Io {
        path: dir.to_path_buf(),
        source,
    };
    for entry in std::fs::read_dir(dir).map_err(io)? {
        let path = entry.map_err(io)?.path();
        if path.is_dir() {
            collect_protos(&path, out)?;
        } else if path.extension().is_some_and(|e| e == "proto") {
            out.push(path);
        }
    }
    Ok(())
}

/// The Rust module path of a proto package, as prost lays it out (`goby::middleware::protobuf`).
pub fn package_modules(package: &str) -> Vec<String> {
    package
        .split('.')
        .filter(|s| !s.is_empty())
        .map(|s| s.to_snake_case())
        .collect()
}

/// The path of a message's Rust type relative to the `proto` module, as prost names it
/// (`goby::middleware::frontseat::protobuf::CtdSample`, nested types in snake-case modules).
pub fn rust_path(msg: &MessageDescriptor) -> Vec<String> {
    let mut path = package_modules(msg.package_name());
    let mut parents = Vec::new();
    let mut parent = msg.parent_message();
    while let Some(p) = parent {
        parents.push(p.name().to_snake_case());
        parent = p.parent_message();
    }
    parents.reverse();
    path.extend(parents);
    path.push(msg.name().to_upper_camel_case());
    path
}
