//! `frontseat sim --vehicle bluefin`'s own option (how the emulated Huxley answers) and its
//! check; the Huxley emulator on the payload port (29500 unless `--port`), with the simulator
//! config's bind address, line bound, vehicle count and current, is `compose::emulators`.

use std::process::ExitCode;

use clap::ValueEnum;
use frontseat_bluefin::Refusal;
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

/// `frontseat sim --vehicle bluefin`: checks the warp, then runs the Huxley emulator's root.
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
    crate::compose::emulators::serve_huxley(config, port, refusal.into(), warp).await
}
