//! One test per "better than the reference" point of issue 3, over real loopback TCP.

mod common;

use std::time::Duration;

use common::*;
use frontseat_sim::SimOptions;

const POS: &str = "LAT:42.358456,LON:-71.087589";

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn bad_start_values_are_refused_and_the_vehicle_stays_as_it_was() {
    let h = sim(SimOptions::default()).await;
    let mut c = Client::connect(&h).await;
    // (fields after START, field the reason must name)
    let rows = [
        ("LAT:42,LON:-71,FREQ:0", "FREQ"),
        ("LAT:42,LON:-71,WARP:0", "WARP"),
        ("LAT:95,LON:-71", "LAT"),
        ("LAT:abc,LON:-71", "LAT"),
        ("LAT:nan,LON:-71", "LAT"),
        ("LAT:42,LON:inf", "LON"),
        ("LAT:42,LON:-181", "LON"),
        ("LON:-71", "LAT"),
        ("LAT:42,LON:-71,FREQ:-10", "FREQ"),
        ("LAT:42,LON:-71,FREQ:5000", "FREQ"),
        ("LAT:42,LON:-71,WARP:1e6", "WARP"),
        ("LAT:42,LON:-71,DURATION:-1", "DURATION"),
        ("LAT:42,LON:-71,ACCEL:-1", "ACCEL"),
        ("LAT:42,LON:-71,HDG_RATE:-1", "HDG_RATE"),
        ("LAT:42,LON:-71,Z_RATE:-1", "Z_RATE"),
    ];
    for (fields, field) in rows {
        c.send(&format!("START,{fields}")).await;
        let l = c.must_line().await;
        assert!(l.starts_with("ERROR,REASON:"), "{fields}: {l}");
        assert!(l.contains(field), "{fields}: {l}");
        assert_eq!(l.matches(',').count(), 1, "reason has no commas: {l}");
    }
    // Still not started: no NAV came, and CMD is refused.
    c.send("CMD,HEADING:90,SPEED:1,DEPTH:0").await;
    assert_eq!(c.must_line().await, "CMD,RESULT:ERROR");
    assert_eq!(h.stats().start_errors, rows.len() as u64);

    // While running, a bad START changes nothing: the vehicle keeps its course and speed.
    c.send(&format!("START,{POS},FREQ:10,WARP:20,ACCEL:5,HDG_RATE:900"))
        .await;
    assert_eq!(c.must_line().await, "CTRL,STATE:PAYLOAD");
    c.send("CMD,HEADING:90,SPEED:2,DEPTH:0").await;
    c.expect("CMD,RESULT:OK").await;
    c.others_until_navs(10).await;
    c.send("START,LAT:95,LON:-71").await;
    let l = c.non_nav().await.unwrap();
    assert!(
        l.starts_with("ERROR,REASON:LAT") || l.contains("LAT"),
        "{l}"
    );
    let n = c.nav().await;
    assert_eq!((n.heading, n.speed), (90.0, 2.0));
    assert!(n.lon > -71.087589 && n.lat.is_finite());
    h.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn freq_2_5_ticks_every_0_4_simulated_seconds() {
    let h = sim(SimOptions::default()).await;
    let mut truth = h.subscribe_truth();
    let mut c = Client::connect(&h).await;
    let id = new_vehicle(&h, &[]).await;
    c.send(&format!("START,{POS},FREQ:2.5,WARP:100")).await;
    assert_eq!(c.must_line().await, "CTRL,STATE:PAYLOAD");
    let mut last = truth_of(&mut truth, id).await.sim_time;
    assert_eq!(last, 0.0);
    for _ in 0..5 {
        let t = truth_of(&mut truth, id).await.sim_time;
        assert!(
            ((t - last) * 2.5 - ((t - last) * 2.5).round()).abs() < 1e-9,
            "{last} -> {t}"
        );
        assert!(t > last);
        last = t;
    }
    let s = h.stats();
    // Every tick is 0.4 s apart in sim time; without skips they are consecutive.
    if s.skipped_ticks == 0 {
        assert!((last - 2.0).abs() < 1e-9, "{last}");
    }
    h.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn duration_is_honoured_to_the_tick() {
    let h = sim(SimOptions::default()).await;
    // (DURATION, FREQ, NAV lines before IDLE)
    for (duration, freq, want) in [(1.0, 10.0, 10), (0.25, 10.0, 3), (2.0, 2.5, 5)] {
        let mut c = Client::connect(&h).await;
        c.send(&format!(
            "START,{POS},DURATION:{duration},FREQ:{freq},WARP:20"
        ))
        .await;
        assert_eq!(c.must_line().await, "CTRL,STATE:PAYLOAD");
        let before = h.stats().skipped_ticks;
        let mut navs = 0;
        loop {
            let l = c.must_line().await;
            if l == "CTRL,STATE:IDLE" {
                break;
            }
            assert!(is_nav(&l), "{l}");
            navs += 1;
        }
        let skipped = (h.stats().skipped_ticks - before) as usize;
        assert_eq!(navs + skipped, want, "DURATION {duration} FREQ {freq}");
        // No NAV after IDLE: the very next line answers this CMD, with ERROR (not started).
        c.send("CMD,HEADING:0,SPEED:1,DEPTH:0").await;
        assert_eq!(c.must_line().await, "CMD,RESULT:ERROR");
    }
    h.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn each_connection_is_its_own_vehicle() {
    let h = sim(SimOptions::default()).await;
    let mut a = Client::connect(&h).await;
    let mut b = Client::connect(&h).await;
    a.send("START,LAT:10,LON:20,WARP:20,HDG_RATE:90").await;
    assert_eq!(a.must_line().await, "CTRL,STATE:PAYLOAD");
    a.others_until_navs(3).await;
    // B has not started: it gets no NAV, and its CMD is refused on B only.
    b.send("CMD,HEADING:180,SPEED:1,DEPTH:0").await;
    assert_eq!(b.must_line().await, "CMD,RESULT:ERROR");
    b.send("START,LAT:-30,LON:150,WARP:20").await;
    assert_eq!(b.must_line().await, "CTRL,STATE:PAYLOAD");
    let nb = b.nav().await;
    assert_eq!((nb.lat, nb.lon), (-30.0, 150.0));
    a.send("CMD,HEADING:90,SPEED:1,DEPTH:3").await;
    a.expect("CMD,RESULT:OK").await;
    let mut last_a = a.nav().await;
    for _ in 0..20 {
        last_a = a.nav().await;
    }
    assert_eq!(last_a.heading, 90.0);
    assert!((last_a.lat - 10.0).abs() < 0.01 && (last_a.lon - 20.0).abs() < 0.01);
    let others = b.others_until_navs(20).await;
    assert!(others.is_empty(), "B saw A's lines: {others:?}");
    let nb = b.nav().await;
    assert_eq!(
        (nb.lat, nb.lon, nb.heading, nb.speed, nb.depth),
        (-30.0, 150.0, 0.0, 0.0, 0.0)
    );
    h.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_new_start_resets_the_vehicle_at_rest_at_the_new_position() {
    let h = sim(SimOptions::default()).await;
    let mut c = Client::connect(&h).await;
    c.send(&format!("START,{POS},WARP:20,ACCEL:2")).await;
    assert_eq!(c.must_line().await, "CTRL,STATE:PAYLOAD");
    c.send("CMD,HEADING:90,SPEED:2,DEPTH:10").await;
    c.expect("CMD,RESULT:OK").await;
    loop {
        if c.nav().await.speed >= 2.0 {
            break;
        }
    }
    c.send("START,LAT:43,LON:-70,WARP:20").await;
    c.expect("CTRL,STATE:PAYLOAD").await;
    for _ in 0..5 {
        let n = c.nav().await;
        assert_eq!(
            (n.lat, n.lon, n.depth, n.heading, n.speed),
            (43.0, -70.0, 0.0, 0.0, 0.0)
        );
    }
    h.shutdown().await;
}

#[tokio::test(start_paused = true)]
async fn deadline_ticks_do_not_drift() {
    let h = sim(SimOptions::default()).await;
    let mut c = Client::connect(&h).await;
    c.send(&format!("START,{POS},FREQ:3,WARP:1")).await;
    assert_eq!(c.must_line().await, "CTRL,STATE:PAYLOAD");
    c.nav().await;
    let t0 = tokio::time::Instant::now();
    // 3 Hz: a period of 1/3 s that no float sum adds up exactly; 3000 ticks = 1000 s.
    for _ in 0..3000 {
        c.nav().await;
    }
    let elapsed = t0.elapsed();
    let want = Duration::from_secs(1000);
    let off = elapsed.abs_diff(want);
    assert!(off < Duration::from_millis(2), "elapsed {elapsed:?}");
    let s = h.stats();
    assert_eq!((s.skipped_ticks, s.late_ticks), (0, 0));
    h.shutdown().await;
}

#[tokio::test(start_paused = true)]
async fn stale_ticks_are_skipped_not_burst() {
    let h = sim(SimOptions::default()).await;
    let mut truth = h.subscribe_truth();
    let mut c = Client::connect(&h).await;
    let id = new_vehicle(&h, &[]).await;
    c.send(&format!("START,{POS},FREQ:10,WARP:1")).await;
    assert_eq!(c.must_line().await, "CTRL,STATE:PAYLOAD");
    c.send("CMD,HEADING:0,SPEED:1,DEPTH:0").await;
    c.expect("CMD,RESULT:OK").await;
    assert_eq!(truth_of(&mut truth, id).await.sim_time, 0.0);
    // The process "stalls" for 2 s: ticks 1..=20 all come due at once.
    tokio::time::advance(Duration::from_secs(2)).await;
    let n = c.nav().await;
    let t = truth_of(&mut truth, id).await;
    assert!((t.sim_time - 2.0).abs() < 1e-9, "{}", t.sim_time);
    // The skipped ticks were still integrated: 20 ticks of ramping at 0.5 m/s².
    assert!((n.speed - 1.0).abs() < 1e-9, "{}", n.speed);
    assert!(t.y > 0.5, "{}", t.y);
    assert_eq!(h.stats().skipped_ticks, 19);
    h.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn oversized_line_closes_only_that_connection() {
    let h = sim(SimOptions::default()).await;
    let mut a = Client::connect(&h).await;
    let mut b = Client::connect(&h).await;
    for c in [&mut a, &mut b] {
        c.send(&format!("START,{POS},WARP:20")).await;
        c.expect("CTRL,STATE:PAYLOAD").await;
    }
    // Exactly at the limit: accepted as a line (unknown key), not oversized.
    a.send(&"A".repeat(1024)).await;
    a.others_until_navs(3).await;
    assert_eq!((h.stats().oversized, h.stats().bad_lines), (0, 1));
    // One byte over; a second writer with no newline at all must be bounded too.
    a.try_send_raw(format!("{}\r\n", "A".repeat(1025)).as_bytes())
        .await;
    assert_eq!(a.until_eof().await, Vec::<String>::new());
    let mut c = Client::connect(&h).await;
    c.try_send_raw(&vec![b'x'; 1 << 20]).await;
    c.until_eof().await;
    assert_eq!(h.stats().oversized, 2);
    // B is unaffected.
    assert!(b.others_until_navs(10).await.is_empty());
    b.send("CMD,HEADING:1,SPEED:1,DEPTH:0").await;
    b.expect("CMD,RESULT:OK").await;
    h.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn bad_lines_are_counted_and_answered_where_a_reply_is_due() {
    let h = sim(SimOptions::default()).await;
    let mut c = Client::connect(&h).await;
    // Before START: CMD is refused.
    c.send("CMD,HEADING:90,SPEED:1.5,DEPTH:0").await;
    assert_eq!(c.must_line().await, "CMD,RESULT:ERROR");
    assert_eq!(h.stats().cmd_errors, 1);
    c.send(&format!("START,{POS},WARP:20")).await;
    c.expect("CTRL,STATE:PAYLOAD").await;
    c.send_raw(b"\xff\xfe\r\n\r\nFOO,BAR:1\r\nCMD,HEADING:\xff9,SPEED:1,DEPTH:0\r\n")
        .await;
    c.send_raw(b"START,LAT:\xff\r\nCMD,HEADING:90,SPEED:1,DEPTH:0\n")
        .await;
    let mut replies = Vec::new();
    while replies.len() < 3 {
        replies.push(c.non_nav().await.unwrap());
    }
    assert_eq!(replies[0], "CMD,RESULT:ERROR");
    assert!(replies[1].starts_with("ERROR,REASON:") && replies[1].contains("UTF-8"));
    assert_eq!(replies[2], "CMD,RESULT:OK", "LF-only line is a line");
    let s = h.stats();
    assert_eq!((s.bad_lines, s.cmd_errors, s.start_errors), (5, 2, 1));
    h.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn ocean_current_drifts_the_vehicle() {
    let h = sim(SimOptions {
        current_east: 0.5,
        current_north: -0.25,
        ..SimOptions::default()
    })
    .await;
    let mut truth = h.subscribe_truth();
    let mut c = Client::connect(&h).await;
    let id = new_vehicle(&h, &[]).await;
    c.send(&format!("START,{POS},WARP:50")).await;
    c.expect("CTRL,STATE:PAYLOAD").await;
    let mut t = truth_of(&mut truth, id).await;
    while t.sim_time < 10.0 - 1e-9 {
        t = truth_of(&mut truth, id).await;
    }
    assert!(
        (t.x - 5.0).abs() < 1e-6 && (t.y + 2.5).abs() < 1e-6,
        "{t:?}"
    );
    assert_eq!(t.speed, 0.0);
    assert!(t.lon > -71.087589 && t.lat < 42.358456);
    assert!((metres((42.358456, -71.087589), (t.lat, t.lon)) - 5.59).abs() < 0.01);
    h.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn truth_matches_what_nav_reports() {
    let h = sim(SimOptions::default()).await;
    let mut truth = h.subscribe_truth();
    let mut c = Client::connect(&h).await;
    let id = new_vehicle(&h, &[]).await;
    c.send(&format!("START,{POS},WARP:20")).await;
    c.expect("CTRL,STATE:PAYLOAD").await;
    c.send("CMD,HEADING:300,SPEED:1.5,DEPTH:4").await;
    let mut compared = 0;
    while compared < 30 {
        let l = c.must_line().await;
        if !is_nav(&l) {
            continue;
        }
        let n = nav_of(&l);
        let t = truth_of(&mut truth, id).await;
        assert!((n.lat - t.lat).abs() < 1e-8 && (n.lon - t.lon).abs() < 1e-8);
        assert!((n.heading - t.heading).abs() < 1e-6 && (n.speed - t.speed).abs() < 1e-6);
        assert!((n.depth - t.depth).abs() < 1e-6);
        compared += 1;
    }
    h.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn connections_over_max_vehicles_are_told_and_closed() {
    let h = sim(SimOptions {
        max_vehicles: 2,
        ..SimOptions::default()
    })
    .await;
    // Vehicles are connections that sent START; silent ones are bounded by max_pending instead
    // (tests/hostile_idle.rs).
    let mut a = Client::connect(&h).await;
    a.send(&format!("START,{POS}")).await;
    a.expect("CTRL,STATE:PAYLOAD").await;
    let mut b = Client::connect(&h).await;
    b.send(&format!("START,{POS}")).await;
    b.expect("CTRL,STATE:PAYLOAD").await;
    let mut c = Client::connect(&h).await;
    let l = c.must_line().await;
    assert!(l.starts_with("ERROR,REASON:too many vehicles"), "{l}");
    assert_eq!(c.line().await, None);
    assert_eq!(h.stats().refused, 1);
    h.shutdown().await;
}

/// The tick accounting a benchmark reads: every due tick is integrated (a stall skips reporting
/// stale ones, never their integration), and the ticks of a window are counted by deadline,
/// integrated and reported apart, however late they are processed.
#[tokio::test(start_paused = true)]
async fn ticks_are_counted_integrated_and_reported_apart_by_deadline() {
    let h = sim(SimOptions::default()).await;
    let mut c = Client::connect(&h).await;
    c.send(&format!("START,{POS},FREQ:10,WARP:1")).await;
    assert_eq!(c.must_line().await, "CTRL,STATE:PAYLOAD");
    c.nav().await;
    assert_eq!(h.stats().running, 1);
    let t0 = tokio::time::Instant::now();
    // Ticks 5..=14 are due in this window (deadlines 0.5 s .. 1.4 s).
    h.count_ticks_due_in(t0 + ms(450), t0 + ms(1450));
    // The process "stalls" for 2 s: ticks 1..=20 come due at once, only tick 20 is reported.
    tokio::time::advance(Duration::from_secs(2)).await;
    c.nav().await;
    let s = h.stats();
    assert_eq!(
        (s.integrated_ticks, s.nav_lines, s.skipped_ticks),
        (21, 2, 19)
    );
    assert_eq!((s.window_ticks, s.window_navs), (10, 0));
    // On time: ticks 21..=30 due in the next window, all integrated and reported.
    let t1 = t0 + Duration::from_secs(2);
    h.count_ticks_due_in(t1 + ms(50), t1 + ms(1050));
    for _ in 0..11 {
        c.nav().await;
    }
    let s = h.stats();
    assert_eq!((s.integrated_ticks, s.nav_lines), (32, 13));
    assert_eq!((s.window_ticks, s.window_navs), (20, 10));
    drop(c);
    // A closed connection no longer runs.
    tokio::time::timeout(Duration::from_secs(5), async {
        while h.stats().running > 0 {
            tokio::time::sleep(ms(10)).await;
        }
    })
    .await
    .expect("the vehicle's connection closed");
    h.shutdown().await;
}

fn ms(v: u64) -> Duration {
    Duration::from_millis(v)
}
