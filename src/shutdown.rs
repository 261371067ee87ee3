//! Waiting for the service manager's or the user's request to stop (SIGTERM, SIGINT), how long
//! draining may take, and the exit code a service ends with: shared by every long-running
//! subcommand.

use std::process::ExitCode;
use std::time::Duration;

use frontseat_actors::interface::ServiceExit;

/// How long an orderly shutdown may take before we give up waiting.
pub const SHUTDOWN_BOUND: Duration = Duration::from_secs(3);

/// The process exit code for how a service ended (logged when it is an error).
pub fn exit_code(exit: &ServiceExit) -> ExitCode {
    match exit {
        ServiceExit::Clean => ExitCode::SUCCESS,
        other => {
            tracing::error!(?other, "service ended with an error");
            ExitCode::from(other.code() as u8)
        }
    }
}

/// Resolves on SIGTERM or SIGINT.
pub async fn shutdown_signal() {
    #[cfg(unix)]
    {
        use tokio::signal::unix::{SignalKind, signal};
        match signal(SignalKind::terminate()) {
            Ok(mut term) => {
                tokio::select! {
                    _ = term.recv() => tracing::info!("SIGTERM received"),
                    _ = tokio::signal::ctrl_c() => tracing::info!("SIGINT received"),
                }
            }
            Err(e) => {
                tracing::warn!(error = %e, "cannot listen for SIGTERM; only SIGINT stops the service");
                let _ = tokio::signal::ctrl_c().await;
            }
        }
    }
    #[cfg(not(unix))]
    {
        let _ = tokio::signal::ctrl_c().await;
    }
}
