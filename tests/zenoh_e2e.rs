//! Across real processes over Zenoh: `frontseat sim` and `frontseat interface` (interprocess
//! enabled on a free loopback port) run as children; a client in this test process — or the
//! Python helm in a third process — drives the vehicle through Zenoh only. Every wait has a
//! deadline; children are killed when the test ends, pass or fail.

mod common;

use common::procs::{
    Kill, finish_within, free_port, frontseat_interface, frontseat_sim, scratch, wait_for_tcp,
};

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

use frontseat_actors::groups;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    DesiredCourse, HelmState, HelmStateReport, InterfaceState, InterfaceStatus, NodeStatus,
};
use frontseat_helm_side::zenoh::{self, Wait};
use frontseat_helm_side::{client_config, key_for, put_message};
use prost::Message;

const WARP: f64 = 10.0;
const LONG: Duration = Duration::from_secs(60);

/// A running sim + interface pair; `zenoh` is the interface's Zenoh listen port.
struct Stack {
    zenoh: u16,
    dir: PathBuf,
    _sim: Kill,
    _interface: Kill,
}

async fn start_stack(name: &str, platform: &str) -> Stack {
    let dir = scratch("zenoh", name);
    let (sim, sim_port) = frontseat_sim(std::fs::File::create(dir.join("sim.log")).unwrap()).await;
    let zport = free_port();
    let cfg = format!(
        r#"name = "{platform}"
sim_warp_factor = {WARP}
status_period = 0.5
helm_running_timeout = 5.0
[driver]
name = "basic_simulator"
[driver.basic_simulator]
tcp_port = {sim_port}
[interprocess]
enabled = true
listen = ["tcp/127.0.0.1:{zport}"]
"#
    );
    let interface = frontseat_interface(&dir, &cfg);
    wait_for_tcp(zport).await;
    Stack {
        zenoh: zport,
        dir,
        _sim: sim,
        _interface: interface,
    }
}

impl Stack {
    fn log(&self) -> String {
        std::fs::read_to_string(self.dir.join("interface.log")).unwrap_or_default()
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_client_in_another_process_commands_the_interface_over_zenoh() {
    let stack = start_stack("client", "zauv").await;
    let session = zenoh::open(client_config(&[format!("tcp/127.0.0.1:{}", stack.zenoh)]).unwrap())
        .await
        .unwrap();
    let key = |g: &str| key_for("zauv", g);
    let (ntx, mut nav) = tokio::sync::mpsc::unbounded_channel();
    let _n = session
        .declare_subscriber(key(groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS.name()))
        .callback(move |s| {
            let enc = s.encoding().to_string();
            let _ = ntx.send((enc, NodeStatus::decode(&*s.payload().to_bytes()).unwrap()));
        })
        .await
        .unwrap();
    let (stx, mut status) = tokio::sync::mpsc::unbounded_channel();
    let _s = session
        .declare_subscriber(key(groups::GOBY_MIDDLEWARE_FRONTSEAT_STATUS.name()))
        .callback(move |s| {
            let _ = stx.send(InterfaceStatus::decode(&*s.payload().to_bytes()).unwrap());
        })
        .await
        .unwrap();

    // The helm: DRIVE every 100 ms, and a course due east.
    let helm_key = key(groups::GOBY_MIDDLEWARE_FRONTSEAT_HELM_STATE.name());
    let course_key = key(groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE.name());
    let hb_session = session.clone();
    let heartbeat = tokio::spawn(async move {
        loop {
            let drive = HelmStateReport {
                state: HelmState::HelmDrive as i32,
            };
            put_message(
                &hb_session,
                &helm_key,
                groups::GOBY_MIDDLEWARE_FRONTSEAT_HELM_STATE.type_name(),
                &drive,
                None,
            )
            .unwrap();
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
    });

    // Status arrives over Zenoh and reaches COMMAND.
    let mut states = Vec::new();
    let deadline = tokio::time::Instant::now() + LONG;
    loop {
        let s = match tokio::time::timeout_at(deadline, status.recv()).await {
            Ok(Some(s)) => s,
            _ => panic!(
                "no COMMAND over Zenoh; states {states:?}\ninterface log:\n{}",
                stack.log()
            ),
        };
        if states.last() != Some(&s.state()) {
            states.push(s.state());
        }
        if s.state() == InterfaceState::InterfaceCommand {
            break;
        }
    }

    // The vehicle turns to the commanded heading: node_status over Zenoh shows it.
    let deadline = tokio::time::Instant::now() + LONG;
    let mut first_heading = None;
    loop {
        let dc = DesiredCourse {
            heading: Some(90.0),
            speed: Some(1.5),
            depth: Some(0.0),
            ..Default::default()
        };
        put_message(
            &session,
            &course_key,
            groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE.type_name(),
            &dc,
            Some("00-0af7651916cd43dd8448eb211c80319c-b7ad6b7169203331-01"),
        )
        .unwrap();
        let (enc, ns) = match tokio::time::timeout_at(deadline, nav.recv()).await {
            Ok(Some(v)) => v,
            _ => panic!("vehicle did not turn east\ninterface log:\n{}", stack.log()),
        };
        assert_eq!(
            enc,
            "application/protobuf;goby.middleware.frontseat.protobuf.NodeStatus"
        );
        assert_eq!(ns.name.as_deref(), Some("zauv"));
        first_heading.get_or_insert(ns.pose.heading());
        if (ns.pose.heading() - 90.0).abs() < 1.0 && ns.speed.over_ground > 1.4 {
            break;
        }
    }
    assert!(
        (first_heading.unwrap() - 90.0).abs() > 1.0,
        "it started elsewhere and turned"
    );
    heartbeat.abort();
    session.close().await.unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn garbage_on_an_imported_key_is_counted_and_survived() {
    let stack = start_stack("garbage", "gauv").await;
    let session = zenoh::open(client_config(&[format!("tcp/127.0.0.1:{}", stack.zenoh)]).unwrap())
        .await
        .unwrap();
    let course_key = key_for(
        "gauv",
        groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE.name(),
    );
    let helm_key = key_for("gauv", groups::GOBY_MIDDLEWARE_FRONTSEAT_HELM_STATE.name());
    let (stx, mut status) = tokio::sync::mpsc::unbounded_channel();
    let _s = session
        .declare_subscriber(key_for(
            "gauv",
            groups::GOBY_MIDDLEWARE_FRONTSEAT_STATUS.name(),
        ))
        .callback(move |s| {
            let _ = stx.send(InterfaceStatus::decode(&*s.payload().to_bytes()).unwrap());
        })
        .await
        .unwrap();
    // Let the routes settle: the first status over Zenoh proves the link works.
    tokio::time::timeout(LONG, status.recv())
        .await
        .expect("a status over Zenoh")
        .unwrap();
    for _ in 0..50 {
        session
            .put(&course_key, vec![0x0f, 0xff, 0xff])
            .wait()
            .unwrap();
        session.put(&helm_key, vec![0x08]).wait().unwrap(); // truncated varint
        session
            .put(&course_key, "not protobuf")
            .encoding("text/plain")
            .wait()
            .unwrap();
        session.put(&course_key, vec![0u8; 200_000]).wait().unwrap();
    }
    // Survived: still answering, and the helm can still bring it to COMMAND.
    let drive = HelmStateReport {
        state: HelmState::HelmDrive as i32,
    };
    let deadline = tokio::time::Instant::now() + LONG;
    loop {
        put_message(
            &session,
            &helm_key,
            groups::GOBY_MIDDLEWARE_FRONTSEAT_HELM_STATE.type_name(),
            &drive,
            None,
        )
        .unwrap();
        match tokio::time::timeout_at(deadline, status.recv()).await {
            Ok(Some(s)) if s.state() == InterfaceState::InterfaceCommand => break,
            Ok(Some(_)) => {}
            _ => panic!("interface stopped answering\n{}", stack.log()),
        }
    }
    session.close().await.unwrap();
    // The refusals are logged naming key and type, with their counts.
    let log = stack.log();
    for what in [
        "undecodable Zenoh payload refused",
        "Zenoh payload of another type refused",
        "oversized Zenoh payload refused",
    ] {
        assert!(log.contains(what), "no {what:?} in the log:\n{log}");
    }
    assert!(log.contains("gauv/goby/middleware/frontseat/desired_course"));
    assert!(log.contains("goby.middleware.frontseat.protobuf.DesiredCourse"));
}

/// Whether the Python helm's packages are there. `.ci/run` installs them and sets
/// FRONTSEAT_REQUIRE_PYTHON_HELM: there, a missing package is a failure, never a skip. Elsewhere
/// (a machine with only the Rust toolchain) the skip is reported.
fn python_helm_can_run(test: &str) -> bool {
    if python_has_zenoh() {
        return true;
    }
    assert!(
        std::env::var_os("FRONTSEAT_REQUIRE_PYTHON_HELM").is_none(),
        "FRONTSEAT_REQUIRE_PYTHON_HELM is set but python3 cannot import zenoh/protobuf/grpc_tools"
    );
    println!(
        "SKIPPED {test}: python3 cannot import zenoh/protobuf/grpc_tools \
         (pip install -r examples/python/requirements.txt)"
    );
    false
}

/// `examples/python/helm.py` against the stack's Zenoh, its protobuf modules generated into the
/// stack's directory, stdout and stderr piped.
fn python_helm(stack: &Stack, platform: &str, args: &[&str]) -> Kill {
    python_helm_spawn(stack, &python_gen(stack), platform, args)
}

/// The helm's protobuf modules, generated into the stack's directory.
fn python_gen(stack: &Stack) -> PathBuf {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let gen_dir = stack.dir.join("gen");
    let st = Command::new("bash")
        .arg(root.join("examples/python/gen_protos.sh"))
        .arg(&gen_dir)
        .status()
        .unwrap();
    assert!(st.success(), "gen_protos.sh failed");
    gen_dir
}

fn python_helm_spawn(stack: &Stack, gen_dir: &Path, platform: &str, args: &[&str]) -> Kill {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    Kill(
        Command::new("python3")
            .arg(root.join("examples/python/helm.py"))
            .args(["--connect", &format!("tcp/127.0.0.1:{}", stack.zenoh)])
            .args(["--platform", platform])
            .args(["--warp", &WARP.to_string()])
            .args(args)
            .env("FRONTSEAT_PY_GEN", gen_dir)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap(),
    )
}

/// Sends `signal` (a `kill` name: INT, TERM) to the helm, then awaits its exit for at most 20 s;
/// returns its exit code and everything it wrote on stderr (`stderr` collects it in a thread).
async fn signal_and_wait(
    helm: &mut Kill,
    signal: &str,
    stderr: std::sync::mpsc::Receiver<String>,
) -> (Option<i32>, String) {
    // bash's built-in kill: no procps needed.
    let st = Command::new("bash")
        .args(["-c", &format!("kill -{signal} {}", helm.0.id())])
        .status()
        .unwrap();
    assert!(st.success(), "kill -{signal}");
    let until = std::time::Instant::now() + Duration::from_secs(20);
    let status = loop {
        if let Some(s) = helm.0.try_wait().unwrap() {
            break s;
        }
        assert!(
            std::time::Instant::now() < until,
            "the helm was still running 20 s after SIG{signal}"
        );
        tokio::time::sleep(Duration::from_millis(20)).await;
    };
    // The pipe closes with the process: the reader thread ends and every line is in.
    let err: Vec<String> = stderr.iter().collect();
    (status.code(), err.join("\n"))
}

/// The helm's stderr, line by line, from a thread (a pipe read blocks).
fn stderr_lines(helm: &mut Kill) -> std::sync::mpsc::Receiver<String> {
    let stderr = helm.0.stderr.take().unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stderr).lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    rx
}

fn python_has_zenoh() -> bool {
    Command::new("python3")
        .args(["-c", "import zenoh, google.protobuf, grpc_tools"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn python_helm_completes_its_triangle() {
    if !python_helm_can_run("python_helm_completes_its_triangle") {
        return;
    }
    let stack = start_stack("python", "pyauv").await;
    let mut helm = python_helm(
        &stack,
        "pyauv",
        &["--t1", "60", "--t2", "60", "--timeout", "90"],
    );
    // The helm bounds itself (--timeout 90); this bounds the test if it hangs anyway.
    let (status, out, err) =
        finish_within(&mut helm, Duration::from_secs(120), "python helm").await;
    assert!(
        status.success(),
        "python helm failed: {status}\n{out}\n{err}\ninterface log:\n{}",
        stack.log()
    );
    for leg in ["leg east", "leg south", "leg northwest", "triangle done"] {
        assert!(out.contains(leg), "no {leg:?} in:\n{out}");
    }
    // Equal legs at 1.5 m/s: the northwest leg passes near the start.
    let closest: f64 = out
        .lines()
        .find_map(|l| l.strip_prefix("triangle done: closest approach "))
        .and_then(|r| r.split(' ').next())
        .and_then(|v| v.parse().ok())
        .expect("closest approach printed");
    assert!(closest < 15.0, "closest approach {closest} m:\n{out}");
}

/// Ctrl-C stops the Python helm: the zenoh library takes SIGINT over when a session opens, and
/// an open session kept the interpreter from exiting; the helm owns the signal again and closes
/// its session.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn python_helm_stops_on_ctrl_c() {
    if !python_helm_can_run("python_helm_stops_on_ctrl_c") {
        return;
    }
    let stack = start_stack("pyint", "pyint").await;
    let mut helm = python_helm(&stack, "pyint", &["--timeout", "90"]);
    let stdout = helm.0.stdout.take().unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    // Interrupted only once it is flying: its session is open and its loop running.
    let flying = tokio::task::spawn_blocking(move || {
        let until = std::time::Instant::now() + Duration::from_secs(60);
        while let Some(left) = until.checked_duration_since(std::time::Instant::now()) {
            match rx.recv_timeout(left) {
                Ok(l) if l.starts_with("leg east") => return true,
                Ok(_) => {}
                Err(_) => return false,
            }
        }
        false
    })
    .await
    .unwrap();
    assert!(
        flying,
        "the helm never started its first leg\n{}",
        stack.log()
    );
    let errs = stderr_lines(&mut helm);
    let (code, err) = signal_and_wait(&mut helm, "INT", errs).await;
    assert_eq!(code, Some(130), "{err}");
    assert!(err.contains("helm: interrupted"), "{err}");
    assert!(!err.contains("Traceback"), "{err}");
}

/// Ctrl-C at any moment of the helm's start — its imports (zenoh's takes a while), the session
/// opening, its first heartbeats — ends it the same way: exit 130, "helm: interrupted", no
/// traceback (Python's own KeyboardInterrupt printed one from wherever it landed, exit 1 or killed
/// by the signal). The moments are taken after the helm's first line ("helm: started": its
/// handlers are in place; before it is the interpreter's own start), spread over its start-up.
/// SIGTERM likewise, with 143.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn python_helm_stops_cleanly_on_ctrl_c_at_any_moment_of_its_start() {
    if !python_helm_can_run("python_helm_stops_cleanly_on_ctrl_c_at_any_moment_of_its_start") {
        return;
    }
    let stack = start_stack("pystart", "pystart").await;
    let gen_dir = python_gen(&stack);
    let moments_ms = [0u64, 5, 20, 50, 100, 200, 400, 800, 1500];
    let cases = moments_ms
        .iter()
        .map(|&ms| ("INT", ms, 130))
        .chain([("TERM", 50, 143), ("TERM", 1500, 143)]);
    for (signal, ms, want) in cases {
        let mut helm = python_helm_spawn(&stack, &gen_dir, "pystart", &["--timeout", "90"]);
        let errs = stderr_lines(&mut helm);
        let first = tokio::task::spawn_blocking(move || {
            let first = errs.recv_timeout(Duration::from_secs(30));
            (first, errs)
        });
        let (first, errs) = first.await.unwrap();
        assert_eq!(
            first.as_deref(),
            Ok("helm: started"),
            "the helm's first line on stderr"
        );
        // The moment to interrupt, counted from its first line: not a wait for anything.
        tokio::time::sleep(Duration::from_millis(ms)).await;
        let (code, err) = signal_and_wait(&mut helm, signal, errs).await;
        assert_eq!(code, Some(want), "SIG{signal} {ms} ms after start:\n{err}");
        assert!(
            err.contains("helm: interrupted") && !err.contains("Traceback"),
            "SIG{signal} {ms} ms after start:\n{err}"
        );
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_hostile_helm_over_zenoh_is_refused_before_the_frontseat() {
    use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
        CommandRequest, CommandResponse, Raw,
    };
    let stack = start_stack("hostile", "hauv").await;
    let session = zenoh::open(client_config(&[format!("tcp/127.0.0.1:{}", stack.zenoh)]).unwrap())
        .await
        .unwrap();
    let key = |g: &str| key_for("hauv", g);
    let (rtx, mut raw_out) = tokio::sync::mpsc::unbounded_channel();
    let _r = session
        .declare_subscriber(key(groups::GOBY_MIDDLEWARE_FRONTSEAT_RAW_OUT.name()))
        .callback(move |s| {
            let raw = Raw::decode(&*s.payload().to_bytes()).unwrap();
            let _ = rtx.send(String::from_utf8_lossy(raw.raw()).to_string());
        })
        .await
        .unwrap();
    let (ctx, mut responses) = tokio::sync::mpsc::unbounded_channel();
    let _c = session
        .declare_subscriber(key(
            groups::GOBY_MIDDLEWARE_FRONTSEAT_COMMAND_RESPONSE.name()
        ))
        .callback(move |s| {
            let _ = ctx.send(CommandResponse::decode(&*s.payload().to_bytes()).unwrap());
        })
        .await
        .unwrap();
    let (stx, mut status) = tokio::sync::mpsc::unbounded_channel();
    let _s = session
        .declare_subscriber(key(groups::GOBY_MIDDLEWARE_FRONTSEAT_STATUS.name()))
        .callback(move |s| {
            let _ = stx.send(InterfaceStatus::decode(&*s.payload().to_bytes()).unwrap());
        })
        .await
        .unwrap();
    let helm_key = key(groups::GOBY_MIDDLEWARE_FRONTSEAT_HELM_STATE.name());
    let hb_session = session.clone();
    let heartbeat = tokio::spawn(async move {
        loop {
            let drive = HelmStateReport {
                state: HelmState::HelmDrive as i32,
            };
            let t = groups::GOBY_MIDDLEWARE_FRONTSEAT_HELM_STATE.type_name();
            put_message(&hb_session, &helm_key, t, &drive, None).unwrap();
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
    });
    let deadline = tokio::time::Instant::now() + LONG;
    loop {
        match tokio::time::timeout_at(deadline, status.recv()).await {
            Ok(Some(s)) if s.state() == InterfaceState::InterfaceCommand => break,
            Ok(Some(_)) => {}
            _ => panic!("no COMMAND over Zenoh\ninterface log:\n{}", stack.log()),
        }
    }
    let request_key = key(groups::GOBY_MIDDLEWARE_FRONTSEAT_COMMAND_REQUEST.name());
    let send = |id: i32, course: DesiredCourse| {
        let req = CommandRequest {
            desired_course: Some(course),
            response_requested: Some(true),
            request_id: Some(id),
            ..Default::default()
        };
        let t = groups::GOBY_MIDDLEWARE_FRONTSEAT_COMMAND_REQUEST.type_name();
        put_message(&session, &request_key, t, &req, None).unwrap();
    };
    let course = |h: f64, s: f64, d: f64| DesiredCourse {
        heading: Some(h),
        speed: Some(s),
        depth: Some(d),
        ..Default::default()
    };
    let hostile = [
        course(f64::NAN, 1.0, 0.0),
        course(90.0, 1e308, 0.0),
        course(90.0, f64::INFINITY, 0.0),
        course(90.0, 1.0, -3.0),
        course(90.0, 1.0, f64::NAN),
        DesiredCourse {
            pitch: Some(89.0),
            ..course(90.0, 1.0, 0.0)
        },
    ];
    for (i, c) in hostile.iter().enumerate() {
        let id = 100 + i as i32;
        send(id, *c);
        let r = loop {
            match tokio::time::timeout_at(deadline, responses.recv()).await {
                Ok(Some(r)) if r.request_id == Some(id) => break r,
                Ok(Some(_)) => {}
                _ => panic!("no answer to hostile request {id}\n{}", stack.log()),
            }
        };
        assert_eq!(r.request_successful, Some(false), "{c:?}");
        assert_eq!(r.error_code, Some(6), "{r:?}");
        assert!(r.error_string().contains("safety envelope"), "{r:?}");
    }
    // A valid request after them reaches the frontseat; nothing before it was a bad CMD.
    send(200, course(33.0, 1.0, 0.0));
    let mut written = Vec::new();
    loop {
        match tokio::time::timeout_at(deadline, raw_out.recv()).await {
            Ok(Some(l)) => {
                let done = l == "CMD,HEADING:33,SPEED:1,DEPTH:0";
                written.push(l);
                if done {
                    break;
                }
            }
            _ => panic!("the valid command never reached the frontseat: {written:?}"),
        }
    }
    for l in written.iter().filter(|l| l.starts_with("CMD,")) {
        assert!(
            !l.contains("NaN") && !l.contains("inf") && !l.contains("-3") && l.len() < 60,
            "the frontseat received {l}"
        );
    }
    assert!(
        stack.log().contains("refused by the safety envelope"),
        "a WARN names the refusal\n{}",
        stack.log()
    );
    heartbeat.abort();
    session.close().await.unwrap();
}
