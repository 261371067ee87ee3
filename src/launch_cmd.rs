//! `frontseat launch FILE`: the command line of the launcher (frontseat-launch): the config
//! subcommands, `--check` that also plans (vehicle configs generated and validated), and the run.

use std::process::ExitCode;

use frontseat_launch::LaunchConfig;

use crate::config_args::{ConfigArgs, config_commands, load_config, load_plain};

pub fn run(a: &ConfigArgs) -> ExitCode {
    let frontseat = match std::env::current_exe() {
        Ok(p) => p,
        Err(e) => {
            eprintln!("frontseat launch: cannot find this binary: {e}");
            return ExitCode::from(1);
        }
    };
    if a.check {
        // The file alone is not enough: every vehicle's generated config must load too.
        let Some(path) = a.file() else {
            eprintln!("--check needs a config file: --check -c FILE");
            return ExitCode::from(2);
        };
        let cfg = match frontseat_config::load::<LaunchConfig>(path) {
            Ok(c) => c,
            Err(e) => {
                eprintln!("{e}");
                return ExitCode::from(2);
            }
        };
        return match frontseat_launch::check(&cfg, path, &frontseat) {
            Ok(lines) => {
                use frontseat_config::ServiceConfig;
                for w in cfg.warnings() {
                    eprintln!("{}: warning: {w}", path.display());
                }
                for l in lines {
                    println!("{l}");
                }
                println!("{}: ok (launch config)", path.display());
                ExitCode::SUCCESS
            }
            Err(e) => {
                eprintln!("{}: {e}", path.display());
                ExitCode::from(2)
            }
        };
    }
    if let Some(code) = config_commands(a, load_plain::<LaunchConfig>) {
        return code;
    }
    let cfg = match load_config::<LaunchConfig>(a, false) {
        Ok(c) => c,
        Err(code) => return code,
    };
    let Some(file) = a.file().cloned() else {
        return ExitCode::from(2);
    };
    crate::runtime::run_traced(&Default::default(), "launch", "", async move {
        let outcome =
            frontseat_launch::run(cfg, &file, frontseat, crate::shutdown::shutdown_signal()).await;
        if outcome != frontseat_launch::Outcome::Clean {
            eprintln!("frontseat launch: {outcome}");
        }
        ExitCode::from(outcome.exit_code())
    })
}
