//! Silent clients against the basic simulator (issue 31 item 6): connections that never send
//! START must not keep a vehicle out. Real loopback TCP; every wait is bounded by a timeout.

mod common;

use std::time::Duration;

use common::*;
use frontseat_sim::SimOptions;
use tokio::io::AsyncReadExt;
use tokio::net::TcpStream;

const START: &str = "START,LAT:42.358456,LON:-71.087589,FREQ:10,WARP:1";

async fn silent(h: &frontseat_sim::SimHandle) -> TcpStream {
    tokio::time::timeout(WAIT, TcpStream::connect(h.local_addr()))
        .await
        .expect("connect within the bound")
        .expect("connect")
}

/// Waits (bounded) for the server to close a connection it was sent nothing on.
async fn closed_by_server(s: &mut TcpStream) -> bool {
    let mut b = [0u8; 256];
    loop {
        match tokio::time::timeout(WAIT, s.read(&mut b)).await {
            Ok(Ok(0)) | Ok(Err(_)) => return true,
            Ok(Ok(_)) => continue,
            Err(_) => return false,
        }
    }
}

async fn until<F: Fn() -> bool>(f: F) -> bool {
    tokio::time::timeout(WAIT, async {
        while !f() {
            tokio::time::sleep(Duration::from_millis(10)).await;
        }
    })
    .await
    .is_ok()
}

/// This process's soft limit of open files (Linux), to hold as many silent connections as the
/// machine allows.
fn open_files_limit() -> Option<usize> {
    let text = std::fs::read_to_string("/proc/self/limits").ok()?;
    let line = text.lines().find(|l| l.starts_with("Max open files"))?;
    line.split_whitespace().nth(3)?.parse().ok()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_new_vehicle_gets_in_while_1100_silent_connections_are_held() {
    // A start timeout longer than the test: the slot must come from eviction, not from waiting
    // out the timeout. The 1 100 silent connections where the fd limit allows (CI's may
    // be 1 024), and always more than max_vehicles + max_pending, so that without eviction the
    // new vehicle would be refused.
    // Half the limit: the server side of each connection holds one too until it is closed.
    let silent_n = open_files_limit().map_or(1100, |l| (l / 2).min(1100));
    let opts = SimOptions {
        start_timeout: Duration::from_secs(600),
        max_vehicles: silent_n.min(1024) / 2,
        ..SimOptions::default()
    };
    let (max_pending, max_vehicles) = (opts.max_pending, opts.max_vehicles);
    assert!(
        silent_n > max_vehicles + max_pending,
        "open-file limit too low for this test: {silent_n}"
    );
    let h = sim(opts).await;
    let mut held = Vec::new();
    for _ in 0..silent_n {
        held.push(silent(&h).await);
    }

    let mut c = Client::connect(&h).await;
    c.send(START).await;
    c.expect("CTRL,STATE:PAYLOAD").await;
    c.nav().await;
    let s = h.stats();
    assert_eq!(s.refused, 0, "{s:?}");
    assert!(s.evicted >= (silent_n - max_pending) as u64, "{s:?}");
    // The server keeps at most max_pending silent connections (descriptors bounded).
    assert!(
        until(|| h.vehicles().len() <= max_pending + 1).await,
        "{} connections still open on the server",
        h.vehicles().len()
    );
    // The oldest silent connections were closed by the server.
    assert!(closed_by_server(&mut held[0]).await);

    // A started vehicle is never evicted: more silent clients arrive, its NAV keeps coming.
    for _ in 0..(2 * max_pending) {
        held.push(silent(&h).await);
    }
    for _ in 0..5 {
        c.nav().await;
    }
    assert!(h.vehicles().len() <= max_pending + 1);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_connection_without_start_is_closed_after_the_start_timeout_a_started_one_is_not() {
    let timeout = Duration::from_millis(300);
    let h = sim(SimOptions {
        start_timeout: timeout,
        ..SimOptions::default()
    })
    .await;
    let mut quiet = silent(&h).await;
    let mut c = Client::connect(&h).await;
    c.send(START).await;
    c.expect("CTRL,STATE:PAYLOAD").await;

    assert!(closed_by_server(&mut quiet).await, "silent connection kept");
    assert_eq!(h.stats().start_timeouts, 1);
    // Well past the timeout (10 Hz NAV: 20 lines ≈ 2 s ≥ 6 timeouts) the started one runs on.
    for _ in 0..20 {
        c.nav().await;
    }
    assert_eq!(h.stats().start_timeouts, 1);
    assert_eq!(h.vehicles().len(), 1);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_oldest_silent_connection_makes_room_and_a_bad_start_does_not_count_as_one() {
    let h = sim(SimOptions {
        start_timeout: Duration::from_secs(600),
        max_pending: 2,
        max_vehicles: 2,
        ..SimOptions::default()
    })
    .await;
    // A client that only sends refused STARTs is still waiting for its first valid one.
    let mut bad = Client::connect(&h).await;
    bad.send("START,LAT:95,LON:-71").await;
    assert!(bad.must_line().await.starts_with("ERROR,REASON:"));
    let mut s2 = silent(&h).await;
    // A third waiting connection: the oldest (the bad START) goes.
    let _s3 = silent(&h).await;
    assert_eq!(bad.until_eof().await.len(), 0);
    assert!(until(|| h.stats().evicted == 1).await);
    // Two vehicles start; the waiting ones never counted against max_vehicles.
    let mut a = Client::connect(&h).await;
    a.send(START).await;
    a.expect("CTRL,STATE:PAYLOAD").await;
    let mut b = Client::connect(&h).await;
    b.send(START).await;
    b.expect("CTRL,STATE:PAYLOAD").await;
    assert!(closed_by_server(&mut s2).await);
    // max_vehicles started: a further client is refused with the reason, as before.
    let mut d = Client::connect(&h).await;
    let l = d.must_line().await;
    assert!(l.contains("too many vehicles"), "{l}");
    a.nav().await;
    b.nav().await;
}
