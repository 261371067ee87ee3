//! Child processes of the real binaries for end-to-end tests: a guard that kills on drop, a free
//! loopback port, a scratch directory, waiting (with a deadline) for a port to listen, starting
//! `frontseat sim` and `frontseat interface`, and collecting a child's output within a bound.

use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::Duration;

/// Kills its child on drop, so a failing assertion never leaves a process behind.
pub struct Kill(pub Child);

impl Drop for Kill {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

impl Kill {
    /// SIGTERM, then up to `bound` for the process to end; its exit status, `None` if it did
    /// not end (the drop then kills it). A launcher stops its children on SIGTERM; SIGKILL would
    /// leave them running.
    pub fn term(&mut self, bound: Duration) -> Option<ExitStatus> {
        let _ = Command::new("kill")
            .args(["-TERM", &self.0.id().to_string()])
            .status();
        let t0 = std::time::Instant::now();
        while t0.elapsed() < bound {
            if let Ok(Some(st)) = self.0.try_wait() {
                return Some(st);
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        None
    }
}

/// The processes whose command line contains `needle` (from /proc).
pub fn processes_with(needle: &str) -> Vec<String> {
    let Ok(dir) = std::fs::read_dir("/proc") else {
        return Vec::new();
    };
    dir.flatten()
        .filter(|e| {
            e.file_name()
                .to_string_lossy()
                .bytes()
                .all(|b| b.is_ascii_digit())
        })
        .filter_map(|e| std::fs::read(e.path().join("cmdline")).ok())
        .map(|c| String::from_utf8_lossy(&c).replace('\0', " "))
        .filter(|c| c.contains(needle))
        .collect()
}

pub fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// A directory of this test process: `<tmp>/frontseat-<suite>-<pid>-<name>`.
pub fn scratch(suite: &str, name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("frontseat-{suite}-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Resolves once something accepts TCP connections on 127.0.0.1:`port`; panics after 20 s.
pub async fn wait_for_tcp(port: u16) {
    let deadline = tokio::time::Instant::now() + Duration::from_secs(20);
    while tokio::net::TcpStream::connect(("127.0.0.1", port))
        .await
        .is_err()
    {
        assert!(
            tokio::time::Instant::now() < deadline,
            "nothing listens on {port}"
        );
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

/// `frontseat sim` (the basic simulator) on a free port, once it listens; its stderr goes to
/// `stderr`. Returns the guard and the port.
pub async fn frontseat_sim(stderr: impl Into<Stdio>) -> (Kill, u16) {
    let port = free_port();
    let sim = Kill(
        Command::new(env!("CARGO_BIN_EXE_frontseat"))
            .args(["sim", "--port", &port.to_string()])
            .stdout(Stdio::null())
            .stderr(stderr)
            .spawn()
            .unwrap(),
    );
    wait_for_tcp(port).await;
    (sim, port)
}

/// `frontseat interface` on `cfg`, written to `<dir>/interface.toml`, logging (RUST_LOG=info) to
/// `<dir>/interface.log`.
pub fn frontseat_interface(dir: &Path, cfg: &str) -> Kill {
    let path = dir.join("interface.toml");
    std::fs::write(&path, cfg).unwrap();
    Kill(
        Command::new(env!("CARGO_BIN_EXE_frontseat"))
            .arg("interface")
            .arg("-c")
            .arg(&path)
            .env("RUST_LOG", "info")
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(dir.join("interface.log")).unwrap())
            .spawn()
            .unwrap(),
    )
}

/// Waits for a child spawned with piped stdout and stderr to finish, its stdout read within
/// `bound` (else panics naming `what`): its exit status, stdout lines joined, and stderr.
pub async fn finish_within(
    child: &mut Kill,
    bound: Duration,
    what: &str,
) -> (ExitStatus, String, String) {
    let stdout = child.0.stdout.take().unwrap();
    let lines = tokio::task::spawn_blocking(move || {
        BufReader::new(stdout)
            .lines()
            .map_while(Result::ok)
            .collect::<Vec<_>>()
    });
    let lines = tokio::time::timeout(bound, lines)
        .await
        .unwrap_or_else(|_| panic!("{what} did not finish within {bound:?}"))
        .unwrap();
    let status = child.0.wait().unwrap();
    let mut err = String::new();
    if let Some(mut e) = child.0.stderr.take() {
        let _ = e.read_to_string(&mut err);
    }
    (status, lines.join("\n"), err)
}
