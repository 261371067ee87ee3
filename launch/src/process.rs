//! One launched OS process as a supervised [`Service`]: spawned in its own process group (so a
//! stop reaches everything it started), its stdout and stderr copied line by line with its name
//! in front, started only once ready (sd_notify READY=1, a TCP port, or a line), and stopped with
//! SIGTERM then SIGKILL. What the launcher as a whole needs to know (who failed, who finished) is
//! kept in [`Shared`].

use std::io::Write;
use std::path::PathBuf;
use std::process::Stdio;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use frontseat_actors::service_child::{BoxFuture, Service};
use frontseat_actors::supervisor::ChildFailure;
use frontseat_config::RestartPolicy;
use tokio::io::{AsyncBufReadExt, AsyncRead, BufReader};
use tokio::process::{Child, Command};
use tokio::sync::mpsc;

use crate::config::ReadyKind;
use crate::plan::ProcSpec;

/// Longest log line copied from a child; the rest of a longer line is dropped and marked.
pub const MAX_LINE_BYTES: usize = 16 * 1024;
/// Largest sd_notify datagram read.
const MAX_NOTIFY_BYTES: usize = 4096;

/// A process that failed, as the launcher reports it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Failure {
    pub index: usize,
    pub name: String,
    pub why: String,
}

/// What every launched process reports to the launcher.
#[derive(Debug, Default)]
pub struct Shared {
    /// The last failure seen (the one a give-up is about).
    pub failed: Mutex<Option<Failure>>,
    /// Processes that ended for good with exit 0 (their policy does not restart them).
    pub finished: AtomicUsize,
    pub finished_changed: tokio::sync::Notify,
    /// Set once the launcher stops everything: ends are orderly from then on, never restarted.
    pub stopping: AtomicBool,
    /// The process group of each running process, by start index.
    pub groups: Mutex<Vec<Option<i32>>>,
    /// Where readiness sockets go.
    pub run_dir: PathBuf,
}

impl Shared {
    pub fn new(run_dir: PathBuf, processes: usize) -> Self {
        Self {
            run_dir,
            groups: Mutex::new(vec![None; processes]),
            ..Default::default()
        }
    }

    fn set_group(&self, index: usize, pgid: Option<i32>) {
        if let Some(slot) = self
            .groups
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .get_mut(index)
        {
            *slot = pgid;
        }
    }

    pub fn group(&self, index: usize) -> Option<i32> {
        self.groups
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .get(index)
            .copied()
            .flatten()
    }
}

/// Sends `sig` to the whole process group (the process and whatever it started).
pub fn signal_group(pgid: i32, sig: rustix::process::Signal) {
    if let Some(pid) = rustix::process::Pid::from_raw(pgid) {
        let _ = rustix::process::kill_process_group(pid, sig);
    }
}

/// Copies one stream of a child line by line, `[name] ` in front, each line bounded; tells
/// `ready` about the first line containing `needle`.
async fn pump(
    stream: impl AsyncRead + Unpin,
    name: String,
    to_stderr: bool,
    needle: Option<String>,
    ready: mpsc::Sender<()>,
) {
    let mut r = BufReader::new(stream);
    let mut line: Vec<u8> = Vec::new();
    let mut cut = false;
    loop {
        let (done, used) = {
            let buf = match r.fill_buf().await {
                Ok(b) => b,
                Err(_) => break,
            };
            if buf.is_empty() {
                break;
            }
            match buf.iter().position(|&b| b == b'\n') {
                Some(i) => {
                    let room = MAX_LINE_BYTES.saturating_sub(line.len());
                    cut |= i > room;
                    line.extend_from_slice(&buf[..i.min(room)]);
                    (true, i + 1)
                }
                None => {
                    let room = MAX_LINE_BYTES.saturating_sub(line.len());
                    cut |= buf.len() > room;
                    line.extend_from_slice(&buf[..buf.len().min(room)]);
                    (false, buf.len())
                }
            }
        };
        r.consume(used);
        if done {
            emit(&name, &line, cut, to_stderr, needle.as_deref(), &ready);
            line.clear();
            cut = false;
        }
    }
    if !line.is_empty() {
        emit(&name, &line, cut, to_stderr, needle.as_deref(), &ready);
    }
}

fn emit(
    name: &str,
    line: &[u8],
    cut: bool,
    to_stderr: bool,
    needle: Option<&str>,
    ready: &mpsc::Sender<()>,
) {
    let text = String::from_utf8_lossy(line);
    let text = text.trim_end_matches('\r');
    if needle.is_some_and(|n| text.contains(n)) {
        let _ = ready.try_send(());
    }
    let more = if cut { " […line cut]" } else { "" };
    // A closed stdout/stderr (a pipe whose reader left) must not stop the children's pumps.
    if to_stderr {
        let _ = writeln!(std::io::stderr().lock(), "[{name}] {text}{more}");
    } else {
        let _ = writeln!(std::io::stdout().lock(), "[{name}] {text}{more}");
    }
}

/// Waits for READY=1 on the socket.
async fn notify_ready(sock: &tokio::net::UnixDatagram) {
    let mut buf = vec![0u8; MAX_NOTIFY_BYTES];
    loop {
        match sock.recv(&mut buf).await {
            Ok(n) => {
                if String::from_utf8_lossy(&buf[..n])
                    .lines()
                    .any(|l| l.trim() == "READY=1")
                {
                    return;
                }
            }
            Err(_) => std::future::pending::<()>().await,
        }
    }
}

/// Keeps reading the socket after READY=1, so that the process's later STATUS, WATCHDOG and
/// STOPPING messages are received (and dropped) instead of failing on its side.
fn drain_notify(sock: tokio::net::UnixDatagram) -> tokio::task::JoinHandle<()> {
    tokio::spawn(async move {
        let mut buf = vec![0u8; MAX_NOTIFY_BYTES];
        while sock.recv(&mut buf).await.is_ok() {}
    })
}

async fn tcp_ready(address: String) {
    let Ok(addr) = address.parse::<std::net::SocketAddr>() else {
        return std::future::pending().await;
    };
    loop {
        if tokio::net::TcpStream::connect(addr).await.is_ok() {
            return;
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

/// A running child process.
pub struct Running {
    child: Child,
    pgid: Option<i32>,
    spec: Arc<ProcSpec>,
    shared: Arc<Shared>,
    stop_timeout: Duration,
    notify_path: Option<PathBuf>,
    notify_drain: Option<tokio::task::JoinHandle<()>>,
}

impl Drop for Running {
    fn drop(&mut self) {
        if let Some(d) = self.notify_drain.take() {
            d.abort();
        }
    }
}

/// Spawns the process and waits until it is ready; a process that ends or is not ready in
/// time is a failed start (its process group is killed).
pub async fn start(
    spec: Arc<ProcSpec>,
    shared: Arc<Shared>,
    stop_timeout: Duration,
) -> Result<Box<dyn Service>, String> {
    if shared.stopping.load(Ordering::SeqCst) {
        return Err("the launcher is stopping".into());
    }
    let mut cmd = Command::new(&spec.program);
    cmd.args(&spec.args)
        .current_dir(&spec.cwd)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .process_group(0)
        .kill_on_drop(true)
        // Our own supervisor's socket, if any, is not theirs: only ours below.
        .env_remove("NOTIFY_SOCKET");
    for (k, v) in &spec.env {
        cmd.env(k, v);
    }
    let mut notify_path = None;
    let mut notify_sock = None;
    if spec.ready.kind == ReadyKind::Notify {
        let path = shared.run_dir.join(format!("notify-{}.sock", spec.index));
        let _ = std::fs::remove_file(&path);
        let sock = tokio::net::UnixDatagram::bind(&path)
            .map_err(|e| format!("readiness socket {}: {e}", path.display()))?;
        cmd.env("NOTIFY_SOCKET", &path);
        notify_sock = Some(sock);
        notify_path = Some(path);
    }
    let mut child = cmd
        .spawn()
        .map_err(|e| format!("cannot start `{}`: {e}", spec.program.display()))?;
    let pgid = child.id().and_then(|id| i32::try_from(id).ok());
    shared.set_group(spec.index, pgid);
    let (ready_tx, mut ready_rx) = mpsc::channel(1);
    let needle = (spec.ready.kind == ReadyKind::Line).then(|| spec.ready.line.clone());
    if let Some(out) = child.stdout.take() {
        tokio::spawn(pump(
            out,
            spec.name.clone(),
            false,
            needle.clone(),
            ready_tx.clone(),
        ));
    }
    if let Some(err) = child.stderr.take() {
        tokio::spawn(pump(err, spec.name.clone(), true, needle, ready_tx));
    }
    let ready = async {
        match spec.ready.kind {
            ReadyKind::None => {}
            ReadyKind::Notify => match &notify_sock {
                Some(s) => notify_ready(s).await,
                None => std::future::pending().await,
            },
            ReadyKind::Tcp => tcp_ready(spec.ready.address.clone()).await,
            ReadyKind::Line => {
                if ready_rx.recv().await.is_none() {
                    std::future::pending::<()>().await;
                }
            }
        }
    };
    let timeout = Duration::from_secs_f64(spec.ready.timeout_s);
    let failed = tokio::select! {
        _ = ready => None,
        status = child.wait() => Some(format!("ended before it was ready ({})", describe(status))),
        _ = tokio::time::sleep(timeout) => Some(format!("not ready within {} s ({:?})", spec.ready.timeout_s, spec.ready.kind)),
    };
    if let Some(why) = failed {
        if let Some(g) = pgid {
            signal_group(g, rustix::process::Signal::KILL);
        }
        let _ = child.wait().await;
        shared.set_group(spec.index, None);
        record_failure(&shared, &spec, &why);
        return Err(why);
    }
    tracing::info!(process = %spec.name, pid = ?pgid, "ready");
    Ok(Box::new(Running {
        child,
        pgid,
        spec,
        shared,
        stop_timeout,
        notify_path,
        notify_drain: notify_sock.map(drain_notify),
    }))
}

fn describe(status: std::io::Result<std::process::ExitStatus>) -> String {
    match status {
        Ok(s) => s.to_string(),
        Err(e) => format!("cannot wait for it: {e}"),
    }
}

fn record_failure(shared: &Shared, spec: &ProcSpec, why: &str) {
    if shared.stopping.load(Ordering::SeqCst) {
        return;
    }
    *shared.failed.lock().unwrap_or_else(|p| p.into_inner()) = Some(Failure {
        index: spec.index,
        name: spec.name.clone(),
        why: why.to_string(),
    });
}

impl Service for Running {
    fn ended(&mut self) -> BoxFuture<'_, Result<(), ChildFailure>> {
        Box::pin(async move {
            let status = self.child.wait().await;
            self.shared.set_group(self.spec.index, None);
            let stopping = self.shared.stopping.load(Ordering::SeqCst);
            match status {
                Ok(s) if s.success() || stopping => {
                    tracing::info!(process = %self.spec.name, status = %s, "ended");
                    if self.spec.restart.policy != RestartPolicy::Always || stopping {
                        self.shared.finished.fetch_add(1, Ordering::SeqCst);
                        self.shared.finished_changed.notify_one();
                    }
                    Ok(())
                }
                other => {
                    let why = format!("{} ended: {}", self.spec.name, describe(other));
                    tracing::warn!(process = %self.spec.name, %why, "process failed");
                    record_failure(&self.shared, &self.spec, &why);
                    Err(ChildFailure::new(why))
                }
            }
        })
    }

    fn stop(mut self: Box<Self>, within: Duration) -> BoxFuture<'static, ()> {
        Box::pin(async move {
            if let Ok(None) = self.child.try_wait()
                && let Some(g) = self.pgid
            {
                signal_group(g, rustix::process::Signal::TERM);
                let grace = self.stop_timeout.min(within);
                if tokio::time::timeout(grace, self.child.wait())
                    .await
                    .is_err()
                {
                    tracing::warn!(process = %self.spec.name, ?grace, "did not end after SIGTERM; SIGKILL");
                    signal_group(g, rustix::process::Signal::KILL);
                    let _ = self.child.wait().await;
                }
            }
            self.shared.set_group(self.spec.index, None);
            if let Some(d) = self.notify_drain.take() {
                d.abort();
            }
            if let Some(p) = self.notify_path.take() {
                let _ = std::fs::remove_file(p);
            }
        })
    }
}
