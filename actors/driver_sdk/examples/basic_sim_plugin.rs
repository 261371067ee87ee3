//! The basic frontseat simulator driver (sim/PROTOCOL.md) as a plugin, written with the SDK:
//! a `FrontseatDriver` impl plus `export_driver!`. Build: `cargo build -p frontseat-driver-sdk
//! --example basic_sim_plugin`, then `FRONTSEAT_DRIVER_LIBRARY=target/debug/examples/
//! libbasic_sim_plugin.so frontseat interface -c interface.toml`.
//!
//! One thread owns the TCP connection (connect with backoff, START on every connect, read lines
//! and emit them as signals at once); the host's calls write through a shared handle.
#![forbid(unsafe_code)]

use std::io::{BufRead, BufReader, Read, Write};
use std::net::{TcpStream, ToSocketAddrs};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::Duration;

use frontseat_config::InterfaceConfig;
use frontseat_driver_sdk::proto::goby::middleware::frontseat::protobuf::{
    EulerAngles, NodeStatus, Speed, raw::RawType,
};
use frontseat_driver_sdk::proto::goby::middleware::protobuf::LatLonPoint;
use frontseat_driver_sdk::{
    CommandRequest, CommandResponse, DriverFailure, FrontSeatState, FrontseatDriver, Host,
    InterfaceData, LogLevel, Raw,
};

const MAX_LINE: usize = 4096;

struct Settings {
    addr: String,
    start_line: String,
    backoff_initial: Duration,
    backoff_max: Duration,
    nav_timeout: Duration,
}

impl Settings {
    fn from_json(config: &[u8]) -> Result<Self, String> {
        let cfg: InterfaceConfig =
            serde_json::from_slice(config).map_err(|e| format!("config is not valid: {e}"))?;
        let b = &cfg.driver.basic_simulator;
        let s = &b.start;
        Ok(Self {
            addr: format!("{}:{}", b.tcp_address, b.tcp_port),
            start_line: format!(
                "START,LAT:{},LON:{},DURATION:{},FREQ:{},ACCEL:{},HDG_RATE:{},Z_RATE:{},WARP:{}",
                s.lat,
                s.lon,
                s.duration,
                s.control_freq,
                s.vehicle.accel,
                s.vehicle.hdg_rate,
                s.vehicle.z_rate,
                cfg.sim_warp_factor
            ),
            backoff_initial: Duration::from_millis(b.reconnect_initial_ms.max(1)),
            backoff_max: Duration::from_millis(b.reconnect_max_ms.max(1)),
            nav_timeout: Duration::from_secs_f64(b.nav_timeout.max(0.0)),
        })
    }
}

#[derive(Default)]
struct Shared {
    writer: Option<TcpStream>,
    state: FrontSeatState,
    providing: bool,
    /// A NAV arrived since the last loop(): loop() stamps it with simulated time.
    nav_seen: bool,
    last_request: Option<CommandRequest>,
    /// Set by unload under the same lock that installs a new connection, so none slips past it.
    stopping: bool,
}

struct Conn {
    host: Host,
    shared: Mutex<Shared>,
}

impl Conn {
    fn lock(&self) -> MutexGuard<'_, Shared> {
        match self.shared.lock() {
            Ok(g) => g,
            Err(p) => p.into_inner(),
        }
    }

    fn set_state(&self, f: impl FnOnce(&mut Shared)) {
        let (before, after) = {
            let mut s = self.lock();
            let before = (s.state, s.providing);
            f(&mut s);
            (before, (s.state, s.providing))
        };
        if before != after {
            self.host.state_changed(after.0, after.1);
        }
    }

    fn write(&self, line: &str) {
        let mut s = self.lock();
        let Some(w) = s.writer.as_mut() else {
            drop(s);
            self.host
                .log(LogLevel::Debug, &format!("not connected; not sent: {line}"));
            return;
        };
        match w.write_all(format!("{line}\r\n").as_bytes()) {
            Ok(()) => {
                drop(s);
                self.host.raw_to_frontseat(&raw_ascii(line));
            }
            Err(e) => {
                drop(s);
                self.host.log(
                    LogLevel::Warn,
                    &format!("write to the frontseat failed: {e}"),
                );
            }
        }
    }

    fn handle_line(&self, line: &str) {
        self.host.raw_from_frontseat(&raw_ascii(line));
        let (kind, fields) = line.split_once(',').unwrap_or((line, ""));
        match kind {
            "NAV" => match parse_nav(fields) {
                Ok(ns) => {
                    self.set_state(|s| {
                        s.providing = true;
                        s.nav_seen = true;
                    });
                    self.host.data_from_frontseat(&InterfaceData {
                        node_status: Some(ns),
                        ..Default::default()
                    });
                }
                Err(e) => self
                    .host
                    .log(LogLevel::Warn, &format!("bad NAV line `{line}`: {e}")),
            },
            "CTRL" => {
                let st = match field(fields, "STATE") {
                    Some("PAYLOAD") => FrontSeatState::FrontseatAcceptingCommands,
                    Some("AUV") => FrontSeatState::FrontseatInControl,
                    _ => FrontSeatState::FrontseatIdle,
                };
                self.set_state(|s| s.state = st);
            }
            "CMD" => {
                let ok = field(fields, "RESULT") == Some("OK");
                let req = self.lock().last_request;
                if let Some(req) = req
                    && req.response_requested()
                {
                    self.host.command_response(&CommandResponse {
                        request_successful: Some(ok),
                        request_id: req.request_id,
                        error_string: (!ok)
                            .then(|| "frontseat answered CMD,RESULT:ERROR".to_string()),
                        ..Default::default()
                    });
                }
            }
            _ => self.host.log(
                LogLevel::Info,
                &format!("unknown line from the frontseat: {line}"),
            ),
        }
    }
}

fn raw_ascii(line: &str) -> Raw {
    let mut r = Raw {
        raw: Some(line.as_bytes().to_vec()),
        ..Default::default()
    };
    r.set_type(RawType::RawAscii);
    r
}

fn field<'a>(fields: &'a str, key: &str) -> Option<&'a str> {
    fields.split(',').find_map(|kv| {
        let (k, v) = kv.split_once(':')?;
        (k.trim() == key).then_some(v.trim())
    })
}

fn num(fields: &str, key: &str) -> Result<f64, String> {
    let v = field(fields, key).ok_or(format!("missing {key}"))?;
    match v.parse::<f64>() {
        Ok(x) if x.is_finite() => Ok(x),
        _ => Err(format!("{key} is not a finite number: `{v}`")),
    }
}

fn parse_nav(fields: &str) -> Result<NodeStatus, String> {
    let time = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs_f64())
        .unwrap_or_default();
    Ok(NodeStatus {
        time,
        global_fix: LatLonPoint {
            lat: num(fields, "LAT")?,
            lon: num(fields, "LON")?,
            depth: Some(num(fields, "DEPTH")?),
            altitude: None,
        },
        pose: EulerAngles {
            heading: Some(num(fields, "HEADING")?),
            ..Default::default()
        },
        speed: Speed {
            over_ground: num(fields, "SPEED")?,
            over_water: None,
        },
        ..Default::default()
    })
}

/// The connection thread: connect (with backoff), START, read lines, until told to stop.
fn run_link(conn: Arc<Conn>, settings: Arc<Settings>, stop: mpsc::Receiver<()>) {
    let mut backoff = settings.backoff_initial;
    loop {
        let stream = settings
            .addr
            .to_socket_addrs()
            .ok()
            .and_then(|mut a| a.next())
            .ok_or_else(|| format!("cannot resolve {}", settings.addr))
            .and_then(|a| {
                TcpStream::connect_timeout(&a, Duration::from_millis(500))
                    .map_err(|e| e.to_string())
            });
        match stream.and_then(|s| s.try_clone().map(|w| (s, w)).map_err(|e| e.to_string())) {
            Ok((reader, writer)) => {
                backoff = settings.backoff_initial;
                conn.host.log(
                    LogLevel::Info,
                    &format!(
                        "connected to the frontseat at {}; sending START",
                        settings.addr
                    ),
                );
                let mut stopping = false;
                conn.set_state(|s| {
                    stopping = s.stopping;
                    if !stopping {
                        s.writer = Some(writer);
                        s.state = FrontSeatState::FrontseatIdle;
                    }
                });
                if stopping {
                    return;
                }
                conn.write(&settings.start_line);
                read_lines(&conn, reader);
                conn.set_state(|s| {
                    s.writer = None;
                    s.state = FrontSeatState::FrontseatNotConnected;
                    s.providing = false;
                });
                conn.host
                    .log(LogLevel::Warn, "frontseat connection lost; reconnecting");
            }
            Err(e) => conn.host.log(
                LogLevel::Debug,
                &format!("cannot connect to {}: {e}", settings.addr),
            ),
        }
        match stop.recv_timeout(backoff) {
            Err(RecvTimeoutError::Timeout) => backoff = (backoff * 2).min(settings.backoff_max),
            _ => return,
        }
    }
}

fn read_lines(conn: &Conn, stream: TcpStream) {
    let mut r = BufReader::new(stream);
    let mut buf = Vec::new();
    loop {
        buf.clear();
        match (&mut r)
            .take(MAX_LINE as u64 + 1)
            .read_until(b'\n', &mut buf)
        {
            Ok(0) | Err(_) => return,
            Ok(_) if buf.len() > MAX_LINE => {
                conn.host
                    .log(LogLevel::Warn, "line over 4096 bytes dropped");
            }
            Ok(_) => match std::str::from_utf8(&buf) {
                Ok(s) => {
                    let line = s.trim();
                    if !line.is_empty() {
                        conn.handle_line(line);
                    }
                }
                Err(_) => conn.host.log(LogLevel::Warn, "non-UTF-8 line dropped"),
            },
        }
    }
}

struct BasicSimPlugin {
    conn: Arc<Conn>,
    settings: Arc<Settings>,
    last_nav: Option<Duration>,
    stop: Option<mpsc::Sender<()>>,
    link: Option<JoinHandle<()>>,
}

impl FrontseatDriver for BasicSimPlugin {
    fn load(config: &[u8], host: Host) -> Result<Self, String> {
        let settings = Arc::new(Settings::from_json(config)?);
        let conn = Arc::new(Conn {
            host,
            shared: Mutex::new(Shared::default()),
        });
        let (stop, stopped) = mpsc::channel();
        let (c, s) = (conn.clone(), settings.clone());
        let link = std::thread::Builder::new()
            .name("basic-sim-link".into())
            .spawn(move || run_link(c, s, stopped))
            .map_err(|e| format!("cannot start the connection thread: {e}"))?;
        Ok(Self {
            conn,
            settings,
            last_nav: None,
            stop: Some(stop),
            link: Some(link),
        })
    }

    fn send_command_to_frontseat(&mut self, req: CommandRequest) -> Result<(), DriverFailure> {
        let Some(c) = req.desired_course.as_ref() else {
            if req.response_requested() {
                self.conn.host.command_response(&CommandResponse {
                    request_successful: Some(false),
                    request_id: req.request_id,
                    error_code: Some(1),
                    error_string: Some(
                        "the basic simulator accepts only desired_course commands".into(),
                    ),
                });
            }
            return Ok(());
        };
        let line = format!(
            "CMD,HEADING:{},SPEED:{},DEPTH:{}",
            c.heading(),
            c.speed(),
            c.depth()
        );
        self.conn.lock().last_request = Some(req);
        self.conn.write(&line);
        Ok(())
    }

    fn send_data_to_frontseat(&mut self, _data: InterfaceData) -> Result<(), DriverFailure> {
        // The protocol has no data channel to the frontseat (as in Goby3).
        Ok(())
    }

    fn send_raw_to_frontseat(&mut self, raw: Raw) -> Result<(), DriverFailure> {
        match std::str::from_utf8(raw.raw.as_deref().unwrap_or_default()) {
            Ok(s) => self.conn.write(s.trim_end_matches(['\r', '\n'])),
            Err(_) => self
                .conn
                .host
                .log(LogLevel::Warn, "raw_send_request is not text; dropped"),
        }
        Ok(())
    }

    fn do_loop(&mut self, now: Duration) -> Result<(), DriverFailure> {
        let seen = std::mem::take(&mut self.conn.lock().nav_seen);
        if seen {
            self.last_nav = Some(now);
        } else if let Some(t) = self.last_nav
            && now.saturating_sub(t) > self.settings.nav_timeout
        {
            self.last_nav = None;
            self.conn
                .host
                .log(LogLevel::Warn, "no NAV: frontseat not providing data");
            self.conn.set_state(|s| s.providing = false);
        }
        Ok(())
    }

    fn frontseat_state(&self) -> FrontSeatState {
        self.conn.lock().state
    }

    fn frontseat_providing_data(&self) -> bool {
        self.conn.lock().providing
    }
}

impl Drop for BasicSimPlugin {
    fn drop(&mut self) {
        // Wake the thread from its backoff wait and from a blocking read, then join it: no
        // callbacks after unload returns.
        self.stop.take();
        let writer = {
            let mut s = self.conn.lock();
            s.stopping = true;
            s.writer.take()
        };
        if let Some(w) = writer {
            let _ = w.shutdown(std::net::Shutdown::Both);
        }
        if let Some(t) = self.link.take() {
            let _ = t.join();
        }
    }
}

frontseat_driver_sdk::export_driver!(BasicSimPlugin);
