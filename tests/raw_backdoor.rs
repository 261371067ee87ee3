//! The raw backdoor cannot smuggle commands: the test plays a basic simulator frontseat over
//! loopback, brings the interface to COMMAND, and sends raw_send_requests as a hostile helm
//! would — two command lines in one request, an oversized one, raw from Zenoh and from the web
//! commander (not allowed by default), a heading of 1e308 in a command_request — between good
//! ones, then a sentinel. Every line that reaches the vehicle's socket is collected until the
//! sentinel: exactly the good raw lines, each as one line, and nothing else.

mod common;

use frontseat_actors::bus::test_util::UntypedBus as _;
use std::sync::Arc;
use std::time::Duration;

use common::logcap::{accept_start, played_frontseat};
use common::{StatusWatch, helm_heartbeat};
use frontseat_actors::bus::{Bus, Origin, PublishMeta};
use frontseat_actors::groups;
use frontseat_actors::interface::{InterfaceService, error_code};
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CommandRequest, DesiredCourse, HelmState, InterfaceState, Raw,
};
use tokio::io::{AsyncBufReadExt, AsyncWriteExt};

const WAIT: Duration = Duration::from_secs(20);

fn raw(bus: &Bus, bytes: &[u8], origin: Origin) {
    bus.publish_with(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_RAW_SEND_REQUEST,
        Arc::new(Raw {
            raw: Some(bytes.to_vec()),
            ..Default::default()
        }),
        PublishMeta {
            origin,
            ..Default::default()
        },
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn raw_sends_are_one_line_from_allowed_sources_and_absurd_headings_are_refused() {
    let (listener, cfg) = played_frontseat("raw-auv").await;
    let bus = Bus::new();
    let mut status = StatusWatch::new(&bus);
    let (_s, mut responses) = bus.subscribe_channel(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_COMMAND_RESPONSE,
        "t",
        100,
    );
    let service = InterfaceService::start(&cfg, &bus, frontseat_drivers::BUILT_IN)
        .await
        .unwrap();
    let (mut rd, mut wr) = accept_start(&listener).await;
    let helm = helm_heartbeat(&bus, HelmState::HelmDrive);
    let nav = tokio::spawn(async move {
        wr.write_all(b"CTRL,STATE:PAYLOAD\r\n").await.unwrap();
        loop {
            let line = b"NAV,LAT:42.358456,LON:-71.087589,DEPTH:2,HEADING:90,SPEED:1.5\r\n";
            if wr.write_all(line).await.is_err() {
                return;
            }
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
    });
    status
        .until_state(InterfaceState::InterfaceCommand, WAIT)
        .await;

    raw(
        &bus,
        b"CMD,HEADING:nan,SPEED:1e308,DEPTH:-5\nCMD,HEADING:inf,SPEED:99",
        Origin::Local,
    );
    raw(&bus, b"FOO,BAR:1\r\n", Origin::Local);
    raw(&bus, b"ZEN,1", Origin::Imported);
    raw(&bus, b"WEB,1", Origin::Web);
    raw(&bus, b"GOBY,1", Origin::Goby3);
    raw(&bus, &[b'A'; 600], Origin::Local);
    bus.publish(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_COMMAND_REQUEST,
        CommandRequest {
            desired_course: Some(DesiredCourse {
                heading: Some(1e308),
                speed: Some(1.0),
                ..Default::default()
            }),
            response_requested: Some(true),
            request_id: Some(7),
            ..Default::default()
        },
    );
    raw(&bus, b"SENTINEL", Origin::Local);

    let mut lines = Vec::new();
    tokio::time::timeout(WAIT, async {
        let mut line = String::new();
        loop {
            line.clear();
            let n = rd.read_line(&mut line).await.unwrap();
            assert!(n > 0, "the driver closed the connection");
            let l = line.trim_end().to_string();
            if l == "SENTINEL" {
                return;
            }
            lines.push(l);
        }
    })
    .await
    .unwrap_or_else(|_| panic!("the sentinel reaches the vehicle; lines so far: {lines:?}"));
    assert_eq!(
        lines,
        vec!["FOO,BAR:1", "GOBY,1"],
        "exactly the allowed lines"
    );

    let r = tokio::time::timeout(WAIT, async {
        loop {
            let env = responses.recv().await.expect("responses");
            if env.msg.request_id == Some(7) {
                return env.msg;
            }
        }
    })
    .await
    .expect("the 1e308 heading is answered");
    assert_eq!(r.request_successful, Some(false));
    assert_eq!(r.error_code, Some(error_code::OUTSIDE_ENVELOPE), "{r:?}");

    let snap = service.snapshot(WAIT).await.expect("a snapshot");
    assert_eq!((snap.raw_sent, snap.raw_refused), (3, 4));
    helm.abort();
    nav.abort();
    let _ = service.shutdown(Duration::from_secs(3)).await;
}
