//! `frontseat sim --vehicle bluefin` and `frontseat demo --vehicle bluefin`: the Huxley emulator on the payload port (29500 unless
//! `--port`), with the simulator config's bind address, line bound, vehicle count and current.

use std::net::SocketAddr;
use std::process::ExitCode;

use clap::ValueEnum;
use frontseat_bluefin::{HuxleyOptions, HuxleyServer, HuxleyServerOptions, Refusal};
use frontseat_config::SimConfig;

/// How the emulated Huxley answers commands.
#[derive(ValueEnum, Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RefusalArg {
    /// Acknowledge everything as successful.
    #[default]
    None,
    /// Acknowledge commands as failed (status 1).
    Commands,
    /// Acknowledge nothing (an unresponsive Huxley that still streams navigation).
    Silent,
    /// Acknowledge commands as pending first, then successful.
    PendingFirst,
}

impl From<RefusalArg> for Refusal {
    fn from(r: RefusalArg) -> Self {
        match r {
            RefusalArg::None => Refusal::None,
            RefusalArg::Commands => Refusal::Commands,
            RefusalArg::Silent => Refusal::Silent,
            RefusalArg::PendingFirst => Refusal::PendingFirst,
        }
    }
}

pub fn server_options(config: &SimConfig, refusal: RefusalArg, warp: f64) -> HuxleyServerOptions {
    HuxleyServerOptions {
        huxley: HuxleyOptions {
            refusal: refusal.into(),
            current: (config.current.east, config.current.north),
            ..Default::default()
        },
        warp,
        max_line_bytes: config.max_line_bytes,
        max_vehicles: config.max_vehicles,
    }
}

pub async fn serve(
    config: SimConfig,
    port: Option<u16>,
    refusal: RefusalArg,
    warp: f64,
) -> ExitCode {
    if !(warp.is_finite() && warp > 0.0 && warp <= 1000.0) {
        eprintln!("--warp must be in (0, 1000]");
        return ExitCode::from(2);
    }
    let port = port.unwrap_or(frontseat_bluefin::DEFAULT_PORT);
    let addr: SocketAddr = match format!("{}:{port}", config.bind)
        .parse()
        .or_else(|_| format!("[{}]:{port}", config.bind).parse())
    {
        Ok(a) => a,
        Err(e) => {
            eprintln!("bind address `{}`: {e}", config.bind);
            return ExitCode::from(2);
        }
    };
    let server = match HuxleyServer::bind(addr, server_options(&config, refusal, warp)).await {
        Ok(s) => s,
        Err(e) => {
            tracing::error!(error = %e, %addr, "cannot start the Huxley emulator");
            return ExitCode::from(2);
        }
    };
    tracing::info!(addr = %server.local_addr(), ?refusal, warp, "Bluefin Huxley emulator listening");
    crate::shutdown::shutdown_signal().await;
    server.shutdown().await;
    tracing::info!(stats = ?server.stats(), "Huxley emulator stopped");
    ExitCode::SUCCESS
}
