//! Deployment under systemd, the files: the unit files pass `systemd-analyze verify`, the
//! example configs pass `--check`, and install.sh/uninstall.sh work in a staging directory. How
//! the running services speak sd_notify is `sd_notify.rs` beside this file: one test binary for
//! both, so the split costs no extra link of the whole workspace.

#[path = "../common/mod.rs"]
mod common;
mod sd_notify;

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::Command;

use common::temp_dir::TempDir;

const BIN: &str = env!("CARGO_BIN_EXE_frontseat");
const UNITS: [&str; 3] = [
    "frontseat-interface.service",
    "frontseat-sim.service",
    "frontseat-moos-gateway.service",
];

fn deploy_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("deploy")
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
