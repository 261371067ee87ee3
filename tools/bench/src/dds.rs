//! Rows C1, C2 and C3: ROS 2 over DDS. The real `frontseat interface` runs as a child with
//! `[ros2]` on; the ROS 2 side is another process, Eclipse Cyclone DDS (PyPI `cyclonedds`, the
//! DDS of rmw_cyclonedds_cpp) with ROS 2's topic and type names, CDR and QoS, as the CI tests use
//! it (`tests/python/ros2_peer.py bench`, in the repository the bench was built from). C1: NAV
//! line → nav_msgs/Odometry at the peer's reader; C2: desired_course written by the peer → CMD
//! line at the scripted frontseat; C3: the interface's CPU and RSS at 10 Hz NAV with `[ros2]` on
//! (the peer subscribed) and off.
//!
//! The peer stamps with CLOCK_MONOTONIC (Python's `time.monotonic_ns`), the clock `Instant`
//! reads on Linux, so its stamps and the bench's are on one clock. The Python peer's own cost
//! is in both rows: they compare with Z1/Z2, whose other process is a Rust Zenoh client, only
//! as "what a ROS 2 helm in Python sees".

use std::path::Path;
use std::process::Stdio;
use std::sync::Arc;
use std::time::{Duration, Instant};

use serde_json::{Value, json};
use tokio::io::{AsyncBufReadExt, AsyncWriteExt, BufReader};

use super::frontseat::{ScriptedFrontseat, Stamps};
use super::inproc::{GRACE, latency_row, match_up};
use super::procs::{ChildGuard, cpu_percent, interface_child, status_kib};
use super::report::{Figures, Row};

/// How much each row measures.
#[derive(Clone, Copy, Debug)]
pub struct Plan {
    pub c1_count: usize,
    pub c1_rate_hz: f64,
    pub c2_count: usize,
    pub c2_rate_hz: f64,
    /// After running:command, before the CPU window.
    pub settle: Duration,
    pub cpu_window: Duration,
}

const C1: &str = "NAV line written by the frontseat → nav_msgs/Odometry at a Cyclone DDS reader in another process (ROS 2 names, QoS)";
const C2: &str = "desired_course written by a Cyclone DDS writer in another process → CMD line read at the frontseat";
const C3: &str = "interface CPU and RSS at 10 Hz NAV, [ros2] on (a ROS 2 peer subscribed) vs off";

/// The peer script, in the repository this bench was built from.
const PEER: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../tests/python/ros2_peer.py"
);
/// A valid ROS name (the namespace of the topics).
const PLATFORM: &str = "bench_auv";
/// Start-up: the child, the peer's import of cyclonedds, discovery, running:command.
const STARTUP_BOUND: Duration = Duration::from_secs(30);

/// CLOCK_MONOTONIC now, in ns.
fn mono_ns() -> i128 {
    let t = rustix::time::clock_gettime(rustix::time::ClockId::Monotonic);
    i128::from(t.tv_sec) * 1_000_000_000 + i128::from(t.tv_nsec)
}

/// Maps the peer's CLOCK_MONOTONIC stamps onto `Instant`s.
#[derive(Clone, Copy)]
struct Clock {
    at: Instant,
    ns: i128,
}

impl Clock {
    fn now() -> Self {
        Self {
            at: Instant::now(),
            ns: mono_ns(),
        }
    }

    fn instant(&self, ns: i128) -> Option<Instant> {
        let d = ns - self.ns;
        let mag = Duration::from_nanos(u64::try_from(d.unsigned_abs()).ok()?);
        if d >= 0 {
            self.at.checked_add(mag)
        } else {
            self.at.checked_sub(mag)
        }
    }
}

/// Whether the rows can run here: `Err` says what is missing.
async fn peer_available() -> Result<(), String> {
    if !Path::new(PEER).is_file() {
        return Err(format!(
            "{PEER} not found (the rows need the repository the bench was built from)"
        ));
    }
    let ok = tokio::process::Command::new("python3")
        .args(["-c", "import cyclonedds"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .await
        .map(|s| s.success())
        .unwrap_or(false);
    if ok {
        Ok(())
    } else {
        Err(
            "python3 with cyclonedds not found (pip install -r tests/python/requirements.txt)"
                .into(),
        )
    }
}

/// Rows C1, C2, C3. Without python3 and cyclonedds the rows say so (and fail when
/// FRONTSEAT_REQUIRE_PYTHON_HELM is set, as CI sets it).
pub async fn run(exe: &Path, plan: Plan) -> Vec<Row> {
    if let Err(why) = peer_available().await {
        if std::env::var_os("FRONTSEAT_REQUIRE_PYTHON_HELM").is_some() {
            return [("C1", C1), ("C2", C2), ("C3", C3)]
                .into_iter()
                .map(|(id, what)| Row::failed(id, what, why.clone()))
                .collect();
        }
        return [("C1", C1), ("C2", C2), ("C3", C3)]
            .into_iter()
            .map(|(id, what)| Row {
                id,
                what: what.into(),
                figures: Figures::Result(format!("not measured: {why}")),
                detail: "needs 1 peer process".into(),
                extra: json!({ "skipped": why }),
            })
            .collect();
    }
    let on = measure(exe, &plan, true).await;
    let off = measure(exe, &plan, false).await;
    let (c1, c2, cpu_on) = match on {
        Ok(m) => (
            m.c1.unwrap_or_else(|| Row::failed("C1", C1, "not run")),
            m.c2.unwrap_or_else(|| Row::failed("C2", C2, "not run")),
            Some((m.cpu_percent, m.rss_kib)),
        ),
        Err(why) => (
            Row::failed("C1", C1, why.clone()),
            Row::failed("C2", C2, why),
            None,
        ),
    };
    vec![
        c1,
        c2,
        c3(cpu_on, off.map(|m| (m.cpu_percent, m.rss_kib)), &plan),
    ]
}

struct Measured {
    c1: Option<Row>,
    c2: Option<Row>,
    cpu_percent: f64,
    rss_kib: u64,
}

fn c3(on: Option<(f64, u64)>, off: Result<(f64, u64), String>, plan: &Plan) -> Row {
    let Some((cpu_on, rss_on)) = on else {
        return Row::failed("C3", C3, "the run with [ros2] on failed (see C1)");
    };
    let (cpu_off, rss_off) = match off {
        Ok(v) => v,
        Err(why) => return Row::failed("C3", C3, format!("[ros2] off: {why}")),
    };
    let mib = |k: u64| k as f64 / 1024.0;
    Row {
        id: "C3",
        what: C3.into(),
        figures: Figures::Result(format!(
            "on {cpu_on:.1} % of a core, {:.1} MiB RSS; off {cpu_off:.1} %, {:.1} MiB",
            mib(rss_on),
            mib(rss_off)
        )),
        detail: format!(
            "two `frontseat interface` children in turn against the scripted frontseat's 10 Hz keep-alive NAV; CPU from /proc/<pid>/stat over {:?} after {:?} in running:command (on: the Cyclone DDS peer driving helm_state at 10 Hz and reading odom; off: no [ros2], no helm)",
            plan.cpu_window, plan.settle
        ),
        extra: json!({
            "on": { "cpu_percent": cpu_on, "rss_kib": rss_on },
            "off": { "cpu_percent": cpu_off, "rss_kib": rss_off },
        }),
    }
}

/// One interface child, with `[ros2]` and the peer when `ros2`; C1 and C2 only then.
async fn measure(exe: &Path, plan: &Plan, ros2: bool) -> Result<Measured, String> {
    let base = Instant::now();
    let nav_written = Stamps::new(base, plan.c1_count);
    let odom_at = Stamps::new(base, plan.c1_count);
    let cmd_sent = Stamps::new(base, plan.c2_count);
    let cmd_read = Stamps::new(base, plan.c2_count);
    let fs = ScriptedFrontseat::start(nav_written.clone(), cmd_read.clone())
        .map_err(|e| format!("scripted frontseat: {e}"))?;
    // One DDS domain per bench process (0-232 are valid; the CI tests use their own).
    let domain = 150 + std::process::id() % 80;
    // C2 writes at its full rate, above the default 50 Hz command budget (which would refuse
    // most of the burst and count it); 1000 Hz is the most the config allows.
    let section = if ros2 {
        format!("[ros2]\nenabled = true\ndomain_id = {domain}\nmax_command_rate_hz = 1000.0\n")
    } else {
        String::new()
    };
    let cfg = format!(
        "# written by `frontseat bench` (rows C1-C3); removed when it ends\n\
         name = \"{PLATFORM}\"\n\
         status_period = 0.5\n\n\
         [driver.basic_simulator]\n\
         tcp_port = {}\n\n\
         [interprocess]\n\
         enabled = false\n\n\
         # C2 carries its sequence number in DEPTH, C1 in the NAV lines' DEPTH (1 m a line).\n\
         [limits]\n\
         max_depth = 12000.0\n\n\
         [limits.navigation]\n\
         max_depth = 100000.0\n\
         max_abs_depth_rate = 1e9\n\n{section}",
        fs.port()
    );
    let tag = if ros2 { "ros2-on" } else { "ros2-off" };
    let (_cfg, mut child) = interface_child(exe, tag, &cfg)?;
    let r = if ros2 {
        with_peer(
            plan,
            &fs,
            &mut child,
            domain,
            &nav_written,
            &odom_at,
            &cmd_sent,
            &cmd_read,
        )
        .await
    } else {
        steady(plan, &mut child, &["to=\"running:"])
            .await
            .map(|(cpu_percent, rss_kib)| Measured {
                c1: None,
                c2: None,
                cpu_percent,
                rss_kib,
            })
    };
    let r = r.map_err(|e| format!("{e}; the interface logged: {}", child.tail(4)));
    drop(child);
    fs.stop();
    r
}

/// CPU (% of a core) and RSS (KiB) of the child once it logged `needles` and settled.
async fn steady(
    plan: &Plan,
    child: &mut ChildGuard,
    needles: &[&str],
) -> Result<(f64, u64), String> {
    child.wait_for(needles).await?;
    tokio::time::sleep(plan.settle).await;
    let pid = child.pid();
    let (cpu, _) = cpu_percent(pid, plan.cpu_window).await?;
    Ok((cpu, status_kib(pid, "VmRSS:").unwrap_or(0)))
}

/// What the peer printed, stamped onto our clock.
enum Said {
    Ready,
    Odom(usize, Instant),
    Course(usize, Instant),
    CoursesDone,
}

fn parse(line: &str, clock: &Clock) -> Option<Said> {
    let v: Value = serde_json::from_str(line).ok()?;
    if v.get("ready").is_some() {
        return Some(Said::Ready);
    }
    if v.get("courses_done").is_some() {
        return Some(Said::CoursesDone);
    }
    let at = clock.instant(i128::from(v.get("ns")?.as_i64()?))?;
    if let Some(z) = v.get("odom_z").and_then(Value::as_f64) {
        // z up = −depth; the NAV line of sequence i carries DEPTH i + 1.
        let d = -z;
        return (d >= 1.0 && d.fract() == 0.0 && d < 1e9).then(|| Said::Odom(d as usize - 1, at));
    }
    let i = v.get("course")?.as_u64()?;
    Some(Said::Course(usize::try_from(i).ok()?, at))
}

#[allow(clippy::too_many_arguments)]
async fn with_peer(
    plan: &Plan,
    fs: &ScriptedFrontseat,
    child: &mut ChildGuard,
    domain: u32,
    nav_written: &Arc<Stamps>,
    odom_at: &Arc<Stamps>,
    cmd_sent: &Arc<Stamps>,
    cmd_read: &Arc<Stamps>,
) -> Result<Measured, String> {
    let lifetime = STARTUP_BOUND + plan.settle + plan.cpu_window + Duration::from_secs(60);
    let mut peer = tokio::process::Command::new("python3")
        .arg(PEER)
        .args([
            "bench",
            "--domain",
            &domain.to_string(),
            "--namespace",
            PLATFORM,
        ])
        .args(["--seconds", &format!("{:.0}", lifetime.as_secs_f64())])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .kill_on_drop(true)
        .spawn()
        .map_err(|e| format!("spawning the Cyclone DDS peer: {e}"))?;
    let (Some(out), Some(mut stdin), Some(err)) =
        (peer.stdout.take(), peer.stdin.take(), peer.stderr.take())
    else {
        return Err("the peer's pipes".into());
    };
    let clock = Clock::now();
    let (ready_tx, mut ready) = tokio::sync::watch::channel(false);
    let (done_tx, mut done) = tokio::sync::watch::channel(false);
    let (odom, sent) = (odom_at.clone(), cmd_sent.clone());
    let reader = tokio::spawn(async move {
        let mut lines = BufReader::new(out).lines();
        while let Ok(Some(l)) = lines.next_line().await {
            match parse(&l, &clock) {
                Some(Said::Ready) => {
                    let _ = ready_tx.send(true);
                }
                Some(Said::Odom(i, t)) => odom.set(i, t),
                Some(Said::Course(i, t)) => sent.set(i, t),
                Some(Said::CoursesDone) => {
                    let _ = done_tx.send(true);
                }
                None => {}
            }
        }
    });
    let err_tail = tokio::spawn(async move {
        let mut last = String::new();
        let mut lines = BufReader::new(err).lines();
        while let Ok(Some(l)) = lines.next_line().await {
            last = l;
        }
        last
    });
    let r = async {
        if !matches!(tokio::time::timeout(STARTUP_BOUND, ready.wait_for(|r| *r)).await, Ok(Ok(_))) {
            return Err(format!("the Cyclone DDS peer was not ready within {STARTUP_BOUND:?}"));
        }
        let (cpu_percent, rss_kib) = steady(plan, child, &["to=\"running:command\""]).await?;

        fs.burst(0, plan.c1_count, plan.c1_rate_hz, false)
            .await
            .map_err(|_| "the scripted frontseat stopped".to_string())?;
        tokio::time::sleep(GRACE).await;
        let (h, n, lost) = match_up(nav_written, odom_at, 0..plan.c1_count);
        let c1 = latency_row(
            "C1",
            C1,
            &h,
            format!(
                "{n} NAV lines at {} Hz; `frontseat interface` child ([ros2], rustdds) → Python Cyclone DDS reader (best effort, keep last 5: sensor data QoS) in another process, stamped on its WaitSet's wake-up; lost {lost}",
                plan.c1_rate_hz
            ),
            n,
            lost,
        );

        let before = fs.cmds_read();
        stdin
            .write_all(format!("courses {} {}\n", plan.c2_count, plan.c2_rate_hz).as_bytes())
            .await
            .map_err(|e| format!("writing to the peer: {e}"))?;
        let bound = Duration::from_secs_f64(plan.c2_count as f64 / plan.c2_rate_hz.max(1e-3)) + STARTUP_BOUND;
        let _ = tokio::time::timeout(bound, done.wait_for(|d| *d)).await;
        let deadline = tokio::time::Instant::now() + GRACE;
        while fs.cmds_read() < before + plan.c2_count as u64 && tokio::time::Instant::now() < deadline {
            tokio::time::sleep(Duration::from_millis(5)).await;
        }
        let (h, n, lost) = match_up(cmd_sent, cmd_read, 0..plan.c2_count);
        let c2 = latency_row(
            "C2",
            C2,
            &h,
            format!(
                "{n} desired_course at {} Hz (sequence in depth), reliable keep last 10, stamped before the Python write; lost {lost}",
                plan.c2_rate_hz
            ),
            n,
            lost,
        );
        Ok(Measured {
            c1: Some(c1),
            c2: Some(c2),
            cpu_percent,
            rss_kib,
        })
    }
    .await;
    drop(stdin);
    let _ = peer.kill().await;
    reader.abort();
    match r {
        Ok(m) => Ok(m),
        Err(e) => {
            let last = tokio::time::timeout(Duration::from_secs(1), err_tail)
                .await
                .ok()
                .and_then(Result::ok)
                .unwrap_or_default();
            Err(if last.is_empty() {
                e
            } else {
                format!("{e}; the peer said: {last}")
            })
        }
    }
}
