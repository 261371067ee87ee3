//! Fault injection from the handle and from SimOptions, over real loopback TCP.

mod common;

use common::*;
use frontseat_sim::{CtrlState, Fault, ScheduledFault, SimOptions};

const START: &str = "START,LAT:42.358456,LON:-71.087589,WARP:20";

async fn started(h: &frontseat_sim::SimHandle, known: &[u64]) -> (Client, u64) {
    let mut c = Client::connect(h).await;
    let id = new_vehicle(h, known).await;
    c.send(START).await;
    c.expect("CTRL,STATE:PAYLOAD").await;
    (c, id)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn drop_connection_drops_only_that_vehicle() {
    let h = sim(SimOptions::default()).await;
    let (mut a, ida) = started(&h, &[]).await;
    let (mut b, _) = started(&h, &[ida]).await;
    h.inject(Some(ida), Fault::DropConnection);
    assert!(a.until_eof().await.is_empty());
    assert!(b.others_until_navs(5).await.is_empty());
    tokio::time::timeout(WAIT, async {
        while h.vehicles().contains(&ida) {
            tokio::task::yield_now().await;
        }
    })
    .await
    .unwrap();
    assert_eq!(h.vehicles().len(), 1);
    h.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn ctrl_auv_refuses_cmd_until_payload_and_idle_stops_nav() {
    let h = sim(SimOptions::default()).await;
    let (mut c, id) = started(&h, &[]).await;
    h.inject(Some(id), Fault::Ctrl(CtrlState::Auv));
    c.expect("CTRL,STATE:AUV").await;
    c.send("CMD,HEADING:90,SPEED:1,DEPTH:0").await;
    c.expect("CMD,RESULT:ERROR").await;
    // NAV keeps flowing while the frontseat is in control.
    c.others_until_navs(3).await;
    h.inject(Some(id), Fault::Ctrl(CtrlState::Payload));
    c.expect("CTRL,STATE:PAYLOAD").await;
    c.send("CMD,HEADING:90,SPEED:1,DEPTH:0").await;
    c.expect("CMD,RESULT:OK").await;
    h.inject(Some(id), Fault::Ctrl(CtrlState::Idle));
    c.expect("CTRL,STATE:IDLE").await;
    // No NAV after IDLE: the next line is the answer to this CMD.
    c.send("CMD,HEADING:90,SPEED:1,DEPTH:0").await;
    assert_eq!(c.must_line().await, "CMD,RESULT:ERROR");
    assert_eq!(h.stats().faults, 3);
    h.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn garbage_and_oversized_lines_reach_the_client() {
    let h = sim(SimOptions::default()).await;
    let (mut c, id) = started(&h, &[]).await;
    h.inject(Some(id), Fault::Garbage { lines: 5 });
    let mut got = Vec::new();
    while got.len() < 5 {
        let l = c.raw_line().await.unwrap();
        if !l.starts_with(b"NAV,LAT:4") {
            got.push(l);
        }
    }
    assert!(got[0].starts_with(b"#GARBAGE~0~"));
    assert!(got[1].starts_with(b"NAV,LAT:not-a-number"));
    assert!(std::str::from_utf8(&got[2]).is_err());
    assert!(got[3].is_empty());
    assert!(got[4].starts_with(b"#GARBAGE~4~"));
    h.inject(Some(id), Fault::OversizedLine);
    loop {
        let l = c.raw_line().await.unwrap();
        if l.len() > 1024 {
            assert!(l.len() >= 64 * 1024 && l.iter().all(|&b| b == b'X'));
            break;
        }
    }
    c.others_until_navs(2).await;
    h.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn inject_to_every_vehicle() {
    let h = sim(SimOptions::default()).await;
    let (mut a, ida) = started(&h, &[]).await;
    let (mut b, _) = started(&h, &[ida]).await;
    h.inject(None, Fault::Ctrl(CtrlState::Auv));
    a.expect("CTRL,STATE:AUV").await;
    b.expect("CTRL,STATE:AUV").await;
    h.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn scheduled_stop_nav_suppresses_exactly_its_ticks() {
    let h = sim(SimOptions {
        scheduled_faults: vec![ScheduledFault {
            at_s: 1.0,
            fault: Fault::StopNav { seconds: 1.0 },
        }],
        ..SimOptions::default()
    })
    .await;
    let mut truth = h.subscribe_truth();
    let mut c = Client::connect(&h).await;
    let id = new_vehicle(&h, &[]).await;
    c.send("START,LAT:1,LON:1,DURATION:3,FREQ:10,WARP:20").await;
    c.expect("CTRL,STATE:PAYLOAD").await;
    let mut navs = 0;
    loop {
        let l = c.must_line().await;
        if l == "CTRL,STATE:IDLE" {
            break;
        }
        assert!(is_nav(&l));
        navs += 1;
    }
    // Ticks 0..=29 ran; 10..=19 sent no NAV, but truth kept flowing for them.
    let skipped = h.stats().skipped_ticks as usize;
    assert!(
        navs <= 20 && navs + skipped >= 20,
        "{navs} NAV, {skipped} skipped"
    );
    let mut truths = 0;
    while let Ok(t) = truth.try_recv() {
        assert_eq!(t.vehicle, id);
        truths += 1;
    }
    assert!(truths + skipped >= 30, "{truths}");
    h.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn scheduled_drop_fires_at_its_sim_time() {
    let h = sim(SimOptions {
        scheduled_faults: vec![ScheduledFault {
            at_s: 0.5,
            fault: Fault::DropConnection,
        }],
        ..SimOptions::default()
    })
    .await;
    let mut c = Client::connect(&h).await;
    c.send("START,LAT:1,LON:1,FREQ:10,WARP:20").await;
    c.expect("CTRL,STATE:PAYLOAD").await;
    let mut navs = 0;
    while let Some(l) = c.line().await {
        assert!(is_nav(&l));
        navs += 1;
    }
    let skipped = h.stats().skipped_ticks as usize;
    // Ticks 0..=4 report; the fault fires at tick 5 before its NAV.
    assert!(navs <= 5 && navs + skipped >= 5, "{navs}");
    h.shutdown().await;
}
