//! The async runtime a command runs on, with its logs and traces set up first and flushed last.

use std::process::ExitCode;

/// Console logs always (no colours off a TTY, so journald and files stay clean); OTLP traces when
/// `[telemetry]` or the OTEL_* environment asks. Returns the handle that flushes on shutdown.
pub fn init_telemetry(
    cfg: &frontseat_config::TelemetryConfig,
    role: &str,
    platform: &str,
) -> frontseat_telemetry::Telemetry {
    frontseat_telemetry::init(cfg, role, platform)
}

/// Runs a service with telemetry, and flushes the last spans before exiting.
pub fn run_traced(
    cfg: &frontseat_config::TelemetryConfig,
    role: &str,
    platform: &str,
    fut: impl std::future::Future<Output = ExitCode>,
) -> ExitCode {
    let mut telemetry = init_telemetry(cfg, role, platform);
    let code = run(fut);
    telemetry.shutdown();
    code
}

/// Runs `fut` to its end on a multi-threaded runtime.
pub fn run(fut: impl std::future::Future<Output = ExitCode>) -> ExitCode {
    match tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
    {
        Ok(rt) => rt.block_on(fut),
        Err(e) => {
            eprintln!("cannot start the async runtime: {e}");
            ExitCode::from(1)
        }
    }
}
