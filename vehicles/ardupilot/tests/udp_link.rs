//! The byte link's UDP transports, as MAVLink routers and BlueOS use them, over loopback:
//! `udpout` sends to the vehicle's socket and reads what comes back to its own ephemeral port;
//! `udpin` binds, learns its peer from the first datagram and answers it. Both cut datagrams into
//! checked MAVLink frames and report noise as bad input.

use std::sync::Arc;
use std::time::Duration;

use frontseat_actors::driver::{DriverIoEvent, IoSender};
use frontseat_actors::link::LineWriter;
use frontseat_actors::link::byte::{self, ByteLinkConfig, LinkStats, Transport};
use frontseat_actors::link::framing::Framing;
use frontseat_ardupilot::codec::{MavMessage, encode};
use tokio::net::UdpSocket;
use tokio::sync::mpsc::{UnboundedReceiver, unbounded_channel};

const WITHIN: Duration = Duration::from_secs(5);

fn link(
    transport: Transport,
) -> (
    tokio::task::JoinHandle<()>,
    UnboundedReceiver<DriverIoEvent>,
) {
    let (tx, rx) = unbounded_channel();
    let task = byte::spawn(
        ByteLinkConfig {
            transport,
            framing: Framing::Frames(frontseat_ardupilot::driver::mavlink_frames),
            backoff_initial: Duration::from_millis(10),
            backoff_max: Duration::from_millis(100),
        },
        IoSender::new(move |ev| tx.send(ev).is_ok()),
        Arc::new(LinkStats::default()),
    );
    (task, rx)
}

async fn connected(rx: &mut UnboundedReceiver<DriverIoEvent>) -> LineWriter {
    match tokio::time::timeout(WITHIN, rx.recv()).await {
        Ok(Some(DriverIoEvent::Connected(w))) => w,
        other => panic!("expected Connected, got {other:?}"),
    }
}

fn heartbeat(system: u8) -> Vec<u8> {
    encode(system, 1, 0, &MavMessage::HEARTBEAT(Default::default()))
}

/// Frames and bad-input reports until `frames` frames came.
async fn frames(rx: &mut UnboundedReceiver<DriverIoEvent>, frames: usize) -> (Vec<Vec<u8>>, usize) {
    let (mut got, mut bad) = (Vec::new(), 0);
    while got.len() < frames {
        match tokio::time::timeout(WITHIN, rx.recv()).await {
            Ok(Some(DriverIoEvent::Frame(f))) => got.push(f),
            Ok(Some(DriverIoEvent::BadInput(_))) => bad += 1,
            other => panic!("expected frames, got {other:?}"),
        }
    }
    (got, bad)
}

#[tokio::test]
async fn udpout_sends_to_the_vehicle_and_reads_its_answers() {
    let vehicle = UdpSocket::bind("127.0.0.1:0").await.unwrap();
    let port = vehicle.local_addr().unwrap().port();
    let (task, mut rx) = link(Transport::UdpOut {
        host: "127.0.0.1".into(),
        port,
    });
    let w = connected(&mut rx).await;
    w.write_bytes(heartbeat(255)).unwrap();
    let mut buf = [0u8; 1024];
    let (n, from) = tokio::time::timeout(WITHIN, vehicle.recv_from(&mut buf))
        .await
        .unwrap()
        .unwrap();
    assert_eq!(&buf[..n], &heartbeat(255)[..]);
    let mut answer = b"noise".to_vec();
    answer.extend_from_slice(&heartbeat(1));
    answer.extend_from_slice(&heartbeat(1));
    vehicle.send_to(&answer, from).await.unwrap();
    let (got, bad) = frames(&mut rx, 2).await;
    assert_eq!(got, vec![heartbeat(1), heartbeat(1)]);
    assert_eq!(bad, 1, "the noise before the frames");
    task.abort();
}

#[tokio::test]
async fn udpin_learns_its_peer_and_answers_it() {
    let port = std::net::UdpSocket::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let (task, mut rx) = link(Transport::UdpIn {
        host: "127.0.0.1".into(),
        port,
    });
    let w = connected(&mut rx).await;
    let vehicle = UdpSocket::bind("127.0.0.1:0").await.unwrap();
    vehicle
        .send_to(&heartbeat(1), ("127.0.0.1", port))
        .await
        .unwrap();
    let (got, _) = frames(&mut rx, 1).await;
    assert_eq!(got, vec![heartbeat(1)]);
    w.write_bytes(heartbeat(255)).unwrap();
    let mut buf = [0u8; 1024];
    let (n, _) = tokio::time::timeout(WITHIN, vehicle.recv_from(&mut buf))
        .await
        .unwrap()
        .unwrap();
    assert_eq!(&buf[..n], &heartbeat(255)[..]);
    task.abort();
}
