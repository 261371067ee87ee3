//! Subcommands that live in a sibling executable (`frontseat bench` → `frontseat-bench`,
//! `frontseat chaos` → `frontseat-chaos`): test and measurement tools the service binary must not
//! link. The sibling is looked up next to this executable and replaces this process, with the
//! arguments that followed the subcommand, so its output, signals and exit code are the
//! command's own.

use std::ffi::OsString;
use std::path::PathBuf;
use std::process::ExitCode;

/// Where the sibling `name` of this executable is expected.
fn sibling_path(name: &str) -> std::io::Result<PathBuf> {
    let me = std::env::current_exe()?;
    Ok(me.with_file_name(format!("{name}{}", std::env::consts::EXE_SUFFIX)))
}

/// The arguments after `subcommand` on this process's command line (no option of `frontseat`
/// itself comes before a subcommand).
fn args_after(subcommand: &str) -> Vec<OsString> {
    let mut args = std::env::args_os().skip(1);
    for a in args.by_ref() {
        if a == subcommand {
            break;
        }
    }
    args.collect()
}

/// Runs the sibling `name` in place of this process; returns only on failure (exit 1).
pub fn exec(subcommand: &str, name: &str) -> ExitCode {
    let path = match sibling_path(name) {
        Ok(p) => p,
        Err(e) => {
            eprintln!("frontseat {subcommand}: cannot find this executable's directory: {e}");
            return ExitCode::from(1);
        }
    };
    if !path.is_file() {
        eprintln!(
            "frontseat {subcommand}: runs the separate executable `{name}`, which is not next to this one ({}); it is built and installed with the frontseat package (`cargo build --bins`, `cargo install --path .`)",
            path.display()
        );
        return ExitCode::from(1);
    }
    let mut cmd = std::process::Command::new(&path);
    cmd.args(args_after(subcommand));
    // The bench starts this executable (the service) as the children of its cross-process rows.
    if let Ok(me) = std::env::current_exe() {
        cmd.env("FRONTSEAT_EXE", me);
    }
    #[cfg(unix)]
    {
        use std::os::unix::process::CommandExt;
        let e = cmd.exec();
        eprintln!("frontseat {subcommand}: cannot run {}: {e}", path.display());
        ExitCode::from(1)
    }
    #[cfg(not(unix))]
    match cmd.status() {
        Ok(s) => ExitCode::from(s.code().and_then(|c| u8::try_from(c).ok()).unwrap_or(1)),
        Err(e) => {
            eprintln!("frontseat {subcommand}: cannot run {}: {e}", path.display());
            ExitCode::from(1)
        }
    }
}
