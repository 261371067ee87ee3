//! SV2 frames over the serial byte link on a real pseudo-terminal (openpty; tokio-serial opens the
//! slave as it would a USB adapter): every kind of bad input between frames is counted and the
//! link resynchronises on the next good frame.

use std::sync::Arc;
use std::time::Duration;

use frontseat_actors::driver::{DriverIoEvent, IoSender};
use frontseat_actors::link::byte::{self, ByteLinkConfig, LinkStats, Transport};
use frontseat_actors::link::framing::Framing;
use frontseat_actors::link::serial::SerialSettings;
use frontseat_sim::pty::PtyMaster;
use frontseat_waveglider_sv2::codec::{Frame, Message, Packet};
use frontseat_waveglider_sv2::driver::sv2_frames;
use tokio::sync::mpsc;

const WITHIN: Duration = Duration::from_secs(10);

fn link(path: &str, framing: Framing) -> ByteLinkConfig {
    ByteLinkConfig {
        transport: Transport::Serial(SerialSettings::new_8n1(path, 19200)),
        framing,
        backoff_initial: Duration::from_millis(20),
        backoff_max: Duration::from_millis(200),
    }
}

fn collector() -> (IoSender, mpsc::UnboundedReceiver<DriverIoEvent>) {
    let (tx, rx) = mpsc::unbounded_channel();
    (IoSender::new(move |ev| tx.send(ev).is_ok()), rx)
}

async fn next(rx: &mut mpsc::UnboundedReceiver<DriverIoEvent>) -> DriverIoEvent {
    tokio::time::timeout(WITHIN, rx.recv())
        .await
        .expect("an event in time")
        .expect("link alive")
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn sv2_frames_resynchronise_after_every_kind_of_bad_input() {
    let pty = PtyMaster::open().unwrap();
    let path = pty.slave_path().to_string_lossy().into_owned();
    let stats = Arc::new(LinkStats::default());
    let (io, mut rx) = collector();
    let task = byte::spawn(link(&path, Framing::Frames(sv2_frames)), io, stats.clone());
    // Holding the writer keeps the link open (dropping it is how a driver closes the port).
    let DriverIoEvent::Connected(_w) = next(&mut rx).await else {
        panic!("first event is Connected")
    };

    let good = Packet {
        dest: 0x0301,
        src: 0,
        transaction_id: 0x7D7E, // escapes in the header
        message: Message::RequestQueuedMessage,
    }
    .encode()
    .unwrap();
    let mut bad_crc = good.clone();
    let n = bad_crc.len();
    bad_crc[n - 3] ^= 0x01;
    let mut bytes = b"line noise".to_vec();
    bytes.extend_from_slice(&good[..7]); // truncated by the next start byte
    bytes.extend_from_slice(&bad_crc);
    bytes.extend_from_slice(&[0x7E, 0x20, 0x7D, 0x01]); // bad escape
    bytes.extend_from_slice(&[0x7E, 0x00, 0x10]); // larger than the protocol allows
    bytes.extend_from_slice(&good);
    pty.write_all(&bytes, WITHIN).await.unwrap();

    let mut bad = 0;
    loop {
        match next(&mut rx).await {
            DriverIoEvent::BadInput(_) => bad += 1,
            DriverIoEvent::Frame(f) => {
                let p = Packet::from_frame(&Frame::from_unescaped(&f).unwrap()).unwrap();
                assert_eq!(p.transaction_id, 0x7D7E);
                break;
            }
            other => panic!("unexpected {other:?}"),
        }
    }
    // noise, truncated, bad CRC, bad escape, oversize.
    assert_eq!(bad, 5);
    assert_eq!(LinkStats::get(&stats.bad_input), 5);
    assert_eq!(LinkStats::get(&stats.messages), 1);
    task.abort();
}
