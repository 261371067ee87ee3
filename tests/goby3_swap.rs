//! A Goby3 vehicle swaps to frontseat without editing anything, tried as a Goby3 user would:
//! Goby3's own example goby_frontseat_interface config (config_schema/tests/fixtures/goby3/, as
//! Goby3 prints it, with the values a user fills in), the environment of a Goby3 unit file
//! (`FRONTSEAT_DRIVER_LIBRARY=libgoby_frontseat_basic_simulator.so.30`), a gobyd that holds every
//! client until `goby_frontseat_interface` is ready (the stand-in gobyd recorded from gobyd
//! 3.1.5a), and pHelmIvP on a MOOSDB (a scripted one on our broker) through the interface's own
//! moos_helm bridge. The vehicle must fly the helm's heading, and a Goby3 client held by gobyd
//! must see it. Also: exit_on_error ends the process with Goby3's exit code 0 (or ours, when
//! configured). Every wait has a deadline; children are killed when the test ends.

mod common;

use common::procs::{Kill, free_port, frontseat_sim, scratch};
use frontseat_actors::bus::test_util::UntypedBus as _;

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Duration;

use common::phelm::{ScriptedHelm, heading_near};
use frontseat_actors::bus::Bus;
use frontseat_actors::groups;
use frontseat_config::Goby3Config;
use frontseat_helm_side::GatewayOptions;
use frontseat_helm_side::goby3::standin::{StandinGobyd, StandinTransport};
use frontseat_helm_side::goby3::{self, Goby3Settings};
use frontseat_moos::Broker;
use tokio::time::{Instant, timeout_at};

const LONG: Duration = Duration::from_secs(60);
const BIN: &str = env!("CARGO_BIN_EXE_frontseat");

/// Goby3's printed example for the basic simulator, with what a user fills in: the datum, the
/// simulator's address, gobyd's socket and platform, the MOOSDB port and a warp of 10.
fn goby3_user_config(sim_port: u16, moos_port: u16, socket: &str) -> String {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("config_schema/tests/fixtures/goby3/goby_frontseat_interface_basic_simulator.example.pb.cfg");
    let text = std::fs::read_to_string(&p).unwrap();
    let mut section = Vec::new();
    let mut out = String::new();
    // Goby3 prints this to stdout as it loads the driver: not part of a config.
    for line in text
        .lines()
        .filter(|l| !l.starts_with("Loading frontseat driver library:"))
    {
        let t = line.trim_start();
        let indent = &line[..line.len() - t.len()];
        let key = t.split([':', ' ']).next().unwrap_or("");
        let value = match (section.last().map(String::as_str), key) {
            (_, "lat") => Some("42.358".to_string()),
            (_, "lon") => Some("-71.087".to_string()),
            (_, "tcp_address") => Some("\"127.0.0.1\"".to_string()),
            (Some("[goby.middleware.frontseat.protobuf.basic_simulator_config]"), "tcp_port") => {
                Some(sim_port.to_string())
            }
            (Some("[goby.moos.protobuf.moos_helm]"), "port") => Some(moos_port.to_string()),
            (Some("interprocess"), "platform") => Some("\"auv1\"".to_string()),
            (Some("interprocess"), "socket_name") => Some(format!("{socket:?}")),
            (_, "warp_factor") | (_, "sim_warp_factor") => Some("10".to_string()),
            (_, "helm_running_timeout") => Some("30".to_string()),
            _ => None,
        };
        match value {
            Some(v) => out.push_str(&format!("{indent}{key}: {v}\n")),
            None => {
                out.push_str(line);
                out.push('\n');
            }
        }
        // Track the block we are in: `name {` opens, a line starting with `}` closes.
        if let Some(name) = t.split('#').next().and_then(|s| s.trim().strip_suffix('{')) {
            section.push(name.trim().to_string());
        } else if t.starts_with('}') {
            section.pop();
        }
    }
    out
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn goby3s_example_config_and_unit_environment_fly_through_gobyds_hold() {
    let dir = scratch("goby3swap", "fly");
    let socket = dir.join("goby_auv1").display().to_string();
    // gobyd, configured as on a Goby3 vehicle: hold everyone until the interface is ready.
    let gobyd = StandinGobyd::start(
        StandinTransport::Ipc {
            base: socket.clone(),
        },
        &["goby_frontseat_interface"],
    )
    .await
    .unwrap();
    let (_sim, sim_port) = frontseat_sim(std::fs::File::create(dir.join("sim.log")).unwrap()).await;
    let broker = Broker::bind("127.0.0.1:0").await.unwrap();
    let moos_port = broker.local_addr().port();

    let cfg_path = dir.join("goby_frontseat_interface.pb.cfg");
    std::fs::write(&cfg_path, goby3_user_config(sim_port, moos_port, &socket)).unwrap();
    // `--check` takes it as it is, naming what it ignores.
    let check = Command::new(BIN)
        .args(["interface", "--check", "-c", cfg_path.to_str().unwrap()])
        .env(
            "FRONTSEAT_DRIVER_LIBRARY",
            "libgoby_frontseat_basic_simulator.so.30",
        )
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&check.stderr).to_string();
    assert!(check.status.success(), "{said}");
    assert!(said.contains("app.glog_config.tty_verbosity"), "{said}");
    assert!(said.contains("built-in `basic_simulator` driver"), "{said}");

    // The unit file's ExecStart and environment, the binary swapped: ours installed under
    // Goby3's name, the config as Goby3 takes it (positional).
    let goby_name = dir.join("goby_frontseat_interface");
    std::os::unix::fs::symlink(BIN, &goby_name).unwrap();
    let interface_log = dir.join("interface.log");
    let _interface = Kill(
        Command::new(&goby_name)
            .arg(cfg_path.to_str().unwrap())
            .env(
                "FRONTSEAT_DRIVER_LIBRARY",
                "libgoby_frontseat_basic_simulator.so.30",
            )
            .env("RUST_LOG", "info")
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(&interface_log).unwrap())
            .spawn()
            .unwrap(),
    );
    let log = || std::fs::read_to_string(&interface_log).unwrap_or_default();

    // Another Goby3 client on the vehicle: held by gobyd until goby_frontseat_interface is ready.
    let bus = Bus::new();
    let (_s, mut nav) =
        bus.subscribe_channel(&groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS, "t", 1000);
    let observer_cfg = Goby3Config {
        enabled: true,
        socket_name: socket.clone(),
        client_name: "goby_liaison".into(),
        settle_ms: 100,
        reconnect_initial_ms: 20,
        reconnect_max_ms: 200,
        manager_timeout_seconds: 1.0,
        ..Default::default()
    };
    let observer = goby3::start(
        &bus,
        Goby3Settings::from_config(&observer_cfg, "auv1").unwrap(),
        &["FrontSeatTranslation"],
        GatewayOptions::default(),
    )
    .unwrap();

    // pHelmIvP on the MOOSDB, at the community's warp.
    let mut helm = ScriptedHelm::start(moos_port, 270.0, 10.0);
    let deadline = Instant::now() + LONG;
    assert!(
        helm.sees_heading(270.0, deadline).await,
        "pHelmIvP never saw the vehicle head west\ninterface log:\n{}",
        log()
    );
    // Through gobyd's hold: the held client sees the vehicle heading west too.
    loop {
        match timeout_at(deadline, nav.recv()).await {
            Ok(Some(n)) if heading_near(n.msg.pose.heading(), 270.0, 5.0) => break,
            Ok(Some(_)) => {}
            _ => panic!(
                "a Goby3 client never saw the vehicle through gobyd\ninterface log:\n{}",
                log()
            ),
        }
    }
    let l = log();
    assert!(l.contains("libgoby_frontseat_basic_simulator.so.30"), "{l}");
    helm.stop().await;
    drop(observer);
    broker.shutdown().await;
    gobyd.stop().await;
    let _ = std::fs::remove_dir_all(&dir);
}

/// exit_on_error with no frontseat to reach: FS error after frontseat_connected_timeout, then
/// the process ends with `code`.
fn exit_code_with(extra: &str) -> Option<i32> {
    let dir = scratch("goby3swap", &format!("exit{}", extra.len()));
    let port = free_port(); // nothing listens there
    let cfg = format!(
        "exit_on_error = true\nfrontseat_connected_timeout = 0.5\nrequire_helm = false\n{extra}\
         [driver.basic_simulator]\ntcp_port = {port}\n"
    );
    let path = dir.join("i.toml");
    std::fs::write(&path, cfg).unwrap();
    let mut child = Kill(
        Command::new(BIN)
            .args(["interface", "-c", path.to_str().unwrap()])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap(),
    );
    let deadline = std::time::Instant::now() + LONG;
    loop {
        if let Some(status) = child.0.try_wait().unwrap() {
            let _ = std::fs::remove_dir_all(&dir);
            return status.code();
        }
        assert!(
            std::time::Instant::now() < deadline,
            "the interface did not exit"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn exit_on_error_exits_with_goby3s_code_unless_told_otherwise() {
    assert_eq!(exit_code_with(""), Some(0), "Goby3 quits with 0");
    assert_eq!(exit_code_with("exit_on_error_code = 2\n"), Some(2));
}

/// `--import-goby3` prints TOML that `--check` takes, for both Goby3 applications.
#[test]
fn import_goby3_prints_toml_that_checks() {
    let dir = scratch("goby3swap", "import");
    let gw = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("config_schema/tests/fixtures/goby3/goby_moos_gateway_ivp.example.pb.cfg");
    let iface = dir.join("auv1.pb.cfg");
    std::fs::write(&iface, goby3_user_config(54321, 9000, "/tmp/goby_auv1")).unwrap();
    for (sub, file) in [
        ("interface", iface.as_path()),
        ("moos-gateway", gw.as_path()),
    ] {
        let out = Command::new(BIN)
            .args([sub, "--import-goby3", file.to_str().unwrap()])
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let toml = String::from_utf8(out.stdout).unwrap();
        assert!(
            toml.contains("[goby3]") && toml.contains("enabled = true"),
            "{toml}"
        );
        let path = dir.join(format!("{sub}.toml"));
        std::fs::write(&path, &toml).unwrap();
        let check = Command::new(BIN)
            .args([sub, "--check", "-c", path.to_str().unwrap()])
            .output()
            .unwrap();
        assert!(
            check.status.success(),
            "{sub}: {}\n{toml}",
            String::from_utf8_lossy(&check.stderr)
        );
    }
    // A service with no Goby3 counterpart says so.
    let out = Command::new(BIN)
        .args(["sim", "--import-goby3", iface.to_str().unwrap()])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no Goby3 counterpart"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// Goby3's basic-simulator example exactly as `goby_frontseat_interface -e` prints it (banner
/// line and blank values included) imports and checks through the binary, every fill-in a
/// warning; the real vehicles' examples are refused at their blank datum's line and column; a
/// byte that is not UTF-8 is refused at its line and column like any parse error (exit 2).
#[test]
fn goby3s_printed_example_imports_and_a_non_utf8_byte_is_a_located_error() {
    let dir = scratch("goby3swap", "printed");
    let fixtures = Path::new(env!("CARGO_MANIFEST_DIR")).join("config_schema/tests/fixtures/goby3");
    let run = |args: &[&str]| {
        let out = Command::new(BIN).args(args).output().unwrap();
        (
            out.status.code(),
            String::from_utf8_lossy(&out.stdout).into_owned(),
            String::from_utf8_lossy(&out.stderr).into_owned(),
        )
    };
    let basic = fixtures.join("goby_frontseat_interface_basic_simulator.example.pb.cfg");
    let (code, toml, err) = run(&["interface", "--import-goby3", basic.to_str().unwrap()]);
    assert_eq!(code, Some(0), "{err}");
    assert!(toml.contains("name = \"basic_simulator\""), "{toml}");
    let (code, out, err) = run(&["interface", "--check", "-c", basic.to_str().unwrap()]);
    assert_eq!(code, Some(0), "{err}");
    assert!(out.contains("ok (interface config)"), "{out}");
    assert!(
        err.contains("frontseat_cfg.origin.lat = (blank) ignored: no datum given"),
        "{err}"
    );
    for vehicle in ["bluefin", "iver", "waveglider_sv2"] {
        let f = fixtures.join(format!("goby_frontseat_interface_{vehicle}.example.pb.cfg"));
        let (code, _, err) = run(&["interface", "--check", "-c", f.to_str().unwrap()]);
        assert_eq!(code, Some(2), "{vehicle}: {err}");
        assert!(
            err.starts_with(&format!(
                "{}:66:5: Goby3 config (protobuf text format): frontseat_cfg.origin.lat has no value",
                f.display()
            )),
            "{vehicle}: {err}"
        );
    }
    let bad = dir.join("latin1.pb.cfg");
    std::fs::write(
        &bad,
        b"frontseat_cfg {\n  origin { lat: 42 lon: -71 }\n  # caf\xe9\n}\n",
    )
    .unwrap();
    let want = format!(
        "{}:3:8: Goby3 config (protobuf text format): byte 0xE9 is not UTF-8: a config file is UTF-8 text\n",
        bad.display()
    );
    for args in [
        ["interface", "--import-goby3", bad.to_str().unwrap()].as_slice(),
        ["interface", "--check", "-c", bad.to_str().unwrap()].as_slice(),
        ["interface", bad.to_str().unwrap()].as_slice(),
    ] {
        let (code, _, err) = run(args);
        assert_eq!(code, Some(2), "{args:?}: {err}");
        assert_eq!(err, want, "{args:?}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
