//! The real OpenCPN 5.10.2 (Debian bookworm-backports) receives the demo fleet's AIS:
//! `frontseat demo --fleet 3 --ais` to the UDP input of an OpenCPN running headless under Xvfb
//! (a config written first, with the two keys that keep its startup dialogs away, as the shared
//! OpenCPN notes §6 found), then OpenCPN is stopped with SIGTERM and its name cache
//! (`~/.opencpn/mmsitoname.csv`, written from the targets it holds) must name every vehicle by
//! its MMSI. That shows OpenCPN decoded our static reports into targets; it does not show what
//! it drew (the pyais tests check every field).
//!
//! And the other way: a route saved as active in OpenCPN's navobj.xml, a fixed own-ship fix
//! sent to it as RMC, its autopilot output (RMB/RMC/APB/XTE, whitelisted) pointed at a real
//! `frontseat interface` with `[opencpn.helm]` on a basic simulator: the vehicle turns to the
//! bearing OpenCPN computes (seen in the interface's own AIS).
//!
//! Without `opencpn` and `Xvfb` they report SKIPPED, unless FRONTSEAT_REQUIRE_OPENCPN is set
//! (`.ci/run` installs both and sets it): there it fails.

mod common;

use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::ais::{angle_diff, type18};
use common::procs::{Kill, frontseat_interface, frontseat_sim, scratch};

fn installed(bin: &str) -> bool {
    Command::new("sh")
        .args(["-c", &format!("command -v {bin}")])
        .stdout(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// One OpenCPN at a time: each opens a REST server on port 8443 of every address.
static ONE_OPENCPN: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// Xvfb and OpenCPN under `home` (its `.opencpn/opencpn.conf` written before), until OpenCPN has
/// bound UDP `port` (its input: our own bind of it fails once it has).
fn start_opencpn(home: &std::path::Path, port: u16) -> (Kill, Kill) {
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
            .env("HOME", home)
            .env("DISPLAY", &display)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap(),
    );
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
    (xvfb, opencpn)
}

/// Whether the tests can run; panics when FRONTSEAT_REQUIRE_OPENCPN says they must.
fn can_run(test: &str) -> bool {
    if installed("opencpn") && installed("Xvfb") {
        return true;
    }
    assert!(
        std::env::var_os("FRONTSEAT_REQUIRE_OPENCPN").is_none(),
        "FRONTSEAT_REQUIRE_OPENCPN is set but opencpn or Xvfb is not installed"
    );
    println!(
        "SKIPPED {test}: no opencpn/Xvfb (apt-get install -t bookworm-backports opencpn xvfb)"
    );
    false
}

#[test]
fn opencpn_names_every_vehicle_of_the_demo_fleet() {
    if !can_run("opencpn_names_every_vehicle_of_the_demo_fleet") {
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
    let _one = ONE_OPENCPN.lock().unwrap_or_else(|p| p.into_inner());
    let t0 = Instant::now();
    let (_xvfb, mut opencpn) = start_opencpn(&home, port);
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

fn nmea(body: &str) -> String {
    let sum = body.bytes().fold(0u8, |a, b| a ^ b);
    format!("${body}*{sum:02X}\r\n")
}

#[test]
fn an_active_route_in_opencpn_steers_the_vehicle() {
    if !can_run("an_active_route_in_opencpn_steers_the_vehicle") {
        return;
    }
    let _one = ONE_OPENCPN.lock().unwrap_or_else(|p| p.into_inner());
    tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .unwrap()
        .block_on(route_steers());
}

async fn route_steers() {
    let dir = scratch("opencpn_real", "route");
    let (_sim, sim_port) = frontseat_sim(Stdio::null()).await;
    let udp_port = || {
        std::net::UdpSocket::bind("127.0.0.1:0")
            .unwrap()
            .local_addr()
            .unwrap()
            .port()
    };
    let (helm_port, fix_port) = (udp_port(), udp_port());
    let ais = tokio::net::UdpSocket::bind("127.0.0.1:0").await.unwrap();
    let cfg = format!(
        "name = \"auv1\"\nhelm_state_timeout = 3.0\n[driver.basic_simulator]\ntcp_port = {sim_port}\n[interprocess]\nenabled = false\n\
         [opencpn.ais]\nenabled = true\nudp = [\"{}\"]\nposition_interval_s = 0.5\n[[opencpn.ais.vehicle]]\nname = \"auv1\"\nmmsi = 299000001\n\
         [opencpn.helm]\nenabled = true\nlisten = \"127.0.0.1:{helm_port}\"\nspeed = 1.5\ntimeout_s = 3.0\n",
        ais.local_addr().unwrap()
    );
    let _iface = frontseat_interface(&dir, &cfg);
    // OpenCPN: a fix input, an autopilot output with the whitelist, and a route saved active.
    let home = dir.join("home");
    let conf = home.join(".opencpn");
    std::fs::create_dir_all(&conf).unwrap();
    let guid = "7a3c1f00-0000-4000-8000-000000000001";
    std::fs::write(
        conf.join("opencpn.conf"),
        format!(
            "[Settings]\nNavMessageShown=1\nConfigVersionString=Version 5.10.2 Build 2026-06-07\nPersistActiveRoute=1\nActiveRoute={guid}\n\
             [Settings/NMEADataSource]\nDataConnections=1;1;127.0.0.1;{fix_port};0;;4800;1;0;0;;0;;0;0;0;0;1;fix in;0;;0;0;|\
             1;1;127.0.0.1;{helm_port};0;;4800;1;2;0;;0;ECRMB,ECRMC,ECAPB,ECXTE;0;0;0;0;1;autopilot out;0;;0;0;\n"
        ),
    )
    .unwrap();
    let wpt = |name: &str, lat: f64, lon: f64, n: u32| {
        format!(
            "    <rtept lat=\"{lat:.6}\" lon=\"{lon:.6}\">\n      <name>{name}</name>\n      <sym>diamond</sym>\n      <extensions><opencpn:guid>7a3c1f00-0000-4000-8000-00000000010{n}</opencpn:guid></extensions>\n    </rtept>\n"
        )
    };
    std::fs::write(
        conf.join("navobj.xml"),
        format!(
            "<?xml version=\"1.0\" encoding=\"utf-8\" ?>\n<gpx version=\"1.1\" creator=\"OpenCPN\" xmlns=\"http://www.topografix.com/GPX/1/1\" xmlns:opencpn=\"http://www.opencpn.org\">\n  <rte>\n    <name>frontseat test</name>\n    <extensions>\n      <opencpn:guid>{guid}</opencpn:guid>\n    </extensions>\n{}{}  </rte>\n</gpx>\n",
            wpt("WPA", 42.36, -71.085, 1),
            wpt("WPB", 42.37, -71.07, 2)
        ),
    )
    .unwrap();
    let (_xvfb, _opencpn) = start_opencpn(&home, fix_port);
    // Own ship south-west of WPA: OpenCPN steers from it (bearing about 36 deg true).
    let fix = tokio::net::UdpSocket::bind("127.0.0.1:0").await.unwrap();
    let t0 = Instant::now();
    let mut buf = vec![0u8; 4096];
    let mut next_fix = Instant::now();
    let mut last = None;
    loop {
        assert!(
            t0.elapsed() < Duration::from_secs(90),
            "the vehicle did not turn to OpenCPN's bearing within 90 s; last heading {last:?}"
        );
        if Instant::now() >= next_fix {
            let rmc = nmea("GPRMC,120000.00,A,4221.3000,N,07105.4000,W,0.0,0.0,281126,,,A");
            fix.send_to(rmc.as_bytes(), ("127.0.0.1", fix_port))
                .await
                .unwrap();
            next_fix = Instant::now() + Duration::from_secs(1);
        }
        let Ok(Ok(n)) = tokio::time::timeout(Duration::from_millis(200), ais.recv(&mut buf)).await
        else {
            continue;
        };
        let text = String::from_utf8_lossy(&buf[..n]).into_owned();
        for l in text.lines() {
            if let Some((299_000_001, h, _)) = type18(l) {
                last = Some(h);
                if h != 511 && angle_diff(h as f64, 36.46) <= 3.0 {
                    println!(
                        "OpenCPN's route steered the vehicle to heading {h} in {:?}",
                        t0.elapsed()
                    );
                    return;
                }
            }
        }
    }
}
