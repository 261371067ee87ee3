//! Capacity benchmark of the basic simulator: `cargo run --release -p frontseat-sim --example
//! capacity -- [VEHICLES] [FREQ] [WARP] [SECONDS]` (defaults 100 10 100 10).

use std::time::Duration;

#[tokio::main]
async fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |i: usize, default: f64| -> f64 {
        args.get(i).and_then(|a| a.parse().ok()).unwrap_or(default)
    };
    let vehicles = arg(0, 100.0) as usize;
    let (freq, warp, secs) = (arg(1, 10.0), arg(2, 100.0), arg(3, 10.0));
    let report =
        frontseat_sim::capacity_bench(vehicles, freq, warp, Duration::from_secs_f64(secs)).await;
    print!("{report}");
}
