//! `frontseat launch FILE`, the real binary with real child processes: ordered start with each
//! process waited for until ready, log lines prefixed with the process name, SIGTERM stopping
//! all in reverse order, the exit code naming the failed process, restarts by policy, and a
//! fleet of a simulator and two interfaces that each say READY=1 over sd_notify.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_frontseat");
const BOUND: Duration = Duration::from_secs(30);

struct Dir(PathBuf);
impl Dir {
    fn new(what: &str) -> Self {
        let p = std::env::temp_dir().join(format!(
            "frontseat-fleet-launch-{what}-{}",
            std::process::id()
        ));
        let _ = std::fs::remove_dir_all(&p);
        std::fs::create_dir_all(&p).unwrap();
        Self(p)
    }
}
impl Drop for Dir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// A launch running in the background; every line of its stdout and stderr arrives on `lines`.
struct Launch {
    child: Child,
    lines: mpsc::Receiver<String>,
    seen: Vec<String>,
}

impl Launch {
    fn start(file: &Path) -> Self {
        let mut child = Command::new(BIN)
            .args(["launch", "-c"])
            .arg(file)
            .env("RUST_LOG", "info")
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let (tx, rx) = mpsc::channel();
        for stream in [
            Box::new(child.stdout.take().unwrap()) as Box<dyn std::io::Read + Send>,
            Box::new(child.stderr.take().unwrap()),
        ] {
            let tx = tx.clone();
            std::thread::spawn(move || {
                for l in BufReader::new(stream).lines().map_while(Result::ok) {
                    let _ = tx.send(l);
                }
            });
        }
        Self {
            child,
            lines: rx,
            seen: Vec::new(),
        }
    }

    /// Waits (bounded) for a line containing `text`.
    fn expect(&mut self, text: &str) {
        let deadline = Instant::now() + BOUND;
        if self.seen.iter().any(|l| l.contains(text)) {
            return;
        }
        while let Some(left) = deadline.checked_duration_since(Instant::now()) {
            match self.lines.recv_timeout(left) {
                Ok(l) => {
                    let hit = l.contains(text);
                    self.seen.push(l);
                    if hit {
                        return;
                    }
                }
                Err(_) => break,
            }
        }
        let _ = self.child.kill();
        panic!("no line with {text:?}; saw:\n{}", self.seen.join("\n"));
    }

    fn term(&self) {
        let ok = Command::new("kill")
            .args(["-TERM", &self.child.id().to_string()])
            .status()
            .unwrap();
        assert!(ok.success());
    }

    /// Waits (bounded) for the launch to end; its exit code, with every line it printed.
    fn wait(mut self) -> (i32, Vec<String>) {
        let deadline = Instant::now() + BOUND;
        loop {
            if let Some(s) = self.child.try_wait().unwrap() {
                // The pipes close with the process: collect what is left.
                while let Ok(l) = self.lines.recv_timeout(Duration::from_millis(500)) {
                    self.seen.push(l);
                }
                return (s.code().unwrap_or(-1), self.seen);
            }
            if Instant::now() > deadline {
                let _ = self.child.kill();
                panic!("launch did not end; saw:\n{}", self.seen.join("\n"));
            }
            if let Ok(l) = self.lines.recv_timeout(Duration::from_millis(20)) {
                self.seen.push(l);
            }
        }
    }
}

fn position(lines: &[String], text: &str) -> usize {
    lines
        .iter()
        .position(|l| l.contains(text))
        .unwrap_or_else(|| panic!("no line with {text:?} in:\n{}", lines.join("\n")))
}

/// A shell process that says it is ready, and says goodbye on SIGTERM.
fn polite(name: &str) -> String {
    format!(
        r#"
[[process]]
name = "{name}"
command = ["sh", "-c", "trap 'echo bye-{name}; exit 0' TERM; echo ready-{name}; while :; do sleep 0.05; done"]
ready = {{ kind = "line", line = "ready-{name}" }}
"#
    )
}

#[test]
fn starts_in_order_prefixes_logs_and_stops_in_reverse_on_sigterm() {
    let dir = Dir::new("order");
    let file = dir.0.join("fleet.toml");
    std::fs::write(
        &file,
        format!(
            "stop_timeout_s = 5\n{}{}{}",
            polite("a"),
            polite("b"),
            polite("c")
        ),
    )
    .unwrap();
    let mut l = Launch::start(&file);
    l.expect("every process is up");
    l.term();
    let (code, lines) = l.wait();
    assert_eq!(code, 0, "{}", lines.join("\n"));
    // Every process's output is relayed with its name.
    for n in ["a", "b", "c"] {
        position(&lines, &format!("[{n}] ready-{n}"));
        position(&lines, &format!("[{n}] bye-{n}"));
    }
    // Started in file order, each only once the one before was ready; stopped last first, each
    // gone before the next is told. Read from the launcher's own log: the relayed output of two
    // processes comes through two pipes, so its interleaving says nothing about the order.
    let (ra, rb, rc) = (
        position(&lines, "ready process=a"),
        position(&lines, "ready process=b"),
        position(&lines, "ready process=c"),
    );
    assert!(ra < rb && rb < rc, "{}", lines.join("\n"));
    let (ea, eb, ec) = (
        position(&lines, "ended process=a"),
        position(&lines, "ended process=b"),
        position(&lines, "ended process=c"),
    );
    assert!(ec < eb && eb < ea, "{}", lines.join("\n"));
}

#[test]
fn the_exit_code_names_the_process_that_failed_and_the_others_are_stopped() {
    let dir = Dir::new("fail");
    let file = dir.0.join("fleet.toml");
    std::fs::write(
        &file,
        format!(
            r#"{}
[[process]]
name = "breaks"
command = ["sh", "-c", "sleep 0.2; echo breaking; exit 3"]
restart = {{ policy = "never" }}
"#,
            polite("steady")
        ),
    )
    .unwrap();
    let (code, lines) = Launch::start(&file).wait();
    // Second in start order: 10 + 1.
    assert_eq!(code, 11, "{}", lines.join("\n"));
    position(&lines, "[breaks] breaking");
    position(&lines, "[steady] bye-steady");
    let said = position(&lines, "process breaks (#2) failed");
    assert!(lines[said].contains("exit status: 3"), "{}", lines[said]);
}

#[test]
fn a_failing_process_is_restarted_by_its_policy_until_its_limit() {
    let dir = Dir::new("restart");
    let file = dir.0.join("fleet.toml");
    let count = dir.0.join("runs");
    std::fs::write(
        &file,
        format!(
            r#"
[[process]]
name = "flaky"
command = ["sh", "-c", "echo run >> {}; sleep 0.1; exit 1"]
restart = {{ policy = "on-failure", max_restarts = 2, restart_window_s = 60, backoff_initial_ms = 10, backoff_max_ms = 50 }}
"#,
            count.display()
        ),
    )
    .unwrap();
    let (code, lines) = Launch::start(&file).wait();
    assert_eq!(code, 10, "{}", lines.join("\n"));
    let runs = std::fs::read_to_string(&count).unwrap().lines().count();
    assert_eq!(runs, 3, "the first run and two restarts");
}

#[test]
fn a_process_that_is_never_ready_fails_the_launch() {
    let dir = Dir::new("notready");
    let file = dir.0.join("fleet.toml");
    std::fs::write(
        &file,
        r#"
[[process]]
name = "mute"
command = ["sleep", "30"]
ready = { kind = "line", line = "never printed", timeout_s = 0.5 }
restart = { policy = "never" }
"#,
    )
    .unwrap();
    let (code, lines) = Launch::start(&file).wait();
    assert_eq!(code, 10, "{}", lines.join("\n"));
    position(&lines, "not ready within 0.5 s");
}

#[test]
fn a_simulator_and_two_interfaces_start_ready_over_sd_notify() {
    let dir = Dir::new("fleet");
    let file = dir.0.join("fleet.toml");
    let port = {
        let l = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        l.local_addr().unwrap().port()
    };
    let zenoh: Vec<u16> = (0..2)
        .map(|_| {
            let l = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
            l.local_addr().unwrap().port()
        })
        .collect();
    std::fs::write(
        &file,
        format!(
            r#"
run_dir = "run"
[[process]]
name = "sim"
command = ["frontseat", "sim", "--port", "{port}"]
ready = {{ kind = "notify" }}
[[vehicle]]
name = "auv1"
sim_port = {port}
zenoh_listen = ["tcp/127.0.0.1:{z0}"]
[[vehicle]]
name = "auv2"
sim_port = {port}
zenoh_listen = ["tcp/127.0.0.1:{z1}"]
start = {{ lat = 42.36, lon = -71.08 }}
"#,
            z0 = zenoh[0],
            z1 = zenoh[1]
        ),
    )
    .unwrap();
    let check = Command::new(BIN)
        .args(["launch", "--check", "-c"])
        .arg(&file)
        .output()
        .unwrap();
    assert!(check.status.success(), "{check:?}");
    let mut l = Launch::start(&file);
    l.expect("every process is up");
    // The generated configs carry each vehicle's values.
    let auv2 = std::fs::read_to_string(dir.0.join("run/interface-auv2.toml")).unwrap();
    assert!(auv2.contains("auv2") && auv2.contains(&zenoh[1].to_string()));
    // Both interfaces reached their simulator vehicle.
    l.expect("START vehicle=2");
    l.term();
    let (code, lines) = l.wait();
    assert_eq!(code, 0, "{}", lines.join("\n"));
    let up = |n: &str| position(&lines, &format!("ready process={n}"));
    assert!(up("sim") < up("interface-auv1") && up("interface-auv1") < up("interface-auv2"));
    assert_eq!(
        lines
            .iter()
            .filter(|l| l.starts_with("[sim]") && l.contains("START"))
            .count(),
        2,
        "one simulated vehicle per interface"
    );
}

#[test]
fn check_refuses_a_bad_vehicle_value_naming_it() {
    let dir = Dir::new("check");
    let file = dir.0.join("fleet.toml");
    std::fs::write(
        &file,
        "[[vehicle]]\nname = \"auv1\"\nset = { sim_warp_factor = -2 }\n",
    )
    .unwrap();
    let out = Command::new(BIN)
        .args(["launch", "--check", "-c"])
        .arg(&file)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("auv1") && err.contains("sim_warp_factor"),
        "{err}"
    );
}

/// Two vehicles given one port: `--check` names both and the port (exit 2), and the launch
/// itself refuses before starting anything (it started the first interface and failed on the
/// second's bind, exit 11).
#[test]
fn two_vehicles_on_one_port_are_refused_by_check_and_before_the_run() {
    let dir = Dir::new("ports");
    let file = dir.0.join("fleet.toml");
    let port = {
        let l = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        l.local_addr().unwrap().port()
    };
    std::fs::write(
        &file,
        format!(
            "[[vehicle]]\nname = \"auv1\"\nzenoh_listen = [\"tcp/127.0.0.1:{port}\"]\n\
             [[vehicle]]\nname = \"auv2\"\nzenoh_listen = [\"tcp/127.0.0.1:{port}\"]\n"
        ),
    )
    .unwrap();
    let want = format!(
        "port {port} (TCP) is bound by both vehicle auv1 (interprocess.listen \
         \"tcp/127.0.0.1:{port}\") and vehicle auv2 (interprocess.listen \
         \"tcp/127.0.0.1:{port}\"): give each its own port"
    );
    for args in [
        ["launch", "--check", "-c"].as_slice(),
        ["launch", "-c"].as_slice(),
    ] {
        let out = Command::new(BIN).args(args).arg(&file).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(&want), "{args:?}: {err}");
        assert!(!err.contains("[interface-auv1]"), "nothing started: {err}");
    }
}
