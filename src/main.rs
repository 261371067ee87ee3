//! The `frontseat` command line: parses arguments, loads and validates config, composes the
//! crates, waits for a shutdown signal and drains. Everything with logic lives in the crates.
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
mod demo;
mod docs_gen;
mod driver_host;
mod fleet_demo;
mod gateway_cmd;
mod launch_cmd;
mod record_cmd;
mod service;
mod shutdown;
mod sibling;
mod vehicle_kind;
mod vehicle_sim;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Args, Parser, Subcommand};

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

/// Config handling shared by every service subcommand.
#[derive(Args, Debug, Clone)]
struct ConfigArgs {
    /// Configuration file: TOML, or a Goby3 .pb.cfg of the Goby3 application this replaces.
    /// `--example_config` prints a complete TOML one.
    #[arg(short = 'c', long = "config", value_name = "FILE")]
    config: Option<PathBuf>,
    /// The configuration file given as Goby3 applications take it (`goby_frontseat_interface
    /// vehicle.pb.cfg`): the same as -c.
    #[arg(value_name = "CONFIG", conflicts_with = "config")]
    config_positional: Option<PathBuf>,
    /// Print a complete example config (every field, its default, unit and description) and exit.
    #[arg(long = "example_config", alias = "example-config")]
    example_config: bool,
    /// Print the JSON Schema of the config and exit.
    #[arg(long)]
    schema: bool,
    /// Validate the config given with -c and exit: 0 when valid, 2 with the errors otherwise.
    #[arg(long)]
    check: bool,
    /// Print the TOML equivalent of a Goby3 .pb.cfg of the Goby3 application this replaces
    /// (goby_frontseat_interface, goby_moos_gateway), a comment per field, and exit. `-c
    /// FILE.pb.cfg` runs such a file as it is.
    #[arg(
        long = "import-goby3",
        alias = "import_goby3",
        value_name = "FILE.pb.cfg"
    )]
    import_goby3: Option<PathBuf>,
}

impl ConfigArgs {
    /// The config file, by -c or as Goby3's positional argument.
    fn file(&self) -> Option<&PathBuf> {
        self.config.as_ref().or(self.config_positional.as_ref())
    }
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

/// Console logs always (no colours off a TTY, so journald and files stay clean); OTLP traces when
/// `[telemetry]` or the OTEL_* environment asks. Returns the handle that flushes on shutdown.
fn init_telemetry(
    cfg: &frontseat_config::TelemetryConfig,
    role: &str,
    platform: &str,
) -> frontseat_telemetry::Telemetry {
    frontseat_telemetry::init(cfg, role, platform)
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

/// How a service's config is loaded: the config and the lines to log about it (a Goby3 .pb.cfg's
/// ignored fields, the driver a Goby3 library name selected).
type Loaded<T> = Result<(T, Vec<String>), frontseat_config::ConfigError>;

fn load_plain<T: frontseat_config::ServiceConfig>(path: &std::path::Path) -> Loaded<T> {
    frontseat_config::load_with_notes::<T>(path)
}

/// The interface's config as Goby3 would choose its driver: FRONTSEAT_DRIVER_LIBRARY naming one
/// of Goby3's driver libraries selects our built-in driver of that vehicle (then validated again,
/// since that driver's section now counts).
fn load_interface(path: &std::path::Path) -> Loaded<frontseat_config::InterfaceConfig> {
    use frontseat_config::ServiceConfig;
    let (mut cfg, mut notes) = load_plain::<frontseat_config::InterfaceConfig>(path)?;
    let env = std::env::var("FRONTSEAT_DRIVER_LIBRARY").ok();
    if let Some(chosen) = cfg.select_goby3_driver(env.as_deref()) {
        notes.push(chosen);
        let errors = cfg.validate();
        if !errors.is_empty() {
            return Err(frontseat_config::ConfigError::Invalid {
                file: path.display().to_string(),
                errors,
            });
        }
    }
    Ok((cfg, notes))
}

/// `--example_config`, `--schema`, `--check`, `--import-goby3`: answered here, before any service
/// starts. Returns Some(exit code) when one of them was asked for.
fn config_commands<T: frontseat_config::ServiceConfig>(
    a: &ConfigArgs,
    loader: fn(&std::path::Path) -> Loaded<T>,
) -> Option<ExitCode> {
    if let Some(path) = &a.import_goby3 {
        return Some(match frontseat_config::import_goby3::<T>(path) {
            Ok(imported) => {
                print!("{}", imported.toml);
                ExitCode::SUCCESS
            }
            Err(e) => {
                eprintln!("{e}");
                ExitCode::from(2)
            }
        });
    }
    if a.example_config {
        print!("{}", frontseat_config::example::<T>());
        return Some(ExitCode::SUCCESS);
    }
    if a.schema {
        println!("{}", frontseat_config::schema::<T>());
        return Some(ExitCode::SUCCESS);
    }
    if a.check {
        let Some(path) = a.file() else {
            eprintln!("--check needs a config file: --check -c FILE");
            return Some(ExitCode::from(2));
        };
        return Some(match loader(path) {
            Ok((cfg, notes)) => {
                for w in notes.iter().chain(cfg.warnings().iter()) {
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
    load_config_with(a, optional, load_plain::<T>).map(|(cfg, _)| cfg)
}

/// [`load_config`] with the service's loader, keeping the lines to log once logging is up.
fn load_config_with<T: frontseat_config::ServiceConfig>(
    a: &ConfigArgs,
    optional: bool,
    loader: fn(&std::path::Path) -> Loaded<T>,
) -> Result<(T, Vec<String>), ExitCode> {
    match a.file() {
        Some(path) => loader(path).map_err(|e| {
            eprintln!("{e}");
            ExitCode::from(2)
        }),
        None if optional => Ok((T::default(), Vec::new())),
        None => {
            let s = T::SERVICE;
            eprintln!(
                "frontseat {s}: a config file is required: frontseat {s} -c FILE\n\
                 Start from the complete example (every field, its default and unit):\n  \
                 frontseat {s} --example_config > {s}.toml\n  \
                 frontseat {s} --check -c {s}.toml\n  \
                 frontseat {s} -c {s}.toml"
            );
            Err(ExitCode::from(2))
        }
    }
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
            print!("{}", service::supervision_tree());
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
                service::interface(config).await
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
            run_traced(&tel, "sim", "", service::sim(config))
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
                gateway_cmd::moos_gateway(config).await
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
                ExitCode::from(frontseat_topside::run(config, service::shutdown_signal()).await)
            })
        }
        Command::Completions { shell } => {
            docs_gen::completions(shell, &mut std::io::stdout());
            ExitCode::SUCCESS
        }
        Command::ManPages { dir } => match docs_gen::man_pages(&dir) {
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
