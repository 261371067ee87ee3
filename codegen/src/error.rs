//! The compiler's one error type, and the located diagnostics it carries for bad interface yaml.
//!
//! Every rule violation names the yaml file, line and column, so that a failed build points the
//! user at the declaration to fix; all violations of one run are reported together.

use std::fmt;
use std::path::PathBuf;

/// Which rule a diagnostic is about (tests match on it; the message says it in words).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Rule {
    /// The file is not valid yaml, or a value has the wrong shape.
    Syntax,
    /// A top-level key other than `application`, `vehicle`, `interprocess`, `interthread`.
    UnknownKey,
    /// A layer other than `interprocess` / `interthread`.
    UnknownLayer,
    /// `application`, `group`, `type` or `actor` is missing.
    MissingField,
    /// `type` names no message of the compiled .proto files.
    UnknownType,
    /// Two publications of one group with different types.
    TwoTypes,
    /// A subscription whose type differs from the type the group is published with.
    TypeMismatch,
    /// The same application/layer/direction/group/actor declared twice.
    Duplicate,
    /// A group or actor name that cannot become a Rust name.
    InvalidName,
    /// Two groups that would generate the same Rust name (constant, method or inbox variant).
    NameCollision,
    /// A bad `extension:`: unknown kind, wrong direction or layer, no `vehicle:`, or a type that
    /// is not a mirror of the message it extends.
    Extension,
}

/// One located problem in the interface yaml.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Diagnostic {
    pub file: PathBuf,
    pub line: u64,
    pub column: u64,
    pub rule: Rule,
    pub message: String,
}

impl fmt::Display for Diagnostic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}:{}:{}: {}",
            self.file.display(),
            self.line,
            self.column,
            self.message
        )
    }
}

#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error("invalid interface yaml:\n{}", display_all(.0))]
    Interface(Vec<Diagnostic>),
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("compiling the .proto files: {0}")]
    Proto(String),
    #[error("prost-build: {0}")]
    ProstBuild(std::io::Error),
    #[error("generated code does not parse (a bug in the interface compiler): {0}")]
    Generated(String),
    #[error("environment variable {0} is not set (run from a build script)")]
    Env(&'static str),
}

impl Error {
    /// The diagnostics, when the error is about the yaml.
    pub fn diagnostics(&self) -> &[Diagnostic] {
        match self {
            Error::Interface(d) => d,
            _ => &[],
        }
    }
}

fn display_all(diags: &[Diagnostic]) -> String {
    diags
        .iter()
        .map(|d| format!("  {d}"))
        .collect::<Vec<_>>()
        .join("\n")
}
