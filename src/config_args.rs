//! The config options every service subcommand takes (`-c FILE` or Goby3's positional file,
//! `--example_config`, `--schema`, `--check`, `--import-goby3`), answering the ones that print
//! and exit, and loading the config a service runs with.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;

/// Config handling shared by every service subcommand.
#[derive(Args, Debug, Clone)]
pub struct ConfigArgs {
    /// Configuration file: TOML, or a Goby3 .pb.cfg of the Goby3 application this replaces.
    /// `--example_config` prints a complete TOML one.
    #[arg(short = 'c', long = "config", value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// The configuration file given as Goby3 applications take it (`goby_frontseat_interface
    /// vehicle.pb.cfg`): the same as -c.
    #[arg(value_name = "CONFIG", conflicts_with = "config")]
    pub config_positional: Option<PathBuf>,
    /// Print a complete example config (every field, its default, unit and description) and exit.
    #[arg(long = "example_config", alias = "example-config")]
    pub example_config: bool,
    /// Print the JSON Schema of the config and exit.
    #[arg(long)]
    pub schema: bool,
    /// Validate the config given with -c and exit: 0 when valid, 2 with the errors otherwise.
    #[arg(long)]
    pub check: bool,
    /// Print the TOML equivalent of a Goby3 .pb.cfg of the Goby3 application this replaces
    /// (goby_frontseat_interface, goby_moos_gateway), a comment per field, and exit. `-c
    /// FILE.pb.cfg` runs such a file as it is.
    #[arg(
        long = "import-goby3",
        alias = "import_goby3",
        value_name = "FILE.pb.cfg"
    )]
    pub import_goby3: Option<PathBuf>,
}

impl ConfigArgs {
    /// The config file, by -c or as Goby3's positional argument.
    pub fn file(&self) -> Option<&PathBuf> {
        self.config.as_ref().or(self.config_positional.as_ref())
    }
}

/// How a service's config is loaded: the config and the lines to log about it (a Goby3 .pb.cfg's
/// ignored fields, the driver a Goby3 library name selected).
pub type Loaded<T> = Result<(T, Vec<String>), frontseat_config::ConfigError>;

pub fn load_plain<T: frontseat_config::ServiceConfig>(path: &std::path::Path) -> Loaded<T> {
    frontseat_config::load_with_notes::<T>(path)
}

/// The interface's config as Goby3 would choose its driver: FRONTSEAT_DRIVER_LIBRARY naming one
/// of Goby3's driver libraries selects our built-in driver of that vehicle (then validated again,
/// since that driver's section now counts).
pub fn load_interface(path: &std::path::Path) -> Loaded<frontseat_config::InterfaceConfig> {
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
pub fn config_commands<T: frontseat_config::ServiceConfig>(
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
pub fn load_config<T: frontseat_config::ServiceConfig>(
    a: &ConfigArgs,
    optional: bool,
) -> Result<T, ExitCode> {
    load_config_with(a, optional, load_plain::<T>).map(|(cfg, _)| cfg)
}

/// [`load_config`] with the service's loader, keeping the lines to log once logging is up.
pub fn load_config_with<T: frontseat_config::ServiceConfig>(
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
