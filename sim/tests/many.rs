//! Many vehicles at once, each with its own START and course, over real loopback TCP.

mod common;

use common::*;
use frontseat_sim::SimOptions;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn twenty_vehicles_run_independently() {
    let h = sim(SimOptions::default()).await;
    let mut set = tokio::task::JoinSet::new();
    for i in 0..20u32 {
        let mut c = Client::connect(&h).await;
        set.spawn(async move {
            let (lat, lon) = (-60.0 + 6.0 * i as f64, -170.0 + 17.0 * i as f64);
            let heading = (i * 18) as f64;
            c.send(&format!(
                "START,LAT:{lat},LON:{lon},FREQ:10,WARP:20,HDG_RATE:900,ACCEL:10"
            ))
            .await;
            assert_eq!(c.must_line().await, "CTRL,STATE:PAYLOAD");
            let first = c.nav().await;
            assert_eq!((first.lat, first.lon, first.speed), (lat, lon, 0.0));
            c.send(&format!(
                "CMD,HEADING:{heading},SPEED:{},DEPTH:{i}",
                1.0 + i as f64 / 10.0
            ))
            .await;
            c.expect("CMD,RESULT:OK").await;
            let mut last = first;
            for _ in 0..40 {
                last = c.nav().await;
            }
            assert_eq!(last.heading, heading, "vehicle {i}");
            assert!(
                (last.speed - (1.0 + i as f64 / 10.0)).abs() < 1e-9,
                "vehicle {i}"
            );
            assert!(last.depth > 0.0 || i == 0);
            // Moved a few metres from its own START, along its own heading.
            let d = metres((lat, lon), (last.lat, last.lon));
            assert!(d > 1.0 && d < 20.0, "vehicle {i} moved {d} m");
            let north = (last.lat - lat) * 111_132.0;
            let cosine = north / d;
            assert!(
                (cosine - heading.to_radians().cos()).abs() < 0.05,
                "vehicle {i}"
            );
        });
    }
    while let Some(r) = set.join_next().await {
        r.unwrap();
    }
    assert_eq!(h.stats().connections, 20);
    h.shutdown().await;
}
