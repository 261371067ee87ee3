//! Measures the AIS reporter's cost (BENCHMARKS.md, "OpenCPN"): N vehicles' node_status fed at
//! 10 Hz each into the targets, as the topside's observer does, with the reporter on (type 18
//! every `position_interval_s`, type 24 A/B every `static_interval_s`, over UDP to a loopback
//! socket that counts them) and off; the process's CPU time over each window.
//! `cargo run --release -p frontseat-opencpn --example ais_load -- [N] [SECONDS]`.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use frontseat_actors::proto::goby::middleware::frontseat::protobuf::NodeStatus;
use frontseat_config::{AisConfig, AisVehicleConfig};
use frontseat_opencpn::feed::{AisFleet, report};
use frontseat_opencpn::transport::Outputs;

/// utime + stime of this process, from /proc/self/stat (clock ticks of 10 ms).
fn cpu() -> Duration {
    let s = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let after = s.rsplit_once(')').map(|x| x.1).unwrap_or("");
    let f: Vec<&str> = after.split_whitespace().collect();
    let t = |i: usize| f.get(i).and_then(|v| v.parse::<u64>().ok()).unwrap_or(0);
    Duration::from_millis((t(11) + t(12)) * 10)
}

/// One window: (CPU % of one core, sentences sent, sentences received at the sink).
async fn window(n: usize, secs: u64, ais: bool) -> (f64, u64, u64) {
    let sink = tokio::net::UdpSocket::bind("127.0.0.1:0").await.unwrap();
    let cfg = AisConfig {
        enabled: true,
        udp: vec![sink.local_addr().unwrap().to_string()],
        position_interval_s: 1.0,
        static_interval_s: 30.0,
        vehicle: (0..n)
            .map(|i| AisVehicleConfig {
                name: format!("v{i}"),
                mmsi: 299_000_001 + i as u32,
                label: None,
                ship_type: 33,
                call_sign: None,
                length_m: 4.0,
                beam_m: 2.0,
            })
            .collect(),
        ..Default::default()
    };
    let fleet = AisFleet::new(&cfg);
    let received = Arc::new(AtomicU64::new(0));
    let r = received.clone();
    let count = tokio::spawn(async move {
        let mut buf = vec![0u8; 4096];
        while let Ok(len) = sink.recv(&mut buf).await {
            r.fetch_add(
                buf[..len].iter().filter(|b| **b == b'!').count() as u64,
                Ordering::Relaxed,
            );
        }
    });
    let mut sent = None;
    let reporter = if ais {
        let out = Outputs::open(&cfg.udp, "", 1).await.unwrap();
        sent = Some(out.counters.clone());
        Some(tokio::spawn(report(fleet.clone(), cfg.clone(), out)))
    } else {
        None
    };
    let names: Vec<String> = (0..n).map(|i| format!("v{i}")).collect();
    let c0 = cpu();
    let t0 = Instant::now();
    let mut tick = tokio::time::interval(Duration::from_millis(100));
    let mut ns = NodeStatus::default();
    while t0.elapsed() < Duration::from_secs(secs) {
        tick.tick().await;
        for (i, name) in names.iter().enumerate() {
            ns.time = 1.7e9 + t0.elapsed().as_secs_f64();
            ns.global_fix.lat = 42.35 + i as f64 * 1e-4;
            ns.global_fix.lon = -71.08;
            ns.speed.over_ground = 1.5;
            ns.pose.heading = Some((i * 7) as f64 % 360.0);
            fleet.on_node_status(name, &ns);
        }
    }
    let used = cpu().saturating_sub(c0).as_secs_f64() / t0.elapsed().as_secs_f64() * 100.0;
    if let Some(r) = reporter {
        r.abort();
    }
    tokio::time::sleep(Duration::from_millis(200)).await;
    count.abort();
    let sent = sent.map_or(0, |c| c.sentences.load(Ordering::Relaxed));
    (used, sent, received.load(Ordering::Relaxed))
}

#[tokio::main(flavor = "current_thread")]
async fn main() {
    let args: Vec<String> = std::env::args().collect();
    let n: usize = args.get(1).and_then(|a| a.parse().ok()).unwrap_or(100);
    let secs: u64 = args.get(2).and_then(|a| a.parse().ok()).unwrap_or(10);
    let (off, _, _) = window(n, secs, false).await;
    let (on, sent, received) = window(n, secs, true).await;
    println!(
        "{n} vehicles, node_status at 10 Hz each, {secs} s windows: CPU {off:.1} % of one core without AIS, {on:.1} % with AIS; AIS sent {sent} sentences ({:.1}/s), received {received}",
        sent as f64 / secs as f64
    );
}
