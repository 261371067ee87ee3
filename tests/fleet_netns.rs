//! Across hosts, for real: each vehicle in its own network namespace (its simulator and its
//! interface under `frontseat launch`, Zenoh listening on its veth address), a topside namespace
//! joined to each by a veth pair, and in it the topside and the helms (`demo --fleet 2
//! --fleet-connect`). The trail flies over the veth links, the topside sees both vehicles; with
//! the follower's link down its helm goes stale and its interface leaves COMMAND by the normal
//! rules, and with the link back it climbs back to COMMAND.
//!
//! Per-key authority across hosts: auv1 (its simulator behind a wire tap, its interface with
//! `[interprocess.access]`) in one namespace, a peer holding auv2's certificate in a second and
//! one holding the topside's in a third, each its own host on veth links. auv2's certificate
//! puts helm_state DRIVE and a course on auv1's keys and nothing happens: auv1 never goes to
//! COMMAND and no `CMD` line reaches its vehicle, while auv2 goes on hearing auv1's node_status
//! (the trail); the topside's certificate, doing the same, steers.
//!
//! Needs root and `ip netns`. If namespaces cannot be made the tests FAIL, unless
//! FRONTSEAT_SKIP_NETNS=1 is set: then they say that they did not run.

#[path = "../helm_side/tests/support/certs.rs"]
mod certs;

use std::ffi::OsStr;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_frontseat");
const BOUND: Duration = Duration::from_secs(60);
const WARP: f64 = 5.0;

fn ip(args: &[&str]) -> Result<(), String> {
    let out = Command::new("ip")
        .args(args)
        .output()
        .map_err(|e| format!("ip {args:?}: {e}"))?;
    if out.status.success() {
        Ok(())
    } else {
        Err(format!(
            "ip {args:?}: {}",
            String::from_utf8_lossy(&out.stderr).trim()
        ))
    }
}

/// Namespaces and links, removed on drop (deleting a namespace deletes its veth ends).
struct Net {
    top: String,
    vehicles: Vec<String>,
    /// The topside's end of each vehicle's link.
    top_ends: Vec<String>,
}

impl Net {
    /// `prefix` keeps the namespaces of tests running at once apart (4 characters: an
    /// interface name has at most 15).
    fn build(prefix: &str, n: usize) -> Result<Self, String> {
        let tag = std::process::id() % 100_000;
        let mut net = Net {
            top: format!("{prefix}t{tag}"),
            vehicles: (0..n).map(|i| format!("{prefix}v{i}-{tag}")).collect(),
            top_ends: (0..n).map(|i| format!("{prefix}t{i}-{tag}")).collect(),
        };
        ip(&["netns", "add", &net.top])?;
        ip(&["-n", &net.top, "link", "set", "lo", "up"])?;
        for i in 0..n {
            let (ns, top_end) = (net.vehicles[i].clone(), net.top_ends[i].clone());
            let v_end = format!("{prefix}v{i}e{tag}");
            if let Err(e) = ip(&["netns", "add", &ns]) {
                net.vehicles.truncate(i);
                return Err(e);
            }
            ip(&["-n", &ns, "link", "set", "lo", "up"])?;
            ip(&[
                "link", "add", &v_end, "netns", &ns, "type", "veth", "peer", "name", &top_end,
                "netns", &net.top,
            ])?;
            ip(&[
                "-n",
                &ns,
                "addr",
                "add",
                &format!("10.27.{i}.1/30"),
                "dev",
                &v_end,
            ])?;
            ip(&[
                "-n",
                &net.top,
                "addr",
                "add",
                &format!("10.27.{i}.2/30"),
                "dev",
                &top_end,
            ])?;
            ip(&["-n", &ns, "link", "set", &v_end, "up"])?;
            ip(&["-n", &net.top, "link", "set", &top_end, "up"])?;
        }
        Ok(net)
    }

    /// The top namespace forwards between the vehicles' links, as a topside radio hub would:
    /// vehicle `i` reaches vehicle `j` at `10.27.j.1`.
    fn route_through_top(&self) -> Result<(), String> {
        let out = Command::new("ip")
            .args([
                "netns",
                "exec",
                &self.top,
                "sysctl",
                "-qw",
                "net.ipv4.ip_forward=1",
            ])
            .output()
            .map_err(|e| format!("sysctl: {e}"))?;
        if !out.status.success() {
            return Err(format!("sysctl: {}", String::from_utf8_lossy(&out.stderr)));
        }
        for (i, ns) in self.vehicles.iter().enumerate() {
            for j in (0..self.vehicles.len()).filter(|&j| j != i) {
                ip(&[
                    "-n",
                    ns,
                    "route",
                    "add",
                    &format!("10.27.{j}.0/30"),
                    "via",
                    &format!("10.27.{i}.2"),
                ])?;
            }
        }
        Ok(())
    }
}

impl Drop for Net {
    fn drop(&mut self) {
        for ns in self.vehicles.iter().chain(std::iter::once(&self.top)) {
            let _ = ip(&["netns", "del", ns]);
        }
    }
}

/// A process in a namespace; its output lines arrive on `lines`; killed on drop.
struct Proc {
    name: &'static str,
    child: Child,
    lines: mpsc::Receiver<String>,
    seen: Vec<String>,
}

impl Proc {
    fn start(name: &'static str, ns: &str, args: &[&str], dir: &Path) -> Self {
        Self::start_program(name, ns, OsStr::new(BIN), args, dir, &[])
    }

    /// Any program in namespace `ns`, with `env` added.
    fn start_program(
        name: &'static str,
        ns: &str,
        program: &OsStr,
        args: &[&str],
        dir: &Path,
        env: &[(&str, String)],
    ) -> Self {
        let mut child = Command::new("ip")
            .args(["netns", "exec", ns])
            .arg(program)
            .args(args)
            .current_dir(dir)
            .env("RUST_LOG", "info")
            .envs(env.iter().map(|(k, v)| (k, v)))
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let (tx, rx) = mpsc::channel();
        for s in [
            Box::new(child.stdout.take().unwrap()) as Box<dyn std::io::Read + Send>,
            Box::new(child.stderr.take().unwrap()),
        ] {
            let tx = tx.clone();
            std::thread::spawn(move || {
                for l in BufReader::new(s).lines().map_while(Result::ok) {
                    let _ = tx.send(l);
                }
            });
        }
        Self {
            name,
            child,
            lines: rx,
            seen: Vec::new(),
        }
    }

    /// Waits (bounded) for a line after the `from`-th that satisfies `ok`; its index.
    fn expect_after(&mut self, from: usize, what: &str, ok: impl Fn(&str) -> bool) -> usize {
        let deadline = Instant::now() + BOUND;
        loop {
            if let Some(i) = self.seen.iter().skip(from).position(|l| ok(l)) {
                return from + i;
            }
            let Some(left) = deadline.checked_duration_since(Instant::now()) else {
                break;
            };
            match self.lines.recv_timeout(left) {
                Ok(l) => self.seen.push(l),
                Err(_) => break,
            }
        }
        let tail: Vec<&String> = self.seen.iter().rev().take(40).collect();
        panic!("{}: no {what}; last lines:\n{tail:#?}", self.name);
    }

    /// Takes in every line already printed, without waiting.
    fn drain(&mut self) -> &[String] {
        while let Ok(l) = self.lines.try_recv() {
            self.seen.push(l);
        }
        &self.seen
    }

    fn stop(&mut self) {
        let _ = Command::new("kill")
            .args(["-TERM", &self.child.id().to_string()])
            .status();
    }

    fn wait(&mut self) -> i32 {
        let deadline = Instant::now() + BOUND;
        loop {
            if let Some(s) = self.child.try_wait().unwrap() {
                return s.code().unwrap_or(-1);
            }
            assert!(Instant::now() < deadline, "{} did not end", self.name);
            while let Ok(l) = self.lines.recv_timeout(Duration::from_millis(50)) {
                self.seen.push(l);
            }
        }
    }
}

impl Drop for Proc {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn entered_command(l: &str) -> bool {
    l.contains("[interface-")
        && (l.contains("to=\"running:command\"") || l.contains("to=running:command"))
}

fn left_command(l: &str) -> bool {
    l.contains("[interface-")
        && (l.contains("from=\"running:command\"") || l.contains("from=running:command"))
}

/// The topside's model, read from inside its namespace.
fn topside_fleet(top: &str) -> Option<serde_json::Value> {
    let out = Command::new("ip")
        .args(["netns", "exec", top, "python3", "-c"])
        .arg("import urllib.request;print(urllib.request.urlopen('http://127.0.0.1:50080/api/fleet',timeout=2).read().decode())")
        .output()
        .ok()?;
    serde_json::from_slice(&out.stdout).ok()
}

fn until_topside(top: &str, what: &str, ok: impl Fn(&serde_json::Value) -> bool) {
    let deadline = Instant::now() + BOUND;
    loop {
        if topside_fleet(top).is_some_and(|f| ok(&f)) {
            return;
        }
        assert!(
            Instant::now() < deadline,
            "topside never showed: {what}: {:?}",
            topside_fleet(top)
        );
        std::thread::sleep(Duration::from_millis(200));
    }
}

fn stale(f: &serde_json::Value, name: &str) -> Option<bool> {
    f["vehicles"]
        .as_array()?
        .iter()
        .find(|v| v["name"] == name)?["stale"]
        .as_bool()
}

fn vehicle_launch(dir: &Path, name: &str, i: usize) -> PathBuf {
    let file = dir.join(format!("{name}.toml"));
    std::fs::write(
        &file,
        format!(
            r#"
[[process]]
name = "sim"
command = ["frontseat", "sim", "--port", "54321"]
ready = {{ kind = "notify" }}
[[vehicle]]
name = "{name}"
sim_port = 54321
zenoh_listen = ["tcp/10.27.{i}.1:7447"]
start = {{ lat = {lat}, lon = -71.087589 }}
set = {{ sim_warp_factor = {WARP}, helm_state_timeout = 3.0 }}
"#,
            lat = 42.358456 - 0.0002 * i as f64
        ),
    )
    .unwrap();
    file
}

#[test]
fn a_fleet_across_namespaces_flies_and_a_cut_link_takes_one_vehicle_out_of_command_and_back() {
    let net = match Net::build("fs27", 2) {
        Ok(n) => n,
        Err(e) if std::env::var_os("FRONTSEAT_SKIP_NETNS").is_some() => {
            eprintln!(
                "NOT RUN: cannot create network namespaces ({e}); FRONTSEAT_SKIP_NETNS is set"
            );
            return;
        }
        Err(e) => panic!(
            "cannot create network namespaces: {e}\n(needs root and iproute2; set FRONTSEAT_SKIP_NETNS=1 to skip knowingly)"
        ),
    };
    let dir = std::env::temp_dir().join(format!("frontseat-fleet-netns-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let names = ["leader", "follower1"];
    let mut vehicles: Vec<Proc> = names
        .iter()
        .enumerate()
        .map(|(i, name)| {
            let file = vehicle_launch(&dir, name, i);
            let mut p = Proc::start(
                name,
                &net.vehicles[i],
                &["launch", "-c", file.to_str().unwrap()],
                &dir,
            );
            p.expect_after(0, "launch up", |l| l.contains("every process is up"));
            p
        })
        .collect();
    std::fs::write(
        dir.join("topside.toml"),
        "stale_after_s = 1.0\n[zenoh]\nconnect = [\"tcp/10.27.0.1:7447\", \"tcp/10.27.1.1:7447\"]\n[web]\nlisten = \"127.0.0.1:50080\"\n",
    )
    .unwrap();
    let mut topside = Proc::start(
        "topside",
        &net.top,
        &["topside", "-c", "topside.toml"],
        &dir,
    );
    topside.expect_after(0, "topside serving", |l| l.contains("topside serving"));
    let out = dir.join("out");
    let mut helms = Proc::start(
        "helms",
        &net.top,
        &[
            "demo",
            "--fleet",
            "2",
            "--warp",
            &WARP.to_string(),
            "--out",
            out.to_str().unwrap(),
            "--fleet-connect",
            "tcp/10.27.0.1:7447,tcp/10.27.1.1:7447",
        ],
        &dir,
    );
    // Both vehicles reach COMMAND through their links, and the topside sees both.
    let first = vehicles[1].expect_after(0, "follower in COMMAND", entered_command);
    vehicles[0].expect_after(0, "leader in COMMAND", entered_command);
    until_topside(&net.top, "both vehicles fresh", |f| {
        stale(f, "leader") == Some(false) && stale(f, "follower1") == Some(false)
    });

    // Cut the follower's link: its helm goes stale, its interface leaves COMMAND.
    ip(&["-n", &net.top, "link", "set", &net.top_ends[1], "down"]).unwrap();
    let cut = vehicles[1].expect_after(first, "follower leaving COMMAND", left_command);
    until_topside(&net.top, "follower stale, leader fresh", |f| {
        stale(f, "follower1") == Some(true) && stale(f, "leader") == Some(false)
    });
    assert!(
        !vehicles[0].seen.iter().any(|l| left_command(l)),
        "the leader, whose link stayed up, never left COMMAND"
    );
    // Link back: the helm is heard again and the interface climbs back.
    ip(&["-n", &net.top, "link", "set", &net.top_ends[1], "up"]).unwrap();
    vehicles[1].expect_after(cut, "follower back in COMMAND", entered_command);
    until_topside(&net.top, "follower fresh again", |f| {
        stale(f, "follower1") == Some(false)
    });

    // The leader completes its path; the helms end 0.
    assert_eq!(
        helms.wait(),
        0,
        "{:#?}",
        helms.seen.iter().rev().take(30).collect::<Vec<_>>()
    );
    assert!(out.join("track-leader.csv").exists() && out.join("track-follower1.csv").exists());
    topside.stop();
    for v in &mut vehicles {
        v.stop();
        assert_eq!(v.wait(), 0, "{} launch", v.name);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The vehicle's wire, tapped: relays between the interface (`listen`) and the simulator
/// (`upstream`) and prints every line the interface sends as `TO_VEHICLE <line>`. What reaches
/// the vehicle is read here, not from the interface's own account of what it sent.
const WIRE_TAP: &str = r#"
import socket, sys, threading
listen, upstream = int(sys.argv[1]), int(sys.argv[2])
srv = socket.socket()
srv.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
srv.bind(("127.0.0.1", listen))
srv.listen(4)
print("TAP READY", flush=True)
def up(c, v):
    buf = b""
    while True:
        d = c.recv(4096)
        if not d:
            break
        v.sendall(d)
        buf = (buf + d)[-65536:]
        while b"\n" in buf:
            line, buf = buf.split(b"\n", 1)
            print("TO_VEHICLE", line.decode("ascii", "replace").strip(), flush=True)
    v.close()
def down(c, v):
    while True:
        d = v.recv(4096)
        if not d:
            break
        c.sendall(d)
    c.close()
while True:
    c, _ = srv.accept()
    v = socket.create_connection(("127.0.0.1", upstream))
    threading.Thread(target=up, args=(c, v), daemon=True).start()
    threading.Thread(target=down, args=(c, v), daemon=True).start()
"#;

/// How long auv2's certificate tries to steer auv1 (its helm_state DRIVE at 10 Hz, as a helm).
/// A listed commander gets auv1 to COMMAND doing the same within a second or two.
const ATTACK_S: u64 = 8;

fn tls_toml(t: &frontseat_config::ZenohTlsConfig) -> String {
    let q = |v: &Option<String>| format!("{:?}", v.as_deref().unwrap_or_default());
    format!(
        "root_ca_certificate = {}\ncertificate = {}\nprivate_key = {}\n",
        q(&t.root_ca_certificate),
        q(&t.certificate),
        q(&t.private_key)
    )
}

/// The peer in a namespace: this test binary again, running [`peer_in_namespace`].
fn peer(
    name: &'static str,
    ns: &str,
    dir: &Path,
    tls: &frontseat_config::ZenohTlsConfig,
    until_command: bool,
    seconds: u64,
) -> Proc {
    let exe = std::env::current_exe().unwrap();
    let s = |v: &Option<String>| v.clone().unwrap_or_default();
    Proc::start_program(
        name,
        ns,
        exe.as_os_str(),
        &["--ignored", "--exact", "peer_in_namespace", "--nocapture"],
        dir,
        &[
            ("FS37_CA", s(&tls.root_ca_certificate)),
            ("FS37_CERT", s(&tls.certificate)),
            ("FS37_KEY", s(&tls.private_key)),
            ("FS37_CONNECT", "tls/10.27.0.1:7447".into()),
            ("FS37_UNTIL_COMMAND", until_command.to_string()),
            ("FS37_SECONDS", seconds.to_string()),
        ],
    )
}

fn is_cmd(l: &str) -> bool {
    l.starts_with("TO_VEHICLE CMD")
}

#[test]
fn a_vehicle_certificate_cannot_steer_another_vehicle_across_hosts_and_a_commander_can() {
    let net = match Net::build("fs37", 2) {
        Ok(n) => n,
        Err(e) if std::env::var_os("FRONTSEAT_SKIP_NETNS").is_some() => {
            eprintln!(
                "NOT RUN: cannot create network namespaces ({e}); FRONTSEAT_SKIP_NETNS is set"
            );
            return;
        }
        Err(e) => panic!(
            "cannot create network namespaces: {e}\n(needs root and iproute2; set FRONTSEAT_SKIP_NETNS=1 to skip knowingly)"
        ),
    };
    net.route_through_top().unwrap();
    let (auv1_ns, auv2_ns, top_ns) = (&net.vehicles[0], &net.vehicles[1], &net.top);
    let tmp = certs::TempDir::new("authority-netns");
    let dir = tmp.0.clone();
    let ca = certs::Ca::new(&dir, "fleet-ca");
    let auv1_tls = ca.tls_for_hosts("auv1", &["10.27.0.1"]);
    let auv2_tls = ca.tls_for_hosts("auv2", &["10.27.1.1"]);
    let top_tls = ca.tls_for_hosts("topside", &["10.27.0.2"]);

    let mut sim = Proc::start("sim", auv1_ns, &["sim", "--port", "54321"], &dir);
    sim.expect_after(0, "simulator listening", |l| l.contains("listening"));
    let mut wire = Proc::start_program(
        "wire",
        auv1_ns,
        OsStr::new("python3"),
        &["-u", "-c", WIRE_TAP, "54322", "54321"],
        &dir,
        &[],
    );
    wire.expect_after(0, "wire tap ready", |l| l.contains("TAP READY"));
    let cfg = dir.join("auv1.toml");
    std::fs::write(
        &cfg,
        format!(
            r#"name = "auv1"
status_period = 0.2
[driver]
name = "basic_simulator"
[driver.basic_simulator]
tcp_port = 54322
[interprocess]
enabled = true
listen = ["tls/10.27.0.1:7447"]
[interprocess.tls]
{}[interprocess.access]
vehicles = ["auv1", "auv2"]
commanders = ["topside"]
"#,
            tls_toml(&auv1_tls)
        ),
    )
    .unwrap();
    let mut auv1 = Proc::start(
        "auv1",
        auv1_ns,
        &["interface", "-c", cfg.to_str().unwrap()],
        &dir,
    );
    auv1.expect_after(0, "gateway running", |l| {
        l.contains("Zenoh gateway running")
    });
    wire.expect_after(0, "the interface's START at the vehicle", |l| {
        l.starts_with("TO_VEHICLE START")
    });

    // auv2's certificate, from auv2's host: DRIVE and a course on auv1's keys, for ATTACK_S.
    let mut auv2 = peer("auv2", auv2_ns, &dir, &auv2_tls, false, ATTACK_S);
    assert_eq!(auv2.wait(), 0, "auv2's peer: {:#?}", auv2.seen);
    let trail = auv2
        .seen
        .iter()
        .filter(|l| l.starts_with("NODE_STATUS"))
        .count();
    assert!(
        trail >= 5,
        "auv2 did not keep hearing auv1's node_status (the trail): {trail} heard; {:#?}",
        auv2.seen
    );
    assert!(
        auv2.seen.iter().any(|l| l.starts_with("PUTS ")),
        "auv2's peer did not report its puts: {:#?}",
        auv2.seen
    );
    assert!(
        auv2.seen.iter().any(|l| l.starts_with("STATE ")),
        "auv2 heard no status of auv1"
    );
    assert!(
        !auv2.seen.iter().any(|l| l.contains("InterfaceCommand")),
        "auv2's certificate put auv1 in COMMAND: {:#?}",
        auv2.seen
    );
    let cmds: Vec<String> = wire.drain().iter().filter(|l| is_cmd(l)).cloned().collect();
    assert!(
        cmds.is_empty(),
        "auv2's certificate steered auv1's vehicle: {cmds:#?}"
    );
    let after_attack = wire.seen.len();

    // The topside's certificate, from the topside's host: the same puts steer auv1.
    let mut top = peer("topside", top_ns, &dir, &top_tls, true, 60);
    assert_eq!(top.wait(), 0, "the topside's peer: {:#?}", top.seen);
    assert!(
        top.seen.iter().any(|l| l.contains("InterfaceCommand")),
        "the commander did not put auv1 in COMMAND: {:#?}",
        top.seen
    );
    let at = wire.expect_after(after_attack, "the commander's CMD at the vehicle", is_cmd);
    assert!(
        wire.seen[at].contains("HEADING:144"),
        "the commander's course reached the vehicle: {}",
        wire.seen[at]
    );
    for p in [&mut auv1, &mut sim] {
        p.stop();
    }
    assert_eq!(auv1.wait(), 0, "auv1's interface: {:#?}", auv1.seen);
}

/// Not a test on its own: the peer `a_vehicle_certificate_cannot_steer_…` starts inside a
/// namespace (this binary again, `--ignored --exact peer_in_namespace`), with a certificate from
/// FS37_* in the environment. It trails auv1 (prints `NODE_STATUS` per node_status heard and
/// `STATE <state>` per status) and puts helm_state DRIVE and a course of 144° on auv1's keys at
/// 10 Hz, for FS37_SECONDS or, with FS37_UNTIL_COMMAND, until auv1 reports COMMAND (and 2 s
/// more, for the course to reach the vehicle). Without the environment it fails.
#[test]
#[ignore = "a helper process: run inside a namespace by the authority test above"]
fn peer_in_namespace() {
    use frontseat_actors::groups;
    use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
        DesiredCourse, HelmState, HelmStateReport, InterfaceState, InterfaceStatus,
    };
    use frontseat_helm_side::{key_for, put_message, zenoh};
    use prost::Message;

    let var = |k: &str| {
        std::env::var(k).unwrap_or_else(|_| panic!("{k} is not set: run by the netns test"))
    };
    let ip = frontseat_config::InterprocessConfig {
        enabled: true,
        listen: Vec::new(),
        connect: vec![var("FS37_CONNECT")],
        tls: Some(frontseat_config::ZenohTlsConfig {
            root_ca_certificate: Some(var("FS37_CA")),
            certificate: Some(var("FS37_CERT")),
            private_key: Some(var("FS37_KEY")),
            ..Default::default()
        }),
        ..Default::default()
    };
    let until_command = var("FS37_UNTIL_COMMAND") == "true";
    let seconds: u64 = var("FS37_SECONDS").parse().unwrap();
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .unwrap();
    rt.block_on(async move {
        let cfg = frontseat_helm_side::zenoh_config(&ip, 65536).unwrap();
        let s = zenoh::open(cfg).await.unwrap();
        let key = |g: &str| key_for("auv1", g);
        let _ns = s
            .declare_subscriber(key(groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS.name()))
            .callback(|_| println!("NODE_STATUS auv1"))
            .await
            .unwrap();
        let (tx, mut states) = tokio::sync::mpsc::unbounded_channel();
        let _st = s
            .declare_subscriber(key(groups::GOBY_MIDDLEWARE_FRONTSEAT_STATUS.name()))
            .callback(move |sample| {
                if let Ok(st) = InterfaceStatus::decode(&*sample.payload().to_bytes()) {
                    println!("STATE {:?}", st.state());
                    let _ = tx.send(st.state());
                }
            })
            .await
            .unwrap();
        let helm = key(groups::GOBY_MIDDLEWARE_FRONTSEAT_HELM_STATE.name());
        let course = key(groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE.name());
        let drive = HelmStateReport {
            state: HelmState::HelmDrive as i32,
        };
        let dc = DesiredCourse {
            heading: Some(144.0),
            speed: Some(1.5),
            depth: Some(0.0),
            ..Default::default()
        };
        let mut end = tokio::time::Instant::now() + Duration::from_secs(seconds);
        let mut commanded = false;
        let mut puts = 0u64;
        while tokio::time::Instant::now() < end {
            let t = groups::GOBY_MIDDLEWARE_FRONTSEAT_HELM_STATE.type_name();
            put_message(&s, &helm, t, &drive, None).unwrap();
            let t = groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE.type_name();
            put_message(&s, &course, t, &dc, None).unwrap();
            puts += 2;
            tokio::time::sleep(Duration::from_millis(100)).await;
            while let Ok(st) = states.try_recv() {
                if until_command && !commanded && st == InterfaceState::InterfaceCommand {
                    commanded = true;
                    end = tokio::time::Instant::now() + Duration::from_secs(2);
                }
            }
        }
        println!("PUTS {puts}");
        s.close().await.unwrap();
        assert!(!until_command || commanded, "auv1 never reported COMMAND");
    });
}
