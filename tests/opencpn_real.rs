//! The real OpenCPN 5.10.2 (Debian bookworm-backports) receives the demo fleet's AIS:
//! `frontseat demo --fleet 3 --ais` to the UDP input of an OpenCPN running headless under Xvfb
//! (a config written first, with the two keys that keep its startup dialogs away, as the shared
//! OpenCPN notes §6 found), then OpenCPN is stopped with SIGTERM and its name cache
//! (`~/.opencpn/mmsitoname.csv`, written from the targets it holds) must name every vehicle by
//! its MMSI. That shows OpenCPN decoded our static reports into targets; it does not show what
//! it drew (the pyais tests check every field).
//!
//! Without `opencpn` and `Xvfb` it reports SKIPPED, unless FRONTSEAT_REQUIRE_OPENCPN is set
//! (`.ci/run` installs both and sets it): there it fails.

mod common;

use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::procs::{Kill, scratch};

fn installed(bin: &str) -> bool {
    Command::new("sh")
        .args(["-c", &format!("command -v {bin}")])
        .stdout(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

#[test]
fn opencpn_names_every_vehicle_of_the_demo_fleet() {
    if !(installed("opencpn") && installed("Xvfb")) {
        assert!(
            std::env::var_os("FRONTSEAT_REQUIRE_OPENCPN").is_none(),
            "FRONTSEAT_REQUIRE_OPENCPN is set but opencpn or Xvfb is not installed"
        );
        println!(
            "SKIPPED opencpn_names_every_vehicle_of_the_demo_fleet: no opencpn/Xvfb (apt-get install -t bookworm-backports opencpn xvfb)"
        );
        return;
    }
    let home = scratch("opencpn_real", "home");
    let conf_dir = home.join(".opencpn");
    std::fs::create_dir_all(&conf_dir).unwrap();
    let port = {
        let s = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
        s.local_addr().unwrap().port()
    };
    std::fs::write(
        conf_dir.join("opencpn.conf"),
        format!(
            "[Settings]\nNavMessageShown=1\nConfigVersionString=Version 5.10.2 Build 2026-06-07\n\
             [Settings/AIS]\nbMarkLostTargets=1\nMarkLost_Minutes=1\nbRemoveLostTargets=1\nRemoveLost_Minutes=2\n\
             [Settings/NMEADataSource]\nDataConnections=1;1;127.0.0.1;{port};0;;4800;1;0;0;;0;;0;0;0;0;1;frontseat ais;0;;0;0;\n"
        ),
    )
    .unwrap();
    // Xvfb picks a free display and says which.
    let mut xvfb = Kill(
        Command::new("Xvfb")
            .args([
                "-displayfd",
                "1",
                "-screen",
                "0",
                "1280x800x24",
                "-nolisten",
                "tcp",
            ])
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .unwrap(),
    );
    let mut display = String::new();
    BufReader::new(xvfb.0.stdout.take().unwrap())
        .read_line(&mut display)
        .unwrap();
    let display = format!(":{}", display.trim());
    let mut opencpn = Kill(
        Command::new("opencpn")
            .arg("-G")
            .env("HOME", &home)
            .env("DISPLAY", &display)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap(),
    );
    // OpenCPN binds its UDP input on every address: our own bind of it fails once it has.
    let t0 = Instant::now();
    while std::net::UdpSocket::bind(("0.0.0.0", port)).is_ok() {
        assert!(
            t0.elapsed() < Duration::from_secs(90),
            "OpenCPN did not open UDP {port} within 90 s"
        );
        assert!(opencpn.0.try_wait().unwrap().is_none(), "OpenCPN exited");
        std::thread::sleep(Duration::from_millis(200));
    }
    println!("OpenCPN listening after {:?}", t0.elapsed());
    let out = scratch("opencpn_real", "fleet");
    let demo = Command::new(env!("CARGO_BIN_EXE_frontseat"))
        .args([
            "demo",
            "--fleet",
            "3",
            "--warp",
            "10",
            "--ais",
            &format!("127.0.0.1:{port}"),
            "--out",
        ])
        .arg(&out)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut demo = Kill(demo);
    let t1 = Instant::now();
    while demo.0.try_wait().unwrap().is_none() {
        assert!(
            t1.elapsed() < Duration::from_secs(120),
            "the demo did not end within 120 s"
        );
        std::thread::sleep(Duration::from_millis(200));
    }
    // SIGTERM: OpenCPN exits cleanly and writes its name cache.
    Command::new("kill")
        .args(["-TERM", &opencpn.0.id().to_string()])
        .status()
        .unwrap();
    let t2 = Instant::now();
    while opencpn.0.try_wait().unwrap().is_none() {
        assert!(
            t2.elapsed() < Duration::from_secs(30),
            "OpenCPN did not exit within 30 s of SIGTERM"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
    let cache = std::fs::read_to_string(conf_dir.join("mmsitoname.csv")).unwrap_or_default();
    for want in [
        "299000001,LEADER",
        "299000002,FOLLOWER1",
        "299000003,FOLLOWER2",
    ] {
        assert!(
            cache.lines().any(|l| l == want),
            "OpenCPN's name cache lacks {want}:\n{cache}"
        );
    }
    println!("OpenCPN run: {:?} in all", t0.elapsed());
}
