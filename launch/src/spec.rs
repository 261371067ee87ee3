//! One process a launch file starts, as the plan made it: what `plan` produces, what `ports` reads
//! for the ports it will bind, and what `process` runs. Its own module so that the plan (which
//! calls the port check) and the port check (which reads the specs) do not import each other.

use std::path::PathBuf;

use frontseat_config::RestartConfig;

use crate::config::ReadyConfig;

/// One process to start.
#[derive(Debug, Clone, PartialEq)]
pub struct ProcSpec {
    /// Position in start order, from 0; the exit code of a failed launch is 10 + this.
    pub index: usize,
    pub name: String,
    pub program: PathBuf,
    pub args: Vec<String>,
    pub env: Vec<(String, String)>,
    pub cwd: PathBuf,
    pub ready: ReadyConfig,
    pub restart: RestartConfig,
}
