//! Rough latency check: one client posts NAV_X, another receives it through the in-crate broker,
//! one message at a time; prints p50/p99/max. `cargo run --release -p frontseat-moos --example latency`

use std::time::{Duration, Instant};

use frontseat_moos::{Broker, MoosClient, MoosClientConfig, MoosEvent};

#[tokio::main]
async fn main() -> Result<(), Box<dyn std::error::Error>> {
    let broker = Broker::bind("127.0.0.1:0").await?;
    let server = broker.local_addr().to_string();
    let cfg = |name: &str| MoosClientConfig {
        server: server.clone(),
        ..MoosClientConfig::new(name)
    };
    let (helm, mut helm_rx) = MoosClient::start(cfg("helm"))?;
    helm.register("NAV_X", 0.0)?;
    let (nav, mut nav_rx) = MoosClient::start(cfg("nav"))?;
    while nav_rx.recv().await != Some(MoosEvent::Connected) {}
    let mut samples = Vec::with_capacity(5000);
    for i in 0..5000 {
        let t0 = Instant::now();
        nav.notify_double("NAV_X", i as f64, None)?;
        loop {
            match tokio::time::timeout(Duration::from_secs(5), helm_rx.recv()).await? {
                Some(MoosEvent::Mail(m)) if m.as_double() == Some(i as f64) => break,
                Some(_) => {}
                None => return Err("event channel closed".into()),
            }
        }
        samples.push(t0.elapsed());
    }
    samples.sort();
    let q = |p: f64| samples[((samples.len() - 1) as f64 * p) as usize];
    println!(
        "n={} p50={:?} p99={:?} max={:?}",
        samples.len(),
        q(0.5),
        q(0.99),
        q(1.0)
    );
    nav.shutdown().await;
    helm.shutdown().await;
    broker.shutdown().await;
    Ok(())
}
