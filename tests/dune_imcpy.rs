//! The emulator against the reference implementation: `frontseat sim --vehicle dune` on a
//! loopback port, driven by a backseat written with imcpy from PyPI (DUNE's own IMC code;
//! `vehicles/dune/python/imcpy_backseat.py`): it must decode our EstimatedState and VehicleState,
//! and its PlanControl + FollowReference + References must move the emulated LAUV (heading 90,
//! 2 m depth), MANDONE must end the plan, and a plan left without References must time out.

mod common;

use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::Duration;

use common::procs::Kill;

fn python_has_imcpy() -> bool {
    Command::new("python3")
        .args(["-c", "import imcpy"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

#[test]
fn imcpy_decodes_and_steers_the_dune_emulator() {
    if !python_has_imcpy() {
        // `.ci/run` installs imcpy and sets this: there, a missing package is a failure.
        assert!(
            std::env::var_os("FRONTSEAT_REQUIRE_PYTHON_HELM").is_none(),
            "FRONTSEAT_REQUIRE_PYTHON_HELM is set but python3 cannot import imcpy"
        );
        println!(
            "SKIPPED imcpy_decodes_and_steers_the_dune_emulator: python3 cannot import imcpy \
             (pip install -r vehicles/dune/python/requirements.txt)"
        );
        return;
    }
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let mut sim = Kill(
        Command::new(env!("CARGO_BIN_EXE_frontseat"))
            .args(["sim", "--vehicle", "dune", "--tcp", "0"])
            .args(["--emulator-warp", "10"])
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("frontseat sim starts"),
    );
    let mut first = String::new();
    BufReader::new(sim.0.stdout.take().unwrap())
        .read_line(&mut first)
        .expect("the emulator prints its address");
    let addr = first.trim().to_string();
    assert!(addr.starts_with("127.0.0.1:"), "{addr:?}");
    let mut py = Command::new("python3")
        .arg(root.join("vehicles/dune/python/imcpy_backseat.py"))
        .arg(&addr)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("python3 runs");
    // The script bounds itself at 120 s; this bounds the script.
    let deadline = std::time::Instant::now() + Duration::from_secs(150);
    let status = loop {
        if let Some(s) = py.try_wait().unwrap() {
            break s;
        }
        if std::time::Instant::now() > deadline {
            let _ = py.kill();
            panic!("imcpy backseat did not finish within 150 s");
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    let out = py.wait_with_output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        status.success() && stdout.lines().any(|l| l == "PASS"),
        "imcpy backseat failed:\n{stdout}\n{stderr}"
    );
    for step in [
        "ok VehicleState from 0x00d1",
        "ok EstimatedState decodes",
        "ok SERVICE",
        "ok MANEUVER 478",
        "ok steering psi 90 depth 2",
        "ok FollowRefState",
        "ok MANDONE",
        "ok timeout → SERVICE, loops 0",
    ] {
        assert!(stdout.contains(step), "missing {step:?} in:\n{stdout}");
    }
    println!("{stdout}");
}
