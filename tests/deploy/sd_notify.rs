//! sd_notify under systemd: the sd_notify module (frontseat_actors::systemd) reports status and
//! withholds the watchdog from a hung actor, in process; and the real binaries speak sd_notify to
//! a socket this test owns.

use frontseat_actors::bus::test_util::UntypedBus as _;
use std::io::{BufRead, BufReader};
use std::os::unix::net::UnixDatagram;
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use crate::common::temp_dir::TempDir;
use crate::common::{self, config_for, start_sim};
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
