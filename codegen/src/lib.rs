//! The interface compiler: reads `interface_yaml/*.yaml` (and `interface_yaml/vehicles/*.yaml`) and `interface_yaml/proto/**.proto`,
//! checks the declarations (types exist, one type per group, subscribers agree with publishers, no
//! duplicates, known layers and keys) and writes typed Rust wiring into `OUT_DIR`: prost messages,
//! one constant per group, per-actor ports and inboxes. Used from `actors/build.rs`; see
//! `interface_yaml/README.md` for the yaml shape and the error messages.
#![forbid(unsafe_code)]

mod error;
mod generate;
mod model;
mod protos;
mod yaml;

use std::path::{Path, PathBuf};

pub use error::{Diagnostic, Error, Rule};
pub use model::{
    ActorModel, ApplicationModel, ExtensionKind, ExtensionModel, GroupModel, Model, Port,
};
pub use yaml::{Direction, Layer};

/// The name of the generated file in the output directory.
pub const GENERATED_FILE: &str = "frontseat_interfaces.rs";
/// The name of the encoded descriptor set in the output directory.
pub const DESCRIPTOR_SET_FILE: &str = "frontseat_descriptor_set.bin";

/// The result of a successful compilation.
pub struct Compiled {
    pub model: Model,
    /// The generated Rust source (one file).
    pub rust: String,
    /// The resolved interfaces in yaml (also embedded in `rust`).
    pub resolved_yaml: String,
    /// Every input read: the yaml files and the .proto files.
    pub inputs: Vec<PathBuf>,
}

/// The subfolder of the interface folder that holds one yaml file per vehicle protocol (its
/// extension groups), so that adding a vehicle adds a file instead of editing a shared one.
pub const VEHICLES_DIR: &str = "vehicles";

/// The `*.yaml` / `*.yml` files directly in `dir` and in its [`VEHICLES_DIR`] (when there is
/// one), sorted by path.
pub fn yaml_files(dir: &Path) -> Result<Vec<PathBuf>, Error> {
    let mut files = yaml_files_in(dir)?;
    let vehicles = dir.join(VEHICLES_DIR);
    if vehicles.is_dir() {
        files.extend(yaml_files_in(&vehicles)?);
    }
    files.sort();
    Ok(files)
}

fn yaml_files_in(dir: &Path) -> Result<Vec<PathBuf>, Error> {
    let io = |source| Error::Io {
        path: dir.to_path_buf(),
        source,
    };
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(io)? {
        let path = entry.map_err(io)?.path();
        if path.is_file() && path.extension().is_some_and(|e| e == "yaml" || e == "yml") {
            files.push(path);
        }
    }
    Ok(files)
}

/// Checks `yaml_files` against the protos under `proto_dir` and generates the Rust source. prost's
/// intermediate output and the descriptor set go to `out_dir`; nothing else is written.
pub fn compile(
    yaml_files: &[PathBuf],
    proto_dir: &Path,
    out_dir: &Path,
) -> Result<Compiled, Error> {
    let protos = protos::compile(proto_dir, &out_dir.join("prost"))?;
    let descriptor_set_file = out_dir.join(DESCRIPTOR_SET_FILE);
    std::fs::write(&descriptor_set_file, &protos.descriptor_set).map_err(|source| Error::Io {
        path: descriptor_set_file.clone(),
        source,
    })?;

    let mut diags = Vec::new();
    let mut files = Vec::new();
    for path in yaml_files {
        let text = std::fs::read_to_string(path).map_err(|source| Error::Io {
            path: path.clone(),
            source,
        })?;
        if let Some(f) = yaml::read_file(path, &text, &mut diags) {
            files.push(f);
        }
    }
    let model = model::resolve(&files, &protos.pool, &mut diags);
    if !diags.is_empty() {
        diags.sort_by(|a, b| (&a.file, a.line, a.column).cmp(&(&b.file, b.line, b.column)));
        return Err(Error::Interface(diags));
    }
    let rust = generate::generate(
        &model,
        &protos.packages,
        &generate::Target {
            bus_path: "crate::bus",
            descriptor_set_file: &descriptor_set_file,
        },
    )?;
    let resolved_yaml = generate::resolved_yaml(&model);
    let mut inputs: Vec<PathBuf> = yaml_files.to_vec();
    inputs.extend(protos.files);
    Ok(Compiled {
        model,
        rust,
        resolved_yaml,
        inputs,
    })
}

/// The whole job of a build script: compiles `yaml_dir`/*.yaml against `yaml_dir`/proto, writes
/// [`GENERATED_FILE`] into `OUT_DIR` and prints `cargo:rerun-if-changed` for every input. On error
/// it prints every diagnostic (one `cargo::error=` line each, and the same on stderr) and exits
/// non-zero, which fails the build.
pub fn run_build_script(yaml_dir: &Path) {
    if let Err(e) = try_build_script(yaml_dir) {
        match &e {
            Error::Interface(diags) => {
                for d in diags {
                    println!("cargo::error={d}");
                    eprintln!("error: {d}");
                }
            }
            other => {
                let text = other.to_string().replace('\n', " ");
                println!("cargo::error={text}");
                eprintln!("error: {other}");
            }
        }
        std::process::exit(1);
    }
}

fn try_build_script(yaml_dir: &Path) -> Result<(), Error> {
    let yaml_dir = yaml_dir.canonicalize().map_err(|source| Error::Io {
        path: yaml_dir.to_path_buf(),
        source,
    })?;
    let proto_dir = yaml_dir.join("proto");
    // Directories too, so that adding a file reruns the build.
    println!("cargo:rerun-if-changed={}", yaml_dir.display());
    println!(
        "cargo:rerun-if-changed={}",
        yaml_dir.join(VEHICLES_DIR).display()
    );
    rerun_dirs(&proto_dir);
    let out_dir = PathBuf::from(std::env::var_os("OUT_DIR").ok_or(Error::Env("OUT_DIR"))?);
    let files = yaml_files(&yaml_dir)?;
    for f in &files {
        println!("cargo:rerun-if-changed={}", f.display());
    }
    let compiled = compile(&files, &proto_dir, &out_dir)?;
    for input in &compiled.inputs {
        println!("cargo:rerun-if-changed={}", input.display());
    }
    let target = out_dir.join(GENERATED_FILE);
    std::fs::write(&target, compiled.rust).map_err(|source| Error::Io {
        path: target,
        source,
    })
}

fn rerun_dirs(dir: &Path) {
    println!("cargo:rerun-if-changed={}", dir.display());
    if let Ok(entries) = std::fs::read_dir(dir) {
        for entry in entries.flatten() {
            let path = entry.path();
            if path.is_dir() {
                rerun_dirs(&path);
            }
        }
    }
}
