//! The server supervises one task per vehicle connection: a panic in one vehicle closes only its
//! own connection, is counted, and every other vehicle keeps its 10 Hz. Over real loopback TCP.

mod common;

use common::*;
use frontseat_sim::{Fault, SimOptions};

const START: &str = "START,LAT:42.358456,LON:-71.087589,FREQ:10,WARP:1";

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_panic_in_one_vehicle_closes_only_its_connection() {
    let h = sim(SimOptions::default()).await;
    let mut truth = h.subscribe_truth();
    let mut clients = Vec::new();
    let mut ids = Vec::new();
    for _ in 0..3 {
        let mut c = Client::connect(&h).await;
        c.send(START).await;
        assert_eq!(c.must_line().await, "CTRL,STATE:PAYLOAD");
        ids.push(new_vehicle(&h, &ids).await);
        clients.push(c);
    }
    let victim = ids[1];
    h.inject(Some(victim), Fault::Panic);
    // Its connection closes...
    let mut victim_client = clients.remove(1);
    let _ = victim_client.until_eof().await;
    // ...and the server keeps the others: each still ticks 10 times per simulated second.
    for (c, id) in clients.iter_mut().zip([ids[0], ids[2]]) {
        let t0 = truth_of(&mut truth, id).await.sim_time;
        let mut last = t0;
        while last < t0 + 1.0 - 1e-9 {
            let t = truth_of(&mut truth, id).await.sim_time;
            assert!(
                ((t - last) - 0.1).abs() < 1e-9,
                "vehicle {id}: {last} -> {t}"
            );
            last = t;
        }
        let n = c.nav().await;
        assert!(n.lat.is_finite());
    }
    assert_eq!(h.stats().vehicle_panics, 1);
    let mut left = h.vehicles();
    left.sort_unstable();
    assert_eq!(left, vec![ids[0], ids[2]]);
    // The server still accepts vehicles.
    let mut c = Client::connect(&h).await;
    c.send(START).await;
    assert_eq!(c.must_line().await, "CTRL,STATE:PAYLOAD");
    h.shutdown().await;
}
