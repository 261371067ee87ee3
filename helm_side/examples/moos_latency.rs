//! Latency through the MOOS bridge, one message in flight at a time (a benchmark, not a test):
//!
//! * NAV: a NAV line written by a scripted frontseat → interface → node_status →
//!   FrontSeatTranslation → broker → NAV_X at a MOOS client playing pHelmIvP;
//! * CMD: DESIRED_SPEED notified by that client → broker → translation → desired_course →
//!   interface → CMD line read by the scripted frontseat.
//!
//! The scripted frontseat runs on OS threads so that write/read instants are taken right at the
//! socket. Each NAV line carries its sequence number in DEPTH (it comes back as NAV_DEPTH in the
//! same record as NAV_X); each DESIRED_SPEED is preceded by DESIRED_DEPTH = sequence, which the
//! CMD line carries back.
//!
//! `cargo run --release -p frontseat-actors --example moos_latency [-- COUNT]`

use std::io::{BufRead, BufReader, Write};
use std::net::{Ipv4Addr, TcpListener, TcpStream};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use frontseat_actors::bus::Bus;
use frontseat_actors::interface::InterfaceService;
use frontseat_config::{InterfaceConfig, MoosConfig};
use frontseat_helm_side::translation;
use frontseat_moos::{Broker, MoosClient, MoosClientConfig, MoosEvent};
use tokio::sync::mpsc;

type Error = Box<dyn std::error::Error + Send + Sync>;

const WAIT: Duration = Duration::from_secs(10);

fn nav_line(seq: u64) -> String {
    format!("NAV,LAT:42.358456,LON:-71.087589,DEPTH:{seq},HEADING:90,SPEED:1.5\r\n")
}

/// The sequence in a line's DEPTH field.
fn depth_of(line: &str) -> Option<u64> {
    let v = line
        .split(',')
        .find_map(|kv| kv.trim().strip_prefix("DEPTH:"))?;
    let d: f64 = v.trim().parse().ok()?;
    (d >= 1.0 && d.fract() == 0.0).then_some(d as u64)
}

/// A loopback frontseat speaking the basic simulator protocol: answers START with PAYLOAD
/// control, acknowledges CMDs (reporting the read instant of each), keeps NAV flowing at 10 Hz
/// (DEPTH 0, unmeasured) and writes measured NAV lines on request.
struct Frontseat {
    port: u16,
    conn: Arc<Mutex<Option<TcpStream>>>,
}

impl Frontseat {
    fn start(cmds: mpsc::UnboundedSender<(u64, Instant)>) -> Result<Self, Error> {
        let listener = TcpListener::bind((Ipv4Addr::LOCALHOST, 0))?;
        let port = listener.local_addr()?.port();
        let conn: Arc<Mutex<Option<TcpStream>>> = Arc::new(Mutex::new(None));
        let c = conn.clone();
        std::thread::spawn(move || {
            let Ok((stream, _)) = listener.accept() else {
                return;
            };
            let _ = stream.set_nodelay(true);
            let Ok(read_half) = stream.try_clone() else {
                return;
            };
            *c.lock().unwrap_or_else(|p| p.into_inner()) = Some(stream);
            let write = |s: &str| {
                if let Some(w) = c.lock().unwrap_or_else(|p| p.into_inner()).as_mut() {
                    let _ = w.write_all(s.as_bytes());
                }
            };
            let mut started = false;
            for line in BufReader::new(read_half).lines() {
                let Ok(line) = line else { return };
                let now = Instant::now();
                if line.starts_with("CMD,") {
                    if let Some(seq) = depth_of(&line) {
                        let _ = cmds.send((seq, now));
                    }
                    write("CMD,RESULT:OK\r\n");
                } else if line.starts_with("START,") {
                    write("CTRL,STATE:PAYLOAD\r\n");
                    write(&nav_line(0));
                    if !started {
                        started = true;
                        let c = c.clone();
                        std::thread::spawn(move || {
                            loop {
                                std::thread::sleep(Duration::from_millis(100));
                                let mut g = c.lock().unwrap_or_else(|p| p.into_inner());
                                let Some(w) = g.as_mut() else { return };
                                if w.write_all(nav_line(0).as_bytes()).is_err() {
                                    return;
                                }
                            }
                        });
                    }
                }
            }
        });
        Ok(Self { port, conn })
    }

    /// Writes a measured NAV line; returns the instant just before the write.
    fn nav(&self, seq: u64) -> Option<Instant> {
        let mut g = self.conn.lock().unwrap_or_else(|p| p.into_inner());
        let w = g.as_mut()?;
        let t = Instant::now();
        w.write_all(nav_line(seq).as_bytes()).ok()?;
        Some(t)
    }
}

fn report(what: &str, mut samples: Vec<Duration>) {
    if samples.is_empty() {
        println!("{what}: no samples");
        return;
    }
    samples.sort();
    let q = |p: f64| samples[((samples.len() - 1) as f64 * p).round() as usize];
    println!(
        "{what}: n={} p50={:?} p99={:?} max={:?}",
        samples.len(),
        q(0.5),
        q(0.99),
        q(1.0)
    );
}

#[tokio::main(flavor = "multi_thread", worker_threads = 2)]
async fn main() -> Result<(), Error> {
    let count: u64 = std::env::args()
        .nth(1)
        .map(|a| a.parse())
        .transpose()?
        .unwrap_or(2000);
    let (cmd_tx, mut cmd_rx) = mpsc::unbounded_channel();
    let fs = Frontseat::start(cmd_tx)?;
    let broker = Broker::bind("127.0.0.1:0").await?;
    let bus = Bus::new();
    let moos_cfg = MoosConfig {
        port: broker.local_addr().port(),
        ..MoosConfig::default()
    };
    let bridge = translation::spawn(&moos_cfg, "bench-auv", &bus).await?;

    // pHelmIvP stand-in: DRIVE at 4 Hz; records when NAV_X of each measured record arrives.
    let (helm, mut events) = MoosClient::start(MoosClientConfig {
        server: broker.local_addr().to_string(),
        ..MoosClientConfig::new("pHelmIvP")
    })?;
    helm.register("NAV_X", 0.0)?;
    helm.register("NAV_DEPTH", 0.0)?;
    let (nav_tx, mut nav_rx) = mpsc::unbounded_channel::<(u64, Instant)>();
    tokio::spawn(async move {
        let mut nav_x_at = None;
        while let Some(ev) = events.recv().await {
            let now = Instant::now();
            let MoosEvent::Mail(m) = ev else { continue };
            if m.key == "NAV_X" {
                nav_x_at = Some(now);
            } else if m.key == "NAV_DEPTH"
                && let (Some(d), Some(at)) = (m.as_double(), nav_x_at.take())
                && d >= 1.0
            {
                let _ = nav_tx.send((d as u64, at));
            }
        }
    });
    let h = helm.clone();
    let drive = tokio::spawn(async move {
        loop {
            let _ = h.notify_string("IVPHELM_STATE", "DRIVE", None);
            tokio::time::sleep(Duration::from_millis(250)).await;
        }
    });

    let mut cfg = InterfaceConfig {
        name: "bench-auv".into(),
        ..Default::default()
    };
    cfg.driver.basic_simulator.tcp_port = fs.port;
    let service = InterfaceService::start(&cfg, &bus, frontseat_drivers::BUILT_IN).await?;
    // Wait for the interface to reach COMMAND: the first DesiredCourse that makes a CMD.
    let deadline = Instant::now() + WAIT;
    loop {
        if Instant::now() > deadline {
            return Err("the interface never sent a CMD (no COMMAND state)".into());
        }
        helm.notify_double("DESIRED_DEPTH", 1e9, None)?;
        helm.notify_double("DESIRED_SPEED", 1.0, None)?;
        if let Ok(Some(_)) = tokio::time::timeout(Duration::from_millis(200), cmd_rx.recv()).await {
            break;
        }
    }

    let mut nav = Vec::with_capacity(count as usize);
    for seq in 1..=count {
        let Some(t0) = fs.nav(seq) else {
            return Err("frontseat connection lost".into());
        };
        loop {
            match tokio::time::timeout(WAIT, nav_rx.recv()).await {
                Ok(Some((s, at))) if s == seq => {
                    nav.push(at.saturating_duration_since(t0));
                    break;
                }
                Ok(Some(_)) => {}
                _ => return Err(format!("NAV {seq} never reached the MOOS client").into()),
            }
        }
    }
    report("NAV line -> NAV_X at a MOOS client", nav);

    while cmd_rx.try_recv().is_ok() {}
    let mut cmd = Vec::with_capacity(count as usize);
    for seq in 1..=count {
        helm.notify_double("DESIRED_DEPTH", seq as f64, None)?;
        let t0 = Instant::now();
        helm.notify_double("DESIRED_SPEED", 1.0, None)?;
        loop {
            match tokio::time::timeout(WAIT, cmd_rx.recv()).await {
                Ok(Some((s, at))) if s == seq => {
                    cmd.push(at.saturating_duration_since(t0));
                    break;
                }
                Ok(Some(_)) => {}
                _ => return Err(format!("CMD {seq} never reached the frontseat").into()),
            }
        }
    }
    report("DESIRED_SPEED notify -> CMD at the frontseat", cmd);

    drive.abort();
    service.shutdown(Duration::from_secs(3)).await;
    bridge.shutdown().await;
    helm.shutdown().await;
    broker.shutdown().await;
    Ok(())
}
