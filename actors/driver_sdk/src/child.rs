//! The driver-host child process (`frontseat driver-host --library PATH`): loads one driver
//! library, takes frames from the interface on stdin and answers on stdout. A crash here (a
//! segfault in C, an abort) ends only this process; the interface sees the pipe close and the
//! exit status.
//!
//! Before loading anything it keeps private copies of stdin/stdout for the frames and points
//! fd 0 at /dev/null and fd 1 at stderr, so a driver that prints cannot corrupt the protocol.
#![forbid(unsafe_code)]

use std::fs::File;
use std::os::fd::AsFd;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::{Arc, Mutex};

use crate::abi;
use crate::driver::SignalKind;
use crate::error::Error;
use crate::frame::{self, FromHost, LoadFailed, Loaded, ToHost, from_host::Event, to_host::Op};
use crate::loader::{Instance, Plugin, Signal};

/// Exit status after the driver returned FSD_ERR_FATAL.
pub const EXIT_DRIVER_FAILED: u8 = 8;

/// `driver-host` arguments: `--library PATH [--check]`.
#[derive(Debug, Clone, PartialEq)]
pub struct HostArgs {
    pub library: PathBuf,
    /// Only open the library and check its ABI version and symbols; print the result as one
    /// frame on stdout and exit (0 = loadable).
    pub check: bool,
}

impl HostArgs {
    /// Parses the arguments after `driver-host` (for hosts without clap).
    pub fn parse(args: impl IntoIterator<Item = std::ffi::OsString>) -> Result<Self, String> {
        let mut library = None;
        let mut check = false;
        let mut it = args.into_iter();
        while let Some(a) = it.next() {
            match a.to_str() {
                Some("--library") => library = it.next().map(PathBuf::from),
                Some("--check") => check = true,
                _ => return Err(format!("unexpected argument {a:?}")),
            }
        }
        let library = library.ok_or("--library PATH is required")?;
        Ok(Self { library, check })
    }
}

fn take_stdio() -> std::io::Result<(File, File)> {
    let frames_in = File::from(std::io::stdin().as_fd().try_clone_to_owned()?);
    let frames_out = File::from(std::io::stdout().as_fd().try_clone_to_owned()?);
    let null = File::open("/dev/null")?;
    rustix::stdio::dup2_stdin(&null)?;
    rustix::stdio::dup2_stdout(std::io::stderr())?;
    Ok((frames_in, frames_out))
}

type Send = Arc<dyn Fn(Event) + std::marker::Send + Sync>;

fn signal_event(s: Signal) -> Event {
    match s {
        Signal::Bytes(SignalKind::CommandResponse, b) => Event::CommandResponse(b),
        Signal::Bytes(SignalKind::DataFromFrontseat, b) => Event::DataFromFrontseat(b),
        Signal::Bytes(SignalKind::RawFromFrontseat, b) => Event::RawFromFrontseat(b),
        Signal::Bytes(SignalKind::RawToFrontseat, b) => Event::RawToFrontseat(b),
        Signal::State {
            state,
            providing_data,
        } => Event::State(frame::State {
            frontseat_state: state,
            providing_data,
        }),
        Signal::Log { level, message } => Event::Log(frame::Log {
            level: level.to_abi(),
            message,
        }),
    }
}

fn fail(send: &Send, e: &Error) -> ExitCode {
    eprintln!("frontseat driver-host: {e}");
    send(Event::LoadFailed(LoadFailed::from_error(e)));
    ExitCode::from(e.exit_code())
}

/// Runs the driver host until the interface says Unload or goes away; the exit status is 0,
/// [`Error::exit_code`] of a load failure, or [`EXIT_DRIVER_FAILED`].
pub fn run(args: &HostArgs) -> ExitCode {
    let (mut frames_in, frames_out) = match take_stdio() {
        Ok(x) => x,
        Err(e) => {
            eprintln!("frontseat driver-host: cannot set up stdin/stdout: {e}");
            return ExitCode::from(9);
        }
    };
    let out = Mutex::new(frames_out);
    let send: Send = Arc::new(move |ev: Event| {
        let mut w = match out.lock() {
            Ok(w) => w,
            Err(p) => p.into_inner(),
        };
        // The interface gone means stdin ends too; the main loop notices there.
        let _ = frame::write_frame(&mut *w, &FromHost { event: Some(ev) });
    });
    serve(&args.library, args.check, &mut frames_in, send)
}

/// The protocol loop, on any reader (tests use it without a process).
pub fn serve(
    library: &Path,
    check: bool,
    frames_in: &mut impl std::io::Read,
    send: Send,
) -> ExitCode {
    let plugin = match Plugin::open(library) {
        Ok(p) => p,
        Err(e) => return fail(&send, &e),
    };
    if check {
        send(Event::Loaded(Loaded {
            abi_version: abi::ABI_VERSION,
        }));
        return ExitCode::SUCCESS;
    }
    let config = match frame::read_frame::<ToHost>(frames_in) {
        Ok(Some(ToHost {
            op: Some(Op::Load(c)),
        })) => c,
        Ok(None) => return ExitCode::SUCCESS,
        Ok(Some(other)) => {
            return fail(
                &send,
                &Error::Frame(format!("expected Load first, got {other:?}")),
            );
        }
        Err(e) => return fail(&send, &e),
    };
    let s = send.clone();
    let mut inst = match plugin.load(&config, Arc::new(move |sig| s(signal_event(sig)))) {
        Ok(i) => i,
        Err(e) => return fail(&send, &e),
    };
    send(Event::Loaded(Loaded {
        abi_version: abi::ABI_VERSION,
    }));
    let mut last = None;
    report_state(&mut inst, &mut last, &send);
    loop {
        let op = match frame::read_frame::<ToHost>(frames_in) {
            Ok(None) => break,
            Ok(Some(ToHost { op: Some(op) })) => op,
            Ok(Some(ToHost { op: None })) => continue,
            Err(e) => {
                eprintln!("frontseat driver-host: {e}; unloading");
                break;
            }
        };
        let (name, code) = match op {
            Op::Command(b) => ("send_command", inst.send_command(&b)),
            Op::Data(b) => ("send_data", inst.send_data(&b)),
            Op::Raw(b) => ("send_raw", inst.send_raw(&b)),
            Op::Tick(now) => {
                let code = inst.do_loop(now);
                send(Event::TickDone(now));
                ("loop", code)
            }
            Op::Unload(_) => break,
            Op::Load(_) => {
                eprintln!("frontseat driver-host: a second Load is ignored");
                continue;
            }
        };
        if code != abi::OK {
            send(Event::OpFailed(frame::OpFailed {
                op: name.into(),
                code,
            }));
            if code == abi::ERR_FATAL {
                drop(inst);
                return ExitCode::from(EXIT_DRIVER_FAILED);
            }
        }
        report_state(&mut inst, &mut last, &send);
    }
    drop(inst);
    ExitCode::SUCCESS
}

fn report_state(inst: &mut Instance, last: &mut Option<(i32, bool)>, send: &Send) {
    let now = (inst.frontseat_state(), inst.frontseat_providing_data());
    if *last != Some(now) {
        *last = Some(now);
        send(Event::State(frame::State {
            frontseat_state: now.0,
            providing_data: now.1,
        }));
    }
}
