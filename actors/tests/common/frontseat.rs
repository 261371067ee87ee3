//! A basic-simulator frontseat on plain OS threads for the vehicle-side tests: its socket
//! calls are stamped where they happen, away from any async runtime the test may wedge.

use std::io::{BufRead, BufReader, Write};
use std::net::{Ipv4Addr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, mpsc};
use std::time::{Duration, Instant};

/// A basic-simulator frontseat on plain threads: answers START with PAYLOAD, acknowledges every
/// CMD (and reports it), and writes a NAV line every 20 ms.
pub struct Frontseat {
    pub port: u16,
    pub cmds: mpsc::Receiver<(String, Instant)>,
    stop: Arc<AtomicBool>,
}

impl Frontseat {
    pub fn start() -> Self {
        let listener = TcpListener::bind((Ipv4Addr::LOCALHOST, 0)).unwrap();
        let port = listener.local_addr().unwrap().port();
        let stop = Arc::new(AtomicBool::new(false));
        let (tx, cmds) = mpsc::channel();
        let halt = stop.clone();
        std::thread::spawn(move || {
            let Ok((stream, _)) = listener.accept() else {
                return;
            };
            stream.set_nodelay(true).unwrap();
            let conn = Arc::new(Mutex::new(stream.try_clone().unwrap()));
            let send = |c: &Mutex<TcpStream>, line: &str| {
                c.lock().unwrap().write_all(line.as_bytes()).is_ok()
            };
            let (nav_conn, nav_halt) = (conn.clone(), halt.clone());
            std::thread::spawn(move || {
                let mut n = 0u64;
                while !nav_halt.load(Ordering::Acquire) {
                    n += 1;
                    // 0.1 m a line at 50 Hz: 5 m/s, inside the navigation gate's depth-rate
                    // bound, so every line is a NAV the interface takes.
                    let line = format!(
                        "NAV,LAT:42.358456,LON:-71.087589,DEPTH:{:.1},HEADING:90,SPEED:1.5\r\n",
                        n as f64 * 0.1
                    );
                    if !send(&nav_conn, &line) {
                        return;
                    }
                    std::thread::sleep(Duration::from_millis(20));
                }
            });
            for line in BufReader::new(stream).lines() {
                let Ok(line) = line else { return };
                if line.starts_with("START,") {
                    send(&conn, "CTRL,STATE:PAYLOAD\r\n");
                } else if line.starts_with("CMD,") {
                    let _ = tx.send((line, Instant::now()));
                    send(&conn, "CMD,RESULT:OK\r\n");
                }
                if halt.load(Ordering::Acquire) {
                    return;
                }
            }
        });
        Self { port, cmds, stop }
    }
}

impl Drop for Frontseat {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Release);
    }
}

/// Every interface state the interface publishes on `bus`, through a std channel (no runtime
/// needed to receive it).
pub fn states(
    bus: &frontseat_actors::bus::Bus,
) -> (
    frontseat_actors::bus::Subscription,
    mpsc::Receiver<frontseat_actors::proto::goby::middleware::frontseat::protobuf::InterfaceState>,
) {
    use frontseat_actors::bus::test_util::UntypedBus as _;
    let (tx, rx) = mpsc::channel();
    let tx = Mutex::new(tx);
    let sub = bus.subscribe(
        &frontseat_actors::groups::GOBY_MIDDLEWARE_FRONTSEAT_STATUS,
        "test-status",
        1024,
        move |env| {
            let _ = tx.lock().unwrap().send(env.msg.state());
            Ok(())
        },
    );
    (sub, rx)
}

/// Publishes a driving helm and waits (at most `within`) for the interface to say COMMAND.
pub fn drive_until_command(
    bus: &frontseat_actors::bus::Bus,
    states: &mpsc::Receiver<
        frontseat_actors::proto::goby::middleware::frontseat::protobuf::InterfaceState,
    >,
    within: Duration,
) {
    use frontseat_actors::bus::test_util::UntypedBus as _;
    use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
        HelmState, HelmStateReport, InterfaceState,
    };
    bus.publish(
        &frontseat_actors::groups::GOBY_MIDDLEWARE_FRONTSEAT_HELM_STATE,
        HelmStateReport {
            state: HelmState::HelmDrive as i32,
        },
    );
    let until = Instant::now() + within;
    loop {
        let left = until.saturating_duration_since(Instant::now());
        if states
            .recv_timeout(left)
            .expect("a status within the deadline")
            == InterfaceState::InterfaceCommand
        {
            return;
        }
    }
}
