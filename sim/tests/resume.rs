//! A dropped connection does not teleport the vehicle: a client that reconnects within the grace
//! period and repeats its START gets the same vehicle back; a new START, or no grace, gets a new
//! one. Over real loopback TCP.

mod common;

use std::time::Duration;

use common::*;
use frontseat_sim::{SimHandle, SimOptions};

const START_A: &str = "START,LAT:42.358456,LON:-71.087589,FREQ:10,WARP:50,ACCEL:5,HDG_RATE:900";
const START_B: &str = "START,LAT:42.3,LON:-71.0,FREQ:10,WARP:50,ACCEL:5,HDG_RATE:900";

async fn gone(h: &SimHandle, id: u64) {
    tokio::time::timeout(WAIT, async {
        while h.vehicles().contains(&id) {
            tokio::task::yield_now().await;
        }
    })
    .await
    .expect("the server never noticed the closed connection");
}

/// Start a vehicle, send it east at 2 m/s for a few simulated seconds, return (client, id, nav).
async fn moving(
    h: &SimHandle,
    start: &str,
    known: &[u64],
) -> (Client, u64, frontseat_sim::codec::Nav) {
    let mut c = Client::connect(h).await;
    c.send(start).await;
    assert_eq!(c.must_line().await, "CTRL,STATE:PAYLOAD");
    let id = new_vehicle(h, known).await;
    c.send("CMD,HEADING:90,SPEED:2,DEPTH:0").await;
    c.expect("CMD,RESULT:OK").await;
    c.others_until_navs(30).await;
    let n = c.nav().await;
    assert_eq!((n.heading, n.speed), (90.0, 2.0));
    (c, id, n)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_reconnect_with_the_same_start_continues_the_same_vehicle() {
    let h = sim(SimOptions::default()).await;
    let start = (42.358456, -71.087589);
    let (c, id, before) = moving(&h, START_A, &[]).await;
    let away = metres(start, (before.lat, before.lon));
    assert!(away > 3.0, "it moved: {away} m");
    drop(c);
    gone(&h, id).await;

    let mut c = Client::connect(&h).await;
    c.send(START_A).await;
    assert_eq!(c.must_line().await, "CTRL,STATE:PAYLOAD");
    let after = c.nav().await;
    assert_eq!(after.heading, 90.0, "heading kept");
    assert_eq!(after.speed, 2.0, "speed and setpoint kept");
    assert!(
        metres(start, (after.lat, after.lon)) >= away,
        "position kept (and it went on moving): {after:?} vs {before:?}"
    );
    assert_eq!(h.vehicles(), vec![id], "the vehicle keeps its id");
    h.shutdown().await;
}

/// A resumed vehicle reports where it is at once, as a fresh START's first tick does: at FREQ 0.01
/// (a tick every 100 s) the NAV after the reconnect can only come from the resume itself.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_resumed_vehicle_sends_its_nav_at_once() {
    const SLOW: &str = "START,LAT:42.358456,LON:-71.087589,FREQ:0.01,WARP:1";
    let h = sim(SimOptions::default()).await;
    let mut c = Client::connect(&h).await;
    c.send(SLOW).await;
    assert_eq!(c.must_line().await, "CTRL,STATE:PAYLOAD");
    let first = c.nav().await;
    let id = new_vehicle(&h, &[]).await;
    drop(c);
    gone(&h, id).await;

    let mut c = Client::connect(&h).await;
    c.send(SLOW).await;
    assert_eq!(c.must_line().await, "CTRL,STATE:PAYLOAD");
    let again = c.nav().await;
    assert_eq!(
        (again.lat, again.lon),
        (first.lat, first.lon),
        "same vehicle, same place"
    );
    assert_eq!(h.vehicles(), vec![id]);
    h.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn another_start_or_no_grace_makes_a_new_vehicle_at_rest() {
    for (opts, second) in [
        (SimOptions::default(), START_B),
        (
            SimOptions {
                resume_grace: Duration::ZERO,
                ..Default::default()
            },
            START_A,
        ),
    ] {
        let h = sim(opts).await;
        let (c, id, _) = moving(&h, START_A, &[]).await;
        drop(c);
        gone(&h, id).await;
        let mut c = Client::connect(&h).await;
        c.send(second).await;
        assert_eq!(c.must_line().await, "CTRL,STATE:PAYLOAD");
        let n = c.nav().await;
        assert_eq!((n.heading, n.speed, n.depth), (0.0, 0.0, 0.0), "{second}");
        let new = new_vehicle(&h, &[id]).await;
        assert_ne!(new, id);
        h.shutdown().await;
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn many_vehicles_each_get_their_own_back() {
    let h = sim(SimOptions::default()).await;
    let (ca, a, na) = moving(&h, START_A, &[]).await;
    let (cb, b, nb) = moving(&h, START_B, &[a]).await;
    drop(ca);
    drop(cb);
    gone(&h, a).await;
    gone(&h, b).await;
    // Reconnect in the other order.
    let mut cb = Client::connect(&h).await;
    cb.send(START_B).await;
    assert_eq!(cb.must_line().await, "CTRL,STATE:PAYLOAD");
    let mut ca = Client::connect(&h).await;
    ca.send(START_A).await;
    assert_eq!(ca.must_line().await, "CTRL,STATE:PAYLOAD");
    let (na2, nb2) = (ca.nav().await, cb.nav().await);
    assert!(metres((na.lat, na.lon), (na2.lat, na2.lon)) < 1000.0);
    assert!(metres((nb.lat, nb.lon), (nb2.lat, nb2.lon)) < 1000.0);
    assert!(metres((na2.lat, na2.lon), (nb2.lat, nb2.lon)) > 5000.0);
    assert_eq!((na2.speed, nb2.speed), (2.0, 2.0));
    let mut ids = h.vehicles();
    ids.sort_unstable();
    assert_eq!(ids, vec![a, b]);
    h.shutdown().await;
}
