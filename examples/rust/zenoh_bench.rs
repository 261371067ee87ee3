//! Benchmark (not a test) of the interface across processes over Zenoh. This process plays the
//! frontseat (a TCP server speaking the basic simulator protocol, so it can timestamp both ends)
//! and a helm/subscriber (a Zenoh client); `frontseat interface` runs as a child in between.
//!   1. node_status: NAV line written → node_status received over Zenoh (p50/p99).
//!   2. desired_course: Zenoh put → CMD line read at the frontseat (p50/p99).
//!   3. raw_in at 10 000 lines/s for 3 s: lines delivered/lost over Zenoh.
//!
//! cargo build --release -p frontseat && cargo run --release -p frontseat-helm-side \
//!     --example zenoh_bench -- [PATH/TO/frontseat] [samples]

use std::collections::HashMap;
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use frontseat_actors::groups;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    DesiredCourse, HelmState, HelmStateReport, InterfaceState, InterfaceStatus, NodeStatus, Raw,
};
use frontseat_helm_side::{client_config, key_for, put_message};
use hdrhistogram::Histogram;
use prost::Message;
use tokio::io::{AsyncBufReadExt, AsyncWriteExt, BufReader};
use tokio::net::TcpListener;

struct Kill(Child);
impl Drop for Kill {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .unwrap_or(17447)
}

fn nav(seq: u64) -> String {
    format!("NAV,LAT:42.358456,LON:-71.087589,DEPTH:{seq},HEADING:90,SPEED:1\r\n")
}

fn report(name: &str, h: &Histogram<u64>) {
    println!(
        "{name:<44} n={:<6} p50={:>7.1} µs  p99={:>7.1} µs  max={:>8.1} µs",
        h.len(),
        h.value_at_quantile(0.5) as f64 / 1000.0,
        h.value_at_quantile(0.99) as f64 / 1000.0,
        h.max() as f64 / 1000.0
    );
}

type Sent = Arc<Mutex<HashMap<u64, Instant>>>;

#[tokio::main]
async fn main() -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
    let mut args = std::env::args().skip(1);
    let bin = args
        .next()
        .unwrap_or_else(|| "target/release/frontseat".into());
    let samples: u64 = args.next().and_then(|s| s.parse().ok()).unwrap_or(2000);

    // The frontseat, in this process.
    let fs = TcpListener::bind("127.0.0.1:0").await?;
    let fs_port = fs.local_addr()?.port();
    let zport = free_port();
    let dir = std::env::temp_dir().join(format!("frontseat-zbench-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let cfg = dir.join("interface.toml");
    std::fs::write(
        &cfg,
        format!(
            "name = \"bench\"\nstatus_period = 0.5\n[driver]\nname = \"basic_simulator\"\n\
             [driver.basic_simulator]\ntcp_port = {fs_port}\nnav_timeout = 60.0\n\
             [interprocess]\nenabled = true\nlisten = [\"tcp/127.0.0.1:{zport}\"]\n\
             [bus]\nqueue_capacity = 65536\n"
        ),
    )?;
    let _interface = Kill(
        Command::new(&bin)
            .arg("interface")
            .arg("-c")
            .arg(&cfg)
            .env("RUST_LOG", "warn")
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(dir.join("interface.log"))?)
            .spawn()?,
    );
    let (sock, _) = tokio::time::timeout(Duration::from_secs(20), fs.accept()).await??;
    let (rd, mut wr) = sock.into_split();
    let mut lines = BufReader::new(rd).lines();
    // START → PAYLOAD; then every CMD is answered OK and its DEPTH (our sequence) timestamped.
    let cmd_seen: Sent = Arc::default();
    let (start_tx, start_rx) = tokio::sync::oneshot::channel();
    let (ok_tx, mut ok_rx) = tokio::sync::mpsc::unbounded_channel::<()>();
    {
        let cmd_seen = cmd_seen.clone();
        tokio::spawn(async move {
            let mut start_tx = Some(start_tx);
            while let Ok(Some(l)) = lines.next_line().await {
                if l.starts_with("START") {
                    if let Some(t) = start_tx.take() {
                        let _ = t.send(());
                    }
                } else if let Some(rest) = l.strip_prefix("CMD,") {
                    let now = Instant::now();
                    let depth = rest
                        .split(',')
                        .find_map(|f| f.strip_prefix("DEPTH:"))
                        .and_then(|v| v.parse::<f64>().ok());
                    if let Some(d) = depth {
                        cmd_seen.lock().unwrap().insert(d as u64, now);
                    }
                    let _ = ok_tx.send(());
                }
            }
        });
    }
    tokio::time::timeout(Duration::from_secs(20), start_rx).await??;
    wr.write_all(b"CTRL,STATE:PAYLOAD\r\n").await?;

    let session = zenoh::open(client_config(&[format!("tcp/127.0.0.1:{zport}")])?).await?;
    let key = |g: &str| key_for("bench", g);
    let nav_seen: Sent = Arc::default();
    let ns_seen = nav_seen.clone();
    let _ns = session
        .declare_subscriber(key(groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS.name()))
        .callback(move |s| {
            let now = Instant::now();
            if let Ok(m) = NodeStatus::decode(&*s.payload().to_bytes())
                && let Some(d) = m.global_fix.depth
            {
                ns_seen.lock().unwrap().insert(d as u64, now);
            }
        })
        .await?;
    let (st_tx, mut st_rx) = tokio::sync::mpsc::unbounded_channel();
    let _st = session
        .declare_subscriber(key(groups::GOBY_MIDDLEWARE_FRONTSEAT_STATUS.name()))
        .callback(move |s| {
            if let Ok(m) = InterfaceStatus::decode(&*s.payload().to_bytes()) {
                let _ = st_tx.send(m.state());
            }
        })
        .await?;
    let raw_count = Arc::new(std::sync::atomic::AtomicU64::new(0));
    let rc = raw_count.clone();
    let _raw = session
        .declare_subscriber(key(groups::GOBY_MIDDLEWARE_FRONTSEAT_RAW_IN.name()))
        .callback(move |s| {
            if let Ok(r) = Raw::decode(&*s.payload().to_bytes()) {
                let marked = r
                    .raw
                    .as_deref()
                    .is_some_and(|b| b.windows(10).any(|w| w == b"HEADING:45"));
                if marked {
                    rc.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                }
            }
        })
        .await?;
    let hb = session.clone();
    let helm_key = key(groups::GOBY_MIDDLEWARE_FRONTSEAT_HELM_STATE.name());
    tokio::spawn(async move {
        loop {
            let drive = HelmStateReport {
                state: HelmState::HelmDrive as i32,
            };
            let _ = put_message(
                &hb,
                &helm_key,
                groups::GOBY_MIDDLEWARE_FRONTSEAT_HELM_STATE.type_name(),
                &drive,
                None,
            );
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
    });

    // Warm up until COMMAND (NAV flowing, helm driving, routes declared).
    let deadline = Instant::now() + Duration::from_secs(30);
    let mut seq = 1_000_000u64;
    loop {
        wr.write_all(nav(seq).as_bytes()).await?;
        seq += 1;
        tokio::time::sleep(Duration::from_millis(20)).await;
        let mut cmd = false;
        while let Ok(s) = st_rx.try_recv() {
            cmd |= s == InterfaceState::InterfaceCommand;
        }
        if cmd {
            break;
        }
        if Instant::now() > deadline {
            return Err("interface never reached COMMAND".into());
        }
    }

    // 1. node_status: NAV written → node_status received, one at a time (200 Hz).
    let mut sent = HashMap::new();
    for i in 0..samples {
        sent.insert(i, Instant::now());
        wr.write_all(nav(i).as_bytes()).await?;
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    tokio::time::sleep(Duration::from_millis(500)).await;
    let mut h = Histogram::<u64>::new(3)?;
    {
        let seen = nav_seen.lock().unwrap();
        for (i, t0) in &sent {
            if let Some(t1) = seen.get(i) {
                h.record(t1.duration_since(*t0).as_nanos() as u64)?;
            }
        }
    }
    report("node_status: NAV line → Zenoh subscriber", &h);

    // 2. desired_course: Zenoh put → CMD line at the frontseat (200 Hz; NAV keeps flowing).
    let course_key = key(groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE.name());
    let mut sent = HashMap::new();
    for i in 0..samples {
        let dc = DesiredCourse {
            heading: Some(90.0),
            speed: Some(1.0),
            depth: Some(i as f64),
            ..Default::default()
        };
        sent.insert(i, Instant::now());
        put_message(
            &session,
            &course_key,
            groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE.type_name(),
            &dc,
            None,
        )?;
        tokio::time::sleep(Duration::from_millis(5)).await;
        while ok_rx.try_recv().is_ok() {
            wr.write_all(b"CMD,RESULT:OK\r\n").await?;
        }
        if i % 20 == 0 {
            wr.write_all(nav(seq).as_bytes()).await?;
            seq += 1;
        }
    }
    tokio::time::sleep(Duration::from_millis(500)).await;
    let mut h = Histogram::<u64>::new(3)?;
    {
        let seen = cmd_seen.lock().unwrap();
        for (i, t0) in &sent {
            if let Some(t1) = seen.get(i) {
                h.record(t1.duration_since(*t0).as_nanos() as u64)?;
            }
        }
    }
    report("desired_course: Zenoh put → CMD line", &h);

    // 3. raw_in at 10 000 lines/s for 3 s, written 10 per millisecond.
    let total = 30_000u64;
    let t0 = Instant::now();
    let mut tick = tokio::time::interval(Duration::from_millis(1));
    let mut n = 0;
    while n < total {
        tick.tick().await;
        let mut batch = String::new();
        for _ in 0..10 {
            batch.push_str(&format!(
                "NAV,LAT:42.358456,LON:-71.087589,DEPTH:{n},HEADING:45,SPEED:1\r\n"
            ));
            n += 1;
        }
        wr.write_all(batch.as_bytes()).await?;
    }
    let took = t0.elapsed();
    tokio::time::sleep(Duration::from_secs(2)).await;
    let got = raw_count.load(std::sync::atomic::Ordering::Relaxed);
    println!(
        "raw_in: {total} lines in {:.2} s ({:.0}/s): delivered {got}, lost {}",
        took.as_secs_f64(),
        total as f64 / took.as_secs_f64(),
        total - got.min(total)
    );
    session.close().await?;
    Ok(())
}
