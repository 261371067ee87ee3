//! The interface's side of the driver-host child: spawns `HOST driver-host --library PATH`,
//! writes [`ToHost`] frames to its stdin, turns the [`FromHost`] frames of its stdout into
//! [`HostEvent`]s, and reports how the process ended. Also the pre-flight [`probe`] that tells
//! a missing file, a missing symbol or an ABI mismatch before the interface starts.
#![forbid(unsafe_code)]

use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::Stdio;
use std::sync::Arc;
use std::time::{Duration, Instant};

use tokio::io::AsyncWriteExt;
use tokio::sync::mpsc;

use crate::driver::SignalKind;
use crate::error::Error;
use crate::frame::{self, FromHost, ToHost, from_host::Event, to_host::Op};
use crate::loader::Signal;

/// How long a host that was told to stop (stdin closed) may take before it is killed.
pub const GRACE: Duration = Duration::from_secs(2);
/// Frames queued towards the host before sends are refused.
pub const QUEUE: usize = 1024;

#[derive(Debug)]
pub enum HostEvent {
    Loaded,
    LoadFailed(Error),
    Signal(Signal),
    OpFailed {
        op: String,
        code: i32,
    },
    TickDone(u64),
    /// Bytes on the pipe that were not a frame; the host is killed after this.
    ProtocolError(String),
    /// The process ended (always the last event): how, e.g. "signal: 11 (SIGSEGV)".
    Exited(String),
}

fn event(e: Event) -> HostEvent {
    use crate::driver::LogLevel;
    match e {
        Event::Loaded(_) => HostEvent::Loaded,
        Event::LoadFailed(f) => HostEvent::LoadFailed(f.to_error()),
        Event::CommandResponse(b) => {
            HostEvent::Signal(Signal::Bytes(SignalKind::CommandResponse, b))
        }
        Event::DataFromFrontseat(b) => {
            HostEvent::Signal(Signal::Bytes(SignalKind::DataFromFrontseat, b))
        }
        Event::RawFromFrontseat(b) => {
            HostEvent::Signal(Signal::Bytes(SignalKind::RawFromFrontseat, b))
        }
        Event::RawToFrontseat(b) => HostEvent::Signal(Signal::Bytes(SignalKind::RawToFrontseat, b)),
        Event::State(s) => HostEvent::Signal(Signal::State {
            state: s.frontseat_state,
            providing_data: s.providing_data,
        }),
        Event::TickDone(t) => HostEvent::TickDone(t),
        Event::OpFailed(f) => HostEvent::OpFailed {
            op: f.op,
            code: f.code,
        },
        Event::Log(l) => HostEvent::Signal(Signal::Log {
            level: LogLevel::from_abi(l.level),
            message: l.message,
        }),
    }
}

#[derive(Debug, PartialEq, Eq)]
pub enum SendError {
    /// The queue towards the host is full (the host is not reading).
    Full,
    /// The host is gone.
    Closed,
}

/// A running driver host. Dropping it closes the host's stdin: the host unloads the driver and
/// exits, or is killed after [`GRACE`].
pub struct HostProcess {
    tx: mpsc::Sender<ToHost>,
    pid: Option<u32>,
}

impl HostProcess {
    /// Spawns the host (inside a tokio runtime) and queues Load(config). `on_event` is called
    /// from a task for every event; returning false (nobody listens any more) kills the host.
    pub fn spawn(
        host_exe: &Path,
        library: &Path,
        config: Vec<u8>,
        on_event: Arc<dyn Fn(HostEvent) -> bool + Send + Sync>,
    ) -> Result<Self, Error> {
        let mut child = tokio::process::Command::new(host_exe)
            .arg("driver-host")
            .arg("--library")
            .arg(library)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .kill_on_drop(true)
            .spawn()
            .map_err(|e| Error::Host(format!("cannot start {}: {e}", host_exe.display())))?;
        let pid = child.id();
        let (Some(mut stdin), Some(mut stdout)) = (child.stdin.take(), child.stdout.take()) else {
            return Err(Error::Host("driver host without stdin/stdout pipes".into()));
        };
        let (tx, mut rx) = mpsc::channel::<ToHost>(QUEUE);
        tx.try_send(ToHost {
            op: Some(Op::Load(config)),
        })
        .map_err(|_| Error::Host("cannot queue Load".into()))?;
        tokio::spawn(async move {
            while let Some(msg) = rx.recv().await {
                let bytes = frame::encode(&msg);
                if stdin.write_all(&bytes).await.is_err() || stdin.flush().await.is_err() {
                    break;
                }
            }
            // Dropping stdin here is the host's signal to unload and exit.
        });
        tokio::spawn(async move {
            let mut listening = true;
            loop {
                match frame::read_frame_async::<FromHost>(&mut stdout).await {
                    Ok(Some(FromHost { event: Some(e) })) => {
                        if !on_event(event(e)) {
                            listening = false;
                            break;
                        }
                    }
                    Ok(Some(FromHost { event: None })) => {}
                    Ok(None) => break,
                    Err(e) => {
                        listening = on_event(HostEvent::ProtocolError(e.to_string()));
                        let _ = child.start_kill();
                        break;
                    }
                }
            }
            if !listening {
                let _ = child.start_kill();
            }
            let status = match tokio::time::timeout(GRACE, child.wait()).await {
                Ok(Ok(s)) => s.to_string(),
                Ok(Err(e)) => format!("unknown ({e})"),
                Err(_) => {
                    let _ = child.kill().await;
                    "killed after not exiting within the grace period".to_string()
                }
            };
            if listening {
                on_event(HostEvent::Exited(status));
            }
        });
        Ok(Self { tx, pid })
    }

    pub fn send(&self, op: Op) -> Result<(), SendError> {
        self.tx
            .try_send(ToHost { op: Some(op) })
            .map_err(|e| match e {
                mpsc::error::TrySendError::Full(_) => SendError::Full,
                mpsc::error::TrySendError::Closed(_) => SendError::Closed,
            })
    }

    pub fn pid(&self) -> Option<u32> {
        self.pid
    }
}

/// Runs `HOST driver-host --library PATH --check` and waits (at most `within`): Ok when the
/// library opens, has every symbol and the right ABI version; the typed error otherwise. Runs
/// no driver code beyond the library's initialisers and its version function, and those in
/// the child.
pub fn probe(host_exe: &Path, library: &Path, within: Duration) -> Result<(), Error> {
    let mut child = std::process::Command::new(host_exe)
        .arg("driver-host")
        .arg("--library")
        .arg(library)
        .arg("--check")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| Error::Host(format!("cannot start {}: {e}", host_exe.display())))?;
    let drain = |r: Option<Box<dyn Read + Send>>| {
        std::thread::spawn(move || {
            let mut buf = Vec::new();
            if let Some(mut r) = r {
                let _ = r.by_ref().take(1 << 20).read_to_end(&mut buf);
            }
            buf
        })
    };
    let out = drain(
        child
            .stdout
            .take()
            .map(|s| Box::new(s) as Box<dyn Read + Send>),
    );
    let err = drain(
        child
            .stderr
            .take()
            .map(|s| Box::new(s) as Box<dyn Read + Send>),
    );
    let deadline = Instant::now() + within;
    let status = loop {
        if let Some(s) = child.try_wait()? {
            break s;
        }
        if Instant::now() >= deadline {
            let _ = child.kill();
            let _ = child.wait();
            return Err(Error::Host(format!(
                "{} driver-host --check did not finish within {within:?}",
                host_exe.display()
            )));
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    let out = out.join().unwrap_or_default();
    let err = err.join().unwrap_or_default();
    match frame::read_frame::<FromHost>(&mut &out[..]) {
        Ok(Some(FromHost {
            event: Some(Event::Loaded(_)),
        })) if status.success() => Ok(()),
        Ok(Some(FromHost {
            event: Some(Event::LoadFailed(f)),
        })) => Err(f.to_error()),
        _ => Err(Error::Host(format!(
            "{} driver-host --check ended with {status}: {}",
            host_exe.display(),
            String::from_utf8_lossy(&err).trim()
        ))),
    }
}

/// The binary that hosts drivers: `FRONTSEAT_DRIVER_HOST` when set, else this executable.
pub fn default_host_exe(env: impl Fn(&str) -> Option<String>) -> Result<PathBuf, Error> {
    match env("FRONTSEAT_DRIVER_HOST").filter(|s| !s.is_empty()) {
        Some(p) => Ok(PathBuf::from(p)),
        None => std::env::current_exe()
            .map_err(|e| Error::Host(format!("cannot find the frontseat executable: {e}"))),
    }
}
