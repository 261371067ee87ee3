//! Deployment under systemd: the unit files pass `systemd-analyze verify`, the example configs
//! pass `--check`, install.sh/uninstall.sh work in a staging directory, the sd_notify module
//! (frontseat_actors::systemd) reports status and withholds the watchdog from a hung actor, and
//! the real binary speaks sd_notify to a socket this test owns.

mod common;

use frontseat_actors::bus::test_util::UntypedBus as _;
use std::collections::BTreeSet;
use std::io::{BufRead, BufReader};
use std::os::unix::net::UnixDatagram;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use common::{config_for, start_sim};
use frontseat_actors::bus::Bus;
use frontseat_actors::groups;
use frontseat_actors::interface::InterfaceService;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    FrontSeatError, FrontSeatState, HelmError, HelmState, InterfaceState, InterfaceStatus,
};
use frontseat_actors::systemd::{
    self, Notifier, spawn_status_reporter, spawn_watchdog, status_text,
};

const BIN: &str = env!("CARGO_BIN_EXE_frontseat");
const UNITS: [&str; 3] = [
    "frontseat-interface.service",
    "frontseat-sim.service",
    "frontseat-moos-gateway.service",
];

fn deploy_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("deploy")
}

/// A fresh directory under the system temp dir, removed on drop.
struct TempDir(PathBuf);

impl TempDir {
    fn new(what: &str) -> Self {
        let p =
            std::env::temp_dir().join(format!("frontseat-deploy-{what}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&p);
        std::fs::create_dir_all(&p).unwrap();
        Self(p)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

// ---------------------------------------------------------------------------------------------
// Unit files

fn unit_text(name: &str) -> String {
    std::fs::read_to_string(deploy_dir().join("systemd").join(name)).unwrap()
}

/// `key=value` settings of a unit (comments and section headers dropped).
fn settings(text: &str) -> Vec<(String, String)> {
    text.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#') && !l.starts_with('['))
        .filter_map(|l| l.split_once('='))
        .map(|(k, v)| (k.trim().to_string(), v.trim().to_string()))
        .collect()
}

#[test]
fn units_carry_the_required_settings() {
    for unit in UNITS {
        let sub = unit
            .strip_prefix("frontseat-")
            .and_then(|s| s.strip_suffix(".service"))
            .unwrap();
        let s = settings(&unit_text(unit));
        let get = |k: &str| -> Vec<&str> {
            s.iter()
                .filter(|(key, _)| key == k)
                .map(|(_, v)| v.as_str())
                .collect()
        };
        let one = |k: &str| -> &str {
            let v = get(k);
            assert_eq!(v.len(), 1, "{unit}: exactly one {k}=, found {v:?}");
            v[0]
        };
        assert_eq!(one("Type"), "notify", "{unit}");
        assert_eq!(one("NotifyAccess"), "main", "{unit}");
        assert_eq!(one("WatchdogSec"), "5", "{unit}");
        assert_eq!(one("Restart"), "on-failure", "{unit}");
        assert_eq!(one("User"), "frontseat", "{unit}");
        for k in ["RestartSec", "StartLimitIntervalSec", "StartLimitBurst"] {
            one(k);
        }
        for (k, v) in [
            ("NoNewPrivileges", "yes"),
            ("ProtectSystem", "strict"),
            ("ProtectHome", "yes"),
            ("PrivateTmp", "yes"),
            ("RestrictAddressFamilies", "AF_INET AF_INET6 AF_UNIX"),
        ] {
            assert_eq!(one(k), v, "{unit}: {k}");
        }
        let config = format!("/etc/frontseat/{sub}.toml");
        assert_eq!(
            one("ExecStartPre"),
            format!("/usr/local/bin/frontseat {sub} --check -c {config}")
        );
        assert_eq!(
            one("ExecStart"),
            format!("/usr/local/bin/frontseat {sub} -c {config}")
        );
    }
}

#[test]
fn units_pass_systemd_analyze_verify() {
    if Command::new("systemd-analyze")
        .arg("--version")
        .output()
        .is_err()
    {
        eprintln!("note: systemd-analyze is not installed; unit verification skipped");
        return;
    }
    // verify checks that ExecStart names an executable: point the copies at the built binary.
    let dir = TempDir::new("verify");
    for unit in UNITS {
        let text = unit_text(unit).replace("/usr/local/bin/frontseat", BIN);
        let path = dir.0.join(unit);
        std::fs::write(&path, text).unwrap();
        let out = Command::new("systemd-analyze")
            .arg("verify")
            .arg(&path)
            .env("SYSTEMD_LOG_COLOR", "0")
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        // Complaints about our file name it; other lines are about the host's units.
        let ours: Vec<&str> = stderr.lines().filter(|l| l.contains(unit)).collect();
        assert!(
            out.status.success() && ours.is_empty(),
            "systemd-analyze verify {unit}: {:?}\n{stderr}",
            out.status
        );
    }
    // The check must be able to fail: an unknown key is reported against the file.
    let bad = dir.0.join("frontseat-bad.service");
    std::fs::write(
        &bad,
        unit_text(UNITS[0]).replace("/usr/local/bin/frontseat", BIN)
            + "\n[Service]\nWatchdogSecs=5\n",
    )
    .unwrap();
    let out = Command::new("systemd-analyze")
        .arg("verify")
        .arg(&bad)
        .output()
        .unwrap();
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("frontseat-bad.service"),
        "verify did not flag an unknown key"
    );
}

/// The fleet without the launcher: one interface per vehicle, each from /etc/frontseat/<vehicle>.toml,
/// with the hardening and supervision of the single unit.
#[test]
fn template_unit_runs_one_interface_per_vehicle_config() {
    let template = "frontseat-interface@.service";
    let text = unit_text(template);
    let single = unit_text("frontseat-interface.service");
    let s = settings(&text);
    let one = |k: &str| -> String {
        let v: Vec<&String> = s
            .iter()
            .filter(|(key, _)| key == k)
            .map(|(_, v)| v)
            .collect();
        assert_eq!(v.len(), 1, "{template}: exactly one {k}=, found {v:?}");
        v[0].clone()
    };
    assert_eq!(
        one("ExecStart"),
        "/usr/local/bin/frontseat interface -c /etc/frontseat/%i.toml"
    );
    assert_eq!(
        one("ExecStartPre"),
        "/usr/local/bin/frontseat interface --check -c /etc/frontseat/%i.toml"
    );
    // Everything else is the single unit's: same supervision, same hardening.
    let rest = |t: &str| -> Vec<(String, String)> {
        settings(t)
            .into_iter()
            .filter(|(k, _)| {
                ![
                    "ExecStart",
                    "ExecStartPre",
                    "Description",
                    "SyslogIdentifier",
                ]
                .contains(&k.as_str())
            })
            .collect()
    };
    assert_eq!(rest(&text), rest(&single));
    assert!(one("SyslogIdentifier").contains("%i"));

    if Command::new("systemd-analyze")
        .arg("--version")
        .output()
        .is_err()
    {
        eprintln!("note: systemd-analyze is not installed; template verification skipped");
        return;
    }
    // An instance of the template, as systemd would load it for vehicle auv1.
    let dir = TempDir::new("verify-template");
    let path = dir.0.join("frontseat-interface@auv1.service");
    std::fs::write(&path, text.replace("/usr/local/bin/frontseat", BIN)).unwrap();
    let out = Command::new("systemd-analyze")
        .arg("verify")
        .arg(&path)
        .env("SYSTEMD_LOG_COLOR", "0")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    let ours: Vec<&str> = stderr
        .lines()
        .filter(|l| l.contains("frontseat-interface@"))
        .collect();
    assert!(
        out.status.success() && ours.is_empty(),
        "verify: {:?}\n{stderr}",
        out.status
    );
}

#[test]
fn example_configs_pass_check() {
    let mut checked = 0;
    for entry in std::fs::read_dir(deploy_dir().join("examples")).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let sub = if name.starts_with("interface") {
            "interface"
        } else if name.starts_with("sim") {
            "sim"
        } else if name.starts_with("topside") {
            "topside"
        } else {
            panic!("example {name}: name it after its service (interface*, sim*, topside*)");
        };
        let out = Command::new(BIN)
            .args([sub, "--check", "-c"])
            .arg(&path)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        checked += 1;
    }
    assert!(checked >= 2, "examples for the interface and the sim");
}

// ---------------------------------------------------------------------------------------------
// install.sh / uninstall.sh

fn script(name: &str, args: &[&str], destdir: &Path) -> String {
    let out = Command::new("bash")
        .arg(deploy_dir().join(name))
        .args(args)
        .arg("--destdir")
        .arg(destdir)
        .env_remove("DESTDIR")
        .env_remove("PREFIX")
        .env_remove("FRONTSEAT_BINARY")
        .output()
        .unwrap();
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.status.success(), "{name} {args:?} failed:\n{text}");
    text
}

/// Every file under `root`, as absolute paths inside the staged tree.
fn files_under(root: &Path) -> BTreeSet<String> {
    fn walk(root: &Path, dir: &Path, out: &mut BTreeSet<String>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                walk(root, &p, out);
            } else {
                out.insert(format!("/{}", p.strip_prefix(root).unwrap().display()));
            }
        }
    }
    let mut out = BTreeSet::new();
    if root.exists() {
        walk(root, root, &mut out);
    }
    out
}

#[test]
fn install_places_everything_keeps_existing_config_and_uninstall_removes_it() {
    let stage = TempDir::new("install");
    let root = &stage.0;
    // A config the operator already has must survive install, uninstall and purge.
    let mine = "# the operator's own\nname = \"auv7\"\n";
    std::fs::create_dir_all(root.join("etc/frontseat")).unwrap();
    std::fs::write(root.join("etc/frontseat/interface.toml"), mine).unwrap();

    script("install.sh", &["--binary", BIN], root);
    let files = files_under(root);
    for f in [
        "/usr/local/bin/frontseat",
        "/etc/systemd/system/frontseat-interface.service",
        "/etc/systemd/system/frontseat-sim.service",
        "/etc/systemd/system/frontseat-moos-gateway.service",
        "/etc/systemd/system/frontseat-interface@.service",
        "/usr/lib/sysusers.d/frontseat.conf",
        "/usr/local/share/doc/frontseat/README.md",
        "/etc/frontseat/interface.toml",
        "/etc/frontseat/sim.toml",
        "/usr/local/share/frontseat/install-manifest",
    ] {
        assert!(files.contains(f), "{f} not installed; got {files:?}");
    }
    assert_eq!(
        std::fs::read(root.join("usr/local/bin/frontseat")).unwrap(),
        std::fs::read(BIN).unwrap(),
        "the given binary is installed"
    );
    assert_eq!(
        std::fs::read_to_string(root.join("etc/frontseat/interface.toml")).unwrap(),
        mine,
        "an existing config is not overwritten"
    );
    let example = Command::new(BIN)
        .args(["sim", "--example_config"])
        .output()
        .unwrap();
    assert_eq!(
        std::fs::read(root.join("etc/frontseat/sim.toml")).unwrap(),
        example.stdout,
        "a missing config is generated by --example_config"
    );
    let out = Command::new(BIN)
        .args(["sim", "--check", "-c"])
        .arg(root.join("etc/frontseat/sim.toml"))
        .output()
        .unwrap();
    assert!(out.status.success(), "the generated config passes --check");

    // A second install (upgrade) changes nothing the operator owns.
    std::fs::write(root.join("etc/frontseat/sim.toml"), "port = 60000\n").unwrap();
    script("install.sh", &["--binary", BIN], root);
    assert_eq!(
        std::fs::read_to_string(root.join("etc/frontseat/sim.toml")).unwrap(),
        "port = 60000\n"
    );
    assert_eq!(files_under(root), files, "reinstall places the same files");

    // Uninstall removes what install placed, keeping configs; --purge the generated ones too.
    script("uninstall.sh", &[], root);
    let left = files_under(root);
    assert!(
        left.iter().all(|f| f.starts_with("/etc/frontseat/")
            || f == "/usr/local/share/frontseat/install-manifest"),
        "uninstall left {left:?}"
    );
    assert!(
        left.contains("/etc/frontseat/sim.toml"),
        "configs kept without --purge"
    );
    script("uninstall.sh", &["--purge"], root);
    assert_eq!(
        files_under(root),
        BTreeSet::from(["/etc/frontseat/interface.toml".to_string()]),
        "purge removes what install generated, never the operator's own config"
    );
    assert_eq!(
        std::fs::read_to_string(root.join("etc/frontseat/interface.toml")).unwrap(),
        mine
    );
}

/// `--goby3-names`: the binary also answers to Goby3's application names, so a Goby3 unit file
/// runs it unchanged; a real Goby3 binary already there is never replaced.
#[test]
fn install_can_link_goby3s_application_names_and_never_replaces_goby3s_binary() {
    let stage = TempDir::new("goby3names");
    let root = &stage.0;
    script("install.sh", &["--binary", BIN, "--goby3-names"], root);
    let bin = root.join("usr/local/bin");
    for name in ["goby_frontseat_interface", "goby_moos_gateway"] {
        assert_eq!(
            std::fs::read_link(bin.join(name)).unwrap(),
            Path::new("frontseat"),
            "{name}"
        );
    }
    // Called by Goby3's name, it is that application.
    let out = Command::new(bin.join("goby_frontseat_interface"))
        .arg("--example_config")
        .output()
        .unwrap();
    let example = Command::new(BIN)
        .args(["interface", "--example_config"])
        .output()
        .unwrap();
    assert!(out.status.success());
    assert_eq!(out.stdout, example.stdout);
    script("uninstall.sh", &[], root);
    assert!(!bin.join("goby_frontseat_interface").exists());

    // A Goby3 binary in the way: refused, left as it was.
    let other = TempDir::new("goby3names-real");
    let obin = other.0.join("usr/local/bin");
    std::fs::create_dir_all(&obin).unwrap();
    std::fs::write(obin.join("goby_moos_gateway"), "#!/bin/sh\n# Goby3's\n").unwrap();
    let out = Command::new("bash")
        .arg(deploy_dir().join("install.sh"))
        .args(["--binary", BIN, "--goby3-names", "--destdir"])
        .arg(&other.0)
        .output()
        .unwrap();
    assert_eq!(
        out.status.code(),
        Some(2),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(String::from_utf8_lossy(&out.stderr).contains("not our link"));
    assert_eq!(
        std::fs::read_to_string(obin.join("goby_moos_gateway")).unwrap(),
        "#!/bin/sh\n# Goby3's\n"
    );
}

#[test]
fn install_with_a_prefix_rewrites_the_units() {
    let stage = TempDir::new("prefix");
    script(
        "install.sh",
        &["--binary", BIN, "--prefix", "/opt/fs"],
        &stage.0,
    );
    let unit = std::fs::read_to_string(
        stage
            .0
            .join("etc/systemd/system/frontseat-interface.service"),
    )
    .unwrap();
    assert!(
        unit.contains("ExecStart=/opt/fs/bin/frontseat interface -c /etc/frontseat/interface.toml")
    );
    assert!(!unit.contains("/usr/local/"), "{unit}");
    assert!(stage.0.join("opt/fs/bin/frontseat").exists());
    script(
        "uninstall.sh",
        &["--prefix", "/opt/fs", "--purge"],
        &stage.0,
    );
    assert!(
        files_under(&stage.0).is_empty(),
        "{:?}",
        files_under(&stage.0)
    );
}

// ---------------------------------------------------------------------------------------------
// The sd_notify module, in process

fn status(
    state: InterfaceState,
    fs: FrontSeatState,
    helm: HelmState,
    helm_error: HelmError,
    fs_error: FrontSeatError,
) -> InterfaceStatus {
    let mut s = InterfaceStatus::default();
    s.set_state(state);
    s.set_frontseat_state(fs);
    s.set_helm_state(helm);
    s.set_helm_error(helm_error);
    s.set_frontseat_error(fs_error);
    s
}

#[test]
fn status_text_is_goby_words_plus_frontseat_and_helm() {
    use FrontSeatError as F;
    use FrontSeatState as S;
    use HelmError as H;
    use HelmState as M;
    use InterfaceState as I;
    let rows = [
        (
            status(
                I::InterfaceStandby,
                S::FrontseatNotConnected,
                M::HelmNotRunning,
                H::ErrorHelmNone,
                F::ErrorFrontseatNone,
            ),
            "standby frontseat=not_connected helm=not_running",
        ),
        (
            status(
                I::InterfaceListen,
                S::FrontseatInControl,
                M::HelmDrive,
                H::ErrorHelmNone,
                F::ErrorFrontseatNone,
            ),
            "running:listen frontseat=in_control helm=drive",
        ),
        (
            status(
                I::InterfaceCommand,
                S::FrontseatAcceptingCommands,
                M::HelmDrive,
                H::ErrorHelmNone,
                F::ErrorFrontseatNone,
            ),
            "running:command frontseat=accepting_commands helm=drive",
        ),
        (
            status(
                I::InterfaceHelmError,
                S::FrontseatIdle,
                M::HelmPark,
                H::ErrorHelmParked,
                F::ErrorFrontseatNone,
            ),
            "error:helm frontseat=idle helm=park error=helm_parked",
        ),
        (
            status(
                I::InterfaceFsError,
                S::FrontseatNotConnected,
                M::HelmDrive,
                H::ErrorHelmNone,
                F::ErrorFrontseatNotConnected,
            ),
            "error:fs frontseat=not_connected helm=drive error=frontseat_not_connected",
        ),
    ];
    for (s, want) in rows {
        assert_eq!(status_text(&s), want);
    }
}

#[test]
fn translation_status_text_names_link_helm_and_staleness() {
    use frontseat_actors::proto::frontseat::protobuf::TranslationStatus;
    let up = TranslationStatus {
        moos_connected: Some(true),
        helm_state: Some(HelmState::HelmDrive as i32),
        helm_driving: Some(true),
        seconds_since_desired: Some(0.2),
        desired_stale: Some(false),
        reconnects: Some(0),
    };
    assert_eq!(
        systemd::translation_status_text(&up),
        "moos:connected helm=drive"
    );
    let down = TranslationStatus {
        moos_connected: Some(false),
        helm_state: Some(HelmState::HelmNotRunning as i32),
        helm_driving: Some(false),
        seconds_since_desired: None,
        desired_stale: Some(true),
        reconnects: Some(2),
    };
    assert_eq!(
        systemd::translation_status_text(&down),
        "moos:disconnected helm=not_running desired=stale reconnects=2"
    );
    assert_eq!(
        systemd::translation_status_text(&TranslationStatus::default()),
        "moos:disconnected helm=not_running",
        "an empty status reads as not connected"
    );
}

#[tokio::test]
async fn translation_reporter_sends_each_change_once() {
    use frontseat_actors::proto::frontseat::protobuf::TranslationStatus;
    let bus = Bus::new();
    let (n, mut rx) = Notifier::recording(None);
    let _task = systemd::spawn_translation_reporter(Arc::new(n), &bus);
    let mk = |connected: bool, age: f64| TranslationStatus {
        moos_connected: Some(connected),
        seconds_since_desired: Some(age),
        ..Default::default()
    };
    // The ticking age alone is no change worth a STATUS.
    for (c, age) in [(false, 0.0), (false, 1.0), (true, 2.0), (true, 3.0)] {
        bus.publish(&groups::FRONTSEAT_TRANSLATION_STATUS, mk(c, age));
    }
    for want in [
        "STATUS=moos:disconnected helm=not_running\n",
        "STATUS=moos:connected helm=not_running\n",
    ] {
        let got = tokio::time::timeout(Duration::from_secs(5), rx.recv())
            .await
            .expect("a STATUS in time")
            .unwrap();
        assert_eq!(got, want);
    }
    drop(bus);
    // The reporter ends with the bus, after which nothing more may have been sent.
    assert!(
        tokio::time::timeout(Duration::from_secs(5), rx.recv())
            .await
            .expect("the channel closes with the reporter")
            .is_none(),
        "repeats are not reported"
    );
}

#[test]
fn notifier_messages_are_sd_notify_lines_and_status_stays_one_line() {
    let (n, mut rx) = Notifier::recording(Some(Duration::from_secs(4)));
    assert!(n.enabled());
    assert_eq!(n.watchdog_period(), Some(Duration::from_secs(2)));
    n.ready();
    n.status("two\nlines");
    n.watchdog();
    n.stopping();
    let got: Vec<String> = std::iter::from_fn(|| rx.try_recv().ok()).collect();
    assert_eq!(
        got,
        [
            "READY=1\n",
            "STATUS=two lines\n",
            "WATCHDOG=1\n",
            "STOPPING=1\n"
        ]
    );
}

#[test]
fn notifier_is_off_without_notify_socket() {
    if std::env::var_os("NOTIFY_SOCKET").is_some() {
        eprintln!("note: NOTIFY_SOCKET is set for the test itself; skipped");
        return;
    }
    let n = Notifier::from_env();
    assert!(!n.enabled());
    assert_eq!(n.watchdog_period(), None, "no watchdog outside systemd");
    // Sending is a no-op, not an error.
    n.ready();
    n.stopping();
}

#[tokio::test(start_paused = true)]
async fn watchdog_pings_every_half_period_only_while_alive() {
    let usec = Duration::from_millis(1000);
    let p = usec / 2;
    let (n, mut rx) = Notifier::recording(Some(usec));
    let alive = Arc::new(AtomicBool::new(true));
    let a = alive.clone();
    let task = spawn_watchdog(Arc::new(n), move || {
        let a = a.clone();
        async move { a.load(Ordering::SeqCst) }
    })
    .expect("a watchdog when WATCHDOG_USEC is given");
    let mut count = || {
        let mut c = 0;
        while let Ok(m) = rx.try_recv() {
            assert_eq!(m, "WATCHDOG=1\n");
            c += 1;
        }
        c
    };
    // Ticks at 0, p, 2p.
    tokio::time::sleep(p * 2 + p / 2).await;
    assert_eq!(count(), 3);
    alive.store(false, Ordering::SeqCst);
    tokio::time::sleep(p * 3).await;
    assert_eq!(count(), 0, "no ping while an actor does not answer");
    alive.store(true, Ordering::SeqCst);
    tokio::time::sleep(p * 2).await;
    assert_eq!(count(), 2, "pings resume once it answers again");
    task.abort();
}

#[tokio::test(start_paused = true)]
async fn watchdog_probe_that_never_answers_withholds_pings_and_does_not_stall() {
    let (n, mut rx) = Notifier::recording(Some(Duration::from_millis(200)));
    let calls = Arc::new(std::sync::atomic::AtomicU32::new(0));
    let c = calls.clone();
    let task = spawn_watchdog(Arc::new(n), move || {
        c.fetch_add(1, Ordering::SeqCst);
        std::future::pending::<bool>()
    })
    .unwrap();
    tokio::time::sleep(Duration::from_millis(1050)).await;
    assert!(rx.try_recv().is_err(), "no ping from a probe that hangs");
    assert!(
        calls.load(Ordering::SeqCst) >= 4,
        "the probe is retried each period, not awaited forever"
    );
    task.abort();
}

#[test]
fn no_watchdog_task_without_watchdog_usec() {
    let (n, _rx) = Notifier::recording(None);
    assert_eq!(n.watchdog_period(), None);
    assert!(spawn_watchdog(Arc::new(n), || async { true }).is_none());
}

#[tokio::test]
async fn status_reporter_sends_each_change_once() {
    let bus = Bus::new();
    let (n, mut rx) = Notifier::recording(None);
    let task = spawn_status_reporter(Arc::new(n), &bus);
    // Built afresh each time: the generated message may or may not be Copy.
    let mk = |state| {
        status(
            state,
            FrontSeatState::FrontseatNotConnected,
            HelmState::HelmNotRunning,
            HelmError::ErrorHelmNone,
            FrontSeatError::ErrorFrontseatNone,
        )
    };
    let (a, b) = (
        InterfaceState::InterfaceStandby,
        InterfaceState::InterfaceListen,
    );
    for state in [a, a, b, b] {
        bus.publish(&groups::GOBY_MIDDLEWARE_FRONTSEAT_STATUS, mk(state));
    }
    let mut next = async || {
        tokio::time::timeout(Duration::from_secs(5), rx.recv())
            .await
            .expect("a STATUS in time")
            .unwrap()
    };
    assert_eq!(next().await, format!("STATUS={}\n", status_text(&mk(a))));
    assert_eq!(next().await, format!("STATUS={}\n", status_text(&mk(b))));
    drop(bus);
    tokio::time::timeout(Duration::from_secs(5), task)
        .await
        .expect("the reporter ends with the bus")
        .unwrap();
    assert!(rx.try_recv().is_err(), "repeats are not reported");
}

/// Receives from the recording notifier until `pred` matches; panics with what came on timeout.
async fn until(
    rx: &mut tokio::sync::mpsc::UnboundedReceiver<String>,
    seen: &mut Vec<String>,
    within: Duration,
    pred: impl Fn(&str) -> bool,
) -> String {
    let deadline = tokio::time::Instant::now() + within;
    loop {
        match tokio::time::timeout_at(deadline, rx.recv()).await {
            Ok(Some(m)) => {
                seen.push(m.clone());
                if pred(&m) {
                    return m;
                }
            }
            _ => panic!("timed out; seen: {seen:?}"),
        }
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn hung_interface_actor_stops_the_watchdog() {
    let sim = start_sim().await;
    let bus = Bus::new();
    let usec = Duration::from_millis(400);
    let (n, mut rx) = Notifier::recording(Some(usec));
    let n = Arc::new(n);
    let period = n.watchdog_period().unwrap();
    let _reporter = spawn_status_reporter(n.clone(), &bus);
    let mut cfg = config_for(&sim, common::WARP);
    cfg.require_helm = false;
    // Periodic status: the actor publishes it from its own handler, where the hang is planted.
    cfg.status_period = 1.0;
    let service = InterfaceService::start(&cfg, &bus, frontseat_drivers::BUILT_IN)
        .await
        .unwrap();
    n.ready();
    let current = systemd::InterfaceRef::default();
    *current.lock().unwrap() = Some(service.actor().clone());
    let wd = spawn_watchdog(n.clone(), systemd::interface_probe(current, period)).unwrap();

    let mut seen = Vec::new();
    until(&mut rx, &mut seen, Duration::from_secs(20), |m| {
        m.starts_with("STATUS=running:command")
    })
    .await;
    for _ in 0..3 {
        until(&mut rx, &mut seen, Duration::from_secs(5), |m| {
            m == "WATCHDOG=1\n"
        })
        .await;
    }

    // A subscriber whose delivery blocks: the interface actor hangs inside its next publish.
    let armed = Arc::new(AtomicBool::new(true));
    let (entered_tx, mut entered_rx) = tokio::sync::mpsc::unbounded_channel::<()>();
    let (release_tx, release_rx) = std::sync::mpsc::channel::<()>();
    let release_rx = Mutex::new(release_rx);
    let arm = armed.clone();
    let _hang = bus.subscribe(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_STATUS,
        "hang",
        16,
        move |_env| {
            if arm.swap(false, Ordering::SeqCst) {
                let _ = entered_tx.send(());
                // Bounded, so a failing test cannot hang the suite.
                let _ = release_rx
                    .lock()
                    .unwrap()
                    .recv_timeout(Duration::from_secs(30));
            }
            Ok(())
        },
    );
    tokio::time::timeout(Duration::from_secs(10), entered_rx.recv())
        .await
        .expect("the interface publishes a periodic status")
        .unwrap();
    let hung_at = tokio::time::Instant::now();
    // A ping whose probe was answered just before the hang may still arrive within one period;
    // none may after that, for several periods.
    let quiet_from = hung_at + period;
    let quiet_until = hung_at + period * 5;
    loop {
        match tokio::time::timeout_at(quiet_until, rx.recv()).await {
            Ok(Some(m)) => {
                assert!(
                    !(m == "WATCHDOG=1\n" && tokio::time::Instant::now() >= quiet_from),
                    "WATCHDOG=1 sent while the interface actor hangs"
                );
            }
            Ok(None) => panic!("notifier channel closed"),
            Err(_) => break,
        }
    }
    let snap = service.snapshot(period).await;
    assert!(snap.is_none(), "the actor really is hung");

    // Released, the actor answers again and the pings resume.
    release_tx.send(()).unwrap();
    until(&mut rx, &mut seen, Duration::from_secs(5), |m| {
        m == "WATCHDOG=1\n"
    })
    .await;
    wd.abort();
    n.stopping();
    assert_eq!(
        service.shutdown(Duration::from_secs(3)).await,
        frontseat_actors::interface::ServiceExit::Clean
    );
    sim.shutdown().await;
}

// ---------------------------------------------------------------------------------------------
// The real binary against a NOTIFY_SOCKET owned by the test

/// A sd_notify line and when it arrived.
type Received = (Instant, String);

/// Children killed on drop, so a failing assertion leaves no process behind.
struct Children(Vec<Child>);

impl Drop for Children {
    fn drop(&mut self) {
        for c in &mut self.0 {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// Drains a child's stderr into a shared log (for failure messages); sends each line to `lines`.
fn drain(
    stderr: std::process::ChildStderr,
    log: Arc<Mutex<String>>,
    lines: std::sync::mpsc::Sender<String>,
) {
    std::thread::spawn(move || {
        for line in BufReader::new(stderr).lines() {
            let Ok(line) = line else { break };
            log.lock().unwrap().push_str(&line);
            log.lock().unwrap().push('\n');
            let _ = lines.send(line);
        }
    });
}

#[test]
fn binary_speaks_sd_notify_ready_status_watchdog_stopping() {
    let dir = TempDir::new("notify");
    let sim_log = Arc::new(Mutex::new(String::new()));
    let fsi_log = Arc::new(Mutex::new(String::new()));
    let mut children = Children(Vec::new());

    // The simulator hands control to the vehicle (AUV) and back (PAYLOAD), in sim time.
    let sim_cfg = dir.0.join("sim.toml");
    std::fs::write(
        &sim_cfg,
        "[[faults]]\nat = 30.0\nkind = \"ctrl_auv\"\n\n[[faults]]\nat = 60.0\nkind = \"ctrl_payload\"\n",
    )
    .unwrap();
    let mut sim = Command::new(BIN)
        .args(["sim", "--port", "0", "--bind", "127.0.0.1", "-c"])
        .arg(&sim_cfg)
        .env("RUST_LOG", "info")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let (tx, sim_lines) = std::sync::mpsc::channel();
    drain(sim.stderr.take().unwrap(), sim_log.clone(), tx);
    children.0.push(sim);
    let deadline = Instant::now() + Duration::from_secs(20);
    let port: u16 = loop {
        let line = sim_lines
            .recv_timeout(deadline.saturating_duration_since(Instant::now()))
            .unwrap_or_else(|_| panic!("sim did not listen:\n{}", sim_log.lock().unwrap()));
        if let Some(addr) = line.split("listening addr=").nth(1) {
            break addr.trim().rsplit(':').next().unwrap().parse().unwrap();
        }
    };

    let cfg = dir.0.join("interface.toml");
    std::fs::write(
        &cfg,
        format!(
            "name = \"deploy-test\"\nrequire_helm = false\nsim_warp_factor = 10.0\nstatus_period = 0.0\n\
             [driver.basic_simulator]\ntcp_address = \"127.0.0.1\"\ntcp_port = {port}\n"
        ),
    )
    .unwrap();
    let sock_path = dir.0.join("notify.sock");
    let sock = UnixDatagram::bind(&sock_path).unwrap();
    sock.set_read_timeout(Some(Duration::from_millis(100)))
        .unwrap();
    let watchdog_usec = Duration::from_secs(2);
    let mut fsi = Command::new(BIN)
        .args(["interface", "-c"])
        .arg(&cfg)
        .env("NOTIFY_SOCKET", &sock_path)
        .env("WATCHDOG_USEC", watchdog_usec.as_micros().to_string())
        .env_remove("WATCHDOG_PID")
        .env("RUST_LOG", "info")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let pid = fsi.id();
    let (tx, _fsi_lines) = std::sync::mpsc::channel();
    drain(fsi.stderr.take().unwrap(), fsi_log.clone(), tx);
    children.0.push(fsi);

    // (received at, message line)
    let mut got: Vec<Received> = Vec::new();
    let recv_until = |got: &mut Vec<Received>,
                      within: Duration,
                      what: &str,
                      pred: &dyn Fn(&[Received]) -> bool| {
        let deadline = Instant::now() + within;
        let mut buf = [0u8; 4096];
        while !pred(got) {
            assert!(
                Instant::now() < deadline,
                "timed out waiting for {what}; got {:?}\ninterface log:\n{}",
                got.iter().map(|(_, m)| m).collect::<Vec<_>>(),
                fsi_log.lock().unwrap()
            );
            if let Ok(n) = sock.recv(&mut buf) {
                let now = Instant::now();
                for line in String::from_utf8_lossy(&buf[..n]).lines() {
                    got.push((now, line.to_string()));
                }
            }
        }
    };
    let states = |got: &[Received]| -> Vec<String> {
        let mut v: Vec<String> = Vec::new();
        for (_, m) in got {
            if let Some(s) = m.strip_prefix("STATUS=") {
                let w = s.split(' ').next().unwrap().to_string();
                if v.last() != Some(&w) {
                    v.push(w);
                }
            }
        }
        v
    };
    let want = [
        "standby",
        "running:listen",
        "running:command",
        "running:listen",
        "running:command",
    ];
    recv_until(
        &mut got,
        Duration::from_secs(40),
        "PAYLOAD → AUV → PAYLOAD",
        &|g| states(g).len() >= want.len(),
    );
    assert_eq!(states(&got), want, "STATUS= sequence");
    let listen_in_control = got
        .iter()
        .filter_map(|(_, m)| m.strip_prefix("STATUS=running:listen"))
        .any(|rest| rest.contains("frontseat=in_control"));
    assert!(
        listen_in_control,
        "the AUV phase shows frontseat=in_control: {got:?}"
    );
    let ready: Vec<usize> = got
        .iter()
        .enumerate()
        .filter(|(_, (_, m))| m == "READY=1")
        .map(|(i, _)| i)
        .collect();
    assert_eq!(ready.len(), 1, "READY=1 exactly once");

    // Periodic WATCHDOG=1: several, and never a gap systemd would punish.
    recv_until(
        &mut got,
        Duration::from_secs(10),
        "3 watchdog pings",
        &|g| g.iter().filter(|(_, m)| m == "WATCHDOG=1").count() >= 3,
    );
    let pings: Vec<Instant> = got
        .iter()
        .filter(|(_, m)| m == "WATCHDOG=1")
        .map(|(t, _)| *t)
        .collect();
    let first_ping = got.iter().position(|(_, m)| m == "WATCHDOG=1").unwrap();
    assert!(ready[0] < first_ping, "READY=1 before the first WATCHDOG=1");
    for w in pings.windows(2) {
        assert!(
            w[1] - w[0] < watchdog_usec,
            "watchdog gap {:?} ≥ WATCHDOG_USEC",
            w[1] - w[0]
        );
    }

    // SIGTERM: STOPPING=1, then exit 0 within the shutdown bound.
    let status = Command::new("kill")
        .args(["-TERM", &pid.to_string()])
        .status()
        .unwrap();
    assert!(status.success());
    let sent_at = Instant::now();
    recv_until(&mut got, Duration::from_secs(5), "STOPPING=1", &|g| {
        g.iter().any(|(_, m)| m == "STOPPING=1")
    });
    let fsi = children.0.last_mut().unwrap();
    let code = loop {
        if let Some(s) = fsi.try_wait().unwrap() {
            break s;
        }
        assert!(
            sent_at.elapsed() < Duration::from_secs(8),
            "no exit within the shutdown bound\n{}",
            fsi_log.lock().unwrap()
        );
        std::thread::sleep(Duration::from_millis(20));
    };
    assert_eq!(
        code.code(),
        Some(0),
        "exit code after SIGTERM\n{}",
        fsi_log.lock().unwrap()
    );
    // journald gets plain lines: no colour codes when stderr is not a terminal.
    assert!(
        !fsi_log.lock().unwrap().contains('\x1b') && !sim_log.lock().unwrap().contains('\x1b'),
        "ANSI escape codes in the logs"
    );
}

#[test]
fn sim_binary_notifies_ready_status_watchdog_and_stopping() {
    let dir = TempDir::new("notify-sim");
    let log = Arc::new(Mutex::new(String::new()));
    let sock_path = dir.0.join("notify.sock");
    let sock = UnixDatagram::bind(&sock_path).unwrap();
    sock.set_read_timeout(Some(Duration::from_millis(100)))
        .unwrap();
    let mut sim = Command::new(BIN)
        .args(["sim", "--port", "0", "--bind", "127.0.0.1"])
        .env("NOTIFY_SOCKET", &sock_path)
        .env("WATCHDOG_USEC", "400000")
        .env_remove("WATCHDOG_PID")
        .env("RUST_LOG", "info")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let pid = sim.id();
    let (tx, _lines) = std::sync::mpsc::channel();
    drain(sim.stderr.take().unwrap(), log.clone(), tx);
    let mut children = Children(vec![sim]);

    let mut got: Vec<String> = Vec::new();
    let until = |got: &mut Vec<String>, what: &str, pred: &dyn Fn(&[String]) -> bool| {
        let deadline = Instant::now() + Duration::from_secs(20);
        let mut buf = [0u8; 4096];
        while !pred(got) {
            assert!(
                Instant::now() < deadline,
                "timed out waiting for {what}; got {got:?}\nlog:\n{}",
                log.lock().unwrap()
            );
            if let Ok(n) = sock.recv(&mut buf) {
                got.extend(String::from_utf8_lossy(&buf[..n]).lines().map(String::from));
            }
        }
    };
    until(&mut got, "READY=1 and 3 pings", &|g| {
        g.iter().any(|m| m == "READY=1") && g.iter().filter(|m| *m == "WATCHDOG=1").count() >= 3
    });
    let listening = got
        .iter()
        .find_map(|m| m.strip_prefix("STATUS=listening on "))
        .unwrap_or_else(|| panic!("no listening STATUS: {got:?}"))
        .to_string();
    assert!(
        log.lock().unwrap().contains(&format!("addr={listening}")),
        "STATUS names the bound address {listening}"
    );
    assert!(
        Command::new("kill")
            .args(["-TERM", &pid.to_string()])
            .status()
            .unwrap()
            .success()
    );
    until(&mut got, "STOPPING=1", &|g| {
        g.iter().any(|m| m == "STOPPING=1")
    });
    let sent_at = Instant::now();
    let sim = &mut children.0[0];
    let code = loop {
        if let Some(s) = sim.try_wait().unwrap() {
            break s;
        }
        assert!(
            sent_at.elapsed() < Duration::from_secs(8),
            "sim did not exit"
        );
        std::thread::sleep(Duration::from_millis(20));
    };
    assert_eq!(code.code(), Some(0), "{}", log.lock().unwrap());
    assert!(
        !log.lock().unwrap().contains('\x1b'),
        "ANSI escape codes in the log"
    );
}
