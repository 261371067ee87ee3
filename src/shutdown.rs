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

/// Resolves on SIGTERM or SIGINT. The handlers are installed when this is called, not when the
/// future is first polled: a launcher polls it only once its processes are up, and a SIGTERM
/// before that (the default action) killed it and left its children running
/// (`tests/fleet_launch.rs` sends one right after "every process is up").
pub fn shutdown_signal() -> impl std::future::Future<Output = ()> {
    #[cfg(unix)]
    {
        use tokio::signal::unix::{SignalKind, signal};
        let term = signal(SignalKind::terminate());
        let int = signal(SignalKind::interrupt());
        async move {
            match (term, int) {
                (Ok(mut term), Ok(mut int)) => {
                    tokio::select! {
                        _ = term.recv() => tracing::info!("SIGTERM received"),
                        _ = int.recv() => tracing::info!("SIGINT received"),
                    }
                }
                (Err(e), Ok(mut int)) => {
                    tracing::warn!(error = %e, "cannot listen for SIGTERM; only SIGINT stops the service");
                    int.recv().await;
                }
                (Ok(mut term), Err(e)) => {
                    tracing::warn!(error = %e, "cannot listen for SIGINT; only SIGTERM stops the service");
                    term.recv().await;
                }
                (Err(e), Err(_)) => {
                    tracing::warn!(error = %e, "cannot listen for SIGTERM or SIGINT");
                    let _ = tokio::signal::ctrl_c().await;
                }
            }
        }
    }
    #[cfg(not(unix))]
    {
        async {
            let _ = tokio::signal::ctrl_c().await;
        }
    }
}
