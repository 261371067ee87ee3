//! The recording commands: `frontseat log info|export|plot|import|recover` and `frontseat replay`. The
//! work is in `frontseat-record`; this is argument handling and exit codes. (A service's own
//! recorder is started by its composition root: `compose::recording`.)

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Args, Subcommand, ValueEnum};
use frontseat_actors::bus::Bus;
use frontseat_helm_side::outlet::{Onto, Outlet};
use frontseat_record::replay::{ReplayOptions, Speed};
use frontseat_record::{Recording, export, info};

#[derive(Args, Debug)]
pub struct LogArgs {
    #[command(subcommand)]
    pub command: LogCommand,
}

#[derive(Subcommand, Debug)]
pub enum LogCommand {
    /// Span, groups with counts, rates and gaps, the recorder's drops, and whether the file was
    /// closed or cut short (read up to its last whole chunk).
    Info {
        file: PathBuf,
        /// Print JSON instead of the table.
        #[arg(long)]
        json: bool,
    },
    /// One group's messages as CSV (fields flattened by path) or JSON Lines, decoded with the
    /// schema stored in the file.
    Export {
        file: PathBuf,
        /// The Goby3 group, e.g. goby::middleware::frontseat::node_status.
        #[arg(long)]
        group: String,
        #[arg(long, value_enum, default_value_t = ExportFormat::Csv)]
        format: ExportFormat,
        /// Write here instead of standard output (through a temporary file beside it, renamed
        /// at the end; never the input file).
        #[arg(long, short = 'o', value_name = "FILE")]
        output: Option<PathBuf>,
        /// Replace the output file if it exists.
        #[arg(long)]
        force: bool,
    },
    /// Converts a goby_logger `.goby` file to MCAP, using the protobuf descriptors the file
    /// carries (types this binary does not know are kept). PROTOBUF entries are converted; DCCL,
    /// CSTR and other schemes are counted and skipped; damaged entries (bad CRC) are skipped and
    /// the rest of the file is still read.
    Import {
        file: PathBuf,
        /// The MCAP file to write (default: FILE with the extension .mcap).
        #[arg(long, short = 'o', value_name = "FILE")]
        output: Option<PathBuf>,
        /// Replace the output file if it exists.
        #[arg(long)]
        force: bool,
    },
    /// Finishes a recording that a crash (SIGKILL, power loss) left without its summary, so that
    /// every MCAP reader opens it (Foxglove, the Python and C++ readers' ordinary open): the
    /// messages, channels, schemas and metadata up to the last whole chunk are written again with
    /// the summary, indexes and footer into a new file beside FILE, which is synced, read back,
    /// and renamed over FILE. What `mcap recover` does, for frontseat's recordings only.
    ///
    /// The recorder does this itself at start for the files it would have named; this is for a
    /// file moved elsewhere, or one it could not finish (disk full). Refused (exit 2, nothing
    /// written): a symlink (never followed), not a regular file, a file whose MCAP header does
    /// not say frontseat's recorder wrote it, a file a running recorder is writing. A file that
    /// already has its summary is left as it is (exit 0). Exit 1: not MCAP, or the copy failed
    /// (the original is then left as it was).
    Recover {
        file: PathBuf,
        /// Chunk compression of the finished file.
        #[arg(long, value_enum, default_value_t = Compression::Zstd)]
        compression: Compression,
    },
    /// Writes DIR/track.svg (the recorded track on the local grid) and DIR/time.svg (speed,
    /// heading and depth against time, actual from node_status, commanded from desired_course,
    /// over a band of the interface's state from its status group).
    Plot {
        file: PathBuf,
        #[arg(long, value_name = "DIR", default_value = "plot-out")]
        out: PathBuf,
        /// Replace track.svg and time.svg if they exist.
        #[arg(long)]
        force: bool,
    },
}

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum Compression {
    Zstd,
    Lz4,
    None,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum ExportFormat {
    Csv,
    Json,
}

pub fn log(args: LogArgs) -> ExitCode {
    match args.command {
        LogCommand::Import {
            file,
            output,
            force,
        } => import(&file, output, force),
        LogCommand::Recover { file, compression } => recover(&file, compression),
        LogCommand::Plot { file, out, force } => {
            let s = match Recording::open(&file).and_then(frontseat_record::plot::series) {
                Ok(s) => s,
                Err(e) => return fail(&e),
            };
            match frontseat_record::plot::write_dir(&s, &out, force, &file) {
                Ok([track, time]) => {
                    eprintln!(
                        "{} node_status and {} desired_course samples; wrote {} and {}",
                        s.actual.len(),
                        s.commanded.len(),
                        track.display(),
                        time.display()
                    );
                    ExitCode::SUCCESS
                }
                Err(e) => {
                    eprintln!("{e}");
                    ExitCode::from(if e.is_usage() { 2 } else { 1 })
                }
            }
        }
        LogCommand::Info { file, json } => {
            match Recording::open(&file).and_then(info::info) {
                Ok(i) if json => println!("{:#}", i.to_json()),
                Ok(i) => print!("{}", i.render()),
                Err(e) => return fail(&e),
            }
            ExitCode::SUCCESS
        }
        LogCommand::Export {
            file,
            group,
            format,
            output,
            force,
        } => {
            let format = match format {
                ExportFormat::Csv => export::Format::Csv,
                ExportFormat::Json => export::Format::Json,
            };
            let result = Recording::open(&file)
                .map_err(export::ExportError::Read)
                .and_then(|rec| {
                    export::export_to(rec, &group, format, output.as_deref(), force, &file)
                });
            match result {
                Ok(done) => {
                    eprintln!(
                        "{} rows{}{}{}{}",
                        done.rows,
                        if done.undecodable > 0 {
                            format!(", {} undecodable messages skipped", done.undecodable)
                        } else {
                            String::new()
                        },
                        if done.json_cells > 0 {
                            format!(
                                "; {} sub-message columns kept as JSON (a type containing itself, or over {} columns)",
                                done.json_cells,
                                export::MAX_COLUMNS
                            )
                        } else {
                            String::new()
                        },
                        done.truncated
                            .map(|t| format!("; the file was cut short: {t}"))
                            .unwrap_or_default(),
                        done.limits_note
                            .map(|n| format!("; not read: {n}"))
                            .unwrap_or_default()
                    );
                    ExitCode::SUCCESS
                }
                Err(e) => {
                    eprintln!("{e}");
                    ExitCode::from(if e.is_usage() { 2 } else { 1 })
                }
            }
        }
    }
}

fn import(file: &Path, output: Option<PathBuf>, force: bool) -> ExitCode {
    match frontseat_record::import::import_file(file, output, force) {
        Ok((out, stats)) => {
            eprintln!("{}", stats.render());
            eprintln!("wrote {}", out.display());
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("{e}");
            ExitCode::from(if e.is_usage() { 2 } else { 1 })
        }
    }
}

fn recover(file: &Path, compression: Compression) -> ExitCode {
    use frontseat_config::RecordCompression as C;
    use frontseat_record::recover::{Outcome, RecoverOptions};
    let opts = RecoverOptions::new(match compression {
        Compression::Zstd => C::Zstd,
        Compression::Lz4 => C::Lz4,
        Compression::None => C::None,
    });
    let never = std::sync::atomic::AtomicBool::new(false);
    match frontseat_record::recover::recover(file, &opts, &never) {
        Ok(Outcome::AlreadyComplete) => {
            eprintln!(
                "{}: complete already (it has its summary); left as it is",
                file.display()
            );
            ExitCode::SUCCESS
        }
        Ok(Outcome::Recovered(r)) => {
            eprintln!(
                "{}: finished: {} messages kept, every one up to the last whole chunk ({}); {} → {} bytes{}",
                file.display(),
                r.messages,
                r.cut,
                r.bytes_before,
                r.bytes_after,
                if r.unknown_channel > 0 {
                    format!(
                        "; {} messages of a channel the file never defined were not kept",
                        r.unknown_channel
                    )
                } else {
                    String::new()
                }
            );
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("{e}");
            ExitCode::from(if e.is_usage() { 2 } else { 1 })
        }
    }
}

fn fail(e: &dyn std::fmt::Display) -> ExitCode {
    eprintln!("{e}");
    ExitCode::from(1)
}

#[derive(Args, Debug)]
pub struct ReplayArgs {
    /// The recording (MCAP) to replay.
    pub file: PathBuf,
    /// Speed: a factor (2 = twice as fast) or `max`.
    #[arg(long, default_value = "1")]
    pub speed: String,
    /// Start this many seconds after the first message of the file.
    #[arg(long, value_name = "S")]
    pub from: Option<f64>,
    /// Stop this many seconds after the first message of the file.
    #[arg(long, value_name = "S")]
    pub to: Option<f64>,
    /// Only groups matching this regex (among the vehicle's publications).
    #[arg(long, value_name = "REGEX")]
    pub groups: Option<String>,
    /// Start over at the end, until Ctrl-C.
    #[arg(long = "loop")]
    pub looped: bool,
    /// Zenoh platform (key prefix), or the Goby3 platform with `--onto gobyd`; default: the
    /// vehicle name recorded in the file.
    #[arg(long)]
    pub platform: Option<String>,
    /// Zenoh endpoints to listen on (default tcp/127.0.0.1:7447, as the interface).
    #[arg(long = "listen", value_name = "ENDPOINT")]
    pub listen: Vec<String>,
    /// Zenoh endpoints to connect to.
    #[arg(long = "connect", value_name = "ENDPOINT")]
    pub connect: Vec<String>,
    /// Publish onto this process's bus only (for tests and benches): the same as `--onto bus`.
    #[arg(long)]
    pub no_zenoh: bool,
    /// Where the replay goes: Zenoh (as a frontseat interface publishes), a Goby3 gobyd (as
    /// goby_frontseat_interface publishes: Goby3 applications and pHelmIvP through
    /// goby_moos_gateway see the recorded vehicle), or this process's bus only.
    #[arg(long, value_enum, default_value_t = ReplayTo::Zenoh)]
    pub onto: ReplayTo,
    /// gobyd's IPC socket base (Goby3's socket_name; default /tmp/goby_<platform>).
    #[arg(long, value_name = "PATH")]
    pub goby_socket: Option<String>,
    /// gobyd's manager over TCP instead of IPC, e.g. 127.0.0.1:11144.
    #[arg(long, value_name = "HOST:PORT")]
    pub goby_tcp: Option<String>,
    /// The name given to gobyd's manager.
    #[arg(long, default_value = "frontseat_replay")]
    pub goby_client_name: String,
    /// How long to wait for gobyd before giving up. Unit: s.
    #[arg(long, default_value_t = 15.0)]
    pub goby_wait: f64,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ReplayTo {
    Zenoh,
    Gobyd,
    Bus,
}

impl ReplayArgs {
    fn goby3_config(&self) -> Result<frontseat_config::Goby3Config, String> {
        let mut c = frontseat_config::Goby3Config {
            enabled: true,
            platform: self.platform.clone().unwrap_or_default(),
            client_name: self.goby_client_name.clone(),
            ..Default::default()
        };
        if let Some(s) = &self.goby_socket {
            c.socket_name = s.clone();
        }
        if let Some(t) = &self.goby_tcp {
            let (host, port) = t
                .rsplit_once(':')
                .and_then(|(h, p)| Some((h, p.parse::<u16>().ok()?)))
                .ok_or_else(|| format!("--goby-tcp {t:?}: HOST:PORT"))?;
            c.transport = frontseat_config::Goby3Transport::Tcp;
            c.ip_address = host.to_string();
            c.tcp_port = port;
        }
        Ok(c)
    }
}

impl ReplayArgs {
    /// The transport the replay publishes on (None: this process's bus only).
    fn onto(&self) -> Result<Option<Onto>, String> {
        let to = if self.no_zenoh {
            ReplayTo::Bus
        } else {
            self.onto
        };
        let vehicle = || recorded_vehicle(&self.file).unwrap_or_default();
        Ok(match to {
            ReplayTo::Bus => None,
            ReplayTo::Gobyd => Some(Onto::Gobyd {
                cfg: self.goby3_config()?,
                vehicle: vehicle(),
                wait: std::time::Duration::try_from_secs_f64(self.goby_wait.clamp(0.1, 3600.0))
                    .unwrap_or(std::time::Duration::from_secs(15)),
            }),
            ReplayTo::Zenoh => {
                let mut cfg = frontseat_config::InterprocessConfig {
                    enabled: true,
                    ..Default::default()
                };
                if !self.listen.is_empty() {
                    cfg.listen = self.listen.clone();
                }
                cfg.connect = self.connect.clone();
                cfg.platform = self.platform.clone().unwrap_or_default();
                Some(Onto::Zenoh {
                    cfg,
                    vehicle: vehicle(),
                })
            }
        })
    }

    pub fn options(&self) -> Result<ReplayOptions, String> {
        let speed = match self.speed.as_str() {
            "max" => Speed::Max,
            s => match s.parse::<f64>() {
                Ok(f) if f.is_finite() && f > 0.0 => Speed::Factor(f),
                _ => return Err(format!("--speed {s:?}: a number greater than 0, or max")),
            },
        };
        let groups = match &self.groups {
            Some(r) => Some(regex::Regex::new(r).map_err(|e| format!("--groups: {e}"))?),
            None => None,
        };
        for (n, v) in [("--from", self.from), ("--to", self.to)] {
            if v.is_some_and(|v| !(v.is_finite() && v >= 0.0)) {
                return Err(format!("{n}: seconds, 0 or more"));
            }
        }
        Ok(ReplayOptions {
            speed,
            from_s: self.from,
            to_s: self.to,
            groups,
            looped: self.looped,
        })
    }
}

/// The vehicle name the file's run metadata gives, if any.
fn recorded_vehicle(path: &Path) -> Option<String> {
    let mut r = Recording::open(path).ok()?;
    let _ = r.next_message();
    r.metadata()
        .iter()
        .find(|(n, _)| n == frontseat_record::META_RUN)
        .and_then(|(_, m)| m.get("vehicle").cloned())
        .filter(|v| !v.is_empty())
}

pub async fn replay(args: ReplayArgs) -> ExitCode {
    let opts = match args.options() {
        Ok(o) => o,
        Err(e) => {
            eprintln!("{e}");
            return ExitCode::from(2);
        }
    };
    let bus = Bus::new();
    let outlet = match args.onto() {
        Ok(None) => None,
        Ok(Some(onto)) => match Outlet::open(&bus, onto).await {
            Ok(o) => {
                eprintln!("frontseat replay: {}", o.description());
                Some(o)
            }
            Err(e) => {
                eprintln!("{e}");
                return ExitCode::from(if e.is_usage() { 2 } else { 1 });
            }
        },
        Err(e) => {
            eprintln!("{e}");
            return ExitCode::from(2);
        }
    };
    let started = std::time::Instant::now();
    let result = tokio::select! {
        r = frontseat_record::replay::replay(&bus, &args.file, &opts) => Some(r),
        _ = crate::shutdown::shutdown_signal() => None,
    };
    if let Some(o) = outlet {
        // The end of the replay leaves the export queue (bounded) before the link closes.
        let published = match &result {
            Some(Ok(r)) => Some(r.published),
            _ => None,
        };
        o.close(published).await;
    }
    match result {
        None => ExitCode::SUCCESS,
        Some(Ok(s)) => {
            let took = started.elapsed().as_secs_f64();
            eprintln!(
                "replayed {} messages in {took:.3} s ({:.0} msg/s); skipped {} (commands to a vehicle, interthread, or outside --groups); {} undecodable{}",
                s.published,
                s.published as f64 / took.max(1e-9),
                s.skipped,
                s.undecodable,
                s.truncated
                    .map(|t| format!("; the file was cut short: {t}"))
                    .unwrap_or_default()
            );
            ExitCode::SUCCESS
        }
        Some(Err(e)) => fail(&e),
    }
}
