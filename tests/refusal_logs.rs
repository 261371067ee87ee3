//! The interface's refusal logs stay quiet and still account for everything: a helm that sends
//! 50 setpoints outside the safety envelope and a frontseat that sends 30 NAV lines with an
//! impossible latitude get a handful of WARNs each and, once the limiter's window has ended with
//! no further bad input, one summary line for the rest. The frontseat is a TCP listener in this
//! test on loopback speaking the basic simulator protocol; the interface runs in this process at
//! warp 10 (the 10 s window passes in one wall second); the log is captured by a global tracing
//! subscriber writing into memory (one test in this binary, so nothing else writes there).

mod common;

use frontseat_actors::bus::test_util::UntypedBus as _;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use common::logcap::{Captured, accept_start, played_frontseat, summarised, warned};
use frontseat_actors::bus::Bus;
use frontseat_actors::groups;
use frontseat_actors::interface::InterfaceService;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    DesiredCourse, HelmState, HelmStateReport, InterfaceState,
};
use tokio::io::{AsyncBufReadExt, AsyncWriteExt};

const BAD_SETPOINTS: u64 = 50;
const BAD_NAVS: u64 = 30;

/// WARN lines naming `what`, and the sum of N over every "…and N more `summary`" line.
fn tally(text: &str, what: &str, summary: &str) -> (u64, u64) {
    (warned(text, what), summarised(text, summary))
}

const SETPOINT: (&str, &str) = (
    "setpoint refused by the safety envelope",
    "refused setpoints",
);
const NAV: (&str, &str) = (
    "navigation from the frontseat refused",
    "refused navigation messages",
);

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn refused_setpoints_and_navigation_give_a_few_warnings_and_a_summary() {
    let captured = Captured::install();

    let (listener, cfg) = played_frontseat("refusing-auv").await;
    let max_depth = cfg.limits.max_depth;
    let bus = Bus::new();
    let (_st, mut status) =
        bus.subscribe_channel(&groups::GOBY_MIDDLEWARE_FRONTSEAT_STATUS, "test", 64);
    let service = InterfaceService::start(&cfg, &bus, frontseat_drivers::BUILT_IN)
        .await
        .unwrap();

    let (mut rd, wr) = accept_start(&listener).await;
    let wr = Arc::new(tokio::sync::Mutex::new(wr));
    wr.lock()
        .await
        .write_all(b"CTRL,STATE:PAYLOAD\r\n")
        .await
        .unwrap();
    // Good navigation keeps the frontseat "providing data"; every CMD that arrives is kept.
    let nav_wr = wr.clone();
    let nav = tokio::spawn(async move {
        loop {
            let line = b"NAV,LAT:42.358456,LON:-71.087589,DEPTH:2,HEADING:90,SPEED:1.5\r\n";
            if nav_wr.lock().await.write_all(line).await.is_err() {
                return;
            }
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
    });
    let cmds = Arc::new(Mutex::new(Vec::<String>::new()));
    let seen = cmds.clone();
    let reader = tokio::spawn(async move {
        let mut line = String::new();
        while matches!(rd.read_line(&mut line).await, Ok(n) if n > 0) {
            seen.lock()
                .unwrap_or_else(|p| p.into_inner())
                .push(line.clone());
            line.clear();
        }
    });
    let helm_bus = bus.clone();
    let helm = tokio::spawn(async move {
        loop {
            helm_bus.publish(
                &groups::GOBY_MIDDLEWARE_FRONTSEAT_HELM_STATE,
                HelmStateReport {
                    state: HelmState::HelmDrive as i32,
                },
            );
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
    });
    tokio::time::timeout(Duration::from_secs(20), async {
        while let Some(env) = status.recv().await {
            if env.msg.state() == InterfaceState::InterfaceCommand {
                return;
            }
        }
        panic!("status channel closed");
    })
    .await
    .expect("the interface reaches running:command within 20 s");

    // The attack: a burst of setpoints too deep, and a burst of impossible navigation.
    for i in 0..BAD_SETPOINTS {
        bus.publish(
            &groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE,
            DesiredCourse {
                heading: Some(90.0),
                speed: Some(1.0),
                depth: Some(max_depth + 100.0 + i as f64),
                ..Default::default()
            },
        );
    }
    let mut burst = String::new();
    for _ in 0..BAD_NAVS {
        burst.push_str("NAV,LAT:95,LON:-71.087589,DEPTH:2,HEADING:90,SPEED:1.5\r\n");
    }
    wr.lock().await.write_all(burst.as_bytes()).await.unwrap();

    // Every refusal is logged or summarised; the summaries come with no further bad input.
    let deadline = tokio::time::Instant::now() + Duration::from_secs(30);
    let text = loop {
        let text = captured.text();
        let (sw, ss) = tally(&text, SETPOINT.0, SETPOINT.1);
        let (nw, ns) = tally(&text, NAV.0, NAV.1);
        if sw + ss >= BAD_SETPOINTS && nw + ns >= BAD_NAVS {
            break text;
        }
        assert!(
            tokio::time::Instant::now() < deadline,
            "refusals not all logged or summarised within 30 s \
             (setpoints {sw} + {ss}, navigation {nw} + {ns}):\n{text}"
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    };
    let snap = service
        .snapshot(Duration::from_secs(5))
        .await
        .expect("the interface answers a snapshot");
    helm.abort();
    nav.abort();
    let _ = service.shutdown(Duration::from_secs(3)).await;
    reader.abort();

    for (what, summary, n) in [
        (SETPOINT.0, SETPOINT.1, BAD_SETPOINTS),
        (NAV.0, NAV.1, BAD_NAVS),
    ] {
        let (warned, summarised) = tally(&text, what, summary);
        assert!(
            (1..=10).contains(&warned),
            "{warned} WARNs for {n} refusals ({what}):\n{text}"
        );
        assert_eq!(warned + summarised, n, "each refusal logged once:\n{text}");
        assert!(summarised > 0, "the rest summarised ({what}):\n{text}");
    }
    assert_eq!(snap.setpoints_refused, BAD_SETPOINTS);
    assert_eq!(snap.nav_refused, BAD_NAVS);
    let cmds = cmds.lock().unwrap_or_else(|p| p.into_inner());
    assert!(
        cmds.iter().all(|l| !l.starts_with("CMD")),
        "a refused setpoint reached the frontseat: {cmds:?}"
    );
}
