//! OpenCPN's route as a helm, end to end over real sockets: `frontseat sim` (the basic
//! simulator) and `frontseat interface` with `[opencpn.helm]` and `[opencpn.ais]`, both real
//! processes. The test plays OpenCPN: it sends the autopilot sentences captured from OpenCPN
//! 5.10.2 (tests/fixtures/opencpn/), sentences built in the same writers' field order for the
//! legs it needs, garbage and wrong checksums, over UDP to the interface; it watches the vehicle
//! turn in the interface's own AIS reports (UDP, decoded here by the AIS bit layout), and the
//! helm's and the interface's log lines for the checksum count, the arrival and the timeout.

mod common;

use std::process::Stdio;
use std::time::{Duration, Instant};

use common::ais::{angle_diff, type18};
use common::procs::{frontseat_interface, frontseat_sim, scratch};
use tokio::net::UdpSocket;

/// `$` + body + checksum, as OpenCPN's writers do.
fn sentence(body: &str) -> String {
    let sum = body.bytes().fold(0u8, |a, b| a ^ b);
    format!("${body}*{sum:02X}\r\n")
}

fn fixture() -> Vec<String> {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/fixtures/opencpn/autopilot_5.10.2.nmea"
    ))
    .unwrap();
    text.lines()
        .filter(|l| !l.starts_with('#') && !l.is_empty())
        .map(|l| format!("{l}\r\n"))
        .collect()
}

struct Run {
    ais: UdpSocket,
    to_helm: UdpSocket,
    helm: std::net::SocketAddr,
    log: std::path::PathBuf,
}

impl Run {
    /// The newest heading (and SOG) of MMSI 299000001 within `bound`, polling `pred`.
    async fn until_heading(
        &self,
        what: &str,
        bound: Duration,
        mut feed: impl FnMut() -> Vec<String>,
        pred: impl Fn(f64) -> bool,
    ) -> (f64, Duration) {
        let t0 = Instant::now();
        let mut buf = vec![0u8; 4096];
        let mut next_feed = Instant::now();
        let mut last = None;
        loop {
            assert!(
                t0.elapsed() < bound,
                "{what}: not within {bound:?}; last heading {last:?}\n{}",
                self.log_text()
            );
            if Instant::now() >= next_feed {
                for s in feed() {
                    self.to_helm.send_to(s.as_bytes(), self.helm).await.unwrap();
                }
                next_feed = Instant::now() + Duration::from_millis(500);
            }
            if let Ok(Ok(n)) =
                tokio::time::timeout(Duration::from_millis(100), self.ais.recv(&mut buf)).await
            {
                let text = String::from_utf8_lossy(&buf[..n]).into_owned();
                for l in text.lines() {
                    if let Some((299_000_001, h, _)) = type18(l) {
                        last = Some(h);
                        if h != 511 && pred(h as f64) {
                            return (h as f64, t0.elapsed());
                        }
                    }
                }
            }
        }
    }

    fn log_text(&self) -> String {
        std::fs::read_to_string(&self.log).unwrap_or_default()
    }

    async fn until_log(&self, what: &str, bound: Duration) {
        let t0 = Instant::now();
        while !self.log_text().contains(what) {
            assert!(
                t0.elapsed() < bound,
                "log line `{what}` not within {bound:?}:\n{}",
                self.log_text()
            );
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_opencpn_route_steers_the_vehicle_and_times_out() {
    let dir = scratch("opencpn_helm", "route");
    let (_sim, sim_port) = frontseat_sim(Stdio::null()).await;
    let ais = UdpSocket::bind("127.0.0.1:0").await.unwrap();
    let helm_port = {
        let s = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
        s.local_addr().unwrap().port()
    };
    let cfg = format!(
        r#"name = "auv1"
helm_state_timeout = 2.0
status_period = 1.0
[driver.basic_simulator]
tcp_port = {sim_port}
[interprocess]
enabled = false
[opencpn.ais]
enabled = true
udp = ["{ais}"]
position_interval_s = 0.2
stale_after_s = 2.0
[[opencpn.ais.vehicle]]
name = "auv1"
mmsi = 299000001
[opencpn.helm]
enabled = true
listen = "127.0.0.1:{helm_port}"
speed = 2.0
timeout_s = 2.0
"#,
        ais = ais.local_addr().unwrap()
    );
    let _iface = frontseat_interface(&dir, &cfg);
    let log = dir.join("interface.log");
    let run = Run {
        ais,
        to_helm: UdpSocket::bind("127.0.0.1:0").await.unwrap(),
        helm: format!("127.0.0.1:{helm_port}").parse().unwrap(),
        log,
    };
    // The vehicle is reported before any helm drives it.
    run.until_heading(
        "the first AIS report",
        Duration::from_secs(30),
        Vec::new,
        |_| true,
    )
    .await;

    // The captured sentences go once, so the helm must be listening first: a datagram sent
    // before its socket is bound is lost (the AIS report can come first).
    run.until_log("OpenCPN helm: listening", Duration::from_secs(30))
        .await;

    // Leg 1, built in RMB's and APB's field order (arrival V), with garbage and a wrong
    // checksum in the same datagrams; the captured sentences once (their arrival flags are A).
    let mut fixture_once = Some(fixture());
    let leg1 = move || {
        let mut v = fixture_once.take().unwrap_or_default();
        v.push("garbage \u{1}\u{2} $$ !!*\r\n".to_string());
        v.push("$ECAPB,A,A,0.004,L,N,V,V,100.000,T,WPX,100.000,T,100.000,T*00\r\n".to_string());
        v.push(sentence(
            "ECRMB,A,0.010,R,,WP1,4221.700,N,07104.300,W,0.500,100.000,1.000,V,A",
        ));
        v.push(sentence(
            "ECAPB,A,A,0.010,R,N,V,V,100.000,T,WP1,100.000,T,100.000,T",
        ));
        v
    };
    let (h1, t1) = run
        .until_heading(
            "turn to leg 1 (100 deg)",
            Duration::from_secs(60),
            leg1,
            |h| angle_diff(h, 100.0) <= 3.0,
        )
        .await;
    // The route switched mid-leg: a new destination, a new bearing.
    let leg2 = || {
        vec![
            sentence("ECRMB,A,0.020,L,WP1,WP2,4220.900,N,07105.900,W,0.800,230.000,1.000,V,A"),
            sentence("ECAPB,A,A,0.020,L,N,V,V,230.000,T,WP2,230.000,T,230.000,T"),
            sentence("ECXTE,A,A,0.020,L,N"),
        ]
    };
    let switched = Instant::now();
    let (_, t2) = run
        .until_heading(
            "turn to leg 2 (230 deg)",
            Duration::from_secs(60),
            leg2,
            |h| angle_diff(h, 230.0) <= 3.0,
        )
        .await;
    // Settled: the error a few reports later.
    let (h3, _) = run
        .until_heading("settled on leg 2", Duration::from_secs(30), leg2, |_| {
            switched.elapsed() > t2 + Duration::from_secs(2)
        })
        .await;
    println!(
        "MEASURE opencpn helm: leg 1 heading {h1} after {t1:?}; leg 2 switch to within 3 deg in {t2:?}, settled heading {h3} (error {:.1} deg)",
        angle_diff(h3, 230.0)
    );
    run.until_log("OpenCPN helm: bad checksum", Duration::from_secs(5))
        .await;
    run.until_log("OpenCPN helm: arrived", Duration::from_secs(5))
        .await;
    // OpenCPN stops at the route's end: the helm stops driving and the interface's helm timeout
    // takes the vehicle out of COMMAND.
    run.until_log(
        "no valid APB/RMB; no longer driving",
        Duration::from_secs(10),
    )
    .await;
    run.until_log(
        "helm_state not heard within helm_state_timeout",
        Duration::from_secs(10),
    )
    .await;
    assert!(angle_diff(h3, 230.0) <= 3.0, "settled heading {h3}");
}

/// Forwards the interface's connection to the simulator, and sends each CMD line the interface
/// writes (with when it was read) to `tx`.
async fn cmd_tap(
    listen: tokio::net::TcpListener,
    sim_port: u16,
    tx: tokio::sync::mpsc::UnboundedSender<(Instant, String)>,
) {
    use tokio::io::{AsyncBufReadExt, AsyncWriteExt};
    let (inner, _) = listen.accept().await.unwrap();
    let sim = tokio::net::TcpStream::connect(("127.0.0.1", sim_port))
        .await
        .unwrap();
    let (ir, mut iw) = inner.into_split();
    let (mut sr, mut sw) = sim.into_split();
    tokio::spawn(async move {
        let _ = tokio::io::copy(&mut sr, &mut iw).await;
    });
    let mut lines = tokio::io::BufReader::new(ir);
    let mut line = String::new();
    while lines.read_line(&mut line).await.is_ok_and(|n| n > 0) {
        if line.starts_with("CMD,") {
            let _ = tx.send((Instant::now(), line.trim_end().to_string()));
        }
        if sw.write_all(line.as_bytes()).await.is_err() {
            break;
        }
        line.clear();
    }
}

/// Time from a new APB (a new bearing) sent over UDP to the CMD line with that heading at the
/// vehicle: printed (BENCHMARKS.md), not asserted; asserted only that every one arrives.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn every_new_apb_reaches_the_vehicle_as_a_cmd_line() {
    let dir = scratch("opencpn_helm", "latency");
    let (_sim, sim_port) = frontseat_sim(Stdio::null()).await;
    let tap = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let tap_port = tap.local_addr().unwrap().port();
    let (tx, mut cmds) = tokio::sync::mpsc::unbounded_channel();
    tokio::spawn(cmd_tap(tap, sim_port, tx));
    let helm_port = {
        let s = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
        s.local_addr().unwrap().port()
    };
    let cfg = format!(
        "name = \"auv1\"\nhelm_state_timeout = 2.0\n[driver.basic_simulator]\ntcp_port = {tap_port}\n[interprocess]\nenabled = false\n[opencpn.helm]\nenabled = true\nlisten = \"127.0.0.1:{helm_port}\"\nspeed = 2.0\ntimeout_s = 2.0\n"
    );
    let _iface = frontseat_interface(&dir, &cfg);
    let to = UdpSocket::bind("127.0.0.1:0").await.unwrap();
    let helm: std::net::SocketAddr = format!("127.0.0.1:{helm_port}").parse().unwrap();
    let apb = |b: u32| {
        sentence(&format!(
            "ECAPB,A,A,0.000,R,N,V,V,{b}.000,T,WP{b},{b}.000,T,{b}.000,T"
        ))
    };
    // Until the vehicle is in COMMAND: the first course reaches it as a CMD line.
    let t0 = Instant::now();
    loop {
        assert!(
            t0.elapsed() < Duration::from_secs(60),
            "no CMD line within 60 s"
        );
        to.send_to(apb(10).as_bytes(), helm).await.unwrap();
        if let Ok(Some(_)) = tokio::time::timeout(Duration::from_millis(300), cmds.recv()).await {
            break;
        }
    }
    let mut lat = Vec::new();
    for k in 0..20u32 {
        let b = 20 + k * 15;
        while cmds.try_recv().is_ok() {}
        let sent = Instant::now();
        to.send_to(apb(b).as_bytes(), helm).await.unwrap();
        let want = format!("HEADING:{b}");
        loop {
            let (at, line) = tokio::time::timeout(Duration::from_secs(5), cmds.recv())
                .await
                .expect("a CMD line within 5 s")
                .unwrap();
            if line.contains(&want) {
                lat.push(at.duration_since(sent));
                break;
            }
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    lat.sort();
    println!(
        "MEASURE opencpn helm: APB (new bearing) over UDP -> CMD line at the vehicle, {} samples: min {:?}, p50 {:?}, max {:?}",
        lat.len(),
        lat[0],
        lat[lat.len() / 2],
        lat[lat.len() - 1]
    );
}
