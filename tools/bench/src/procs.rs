//! Rows P5 and P4: the real binary as child processes — `frontseat sim` and `frontseat
//! interface -c <tmp config>` — for the start-up time (spawn → the `to="running:command"`
//! transition log line on its stderr) and the steady-state CPU and RSS read from /proc/<pid>.

use std::io::{BufRead, BufReader};
use std::net::{Ipv4Addr, TcpListener};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use serde_json::json;
use tokio::sync::mpsc::{UnboundedReceiver, unbounded_channel};

use super::report::{Figures, Hist, Row, fmt_duration};

const P5: &str =
    "process start → running:command (`frontseat interface` child, `frontseat sim` child)";
const P4: &str = "CPU and RSS at steady state, WARP 1, FREQ 10 (`frontseat sim` + `frontseat interface` children)";

/// How long a child may take to say what we wait for.
const STARTUP_BOUND: Duration = Duration::from_secs(10);

/// A child process that is killed when the bench lets go of it, whatever happened.
pub(super) struct ChildGuard {
    child: Child,
    lines: UnboundedReceiver<(Instant, String)>,
}

impl ChildGuard {
    /// Starts `exe` (the `frontseat` binary) with `args`.
    pub(super) fn spawn(exe: &Path, args: &[String]) -> Result<Self, String> {
        let mut child = Command::new(exe)
            .args(args)
            // The transition log line is at info; a caller's RUST_LOG must not hide it.
            .env("RUST_LOG", "info")
            // The child's config alone decides whether it exports traces, and where.
            .env_remove("OTEL_EXPORTER_OTLP_ENDPOINT")
            .env_remove("OTEL_EXPORTER_OTLP_TRACES_ENDPOINT")
            .env_remove("OTEL_SDK_DISABLED")
            .env_remove("OTEL_TRACES_SAMPLER_ARG")
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|e| format!("spawning `frontseat {}`: {e}", args.join(" ")))?;
        let (tx, lines) = unbounded_channel();
        if let Some(stderr) = child.stderr.take() {
            // Keeps draining after nobody listens, so the child never blocks on a full pipe.
            std::thread::spawn(move || {
                let mut rd = BufReader::new(stderr);
                let mut line = String::new();
                loop {
                    line.clear();
                    match rd.read_line(&mut line) {
                        Ok(0) | Err(_) => return,
                        Ok(_) => {
                            let _ = tx.send((Instant::now(), line.trim_end().to_string()));
                        }
                    }
                }
            });
        }
        Ok(Self { child, lines })
    }

    pub(super) fn pid(&self) -> u32 {
        self.child.id()
    }

    /// The last `n` lines the child logged and nobody read yet: for a failure message.
    pub(super) fn tail(&mut self, n: usize) -> String {
        let mut last = std::collections::VecDeque::with_capacity(n + 1);
        while let Ok((_, l)) = self.lines.try_recv() {
            last.push_back(l);
            if last.len() > n {
                last.pop_front();
            }
        }
        Vec::from(last).join(" ⏎ ")
    }

    /// The instant the child logged a line containing every one of `needles`.
    pub(super) async fn wait_for(&mut self, needles: &[&str]) -> Result<Instant, String> {
        let found = tokio::time::timeout(STARTUP_BOUND, async {
            while let Some((t, line)) = self.lines.recv().await {
                if needles.iter().all(|n| line.contains(n)) {
                    return Some(t);
                }
            }
            None
        })
        .await;
        match found {
            Ok(Some(t)) => Ok(t),
            Ok(None) => Err(format!(
                "child {} exited before logging {needles:?}",
                self.pid()
            )),
            Err(_) => Err(format!(
                "child {} did not log {needles:?} within {STARTUP_BOUND:?}",
                self.pid()
            )),
        }
    }
}

impl Drop for ChildGuard {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// A temporary config file, removed on drop.
pub(super) struct TempConfig(pub(super) PathBuf);

impl Drop for TempConfig {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}

/// `frontseat interface -c <config>` as a child, its config (`text`) written to a temporary file
/// named after this process and `tag`, removed when the returned guard is dropped (after the
/// child: bind the pair as `(_cfg, child)`).
pub(super) fn interface_child(
    exe: &Path,
    tag: &str,
    text: &str,
) -> Result<(TempConfig, ChildGuard), String> {
    let path =
        std::env::temp_dir().join(format!("frontseat-bench-{}-{tag}.toml", std::process::id()));
    std::fs::write(&path, text).map_err(|e| format!("writing {}: {e}", path.display()))?;
    let cfg = TempConfig(path.clone());
    let child = ChildGuard::spawn(
        exe,
        &[
            "interface".to_string(),
            "-c".into(),
            path.display().to_string(),
        ],
    )?;
    Ok((cfg, child))
}

/// The CPU `pid` uses while this task sleeps for `window`: % of one core, and the window as it
/// was measured.
pub(super) async fn cpu_percent(pid: u32, window: Duration) -> Result<(f64, Duration), String> {
    let before = cpu_time(pid);
    let t0 = Instant::now();
    tokio::time::sleep(window).await;
    let took = t0.elapsed();
    match (before, cpu_time(pid)) {
        (Some(a), Some(b)) => Ok((
            100.0 * b.saturating_sub(a).as_secs_f64() / took.as_secs_f64().max(1e-9),
            took,
        )),
        _ => Err(format!("cannot read /proc/{pid}/stat of the interface")),
    }
}

pub(super) fn free_port() -> Result<u16, String> {
    // The port is free when we let go of it; the simulator binds it a moment later.
    TcpListener::bind((Ipv4Addr::LOCALHOST, 0))
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .map_err(|e| format!("no free loopback port: {e}"))
}

/// CPU time (user + system) of a process, from /proc/<pid>/stat, at the usual 100 clock ticks
/// per second (reading the real value needs libc).
pub(super) fn cpu_time(pid: u32) -> Option<Duration> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    let after = stat.rsplit_once(')')?.1;
    let f: Vec<&str> = after.split_whitespace().collect();
    let utime: u64 = f.get(11)?.parse().ok()?;
    let stime: u64 = f.get(12)?.parse().ok()?;
    Some(Duration::from_millis((utime + stime) * 10))
}

/// A `Vm…:` line of /proc/<pid>/status, in KiB.
pub(super) fn status_kib(pid: u32, key: &str) -> Option<u64> {
    let s = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    let line = s.lines().find(|l| l.starts_with(key))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

/// Runs P5 (`runs` cold starts) then P4 (over `window`) on the last started pair; returns the
/// rows in the order P4, P5.
pub async fn run(exe: &Path, runs: usize, settle: Duration, window: Duration) -> Vec<Row> {
    match run_inner(exe, runs, settle, window).await {
        Ok(rows) => rows,
        Err(why) => vec![
            Row::failed("P4", P4, why.clone()),
            Row::failed("P5", P5, why),
        ],
    }
}

async fn run_inner(
    exe: &Path,
    runs: usize,
    settle: Duration,
    window: Duration,
) -> Result<Vec<Row>, String> {
    let port = free_port()?;
    let mut sim = ChildGuard::spawn(exe, &["sim".into(), "--port".into(), port.to_string()])?;
    sim.wait_for(&["simulator listening"]).await?;

    let path = std::env::temp_dir().join(format!("frontseat-bench-{}.toml", std::process::id()));
    let cfg = format!(
        "# written by `frontseat bench` (row P4/P5); removed when it ends\n\
         name = \"bench-auv\"\n\
         # no helm in another process yet: COMMAND needs only the frontseat\n\
         require_helm = false\n\n\
         [driver.basic_simulator]\n\
         tcp_port = {port}\n"
    );
    std::fs::write(&path, cfg).map_err(|e| format!("writing {}: {e}", path.display()))?;
    let _cfg = TempConfig(path.clone());
    let args = [
        "interface".to_string(),
        "-c".into(),
        path.display().to_string(),
    ];

    let mut hist = Hist::new();
    let mut last = None;
    for _ in 0..runs.max(1) {
        // Stop the previous interface first: one vehicle at a time.
        drop(last.take());
        let t0 = Instant::now();
        let mut iface = ChildGuard::spawn(exe, &args)?;
        let t = iface
            .wait_for(&["to=\"running:command\""])
            .await
            .map_err(|e| format!("P5: {e}"))?;
        hist.record(t.saturating_duration_since(t0));
        last = Some(iface);
    }
    let Some(iface) = last else {
        return Err("no interface started".into());
    };
    let p5 = match hist.latency() {
        Some(l) => Row {
            id: "P5",
            what: P5.into(),
            figures: Figures::Latency(l),
            detail: format!(
                "{} cold starts; spawn(2) → the transition log line read from its stderr; the simulator already listening",
                l.samples
            ),
            extra: json!({ "runs": l.samples }),
        },
        None => Row::failed("P5", P5, "no start measured"),
    };

    tokio::time::sleep(settle).await;
    let pids = [("sim", sim.pid()), ("interface", iface.pid())];
    let before: Vec<Option<Duration>> = pids.iter().map(|(_, p)| cpu_time(*p)).collect();
    let t0 = Instant::now();
    tokio::time::sleep(window).await;
    let secs = t0.elapsed().as_secs_f64();
    let mut parts = Vec::new();
    let mut extra = serde_json::Map::new();
    let (mut cpu_sum, mut rss_sum) = (0.0, 0u64);
    for ((name, pid), b) in pids.iter().zip(before) {
        let cpu = match (b, cpu_time(*pid)) {
            (Some(a), Some(b)) => 100.0 * b.saturating_sub(a).as_secs_f64() / secs,
            _ => return Err(format!("P4: cannot read /proc/{pid}/stat of the {name}")),
        };
        let rss = status_kib(*pid, "VmRSS:").unwrap_or(0);
        let hwm = status_kib(*pid, "VmHWM:").unwrap_or(0);
        cpu_sum += cpu;
        rss_sum += rss;
        parts.push(format!(
            "{name} {cpu:.1} % CPU, {:.1} MiB RSS (peak {:.1})",
            rss as f64 / 1024.0,
            hwm as f64 / 1024.0
        ));
        extra.insert(
            (*name).to_string(),
            json!({ "cpu_percent": cpu, "rss_kib": rss, "peak_rss_kib": hwm }),
        );
    }
    let p4 = Row {
        id: "P4",
        what: P4.into(),
        figures: Figures::Result(format!(
            "together {cpu_sum:.1} % of one core, {:.1} MiB RSS; {}",
            rss_sum as f64 / 1024.0,
            parts.join("; ")
        )),
        detail: format!(
            "over {} after {} settling; CPU from /proc/<pid>/stat (10 ms ticks), RSS from /proc/<pid>/status",
            fmt_duration(Duration::from_secs_f64(secs)),
            fmt_duration(settle)
        ),
        extra: serde_json::Value::Object(extra),
    };
    drop(iface);
    drop(sim);
    Ok(vec![p4, p5])
}

/// The bench's own executable as a helper in another process (the role chosen by `env` =
/// `spec`): killed when dropped; it says what it is ready for, waits for `go` on its stdin, and
/// its stdout lines arrive on [`RoleChild::line`]. L4's Zenoh peer and F1's publishers.
pub(super) struct RoleChild {
    child: Child,
    lines: UnboundedReceiver<String>,
    role: &'static str,
}

impl Drop for RoleChild {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl RoleChild {
    pub(super) fn spawn(
        bench_exe: &Path,
        env: &str,
        spec: String,
        role: &'static str,
    ) -> Result<Self, String> {
        let mut child = Command::new(bench_exe)
            .env(env, spec)
            .env_remove("OTEL_EXPORTER_OTLP_ENDPOINT")
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .map_err(|e| format!("spawning {role} {}: {e}", bench_exe.display()))?;
        let (tx, lines) = unbounded_channel();
        if let Some(out) = child.stdout.take() {
            std::thread::spawn(move || {
                for line in BufReader::new(out).lines() {
                    let Ok(line) = line else { return };
                    if tx.send(line).is_err() {
                        return;
                    }
                }
            });
        }
        Ok(Self { child, lines, role })
    }

    pub(super) async fn line(&mut self, within: Duration) -> Result<String, String> {
        match tokio::time::timeout(within, self.lines.recv()).await {
            Ok(Some(l)) => Ok(l),
            Ok(None) => Err(format!("{} ended early", self.role)),
            Err(_) => Err(format!("{} said nothing within {within:?}", self.role)),
        }
    }

    pub(super) fn go(&mut self) -> Result<(), String> {
        use std::io::Write as _;
        let role = self.role;
        let stdin = self
            .child
            .stdin
            .as_mut()
            .ok_or_else(|| format!("{role} has no stdin"))?;
        stdin
            .write_all(b"go\n")
            .and_then(|()| stdin.flush())
            .map_err(|e| format!("{role}: {e}"))
    }

    pub(super) fn pid(&self) -> u32 {
        self.child.id()
    }
}

/// The child side of a [`RoleChild`]: runs `body` on a runtime of its own; its error goes to
/// stderr, where the bench's own stderr shows it.
pub fn role_main(
    role: &str,
    body: impl std::future::Future<Output = Result<(), String>>,
) -> std::process::ExitCode {
    let rt = match tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
    {
        Ok(rt) => rt,
        Err(e) => {
            eprintln!("cannot start the async runtime: {e}");
            return std::process::ExitCode::from(1);
        }
    };
    match rt.block_on(body) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("{role}: {e}");
            std::process::ExitCode::from(1)
        }
    }
}

/// The child side: says `listening` on stdout; the parent's `go` (a line on stdin) arrives on
/// the receiver (which closes when stdin says anything else or ends).
pub(super) fn listening() -> std::sync::mpsc::Receiver<()> {
    use std::io::Write as _;
    let (go_tx, go) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let mut line = String::new();
        if std::io::stdin().lock().read_line(&mut line).is_ok() && line.trim() == "go" {
            let _ = go_tx.send(());
        }
    });
    println!("listening");
    let _ = std::io::stdout().flush();
    go
}

/// A Zenoh session opened as the interface's gateway opens its own: a peer listening on
/// 127.0.0.1:`port`, with the gateway's payload bound.
pub(super) async fn gateway_session(
    port: u16,
) -> Result<frontseat_helm_side::zenoh::Session, String> {
    let ip = frontseat_config::InterprocessConfig {
        enabled: true,
        listen: vec![format!("tcp/127.0.0.1:{port}")],
        ..Default::default()
    };
    let zcfg = frontseat_helm_side::zenoh_config(&ip, frontseat_helm_side::DEFAULT_MAX_PAYLOAD)
        .map_err(|e| e.to_string())?;
    frontseat_helm_side::zenoh::open(zcfg)
        .await
        .map_err(|e| e.to_string())
}

/// A node_status publisher on `key`, declared with the options the gateway declares its exports
/// with (helm_side's `start_on`).
pub(super) async fn node_status_publisher(
    session: &frontseat_helm_side::zenoh::Session,
    key: String,
) -> Result<frontseat_helm_side::zenoh::pubsub::Publisher<'static>, String> {
    use frontseat_helm_side::zenoh::{bytes::Encoding, qos::CongestionControl, sample::Locality};
    let type_name = frontseat_actors::groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS.type_name();
    session
        .declare_publisher(key)
        .encoding(Encoding::from(frontseat_helm_side::wire::encoding_for(
            type_name,
        )))
        .congestion_control(CongestionControl::Block)
        .allowed_destination(Locality::Remote)
        .await
        .map_err(|e| e.to_string())
}
