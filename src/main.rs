//! The `frontseat` command line: parses arguments, loads and validates config, and hands each
//! service to its composition root (`compose/`), which starts it, waits for a shutdown signal and
//! drains. Everything with logic lives in the crates.
#![forbid(unsafe_code)]

// The flags are parsed here and read by the sibling executables (src/bin/): no field is read in
// this binary.
#[allow(dead_code)]
mod bench_args;
mod bench_cmd;
mod bluefin_sim;
#[allow(dead_code)]
mod chaos_args;
mod chaos_cmd;
mod compose;
mod config_args;
mod demo;
mod docs_gen;
mod driver_host;
mod fleet_demo;
mod launch_cmd;
mod record_cmd;
mod runtime;
mod shutdown;
mod sibling;
mod vehicle_kind;
mod vehicle_sim;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{CommandFactory, Parser, Subcommand};

use config_args::{
    ConfigArgs, config_commands, load_config, load_config_with, load_interface, load_plain,
};
use runtime::run_traced;

/// `frontseat --version`: the crate version, the commit and the build (build.rs), so a field
/// report names exactly what ran. `-V` and the man pages say the version alone.
const LONG_VERSION: &str = concat!(
    env!("CARGO_PKG_VERSION"),
    "\ncommit: ",
    env!("FRONTSEAT_BUILD_COMMIT"),
    "\nbuild: ",
    env!("FRONTSEAT_BUILD_PROFILE"),
    ", ",
    env!("FRONTSEAT_BUILD_DATE"),
);

#[derive(Parser, Debug)]
#[command(
    name = "frontseat",
    version,
    long_version = LONG_VERSION,
    about = "Frontseat/backseat interface for marine robots, wire-compatible with Goby3",
    long_about = "Frontseat/backseat interface for marine robots.\n\n\
        Lets an autonomy engine (the helm, e.g. pHelmIvP) drive a vehicle whose own computer \
        (the frontseat) steers and navigates. Speaks Goby3's frontseat protobuf messages and \
        group names.\n\nStart with `frontseat demo`, then `frontseat interface --example_config`."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Run the frontseat interface service (goby_frontseat_interface): driver, state machine,
    /// status, and the MOOS bridge when the config has a [moos] section.
    Interface {
        #[command(flatten)]
        cfg: ConfigArgs,
    },
    /// Run the basic frontseat simulator (TCP server, one vehicle per connection).
    Sim {
        #[command(flatten)]
        cfg: ConfigArgs,
        /// TCP port to listen on (overrides the config).
        #[arg(long)]
        port: Option<u16>,
        /// Address to bind (overrides the config; default 127.0.0.1, loopback only).
        #[arg(long, value_name = "ADDR")]
        bind: Option<String>,
        /// A vehicle emulator instead of the basic simulator (`--vehicle bluefin|iver3|waveglider_sv2|ardupilot|dune`).
        #[command(flatten)]
        emulator: vehicle_sim::EmulatorArgs,
    },
    /// The MOOS bridge alone (Goby3's goby_moos_gateway): FrontSeatTranslation between a MOOSDB
    /// (pHelmIvP) and the interface, reached over Zenoh.
    MoosGateway {
        #[command(flatten)]
        cfg: ConfigArgs,
    },
    /// Internal: the child process a driver plugin runs in (started by the interface).
    #[command(hide = true)]
    DriverHost(driver_host::DriverHostArgs),
    /// Inject seeded faults into the real simulator, interface, helm and MOOS bridge; print the
    /// invariants table; exit non-zero on any violation. Needs `[chaos] enabled = true` in a
    /// config given with -c (the embedded default has it).
    Chaos(chaos_cmd::ChaosArgs),
    /// Simulator + interface + example helm in one process: drives the homework path east,
    /// south, then northwest back towards the start, prints a live status line, writes the
    /// track as CSV and SVG, and exits 0.
    Demo(demo::DemoArgs),
    /// Measure latency, throughput, capacity and footprint; prints one table (`--quick` runs in
    /// seconds).
    Bench(bench_cmd::BenchArgs),
    /// Print the resolved interface (application → layer → publishes/subscribes → group, type,
    /// actor) of every application, as compiled from interface_yaml/.
    Interfaces,
    /// Start and supervise a fleet from one TOML file: simulators, one interface per vehicle,
    /// helms, a topside, any command — in order, each waited for until ready; Ctrl-C or SIGTERM
    /// stops all in reverse order; the exit code is 10 + the start position of a process that
    /// failed past its restart policy.
    Launch {
        #[command(flatten)]
        cfg: ConfigArgs,
    },
    /// Every vehicle of a fleet on one web page, from what their interfaces publish over Zenoh
    /// (`*/goby/middleware/frontseat/node_status`, `status`, `desired_course`): map, states,
    /// errors, stale vehicles; links to each vehicle's own scope and commander.
    Topside {
        #[command(flatten)]
        cfg: ConfigArgs,
    },
    /// Look into a recording (MCAP, from `[record]` or `demo --record`): `info`, `export`,
    /// `plot`; `import` converts a goby_logger `.goby` file to MCAP.
    Log(record_cmd::LogArgs),
    /// Publish a recording's vehicle side (node_status, status, ...) onto Zenoh or a Goby3 gobyd
    /// as it was recorded, so a helm under test meets the recorded vehicle. Never commands a
    /// vehicle.
    Replay(record_cmd::ReplayArgs),
    /// Print a shell completion script: `frontseat completions bash > /etc/bash_completion.d/frontseat`
    /// (zsh: a `_frontseat` file on $fpath; fish: ~/.config/fish/completions/frontseat.fish).
    Completions {
        /// The shell.
        #[arg(value_enum)]
        shell: clap_complete::Shell,
    },
    /// Internal: write the man pages (frontseat.1, one per subcommand) into DIR; the packaged
    /// pages are these, checked against the committed copy by tests/docs.rs.
    #[command(hide = true)]
    ManPages {
        /// Where the pages go (created if missing).
        dir: PathBuf,
    },
}

/// The command line, with Goby3's application names as aliases: installed (or linked) as
/// `goby_frontseat_interface` this binary is `frontseat interface`, as `goby_moos_gateway` it is
/// `frontseat moos-gateway`, so a Goby3 unit file's ExecStart works with the binary swapped.
fn cli_args() -> Vec<std::ffi::OsString> {
    let mut args: Vec<std::ffi::OsString> = std::env::args_os().collect();
    let called = args
        .first()
        .and_then(|a| std::path::Path::new(a).file_name())
        .and_then(|n| n.to_str())
        .map(str::to_owned);
    let sub = match called.as_deref() {
        Some("goby_frontseat_interface") => Some("interface"),
        Some("goby_moos_gateway") => Some("moos-gateway"),
        _ => None,
    };
    if let Some(sub) = sub {
        args.insert(1.min(args.len()), sub.into());
    }
    args
}

fn main() -> ExitCode {
    let cli = Cli::parse_from(cli_args());
    match cli.command {
        Command::Interfaces => {
            print!("{}", frontseat_actors::generated::RESOLVED_INTERFACES_YAML);
            print!("{}", compose::supervision_tree());
            ExitCode::SUCCESS
        }
        Command::Interface { cfg } => {
            if let Some(code) = config_commands(&cfg, load_interface) {
                return code;
            }
            let (config, notes) = match load_config_with(&cfg, false, load_interface) {
                Ok(c) => c,
                Err(code) => return code,
            };
            let tel = config.telemetry.clone();
            let name = config.name.clone();
            run_traced(&tel, "interface", &name, async move {
                log_config_notes(&notes);
                compose::interface::run(config).await
            })
        }
        Command::Sim {
            cfg,
            bind,
            port,
            emulator,
        } if emulator.vehicle == vehicle_sim::VehicleKind::Bluefin => {
            if let Some(code) = config_commands(&cfg, load_plain::<frontseat_config::SimConfig>) {
                return code;
            }
            let mut config = match load_config::<frontseat_config::SimConfig>(&cfg, true) {
                Ok(c) => c,
                Err(code) => return code,
            };
            if let Some(b) = bind {
                config.bind = b;
            }
            let tel = config.telemetry.clone();
            let serve = bluefin_sim::serve(config, port, emulator.refusal, emulator.emulator_warp);
            run_traced(&tel, "sim", "", serve)
        }
        Command::Sim { emulator, .. } if emulator.vehicle != vehicle_sim::VehicleKind::Basic => {
            run_traced(
                &Default::default(),
                "sim",
                "",
                vehicle_sim::run_emulator(emulator),
            )
        }
        Command::Sim {
            cfg, port, bind, ..
        } => {
            if let Some(code) = config_commands(&cfg, load_plain::<frontseat_config::SimConfig>) {
                return code;
            }
            let mut config = match load_config::<frontseat_config::SimConfig>(&cfg, true) {
                Ok(c) => c,
                Err(code) => return code,
            };
            if let Some(p) = port {
                config.port = p;
            }
            if let Some(b) = bind {
                config.bind = b;
            }
            let tel = config.telemetry.clone();
            run_traced(&tel, "sim", "", compose::simulator::run(config))
        }
        Command::MoosGateway { cfg } => {
            if let Some(code) = config_commands(&cfg, load_plain::<frontseat_config::GatewayConfig>)
            {
                return code;
            }
            let (config, notes) = match load_config_with(
                &cfg,
                false,
                load_plain::<frontseat_config::GatewayConfig>,
            ) {
                Ok(c) => c,
                Err(code) => return code,
            };
            let tel = config.telemetry.clone();
            let name = config.name.clone();
            run_traced(&tel, "moos-gateway", &name, async move {
                log_config_notes(&notes);
                compose::moos_gateway::run(config).await
            })
        }
        // No logging set-up: stdout carries the frames to the interface.
        Command::DriverHost(args) => driver_host::run(args),
        Command::Chaos(args) => chaos_cmd::run(args),
        Command::Demo(args) if args.fleet.is_some() => {
            run_traced(&Default::default(), "demo", "", fleet_demo::run(args))
        }
        Command::Demo(args) => {
            match args.vehicle {
                // The serial vehicles fly over a pseudo-terminal through their own drivers.
                kind @ (vehicle_kind::VehicleKind::Iver3
                | vehicle_kind::VehicleKind::WavegliderSv2
                | vehicle_kind::VehicleKind::Ardupilot
                | vehicle_kind::VehicleKind::Dune
                | vehicle_kind::VehicleKind::Ardusub) => run_traced(
                    &Default::default(),
                    "demo",
                    "",
                    vehicle_sim::run_demo(args, kind),
                ),
                _ => run_traced(&Default::default(), "demo", "", demo::run(args)),
            }
        }
        Command::Bench(args) => bench_cmd::run(args),
        Command::Launch { cfg } => launch_cmd::run(&cfg),
        Command::Topside { cfg } => {
            if let Some(code) =
                config_commands(&cfg, load_plain::<frontseat_topside::TopsideConfig>)
            {
                return code;
            }
            let config = match load_config::<frontseat_topside::TopsideConfig>(&cfg, false) {
                Ok(c) => c,
                Err(code) => return code,
            };
            run_traced(&Default::default(), "topside", "", async move {
                ExitCode::from(frontseat_topside::run(config, shutdown::shutdown_signal()).await)
            })
        }
        Command::Completions { shell } => {
            docs_gen::completions(Cli::command(), shell, &mut std::io::stdout());
            ExitCode::SUCCESS
        }
        Command::ManPages { dir } => match docs_gen::man_pages(Cli::command(), &dir) {
            Ok(pages) => {
                for p in pages {
                    println!("{}", p.display());
                }
                ExitCode::SUCCESS
            }
            Err(e) => {
                eprintln!("frontseat man-pages: {}: {e}", dir.display());
                ExitCode::from(1)
            }
        },
        Command::Log(args) => record_cmd::log(args),
        Command::Replay(args) => {
            run_traced(&Default::default(), "replay", "", record_cmd::replay(args))
        }
    }
}

/// What loading the config has to say (a Goby3 file's ignored fields, the driver a Goby3 library
/// name chose), once logging is up.
fn log_config_notes(notes: &[String]) {
    for n in notes {
        tracing::warn!("config: {n}");
    }
}
