//! The errors a newcomer meets first say what to do: a service started without its config points
//! at `--example_config`; a simulator port already taken names the port and the setting; a config
//! from an older version names where the field lives now; a serial port the process may not open
//! names the `dialout` group. Real processes, real sockets on loopback, a real open(2) refused.

use std::process::{Command, Stdio};

const BIN: &str = env!("CARGO_BIN_EXE_frontseat");

fn run(args: &[&str], dir: &std::path::Path) -> (Option<i32>, String) {
    let out = Command::new(BIN)
        .args(args)
        .current_dir(dir)
        .env("NO_COLOR", "1")
        .stdin(Stdio::null())
        .output()
        .unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn temp(what: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("frontseat-newcomer-{what}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn a_service_without_its_config_points_at_the_example() {
    let dir = temp("noconfig");
    for service in ["interface", "moos-gateway", "topside"] {
        let (code, err) = run(&[service], &dir);
        assert_eq!(code, Some(2), "{service}: {err}");
        assert!(
            err.contains("a config file is required"),
            "{service}: {err}"
        );
        let example = format!("frontseat {service} --example_config > {service}.toml");
        assert!(err.contains(&example), "{service}: {err}");
        // What it says to run works as said.
        let out = Command::new("sh")
            .arg("-c")
            .arg(format!("{BIN} {service} --example_config > {service}.toml"))
            .current_dir(&dir)
            .status()
            .unwrap();
        assert!(out.success());
        let (code, err) = run(
            &[service, "--check", "-c", &format!("{service}.toml")],
            &dir,
        );
        assert_eq!(code, Some(0), "{service} --check of the example: {err}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_simulator_port_in_use_names_the_port_and_the_setting() {
    let dir = temp("port");
    let taken = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = taken.local_addr().unwrap().port().to_string();
    let (code, err) = run(&["sim", "--port", &port], &dir);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains(&format!("port {port} is already in use")),
        "{err}"
    );
    assert!(
        err.contains("`port` in the sim config or `--port`"),
        "{err}"
    );
    assert!(err.contains("`[driver.basic_simulator] tcp_port`"), "{err}");
    drop(taken);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_config_from_an_older_version_names_where_the_field_moved() {
    let dir = temp("moved");
    std::fs::write(
        dir.join("old.toml"),
        "name = \"auv1\"\n[driver]\nname = \"basic_simulator\"\ntcp_port = 54321\n",
    )
    .unwrap();
    let (code, err) = run(&["interface", "--check", "-c", "old.toml"], &dir);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("old.toml:4:1: unknown field `tcp_port`"),
        "{err}"
    );
    assert!(
        err.contains("This version has `tcp_port` at `driver.basic_simulator.tcp_port`"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_serial_port_without_permission_names_the_dialout_group() {
    use std::io::BufRead;
    use std::os::unix::fs::PermissionsExt;
    let dir = temp("serial");
    // A device node nobody may open: mode 000. Root (CI) is refused it only without the
    // capabilities that bypass file permissions, so the interface runs without them.
    let port = dir.join("ttyUSB-denied");
    std::fs::write(&port, b"").unwrap();
    std::fs::set_permissions(&port, std::fs::Permissions::from_mode(0o000)).unwrap();
    let cfg = dir.join("iver.toml");
    std::fs::write(
        &cfg,
        format!(
            "name = \"auv1\"\n[driver]\nname = \"iver3\"\n[driver.iver3]\nserial_port = \"{}\"\nremote_helm_version_major = 5\n",
            port.display()
        ),
    )
    .unwrap();
    let is_root = std::fs::metadata("/proc/self").map(|m| {
        use std::os::unix::fs::MetadataExt;
        m.uid() == 0
    });
    let mut cmd = if is_root.unwrap_or(false) {
        let mut c = Command::new("setpriv");
        c.args(["--bounding-set", "-dac_override,-dac_read_search", "--"])
            .arg(BIN);
        c
    } else {
        Command::new(BIN)
    };
    let mut child = cmd
        .args(["interface", "-c"])
        .arg(&cfg)
        .env("RUST_LOG", "warn")
        .env("NO_COLOR", "1")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("setpriv (util-linux) and the binary");
    let stderr = child.stderr.take().unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in std::io::BufReader::new(stderr)
            .lines()
            .map_while(Result::ok)
        {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(30);
    let mut hint = None;
    while let Some(left) = deadline.checked_duration_since(std::time::Instant::now()) {
        match rx.recv_timeout(left) {
            Ok(line) if line.contains("permission denied") => {
                hint = Some(line);
                break;
            }
            Ok(_) => {}
            Err(_) => break,
        }
    }
    let _ = child.kill();
    let _ = child.wait();
    let _ = std::fs::remove_dir_all(&dir);
    let hint = hint.expect("no WARN about the refused serial port within 30 s");
    assert!(hint.contains("WARN"), "{hint}");
    assert!(hint.contains(&port.display().to_string()), "{hint}");
    assert!(hint.contains("`dialout` group"), "{hint}");
    assert!(hint.contains("usermod -aG dialout"), "{hint}");
}
