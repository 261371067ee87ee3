//! Serial ports that vanish come back (issue 46, item 3), for the Iver3, the Wave Glider SV2 and
//! the ArduPilot serial link: the real `frontseat interface` binary, run as an unprivileged user,
//! is configured with a stable udev-style name (`…/serial/by-id/usb-…-if00-port0`, a symlink)
//! to a real pseudo-terminal whose far end is the vehicle's emulator. The cable is knocked: the
//! pty is closed (its `/dev/pts/N` disappears) and the symlink removed, as udev does. The vehicle
//! (its emulator session) keeps running; the adapter comes back as a different tty behind the same
//! name, and the interface climbs back to `running:command` by itself. Then it comes back owned by
//! root with mode 0600 (udev has not given it to the `dialout` group yet): the open fails with
//! EACCES until the mode is fixed, and the interface climbs back again.
//!
//! Each open error is logged once per outage and kind of error, with the configured path (the
//! permission one with what to do), and the reopen line says how many opens failed in between:
//! the rate limit and the counter, read from the child's own log.
//!
//! Why a child under `setpriv`: tests and CI run as root, and root opens any device whatever its
//! mode (CAP_DAC_OVERRIDE), so an in-process interface would never see EACCES. `setpriv
//! --reuid=65534 --regid=65534 --clear-groups --inh-caps=-all` (util-linux, in every Debian base
//! system) execs the interface as `nobody` with no groups; a change of every uid away from 0 clears
//! its effective and permitted capabilities, and `--inh-caps=-all` the inheritable ones, so the
//! kernel applies the device's mode bits to it exactly as to a service user (systemd's `User=`):
//! same namespaces, no capabilities, no groups. A user namespace without mapped ids would also
//! deny the open (capabilities in it do not cover files of unmapped owners), but creating one is
//! refused in many containers (Docker's default seccomp profile blocks `unshare(CLONE_NEWUSER)`
//! without CAP_SYS_ADMIN; some kernels disable unprivileged user namespaces), and it models no
//! deployment. The set-up is checked first (a root-only file must not open); the test fails,
//! never skips, when it cannot be made.
//!
//! Each test prints the wall time from the device's return (the symlink swapped to a tty we can
//! open) to the child's `to="running:command"` line, and from the mode fix to the same. That is
//! a figure, not an assertion. `measure_return_with_default_backoff` (ignored: it takes minutes)
//! measures the same with the default backoff (100 ms doubling to 5 s) after absences of 1.5 to
//! 28 s: `cargo test --test serial_return -- --ignored --nocapture measure`.

mod common;

use std::io::{BufRead, BufReader};
use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use frontseat_ardupilot::dialect::{COMMAND_LONG_DATA, MavCmd, MavMessage};
use frontseat_ardupilot::emulator::{RoverOptions, RoverSession};
use frontseat_iver3::{IverOptions, IverSession};
use frontseat_sim::emulator::{Emulator, Endpoint, Session};
use frontseat_waveglider_sv2::{Sv2Options, Sv2Session};
use tokio::sync::mpsc::{UnboundedReceiver, unbounded_channel};

/// Bound of every wait for the child (a debug build on a loaded 2-core machine).
const LONG: Duration = Duration::from_secs(60);
const WARP: f64 = 10.0;
/// `nobody` on Debian.
const NOBODY: &str = "65534";

/// One emulator session shared by successive emulators: the vehicle keeps running while its
/// USB adapter is unplugged and plugged back; only the tty changes. Only the emulator whose id is
/// `live` drives the session: the next device's emulator exists (its tty allocated) before it is
/// plugged in, and is inert until then.
struct Shared<S> {
    session: Arc<Mutex<S>>,
    id: u64,
    live: Arc<AtomicU64>,
}

impl<S: Session> Shared<S> {
    fn is_live(&self) -> bool {
        self.live.load(Ordering::Acquire) == self.id
    }
}

impl<S: Session> Session for Shared<S> {
    fn on_bytes(&mut self, bytes: &[u8], out: &mut Vec<u8>) {
        if self.is_live() {
            lock(&self.session).on_bytes(bytes, out);
        }
    }
    fn step(&mut self, dt: f64, out: &mut Vec<u8>) {
        if self.is_live() {
            lock(&self.session).step(dt, out);
        }
    }
    fn reset_input(&mut self) {
        if self.is_live() {
            lock(&self.session).reset_input();
        }
    }
}

fn lock<S>(m: &Mutex<S>) -> std::sync::MutexGuard<'_, S> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// The vehicle's end of the cable and the udev name of the backseat's end.
struct Cable<S: Session> {
    session: Arc<Mutex<S>>,
    live: Arc<AtomicU64>,
    ids: u64,
    emu: Option<Emulator<Shared<S>>>,
    /// The device that will appear at the next plug-in, made while the current one still held
    /// its tty, so it is another tty (as a USB adapter often comes back: ttyUSB0 → ttyUSB1).
    next: Option<Emulator<Shared<S>>>,
    /// `…/serial/by-id/usb-…`: what the interface is configured with.
    by_id: PathBuf,
}

impl<S: Session> Cable<S> {
    fn new(session: S, dir: &Path) -> Self {
        let by_id_dir = dir.join("serial/by-id");
        std::fs::create_dir_all(&by_id_dir).unwrap();
        for d in [dir, &dir.join("serial"), &by_id_dir] {
            std::fs::set_permissions(d, std::fs::Permissions::from_mode(0o755)).unwrap();
        }
        Self {
            session: Arc::new(Mutex::new(session)),
            live: Arc::new(AtomicU64::new(0)),
            ids: 0,
            emu: None,
            next: None,
            by_id: by_id_dir.join("usb-FTDI_FT232R_USB_UART_A50285BI-if00-port0"),
        }
    }

    async fn make_next(&mut self) {
        self.ids += 1;
        let shared = Shared {
            session: self.session.clone(),
            id: self.ids,
            live: self.live.clone(),
        };
        let emu = Emulator::start(shared, Endpoint::Pty, WARP)
            .await
            .expect("a pseudo-terminal for the emulator");
        self.next = Some(emu);
    }

    /// Plugged in: the next tty, `mode` on its node, its emulator live, the stable name swapped
    /// to it (a new symlink renamed over the name, as udev does). Returns the tty's path.
    async fn plug(&mut self, mode: u32) -> PathBuf {
        if self.next.is_none() {
            self.make_next().await;
        }
        let emu = self.next.take().expect("made above");
        let tty = emu.pty_path().expect("a pty emulator").to_path_buf();
        std::fs::set_permissions(&tty, std::fs::Permissions::from_mode(mode)).unwrap();
        lock(&self.session).reset_input();
        self.live.store(self.ids, Ordering::Release);
        let tmp = self.by_id.with_extension("new");
        let _ = std::fs::remove_file(&tmp);
        std::os::unix::fs::symlink(&tty, &tmp).unwrap();
        std::fs::rename(&tmp, &self.by_id).unwrap();
        self.emu = Some(emu);
        tty
    }

    /// Unplugged: udev removes the stable name and the tty goes away (its node with it).
    async fn unplug(&mut self) -> PathBuf {
        let emu = self.emu.take().expect("plugged in");
        let tty = emu.pty_path().expect("a pty emulator").to_path_buf();
        // The name first, so a reopen between the two finds nothing rather than a dying tty.
        std::fs::remove_file(&self.by_id).unwrap();
        self.live.store(0, Ordering::Release);
        self.make_next().await;
        drop(emu);
        // The emulator's task closes the master when the runtime drops it: wait for the node.
        let deadline = tokio::time::Instant::now() + LONG;
        while tty.exists() {
            assert!(
                tokio::time::Instant::now() < deadline,
                "{} still there after its master closed",
                tty.display()
            );
            tokio::time::sleep(Duration::from_millis(10)).await;
        }
        tty
    }
}

/// Makes `path` openable by the interface (udev's `GROUP="dialout"`/`MODE`, done late).
fn allow(path: &Path) {
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o666)).unwrap();
}

/// How to run `frontseat` as `nobody`: setpriv, its arguments, then the binary (this build's, or a
/// copy when `nobody` cannot reach the build directory), after checking that `setpriv` really
/// drops every privilege here. Panics (the test fails) when it cannot.
fn unprivileged_prefix(scratch: &Path) -> Vec<String> {
    let setpriv = ["/usr/bin/setpriv", "/bin/setpriv"]
        .into_iter()
        .find(|p| Path::new(p).exists())
        .expect(
            "setpriv (util-linux) is needed to run the interface as an unprivileged user; \
             install util-linux",
        );
    let prefix: Vec<String> = [
        setpriv,
        "--reuid",
        NOBODY,
        "--regid",
        NOBODY,
        "--clear-groups",
        "--inh-caps=-all",
        "--",
    ]
    .into_iter()
    .map(String::from)
    .collect();
    // A root-only file must not open for the child, or EACCES cannot be tested.
    let secret = scratch.join("root-only");
    std::fs::write(&secret, b"x").unwrap();
    std::fs::set_permissions(&secret, std::fs::Permissions::from_mode(0o600)).unwrap();
    let probe = Command::new(&prefix[0])
        .args(&prefix[1..])
        .args(["/bin/sh", "-c", "exec 3< \"$0\"", &secret.to_string_lossy()])
        .output()
        .expect("running setpriv");
    assert!(
        !probe.status.success(),
        "setpriv --reuid={NOBODY} still opened a root-only 0600 file: the child would not see EACCES"
    );
    let stderr = String::from_utf8_lossy(&probe.stderr);
    assert!(
        stderr.contains("ermission denied"),
        "the unprivileged probe failed for another reason: {stderr}"
    );
    let runs = |exe: &Path| {
        Command::new(&prefix[0])
            .args(&prefix[1..])
            .arg(exe)
            .arg("--version")
            .output()
            .expect("running setpriv")
    };
    let built = PathBuf::from(env!("CARGO_BIN_EXE_frontseat"));
    let exe = if runs(&built).status.success() {
        built
    } else {
        // The build directory is out of its reach (a checkout under a 0700 home): a copy.
        let copy = scratch.join("frontseat");
        std::fs::copy(&built, &copy).expect("copying the binary for the unprivileged user");
        std::fs::set_permissions(&copy, std::fs::Permissions::from_mode(0o755)).unwrap();
        let out = runs(&copy);
        assert!(
            out.status.success(),
            "user {NOBODY} cannot run {} nor a copy of it: {}",
            built.display(),
            String::from_utf8_lossy(&out.stderr)
        );
        copy
    };
    let mut prefix = prefix;
    prefix.push(exe.to_string_lossy().into_owned());
    prefix
}

/// The interface child and every line it logged, with the instant it was read.
struct Interface {
    child: Child,
    rx: UnboundedReceiver<(Instant, String)>,
    log: Vec<String>,
}

impl Interface {
    fn spawn(prefix: &[String], config: &Path, home: &Path) -> Self {
        let mut child = Command::new(&prefix[0])
            .args(&prefix[1..])
            .args(["interface", "-c"])
            .arg(config)
            .env("RUST_LOG", "info")
            .env("HOME", home)
            .env("NO_COLOR", "1")
            .env_remove("OTEL_EXPORTER_OTLP_ENDPOINT")
            .env_remove("OTEL_EXPORTER_OTLP_TRACES_ENDPOINT")
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("spawning the interface under setpriv");
        let (tx, rx) = unbounded_channel();
        let stderr = child.stderr.take().expect("piped stderr");
        std::thread::spawn(move || {
            let mut rd = BufReader::new(stderr);
            let mut line = String::new();
            loop {
                line.clear();
                match rd.read_line(&mut line) {
                    Ok(0) | Err(_) => return,
                    Ok(_) => {
                        let _ = tx.send((Instant::now(), line.trim_end().to_string()));
                    }
                }
            }
        });
        Self {
            child,
            rx,
            log: Vec::new(),
        }
    }

    /// The instant the child logged a line for which `pred` holds (lines read since the last
    /// wait only).
    async fn wait_for(&mut self, what: &str, pred: impl Fn(&str) -> bool) -> Instant {
        let deadline = tokio::time::Instant::now() + LONG;
        loop {
            match tokio::time::timeout_at(deadline, self.rx.recv()).await {
                Ok(Some((t, line))) => {
                    let hit = pred(&line);
                    self.log.push(line);
                    if hit {
                        return t;
                    }
                }
                Ok(None) => panic!(
                    "the interface exited before {what}: {:?}\n{}",
                    self.child.try_wait(),
                    self.tail()
                ),
                Err(_) => panic!("no {what} within {LONG:?}:\n{}", self.tail()),
            }
        }
    }

    /// Waits for the link's reopen line, then for COMMAND after it: (failed opens the line
    /// counts, when COMMAND came).
    async fn reopened_then_command(&mut self, by_id: &str) -> (u64, Instant) {
        let reopened = self
            .wait_for("the reopen line", |l| {
                l.contains(&format!("serial port {by_id} open again after"))
            })
            .await;
        let n = self
            .log
            .last()
            .and_then(|l| failed_opens(l))
            .expect("the reopen line says how many opens failed");
        let at_command = self.until_command().await;
        assert!(at_command >= reopened);
        (n, at_command)
    }

    async fn until_command(&mut self) -> Instant {
        self.wait_for("to=\"running:command\"", |l| {
            l.contains("to=\"running:command\"")
        })
        .await
    }

    async fn until_out_of_command(&mut self) -> Instant {
        self.wait_for("from=\"running:command\"", |l| {
            l.contains("from=\"running:command\"")
        })
        .await
    }

    /// Lines logged so far that contain every one of `needles`.
    fn count(&mut self, needles: &[&str]) -> usize {
        while let Ok((_, l)) = self.rx.try_recv() {
            self.log.push(l);
        }
        self.log
            .iter()
            .filter(|l| needles.iter().all(|n| l.contains(n)))
            .count()
    }

    fn tail(&self) -> String {
        let n = self.log.len().saturating_sub(40);
        self.log[n..].join("\n")
    }
}

impl Drop for Interface {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// "… open again after N failed opens …" → N.
fn failed_opens(line: &str) -> Option<u64> {
    line.split("open again after ")
        .nth(1)?
        .split_whitespace()
        .next()?
        .parse()
        .ok()
}

/// The driver's part of the child's config, for the stable name `by_id`.
type DriverToml = fn(by_id: &Path, initial_ms: u64, max_ms: u64) -> String;

fn iver3_toml(by_id: &Path, initial_ms: u64, max_ms: u64) -> String {
    format!(
        "[driver]\nname = \"iver3\"\n\n[driver.iver3]\nserial_port = \"{}\"\n\
         remote_helm_version_major = 5\n\n[driver.iver3.link]\n\
         reconnect_initial_ms = {initial_ms}\nreconnect_max_ms = {max_ms}\n",
        by_id.display()
    )
}

fn sv2_toml(by_id: &Path, initial_ms: u64, max_ms: u64) -> String {
    format!(
        "[driver]\nname = \"waveglider_sv2\"\n\n[driver.waveglider_sv2]\npm_serial_port = \"{}\"\n\n\
         [driver.waveglider_sv2.link]\nreconnect_initial_ms = {initial_ms}\nreconnect_max_ms = {max_ms}\n",
        by_id.display()
    )
}

fn ardupilot_toml(by_id: &Path, initial_ms: u64, max_ms: u64) -> String {
    format!(
        "[driver]\nname = \"ardupilot\"\n\n[driver.ardupilot]\naddress = \"serial:{}:57600\"\n\
         reconnect_initial_ms = {initial_ms}\nreconnect_max_ms = {max_ms}\n",
        by_id.display()
    )
}

/// A Rover the pilot has armed in GUIDED from the ground station, as it is when its companion's
/// USB cable is knocked mid-mission: a new session stepped past its boot and EKF start.
fn rover_in_guided() -> RoverSession {
    let mut s = RoverSession::new(RoverOptions::default());
    let mut out = Vec::new();
    for _ in 0..100 {
        s.step(0.1, &mut out);
    }
    let gcs = |command, param1, param2| {
        frontseat_ardupilot::codec::encode(
            255,
            190,
            0,
            &MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
                command,
                param1,
                param2,
                target_system: 1,
                target_component: 1,
                ..Default::default()
            }),
        )
    };
    s.on_bytes(
        &gcs(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, 1.0, 0.0),
        &mut out,
    );
    s.on_bytes(
        &gcs(
            MavCmd::MAV_CMD_DO_SET_MODE,
            1.0,
            frontseat_ardupilot::modes::rover::GUIDED as f32,
        ),
        &mut out,
    );
    assert!(s.armed(), "the emulated Rover arms after boot");
    assert_eq!(s.mode(), frontseat_ardupilot::modes::rover::GUIDED);
    s
}

struct Scratch(PathBuf);

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn scratch(name: &str) -> Scratch {
    let d = std::env::temp_dir().join(format!(
        "frontseat-serial-return-{}-{name}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    // Whatever the umask: the unprivileged child reads its config here.
    std::fs::set_permissions(&d, std::fs::Permissions::from_mode(0o755)).unwrap();
    Scratch(d)
}

fn write_config(dir: &Path, name: &str, driver: String) -> PathBuf {
    let path = dir.join("interface.toml");
    std::fs::write(
        &path,
        format!(
            "# written by tests/serial_return.rs\nname = \"{name}\"\n\
             # no helm process here: COMMAND needs only the frontseat\nrequire_helm = false\n\
             sim_warp_factor = {WARP}\n\n{driver}"
        ),
    )
    .unwrap();
    std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o644)).unwrap();
    path
}

/// The whole story for one vehicle; returns (device back → COMMAND, mode fixed → COMMAND).
async fn comes_back<S: Session>(
    vehicle: &str,
    session: S,
    driver: DriverToml,
) -> (Duration, Duration) {
    let dir = scratch(vehicle);
    let prefix = unprivileged_prefix(&dir.0);
    let mut cable = Cable::new(session, &dir.0);
    let by_id = cable.by_id.clone();
    let by_id_s = by_id.to_string_lossy().into_owned();
    let config = write_config(&dir.0, vehicle, driver(&by_id, 20, 200));

    let first = cable.plug(0o666).await;
    let mut iface = Interface::spawn(&prefix, &config, &dir.0);
    iface.until_command().await;

    // Knocked out: gone, logged once with the configured name, retried.
    let gone = cable.unplug().await;
    assert!(!by_id.exists());
    iface.until_out_of_command().await;
    iface
        .wait_for("the open error with the path", |l| {
            l.contains(" WARN ") && l.contains(&format!("cannot open serial port {by_id_s}:"))
        })
        .await;
    // Away long enough for several reopen attempts at the 200 ms cap.
    tokio::time::sleep(Duration::from_millis(1500)).await;
    let second = cable.plug(0o666).await;
    assert_ne!(second, first, "the adapter comes back as another tty");
    let back = Instant::now();
    let (n, at_command) = iface.reopened_then_command(&by_id_s).await;
    assert!(n >= 2, "{n} failed opens while away for 1.5 s");
    assert_eq!(
        iface.count(&[" WARN ", &format!("serial port {by_id_s}")]),
        1,
        "{n} failed opens logged once:\n{}",
        iface.tail()
    );
    let back_to_command = at_command.saturating_duration_since(back);
    eprintln!("{vehicle}: {gone:?} gone, back as {second:?}");

    // Knocked out again; back as a tty of root's alone: EACCES, logged once with the hint, until
    // the mode is fixed.
    cable.unplug().await;
    iface.until_out_of_command().await;
    iface
        .wait_for("the open error of the second outage", |l| {
            l.contains(" WARN ")
                && l.contains(&format!("cannot open serial port {by_id_s}:"))
                && !l.contains("permission denied")
        })
        .await;
    let third = cable.plug(0o600).await;
    assert_ne!(third, second, "the adapter comes back as another tty");
    iface
        .wait_for("the permission error with the path and the hint", |l| {
            l.contains(" WARN ")
                && l.contains(&format!(
                    "cannot open serial port {by_id_s}: permission denied"
                ))
                && l.contains("dialout")
        })
        .await;
    tokio::time::sleep(Duration::from_millis(1500)).await;
    let before_fix = iface.count(&["to=\"running:command\""]);
    allow(&third);
    let fixed = Instant::now();
    let (n, at_command) = iface.reopened_then_command(&by_id_s).await;
    assert_eq!(before_fix, 2, "no COMMAND while the port was root's alone");
    assert!(n >= 2, "{n} failed opens while denied for 1.5 s");
    // Over the whole run: one WARN per outage for the missing device, one for the denial.
    assert_eq!(
        iface.count(&[" WARN ", &format!("serial port {by_id_s}")]),
        3,
        "each kind of open error logged once per outage:\n{}",
        iface.tail()
    );
    assert_eq!(
        iface.count(&[" WARN ", "permission denied", &by_id_s]),
        1,
        "{}",
        iface.tail()
    );
    let fix_to_command = at_command.saturating_duration_since(fixed);
    // What an operator reads about the port in the journal, for the test's output.
    for l in iface.log.iter().filter(|l| l.contains(&by_id_s)) {
        eprintln!("{vehicle} child: {l}");
    }
    eprintln!(
        "serial_return: {vehicle}: device back → running:command {:.0} ms; permission back → \
         running:command {:.0} ms (reconnect 20 ms doubling to 200 ms, warp {WARP})",
        back_to_command.as_secs_f64() * 1e3,
        fix_to_command.as_secs_f64() * 1e3
    );
    (back_to_command, fix_to_command)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn iver3_comes_back_behind_its_stable_name() {
    let session = IverSession::new(IverOptions {
        remote_helm_version_major: 5,
        ..Default::default()
    });
    comes_back("iver3", session, iver3_toml).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn waveglider_sv2_comes_back_behind_its_stable_name() {
    comes_back(
        "waveglider_sv2",
        Sv2Session::new(Sv2Options::default()),
        sv2_toml,
    )
    .await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn ardupilot_serial_link_comes_back_behind_its_stable_name() {
    comes_back("ardupilot", rover_in_guided(), ardupilot_toml).await;
}

/// The figure for BENCHMARKS.md: the default backoff (100 ms doubling to 5 s), absences of 1.5
/// to 27.6 s (where the device returns in the backoff's schedule decides most of the wait), the three
/// vehicles at once, each with its own interface child.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
#[ignore = "a measurement (minutes of wall time), not a test: run with --ignored"]
async fn measure_return_with_default_backoff() {
    let (iver, sv2, apm) = tokio::join!(
        measure(
            "iver3",
            IverSession::new(IverOptions {
                remote_helm_version_major: 5,
                ..Default::default()
            }),
            iver3_toml,
        ),
        measure(
            "waveglider_sv2",
            Sv2Session::new(Sv2Options::default()),
            sv2_toml
        ),
        measure("ardupilot", rover_in_guided(), ardupilot_toml),
    );
    println!(
        "vehicle | away | back → reopened | reopened → running:command | back → running:command"
    );
    for (vehicle, rows) in [("iver3", iver), ("waveglider_sv2", sv2), ("ardupilot", apm)] {
        for (away, reopen, command) in rows {
            let ms = |d: Duration| format!("{:.0} ms", d.as_secs_f64() * 1e3);
            println!(
                "{vehicle} | {:.1} s | {} | {} | {}",
                away.as_secs_f64(),
                ms(reopen),
                ms(command),
                ms(reopen + command)
            );
        }
    }
}

/// (away, device back → the reopen line, the reopen line → `to="running:command"`) per return.
async fn measure<S: Session>(
    vehicle: &str,
    session: S,
    driver: DriverToml,
) -> Vec<(Duration, Duration, Duration)> {
    // Not multiples of the 5 s cap, which would meet the backoff's schedule at the same phase.
    const AWAY_MS: [u64; 6] = [1_500, 3_700, 8_300, 13_900, 21_100, 27_600];
    let dir = scratch(&format!("measure-{vehicle}"));
    let prefix = unprivileged_prefix(&dir.0);
    let mut cable = Cable::new(session, &dir.0);
    let by_id_s = cable.by_id.to_string_lossy().into_owned();
    let config = write_config(&dir.0, vehicle, driver(&cable.by_id, 100, 5000));
    cable.plug(0o666).await;
    let mut iface = Interface::spawn(&prefix, &config, &dir.0);
    iface.until_command().await;
    let mut rows = Vec::new();
    for away in AWAY_MS.map(Duration::from_millis) {
        cable.unplug().await;
        iface.until_out_of_command().await;
        tokio::time::sleep(away).await;
        cable.plug(0o666).await;
        let back = Instant::now();
        let reopened = iface
            .wait_for("the reopen line", |l| {
                l.contains(&format!("serial port {by_id_s} open again after"))
            })
            .await;
        let at = iface.until_command().await;
        rows.push((
            away,
            reopened.saturating_duration_since(back),
            at.saturating_duration_since(reopened),
        ));
    }
    rows
}
