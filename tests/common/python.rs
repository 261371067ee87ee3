//! A reference implementation from PyPI (pymavlink, imcpy) on the vehicle side's other end: one
//! of our emulators started as the real `frontseat sim`, a Python script driving it over
//! loopback, bounded in time, judged by the lines it prints.

use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use super::procs::Kill;

/// A Python backseat run against one emulator.
pub struct Backseat<'a> {
    /// The test's name, for the SKIPPED line.
    pub test: &'a str,
    /// What the script imports (`python3 -c "import …"` must succeed).
    pub import: &'a str,
    /// The requirements file that installs it, relative to the repository.
    pub requirements: &'a str,
    /// `frontseat sim --vehicle <vehicle> --tcp 0 --emulator-warp <warp>`.
    pub vehicle: &'a str,
    pub warp: &'a str,
    /// The script, relative to the repository; it gets the emulator's address, then `args`.
    pub script: &'a str,
    pub args: &'a [&'a str],
    /// The script bounds itself; this bounds the script.
    pub bound: Duration,
}

/// Whether python3 can import `module`. False (and `test` reported SKIPPED, naming the
/// `requirements` file that installs it) only when `FRONTSEAT_REQUIRE_PYTHON_HELM` is unset (a
/// machine with only the Rust toolchain); `.ci/run` installs the packages and sets the
/// variable, so there a missing package fails, never skips.
pub fn can_import(test: &str, module: &str, requirements: &str) -> bool {
    let importable = Command::new("python3")
        .args(["-c", &format!("import {module}")])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if !importable {
        assert!(
            std::env::var_os("FRONTSEAT_REQUIRE_PYTHON_HELM").is_none(),
            "FRONTSEAT_REQUIRE_PYTHON_HELM is set but python3 cannot import {module}"
        );
        println!("SKIPPED {test}: python3 cannot import {module} (pip install -r {requirements})");
    }
    importable
}

impl Backseat<'_> {
    /// Runs the script and returns its stdout once it printed `PASS` and exited 0. `None` when
    /// [`can_import`] says the package is missing (reported as SKIPPED).
    pub fn run(&self) -> Option<String> {
        if !can_import(self.test, self.import, self.requirements) {
            return None;
        }
        let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
        let mut sim = Kill(
            Command::new(env!("CARGO_BIN_EXE_frontseat"))
                .args(["sim", "--vehicle", self.vehicle, "--tcp", "0"])
                .args(["--emulator-warp", self.warp])
                .stdout(Stdio::piped())
                .stderr(Stdio::null())
                .spawn()
                .expect("frontseat sim starts"),
        );
        let mut first = String::new();
        BufReader::new(sim.0.stdout.take().expect("piped stdout"))
            .read_line(&mut first)
            .expect("the emulator prints its address");
        let addr = first.trim().to_string();
        assert!(addr.starts_with("127.0.0.1:"), "{addr:?}");
        let mut py = Command::new("python3")
            .arg(root.join(self.script))
            .arg(&addr)
            .args(self.args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("python3 runs");
        let deadline = Instant::now() + self.bound;
        let status = loop {
            if let Some(s) = py.try_wait().expect("wait for python3") {
                break s;
            }
            if Instant::now() > deadline {
                let _ = py.kill();
                panic!("{} did not finish within {:?}", self.script, self.bound);
            }
            std::thread::sleep(Duration::from_millis(50));
        };
        let out = py.wait_with_output().expect("python3's output");
        let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(
            status.success() && stdout.lines().any(|l| l == "PASS"),
            "{} failed:\n{stdout}\n{stderr}",
            self.script
        );
        Some(stdout)
    }
}
