//! `frontseat launch FILE`: starts every process a launch file lists (simulators, one
//! `frontseat interface` per vehicle, helms, a MOOS community, a topside, any command) in order,
//! each waited for until ready, under one supervisor that restarts each by its policy; Ctrl-C or
//! SIGTERM stops them all in reverse order, and the exit code names the process that failed
//! (10 + its position in start order). goby_launch, pAntler and `ros2 launch` are the models.
//!
//! [`config`] is the file, [`plan`] turns it into processes ([`spec`]; pure: `--check` runs it; [`ports`]
//! refuses two of them binding one port), and [`process`] runs one of them as a supervised service.
#![forbid(unsafe_code)]

pub mod config;
pub mod plan;
pub mod ports;
pub mod process;
pub mod spec;

use std::future::Future;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::Duration;

use frontseat_actors::service_child::service_child_with;
use frontseat_actors::supervisor::{Policy, SupervisorHandle};

pub use config::LaunchConfig;
pub use plan::{Plan, PlanError, ProcSpec};
use process::Shared;

/// Exit code of a launch whose process at start index `i` failed.
pub const FAILED_PROCESS_BASE: u8 = 10;
/// Exit code of a launch file that cannot be planned (bad vehicle config, unreadable template).
pub const EXIT_BAD_CONFIG: u8 = 2;
/// Exit code when the launcher itself cannot run (no run directory, no supervisor).
pub const EXIT_LAUNCHER: u8 = 1;

/// The exit code naming the process at start index `index`.
pub fn exit_code_for(index: usize) -> u8 {
    u8::try_from(index)
        .ok()
        .and_then(|i| FAILED_PROCESS_BASE.checked_add(i))
        .unwrap_or(u8::MAX)
}

/// The run directory and whether it is ours to remove.
fn run_dir(cfg: &LaunchConfig, base: &Path) -> std::io::Result<(PathBuf, bool)> {
    if cfg.run_dir.is_empty() {
        let dir = std::env::temp_dir().join(format!("frontseat-launch-{}", std::process::id()));
        std::fs::create_dir_all(&dir)?;
        Ok((dir, true))
    } else {
        let p = Path::new(&cfg.run_dir);
        let dir = if p.is_absolute() {
            p.to_path_buf()
        } else {
            base.join(p)
        };
        std::fs::create_dir_all(&dir)?;
        Ok((dir, false))
    }
}

/// The directory relative paths of the launch file are taken from.
pub fn base_dir(file: &Path) -> PathBuf {
    match file.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// `--check`: everything but starting (vehicle configs generated and validated, PATH looked up).
/// Returns the lines to print: the processes in start order and what is skipped.
pub fn check(cfg: &LaunchConfig, file: &Path, frontseat: &Path) -> Result<Vec<String>, PlanError> {
    let base = base_dir(file);
    let p = plan::plan(cfg, &base, Path::new("<run_dir>"), frontseat, plan::on_path)?;
    let mut lines: Vec<String> = p
        .processes
        .iter()
        .map(|s| {
            format!(
                "{:>3}. {} ({}{}{}; ready: {:?}; restart: {:?})",
                s.index + 1,
                s.name,
                s.program.display(),
                if s.args.is_empty() { "" } else { " " },
                s.args.join(" "),
                s.ready.kind,
                s.restart.policy
            )
        })
        .collect();
    lines.extend(p.skipped);
    for (vehicle, target) in p.records {
        lines.push(format!("     record: {vehicle} -> {target}"));
    }
    lines.extend(p.warnings.into_iter().map(|w| format!("warning: {w}")));
    Ok(lines)
}

/// How a launch ended.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// Stopped on request, or every process finished with exit 0.
    Clean,
    /// A process failed past its restart policy (or could not start).
    Failed(process::Failure),
    /// The launch file could not be turned into processes.
    BadConfig(String),
    /// The launcher could not run.
    Launcher(String),
}

impl Outcome {
    pub fn exit_code(&self) -> u8 {
        match self {
            Outcome::Clean => 0,
            Outcome::Failed(f) => exit_code_for(f.index),
            Outcome::BadConfig(_) => EXIT_BAD_CONFIG,
            Outcome::Launcher(_) => EXIT_LAUNCHER,
        }
    }
}

/// What the launcher says about how it ended (the `frontseat launch` and `demo --fleet` line).
impl std::fmt::Display for Outcome {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Outcome::Clean => write!(f, "every process stopped cleanly"),
            Outcome::Failed(p) => write!(
                f,
                "process {} (#{}) failed: {}; exit {}",
                p.name,
                p.index + 1,
                p.why,
                self.exit_code()
            ),
            Outcome::BadConfig(e) | Outcome::Launcher(e) => write!(f, "{e}"),
        }
    }
}

/// SIGTERM to every running process group, last started first, each waited for up to
/// `grace` (then SIGKILL) before the next.
async fn stop_all(shared: &Shared, grace: Duration) {
    shared.stopping.store(true, Ordering::SeqCst);
    let n = shared
        .groups
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .len();
    for i in (0..n).rev() {
        let Some(g) = shared.group(i) else { continue };
        process::signal_group(g, rustix::process::Signal::TERM);
        let gone = async {
            // The group's leader is reaped by its service's wait; the slot empties then.
            while shared.group(i).is_some() {
                tokio::time::sleep(Duration::from_millis(20)).await;
            }
        };
        if tokio::time::timeout(grace, gone).await.is_err() {
            tracing::warn!(index = i, ?grace, "did not end after SIGTERM; SIGKILL");
            process::signal_group(g, rustix::process::Signal::KILL);
        }
    }
}

/// Runs the launch until `stop` resolves, a process fails past its policy, or every process
/// has finished. `frontseat` is the binary a `frontseat` command runs.
pub async fn run(
    cfg: LaunchConfig,
    file: &Path,
    frontseat: PathBuf,
    stop: impl Future<Output = ()>,
) -> Outcome {
    run_with(cfg, file, frontseat, stop, None).await
}

/// [`run`], telling `up` once every process is up (a program that embeds the launcher, such
/// as `frontseat demo --fleet`, starts its own part then).
pub async fn run_with(
    cfg: LaunchConfig,
    file: &Path,
    frontseat: PathBuf,
    stop: impl Future<Output = ()>,
    up: Option<tokio::sync::oneshot::Sender<()>>,
) -> Outcome {
    let base = base_dir(file);
    let (dir, ours) = match run_dir(&cfg, &base) {
        Ok(d) => d,
        Err(e) => return Outcome::Launcher(format!("run_dir: {e}")),
    };
    let outcome = run_in(&cfg, &base, &dir, frontseat, stop, up).await;
    if ours {
        let _ = std::fs::remove_dir_all(&dir);
    }
    outcome
}

async fn run_in(
    cfg: &LaunchConfig,
    base: &Path,
    dir: &Path,
    frontseat: PathBuf,
    stop: impl Future<Output = ()>,
    up: Option<tokio::sync::oneshot::Sender<()>>,
) -> Outcome {
    let plan = match plan::plan(cfg, base, dir, &frontseat, plan::on_path) {
        Ok(p) => p,
        Err(e) => return Outcome::BadConfig(e.to_string()),
    };
    for s in plan.skipped.iter().chain(&plan.warnings) {
        tracing::warn!("{s}");
    }
    for (vehicle, target) in &plan.records {
        tracing::info!(vehicle = %vehicle, to = %target, "recording");
    }
    for c in &plan.configs {
        if let Err(e) = std::fs::write(&c.path, &c.text) {
            return Outcome::Launcher(format!("cannot write {}: {e}", c.path.display()));
        }
    }
    let total = plan.processes.len();
    if total == 0 {
        tracing::warn!("nothing to launch");
        return Outcome::Clean;
    }
    let shared = Arc::new(Shared::new(dir.to_path_buf(), total));
    let grace = Duration::from_secs_f64(cfg.stop_timeout_s.clamp(0.1, 60.0));
    let children = plan
        .processes
        .into_iter()
        .map(|spec| {
            let policy = Policy::from(&spec.restart);
            let name = spec.name.clone();
            let ctx = (Arc::new(spec), shared.clone());
            service_child_with(&name, policy, ctx, move |(spec, shared)| {
                process::start(spec, shared, grace)
            })
        })
        .collect();
    tracing::info!(processes = total, "launching");
    let failed = |shared: &Shared| {
        shared
            .failed
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .clone()
    };
    let mut root = match SupervisorHandle::start("launch", children, None).await {
        Ok(r) => r,
        Err(e) => {
            stop_all(&shared, grace).await;
            return match failed(&shared) {
                Some(f) => Outcome::Failed(f),
                None => Outcome::Launcher(e),
            };
        }
    };
    tracing::info!(processes = total, "every process is up");
    if let Some(up) = up {
        let _ = up.send(());
    }
    tokio::pin!(stop);
    let outcome = loop {
        tokio::select! {
            _ = root.wait() => {
                break match failed(&shared) {
                    Some(f) => Outcome::Failed(f),
                    None => Outcome::Launcher("the supervisor stopped".into()),
                };
            }
            _ = &mut stop => {
                tracing::info!("stopping every process, last started first");
                break Outcome::Clean;
            }
            _ = shared.finished_changed.notified() => {
                if shared.finished.load(Ordering::SeqCst) >= total {
                    tracing::info!("every process has finished");
                    break Outcome::Clean;
                }
            }
        }
    };
    stop_all(&shared, grace).await;
    root.shutdown(grace * 2).await;
    if let Outcome::Failed(f) = &outcome {
        tracing::error!(
            process = %f.name,
            code = exit_code_for(f.index),
            "{}; every process stopped",
            f.why
        );
    }
    outcome
}
