//! `[sim] start_timeout_s` and `max_pending` reach the simulator the binary runs: a silent
//! connection is closed at the timeout, and past `max_pending` the oldest silent one makes room.
//! Real `frontseat sim` processes over loopback.

use std::io::{BufRead, BufReader, Read};
use std::net::TcpStream;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_frontseat");

struct Sim(Child);

impl Drop for Sim {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Starts `frontseat sim` with `toml` as its config file and returns it with its port.
fn sim(dir: &std::path::Path, toml: &str) -> (Sim, u16) {
    let cfg = dir.join("sim.toml");
    std::fs::write(&cfg, toml).unwrap();
    let mut child = Command::new(BIN)
        .args(["sim", "--port", "0", "--bind", "127.0.0.1", "-c"])
        .arg(&cfg)
        .env("RUST_LOG", "info")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let stderr = child.stderr.take().unwrap();
    let guard = Sim(child);
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stderr).lines().map_while(Result::ok) {
            let _ = tx.send(line);
        }
    });
    let deadline = Instant::now() + Duration::from_secs(30);
    loop {
        let line = rx
            .recv_timeout(deadline.saturating_duration_since(Instant::now()))
            .expect("the simulator did not say where it listens");
        if let Some(addr) = line.split("listening addr=").nth(1) {
            let port = addr.trim().rsplit(':').next().unwrap().parse().unwrap();
            return (guard, port);
        }
    }
}

/// True when the server closed `s` within `within` (read returns end of file).
fn closed_within(s: &mut TcpStream, within: Duration) -> bool {
    s.set_read_timeout(Some(within)).unwrap();
    let mut buf = [0u8; 256];
    loop {
        match s.read(&mut buf) {
            Ok(0) => return true,
            Ok(_) => continue,
            Err(e) if e.kind() == std::io::ErrorKind::ConnectionReset => return true,
            Err(_) => return false,
        }
    }
}

#[test]
fn start_timeout_and_max_pending_come_from_the_config_file() {
    let dir = std::env::temp_dir().join(format!("fs-sim-keys-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();

    // A silent connection is closed once start_timeout_s has passed.
    {
        let (_sim, port) = sim(&dir, "start_timeout_s = 0.3\n");
        let mut silent = TcpStream::connect(("127.0.0.1", port)).unwrap();
        // 5 s: well past 0.3 s on a loaded machine, well before the 10 s default, so a config
        // key that did not reach the simulator fails here.
        assert!(
            closed_within(&mut silent, Duration::from_secs(5)),
            "a silent connection outlived start_timeout_s"
        );
    }

    // No timeout, one pending slot: the second silent client closes the first, and itself
    // stays open (it is the one waiting now).
    {
        let (_sim, port) = sim(&dir, "start_timeout_s = 0\nmax_pending = 1\n");
        let mut first = TcpStream::connect(("127.0.0.1", port)).unwrap();
        let mut second = TcpStream::connect(("127.0.0.1", port)).unwrap();
        assert!(
            closed_within(&mut first, Duration::from_secs(20)),
            "the oldest silent connection was not closed for the new one"
        );
        assert!(
            !closed_within(&mut second, Duration::from_millis(500)),
            "the newest waiting connection was closed with max_pending = 1 and no timeout"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}
