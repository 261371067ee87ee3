//! The serial byte link over real pseudo-terminals (openpty; tokio-serial opens the slave as it
//! would a USB adapter): lines with noise between them, counted bad input, and a device that
//! vanishes and comes back under the same (symlinked) path. Binary frames over the same link are
//! the SV2's test (`vehicles/waveglider_sv2/tests/serial_frames.rs`).

use std::sync::Arc;
use std::time::Duration;

use frontseat_actors::driver::{DriverIoEvent, IoSender};
use frontseat_actors::link::byte::{self, ByteLinkConfig, LinkStats, Transport};
use frontseat_actors::link::framing::Framing;
use frontseat_actors::link::serial::SerialSettings;
use frontseat_sim::pty::PtyMaster;
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
async fn lines_cross_a_pty_both_ways_and_noise_is_counted() {
    let pty = PtyMaster::open().unwrap();
    let path = pty.slave_path().to_string_lossy().into_owned();
    let stats = Arc::new(LinkStats::default());
    let (io, mut rx) = collector();
    let task = byte::spawn(
        link(&path, Framing::Lines { max_line_bytes: 64 }),
        io,
        stats.clone(),
    );
    let DriverIoEvent::Connected(w) = next(&mut rx).await else {
        panic!("first event is Connected")
    };
    w.write_line("$OSD,G,C,S,P,,,,*5F").unwrap();
    let mut got = Vec::new();
    while !got.ends_with(b"\r\n") {
        let mut b = [0u8; 64];
        let n = tokio::time::timeout(WITHIN, pty.read(&mut b))
            .await
            .unwrap()
            .unwrap();
        got.extend_from_slice(&b[..n]);
    }
    assert_eq!(got, b"$OSD,G,C,S,P,,,,*5F\r\n");

    let mut noise = vec![b'z'; 500];
    noise.extend_from_slice(b"\r\n\xff\xfe\r\n$ACK,9,0,0*5C\r\n");
    pty.write_all(&noise, WITHIN).await.unwrap();
    let mut events = Vec::new();
    while events.len() < 3 {
        events.push(next(&mut rx).await);
    }
    assert!(matches!(&events[0], DriverIoEvent::BadInput(w) if w.contains("line over 64")));
    assert!(matches!(&events[1], DriverIoEvent::BadInput(w) if w.contains("UTF-8")));
    assert!(matches!(&events[2], DriverIoEvent::Line(l) if l == "$ACK,9,0,0*5C"));
    assert_eq!(LinkStats::get(&stats.bad_input), 2);
    assert_eq!(LinkStats::get(&stats.messages), 1);
    task.abort();
}

/// udev gives a USB adapter a stable symlink; unplugging it removes the device, plugging it back
/// makes a new one behind the same name. Here: a symlink to a pty, the pty closed, a new pty
/// behind the same symlink.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn device_that_vanishes_and_comes_back_is_reopened() {
    let dir = std::env::temp_dir().join(format!("frontseat-serial-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let link_path = dir.join("ttyUSB0");
    let _ = std::fs::remove_file(&link_path);

    let first = PtyMaster::open().unwrap();
    std::os::unix::fs::symlink(first.slave_path(), &link_path).unwrap();
    let stats = Arc::new(LinkStats::default());
    let (io, mut rx) = collector();
    let task = byte::spawn(
        link(
            &link_path.to_string_lossy(),
            Framing::Lines {
                max_line_bytes: 256,
            },
        ),
        io,
        stats.clone(),
    );
    let DriverIoEvent::Connected(_w1) = next(&mut rx).await else {
        panic!("first event is Connected")
    };
    first.write_all(b"one\r\n", WITHIN).await.unwrap();
    assert!(matches!(next(&mut rx).await, DriverIoEvent::Line(l) if l == "one"));

    // Unplugged: the master goes away and the name disappears.
    drop(first);
    std::fs::remove_file(&link_path).unwrap();
    assert!(matches!(
        next(&mut rx).await,
        DriverIoEvent::Disconnected(_)
    ));
    // The link keeps trying while the device is missing.
    tokio::time::timeout(WITHIN, async {
        while LinkStats::get(&stats.open_failures) == 0 {
            tokio::time::sleep(Duration::from_millis(10)).await;
        }
    })
    .await
    .expect("reopen attempts while unplugged");

    // Plugged back in: a different pty behind the same name.
    let second = PtyMaster::open().unwrap();
    std::os::unix::fs::symlink(second.slave_path(), &link_path).unwrap();
    let w = loop {
        match next(&mut rx).await {
            DriverIoEvent::Connected(w) => break w,
            // Opening the stale name can fail or hit the dead device first.
            DriverIoEvent::Disconnected(_) => continue,
            other => panic!("unexpected {other:?}"),
        }
    };
    second.write_all(b"two\r\n", WITHIN).await.unwrap();
    assert!(matches!(next(&mut rx).await, DriverIoEvent::Line(l) if l == "two"));
    w.write_line("back").unwrap();
    let mut b = [0u8; 16];
    let n = tokio::time::timeout(WITHIN, second.read(&mut b))
        .await
        .unwrap()
        .unwrap();
    assert_eq!(&b[..n], b"back\r\n");
    assert!(LinkStats::get(&stats.opens) >= 2);
    task.abort();
    let _ = std::fs::remove_dir_all(&dir);
}
