//! The `frontseat` command line: parses arguments, loads and validates config, composes the
//! crates, waits for a shutdown signal and drains. Everything with logic lives in the crates.
#![forbid(unsafe_code)]

mod bench_cmd;
mod bluefin_sim;
mod chaos_cmd;
mod demo;
mod driver_host;
mod gateway_cmd;
mod service;
mod shutdown;
mod vehicle_kind;
mod vehicle_sim;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Args, Parser, Subcommand};

#[derive(Parser, Debug)]
#[command(
    name = "frontseat",
    version,
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

/// Config handling shared by every service subcommand.
#[derive(Args, Debug, Clone)]
struct ConfigArgs {
    /// Configuration file (TOML). `--example_config` prints a complete one.
    #[arg(short = 'c', long = "config", value_name = "FILE")]
    config: Option<PathBuf>,
    /// Print a complete example config (every field, its default, unit and description) and exit.
    #[arg(long = "example_config", alias = "example-config")]
    example_config: bool,
    /// Print the JSON Schema of the config and exit.
    #[arg(long)]
    schema: bool,
    /// Validate the config given with -c and exit: 0 when valid, 2 with the errors otherwise.
    #[arg(long)]
    check: bool,
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
        /// A vehicle emulator instead of the basic simulator (`--vehicle bluefin|iver3|waveglider_sv2|ardupilot`).
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
}

/// Console logs always (no colours off a TTY, so journald and files stay clean); OTLP traces when
/// `[telemetry]` or the OTEL_* environment asks. Returns the handle that flushes on shutdown.
fn init_telemetry(
    cfg: &frontseat_config::TelemetryConfig,
    role: &str,
    platform: &str,
) -> frontseat_actors::telemetry::Telemetry {
    frontseat_actors::telemetry::init(cfg, role, platform)
}

/// Runs a service with telemetry, and flushes the last spans before exiting.
fn run_traced(
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

/// `--example_config`, `--schema`, `--check`: answered here, before any service starts.
/// Returns Some(exit code) when one of them was asked for.
fn config_commands<T: frontseat_config::ServiceConfig>(a: &ConfigArgs) -> Option<ExitCode> {
    if a.example_config {
        print!("{}", frontseat_config::example::<T>());
        return Some(ExitCode::SUCCESS);
    }
    if a.schema {
        println!("{}", frontseat_config::schema::<T>());
        return Some(ExitCode::SUCCESS);
    }
    if a.check {
        let Some(path) = &a.config else {
            eprintln!("--check needs a config file: --check -c FILE");
            return Some(ExitCode::from(2));
        };
        return Some(match frontseat_config::load::<T>(path) {
            Ok(cfg) => {
                for w in cfg.warnings() {
                    eprintln!("{}: warning: {w}", path.display());
                }
                println!("{}: ok ({} config)", path.display(), T::SERVICE);
                ExitCode::SUCCESS
            }
            Err(e) => {
                eprintln!("{e}");
                ExitCode::from(2)
            }
        });
    }
    None
}

/// Loads the config named by -c, or the defaults when `optional` and none is given.
fn load_config<T: frontseat_config::ServiceConfig>(
    a: &ConfigArgs,
    optional: bool,
) -> Result<T, ExitCode> {
    match &a.config {
        Some(path) => frontseat_config::load::<T>(path).map_err(|e| {
            eprintln!("{e}");
            ExitCode::from(2)
        }),
        None if optional => Ok(T::default()),
        None => {
            eprintln!(
                "frontseat {}: a config file is required: -c FILE (see --example_config)",
                T::SERVICE
            );
            Err(ExitCode::from(2))
        }
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Command::Interfaces => {
            print!("{}", frontseat_actors::generated::RESOLVED_INTERFACES_YAML);
            print!("{}", frontseat_actors::supervisor::TREE);
            ExitCode::SUCCESS
        }
        Command::Interface { cfg } => {
            if let Some(code) = config_commands::<frontseat_config::InterfaceConfig>(&cfg) {
                return code;
            }
            let config = match load_config::<frontseat_config::InterfaceConfig>(&cfg, false) {
                Ok(c) => c,
                Err(code) => return code,
            };
            let tel = config.telemetry.clone();
            let name = config.name.clone();
            run_traced(&tel, "interface", &name, service::interface(config))
        }
        Command::Sim {
            cfg,
            bind,
            port,
            emulator,
        } if emulator.vehicle == vehicle_sim::VehicleKind::Bluefin => {
            if let Some(code) = config_commands::<frontseat_config::SimConfig>(&cfg) {
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
            if let Some(code) = config_commands::<frontseat_config::SimConfig>(&cfg) {
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
            run_traced(&tel, "sim", "", service::sim(config))
        }
        Command::MoosGateway { cfg } => {
            if let Some(code) = config_commands::<frontseat_config::GatewayConfig>(&cfg) {
                return code;
            }
            let config = match load_config::<frontseat_config::GatewayConfig>(&cfg, false) {
                Ok(c) => c,
                Err(code) => return code,
            };
            let tel = config.telemetry.clone();
            let name = config.name.clone();
            run_traced(
                &tel,
                "moos-gateway",
                &name,
                gateway_cmd::moos_gateway(config),
            )
        }
        // No logging set-up: stdout carries the frames to the interface.
        Command::DriverHost(args) => driver_host::run(args),
        Command::Chaos(args) => {
            // A long run would fill the console with every injected fault at info level.
            frontseat_actors::telemetry::set_default_console_level("warn");
            run_traced(&Default::default(), "chaos", "", chaos_cmd::run(args))
        }
        Command::Demo(args) => {
            match args.vehicle {
                // The serial vehicles fly over a pseudo-terminal through their own drivers.
                kind @ (vehicle_kind::VehicleKind::Iver3
                | vehicle_kind::VehicleKind::WavegliderSv2
                | vehicle_kind::VehicleKind::Ardupilot) => run_traced(
                    &Default::default(),
                    "demo",
                    "",
                    vehicle_sim::run_demo(args, kind),
                ),
                _ => run_traced(&Default::default(), "demo", "", demo::run(args)),
            }
        }
        Command::Bench(args) => run_traced(&Default::default(), "bench", "", bench_cmd::run(args)),
    }
}

fn run(fut: impl std::future::Future<Output = ExitCode>) -> ExitCode {
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
