//! The crate's one error type, [`ConfigError`], and [`FieldError`], one failed validation rule.
//!
//! Every message names the file; parse errors add line and column, validation errors the dotted
//! field path, so an operator can go straight to the offending line.

use std::fmt;

/// One value that failed validation.
///
/// `path` is the dotted TOML path (`driver.basic_simulator.start.lat`, `faults[2].seconds`).
/// `message` starts with the offending value, then says what is wrong with it
/// (`95: outside [-90, 90]`), so `Display` reads `path = value: reason`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FieldError {
    /// Dotted path of the field, as written in the TOML file.
    pub path: String,
    /// `"<value>: <reason>"`.
    pub message: String,
}

impl FieldError {
    /// A rule failure for `path`, whose current value is `value`.
    pub fn new(
        path: impl Into<String>,
        value: impl fmt::Display,
        reason: impl fmt::Display,
    ) -> Self {
        Self {
            path: path.into(),
            message: format!("{value}: {reason}"),
        }
    }
}

impl fmt::Display for FieldError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} = {}", self.path, self.message)
    }
}

/// Why a configuration could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The file could not be read (missing, permissions, larger than the size limit).
    #[error("{file}: {source}")]
    Io {
        /// The file name as given.
        file: String,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// Not valid TOML (or Goby3 text format), a byte that is not UTF-8, a wrong type, a missing
    /// required key, or an unknown key.
    ///
    /// `line` and `column` are 1-based; 0 means the parser gave no position (then `Display`
    /// leaves them out).
    #[error("{}", display_parse(file, *line, *column, message))]
    Parse {
        /// The file name as given.
        file: String,
        /// 1-based line, 0 if unknown.
        line: usize,
        /// 1-based column in characters, 0 if unknown.
        column: usize,
        /// The parser's message, e.g. "unknown field `foo`, expected one of `name`, …".
        message: String,
    },
    /// Parsed, but one or more values break a rule. Never empty.
    #[error("{}", display_invalid(file, errors))]
    Invalid {
        /// The file name as given.
        file: String,
        /// Every failed rule, in field order.
        errors: Vec<FieldError>,
    },
}

fn display_parse(file: &str, line: usize, column: usize, message: &str) -> String {
    if line == 0 {
        format!("{file}: {message}")
    } else {
        format!("{file}:{line}:{column}: {message}")
    }
}

fn display_invalid(file: &str, errors: &[FieldError]) -> String {
    errors
        .iter()
        .map(|e| format!("{file}: {e}"))
        .collect::<Vec<_>>()
        .join("\n")
}
