//! The vehicle-family rows: each family's real driver in the real interface, over the link it
//! uses (a pseudo-terminal for the serial vehicles, loopback TCP for the others), to that
//! family's emulator — not the scripted basic-simulator frontseat of P1/P2.
//!
//! Two rows a family where it can: `<F>1`, the vehicle's navigation written → node_status at a
//! bus subscriber, and `<F>2`, desired_course published → the vehicle's command read at the
//! vehicle. The emulator is wrapped (`Timed`, no hook in the emulators): a navigation message
//! is stamped when the emulator has it ready to write (right before the write, as P1 stamps
//! before write(2)), a command when the bytes carrying it were read. A node_status is matched
//! to the newest navigation write before it (a second node_status from the same write, as the
//! Iver3's `$C` after `$OSI`, is not counted twice); a command to its course by its heading
//! (DUNE's by its speed: a Reference carries a point, not a heading; each course has its own
//! speed too), so a driver's re-send of an older course is never taken for the new one. The
//! ArduPilots are left armed in GUIDED by the emulator's operator hook (as a ground station's
//! operator would), which the bench calls once the firmware takes GUIDED.

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use frontseat_actors::bus::Bus;
use frontseat_actors::interface::InterfaceService;
use frontseat_actors::ports::BenchHelmPorts;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::DesiredCourse;
use frontseat_config::InterfaceConfig;
use frontseat_sim::emulator::{Emulator, Endpoint, Session};
use serde_json::json;

use super::inproc::{helm_drive, node_status_channel, reached_command, status_channel};
use super::report::{Figures, Hist, Row};

/// How long and how hard each row runs.
#[derive(Clone, Copy, Debug)]
pub struct Plan {
    /// Navigation messages measured per `<F>1` row (at the family's own rate, warped).
    pub nav_count: usize,
    /// Courses per `<F>2` row, one at a time.
    pub cmd_count: usize,
    /// How often a course is published (each waits for its command, at most `cmd_wait`).
    pub cmd_rate_hz: f64,
    pub cmd_wait: Duration,
    /// The emulators' and the interface's sim_warp_factor: the families' own rates × this.
    pub warp: f64,
}

pub const I1: &str =
    "Iver3: $OSI written by the emulated UVC (pty) → node_status at a bus subscriber";
pub const I2: &str = "Iver3: desired_course published → $OMS read by the emulated UVC (pty)";
pub const S1: &str =
    "Wave Glider SV2: the C&C's RequestStatus written (pty) → node_status at a bus subscriber";
pub const S2: &str = "Wave Glider SV2: desired_course published → the heading read by the emulated C&C (pty), pulled at its poll";
pub const A1: &str = "ArduPilot Rover: GLOBAL_POSITION_INT written by the emulated autopilot (TCP) → node_status at a bus subscriber";
pub const U1: &str = "ArduSub: GLOBAL_POSITION_INT written by the emulated autopilot (TCP) → node_status at a bus subscriber";
pub const B1: &str = "Bluefin: $BFNVR written to the payload (TCP, from the Huxley emulator) → node_status at a bus subscriber";
pub const B2: &str =
    "Bluefin: desired_course published → $BPRMB read on the Huxley's side (TCP, a blocking reader)";
pub const D1: &str =
    "DUNE: EstimatedState written by the emulated vehicle (TCP) → node_status at a bus subscriber";
pub const A2: &str = "ArduPilot Rover: desired_course published → SET_POSITION_TARGET_GLOBAL_INT read by the emulated autopilot (TCP), armed in GUIDED";
pub const U2: &str = "ArduSub: desired_course published → SET_POSITION_TARGET_LOCAL_NED read by the emulated autopilot (TCP), armed in GUIDED";
pub const D2: &str = "DUNE: desired_course published → IMC Reference read by the emulated vehicle (TCP), our FollowReference plan running";

/// What the bench reads off a family's emulator: whether bytes it wrote carry navigation, and
/// how many commands it has read with the heading of the last.
trait Probe<S>: Send + 'static {
    fn carries_nav(&mut self, out: &[u8]) -> bool;
    /// Commands read so far, and the key of the last: its heading (DUNE: its speed).
    fn commands(&self, s: &S) -> (u64, Option<f64>);
    /// Before each step of the emulator: what the bench does to the vehicle (the ArduPilots:
    /// armed in GUIDED once the firmware takes it).
    fn prepare(&mut self, _s: &mut S) {}
}

/// Instants the emulator wrote navigation at, and read commands at (with their heading).
#[derive(Default)]
struct Seen {
    navs: Vec<Instant>,
    cmds: Vec<(Instant, Option<f64>)>,
}

/// A family's emulator session, stamping what the rows measure.
struct Timed<S, P> {
    inner: S,
    probe: P,
    seen: Arc<Mutex<Seen>>,
}

impl<S: Session, P: Probe<S>> Timed<S, P> {
    fn seen(&self) -> std::sync::MutexGuard<'_, Seen> {
        self.seen.lock().unwrap_or_else(|p| p.into_inner())
    }
    fn after(&mut self, out: &[u8]) {
        if self.probe.carries_nav(out) {
            let now = Instant::now();
            self.seen().navs.push(now);
        }
    }
}

impl<S: Session, P: Probe<S>> Session for Timed<S, P> {
    fn on_bytes(&mut self, bytes: &[u8], out: &mut Vec<u8>) {
        let read_at = Instant::now();
        let (before, _) = self.probe.commands(&self.inner);
        let n0 = out.len();
        self.inner.on_bytes(bytes, out);
        let (after, heading) = self.probe.commands(&self.inner);
        if after > before {
            self.seen().cmds.push((read_at, heading));
        }
        self.after(&out[n0..]);
    }
    fn step(&mut self, dt: f64, out: &mut Vec<u8>) {
        self.probe.prepare(&mut self.inner);
        let n0 = out.len();
        self.inner.step(dt, out);
        self.after(&out[n0..]);
    }
    fn reset_input(&mut self) {
        self.inner.reset_input();
    }
}

struct IverProbe;

impl Probe<frontseat_iver3::IverSession> for IverProbe {
    fn carries_nav(&mut self, out: &[u8]) -> bool {
        out.windows(4).any(|w| w == b"$OSI")
    }
    fn commands(&self, s: &frontseat_iver3::IverSession) -> (u64, Option<f64>) {
        (s.stats.oms, s.stats.last_oms.as_ref().map(|o| o.heading))
    }
}

struct Sv2Probe(frontseat_waveglider_sv2::codec::FrameDecoder);

impl Probe<frontseat_waveglider_sv2::Sv2Session> for Sv2Probe {
    fn carries_nav(&mut self, out: &[u8]) -> bool {
        use frontseat_waveglider_sv2::codec::msg_type;
        let mut nav = false;
        self.0.feed(out, &mut |f| {
            nav |= f.is_ok_and(|f| f.header.kind() == msg_type::REQUEST_STATUS);
        });
        nav
    }
    fn commands(&self, s: &frontseat_waveglider_sv2::Sv2Session) -> (u64, Option<f64>) {
        (s.stats.commands, s.stats.last_heading.map(f64::from))
    }
}

/// MAVLink frames carrying GLOBAL_POSITION_INT (the driver's node_status comes from it); and
/// whether the operator hook was called.
struct MavNav(frontseat_ardupilot::codec::Deframer, bool);

const GLOBAL_POSITION_INT: u32 = 33;

impl MavNav {
    fn carries_nav(&mut self, out: &[u8]) -> bool {
        let mut nav = false;
        self.0.feed(out, &mut |f| {
            nav |= f.is_ok_and(|f| {
                frontseat_ardupilot::codec::header(&f)
                    .is_ok_and(|h| h.message_id == GLOBAL_POSITION_INT)
            });
        });
        nav
    }
}

impl Probe<frontseat_ardupilot::emulator::RoverSession> for MavNav {
    fn carries_nav(&mut self, out: &[u8]) -> bool {
        MavNav::carries_nav(self, out)
    }
    fn commands(&self, s: &frontseat_ardupilot::emulator::RoverSession) -> (u64, Option<f64>) {
        use frontseat_ardupilot::infer::Target;
        let heading = match s.stats.last_target {
            Some(Target::Course { heading, .. }) => Some(heading),
            _ => None,
        };
        (s.stats.targets_followed, heading)
    }
    fn prepare(&mut self, s: &mut frontseat_ardupilot::emulator::RoverSession) {
        if !self.1 && s.ekf_ready() {
            self.1 = true;
            s.operator_arms_guided();
        }
    }
}

impl Probe<frontseat_ardupilot::sub_emulator::SubSession> for MavNav {
    fn carries_nav(&mut self, out: &[u8]) -> bool {
        MavNav::carries_nav(self, out)
    }
    fn commands(&self, s: &frontseat_ardupilot::sub_emulator::SubSession) -> (u64, Option<f64>) {
        use frontseat_ardupilot::infer::SubTarget;
        let yaw = match s.stats.last_target {
            Some(SubTarget::PosVel { yaw, .. } | SubTarget::Vel { yaw, .. }) => yaw,
            _ => None,
        };
        (s.stats.targets_followed, yaw)
    }
    fn prepare(&mut self, s: &mut frontseat_ardupilot::sub_emulator::SubSession) {
        if !self.1 && s.position_ok() {
            self.1 = true;
            s.operator_arms_guided();
        }
    }
}

/// IMC packets carrying EstimatedState (350).
struct ImcNav(frontseat_dune::imc::Deframer);

const ESTIMATED_STATE: u16 = 350;

impl Probe<frontseat_dune::emulator::DuneSession> for ImcNav {
    fn carries_nav(&mut self, out: &[u8]) -> bool {
        let mut nav = false;
        self.0.feed(out, &mut |f| {
            nav |= f.is_ok_and(|f| {
                frontseat_dune::imc::peek(&f).is_ok_and(|(h, _, _)| h.mgid == ESTIMATED_STATE)
            });
        });
        nav
    }
    /// A Reference's speed is the vehicle's speed setpoint once read (each course has its own).
    fn commands(&self, s: &frontseat_dune::emulator::DuneSession) -> (u64, Option<f64>) {
        (s.stats.references, Some(s.vehicle().setpoint().speed))
    }
}

/// One family's rows as asked: (nav row id and words, command row id and words, if it has one).
struct Family {
    nav: (&'static str, &'static str),
    cmd: Option<(&'static str, &'static str)>,
    /// Commands are matched to their course by speed, not heading (DUNE).
    by_speed: bool,
}

/// Runs the vehicle-family rows `sel` wants, one family after the other.
pub async fn run(plan: Plan, sel: &super::Selection) -> Vec<Row> {
    let mut rows = Vec::new();
    if sel.any(&["I1", "I2"]) {
        let fam = Family {
            nav: ("I1", I1),
            cmd: Some(("I2", I2)),
            by_speed: false,
        };
        let session = Timed {
            inner: frontseat_iver3::IverSession::new(frontseat_iver3::IverOptions {
                remote_helm_version_major: 5,
                ..Default::default()
            }),
            probe: IverProbe,
            seen: Arc::default(),
        };
        rows.extend(
            family(plan, &fam, session, Endpoint::Pty, |cfg, at| {
                cfg.driver.name = "iver3".into();
                cfg.driver.iver3.serial_port = at.to_string();
                cfg.driver.iver3.remote_helm_version_major = Some(5);
                cfg.driver.iver3.link.reconnect_initial_ms = 20;
            })
            .await,
        );
    }
    if sel.any(&["S1", "S2"]) {
        let fam = Family {
            nav: ("S1", S1),
            cmd: Some(("S2", S2)),
            by_speed: false,
        };
        let session = Timed {
            inner: frontseat_waveglider_sv2::Sv2Session::new(
                frontseat_waveglider_sv2::Sv2Options::default(),
            ),
            probe: Sv2Probe(frontseat_waveglider_sv2::codec::FrameDecoder::new()),
            seen: Arc::default(),
        };
        rows.extend(
            family(plan, &fam, session, Endpoint::Pty, |cfg, at| {
                cfg.driver.name = "waveglider_sv2".into();
                cfg.driver.waveglider_sv2.pm_serial_port = at.to_string();
                cfg.driver.waveglider_sv2.publish_navigation = true;
            })
            .await,
        );
    }
    let tcp = Endpoint::Tcp(([127, 0, 0, 1], 0).into());
    if sel.any(&["A1", "A2"]) {
        let fam = Family {
            nav: ("A1", A1),
            // Only when asked for: the command row waits for COMMAND (armed in GUIDED).
            cmd: sel.wants("A2").then_some(("A2", A2)),
            by_speed: false,
        };
        let session = Timed {
            inner: frontseat_ardupilot::emulator::RoverSession::new(Default::default()),
            probe: MavNav(frontseat_ardupilot::codec::Deframer::new(), false),
            seen: Arc::default(),
        };
        rows.extend(
            family(plan, &fam, session, tcp.clone(), |cfg, at| {
                cfg.driver.name = "ardupilot".into();
                cfg.driver.ardupilot.address = format!("tcpout:{at}");
                cfg.driver.ardupilot.reconnect_initial_ms = 20;
            })
            .await,
        );
    }
    if sel.any(&["U1", "U2"]) {
        let fam = Family {
            nav: ("U1", U1),
            cmd: sel.wants("U2").then_some(("U2", U2)),
            by_speed: false,
        };
        let session = Timed {
            inner: frontseat_ardupilot::sub_emulator::SubSession::new(Default::default()),
            probe: MavNav(frontseat_ardupilot::codec::Deframer::new(), false),
            seen: Arc::default(),
        };
        rows.extend(
            family(plan, &fam, session, tcp.clone(), |cfg, at| {
                cfg.driver.name = "ardupilot".into();
                cfg.driver.ardupilot.vehicle = frontseat_config::ArdupilotVehicle::Sub;
                // A BlueROV2 without RC disarms on its pilot-input failsafe (FS_PILOT_INPUT) unless
                // the backseat feeds neutral MANUAL_CONTROL, as a deployment does.
                cfg.driver.ardupilot.pilot_input_keepalive = true;
                cfg.driver.ardupilot.address = format!("tcpout:{at}");
                cfg.driver.ardupilot.reconnect_initial_ms = 20;
            })
            .await,
        );
    }
    if sel.any(&["D1", "D2"]) {
        let fam = Family {
            nav: ("D1", D1),
            cmd: sel.wants("D2").then_some(("D2", D2)),
            by_speed: true,
        };
        let session = Timed {
            inner: frontseat_dune::emulator::DuneSession::new(Default::default()),
            probe: ImcNav(frontseat_dune::imc::Deframer::new()),
            seen: Arc::default(),
        };
        rows.extend(
            family(plan, &fam, session, tcp, |cfg, at| {
                let (host, port) = at.rsplit_once(':').unwrap_or((at, "0"));
                cfg.driver.name = "dune".into();
                cfg.driver.dune.address = host.to_string();
                cfg.driver.dune.port = port.parse().unwrap_or(0);
                cfg.driver.dune.reconnect_initial_ms = 20;
            })
            .await,
        );
    }
    if sel.any(&["B1", "B2"]) {
        rows.extend(bluefin(plan).await);
    }
    rows.retain(|r| sel.wants(r.id));
    rows
}

/// The Bluefin rows. The Huxley emulator is a TCP server of its own (not an emulator session),
/// so the bench stands on the wire between it and the payload: a relay on plain threads that
/// stamps each `$BFNVR` right before it writes it to the payload and each `$BPRMB` when its
/// blocking read returns it (B2's last hop: floor L1), and passes every byte on unchanged.
async fn bluefin(plan: Plan) -> Vec<Row> {
    let fam = Family {
        nav: ("B1", B1),
        cmd: Some(("B2", B2)),
        by_speed: false,
    };
    let base = InterfaceConfig::default();
    let hux = match frontseat_bluefin::HuxleyServer::bind(
        ([127, 0, 0, 1], 0).into(),
        frontseat_bluefin::HuxleyServerOptions {
            huxley: frontseat_bluefin::HuxleyOptions {
                lat: base.origin.lat,
                lon: base.origin.lon,
                ..Default::default()
            },
            warp: plan.warp,
            ..Default::default()
        },
    )
    .await
    {
        Ok(h) => h,
        Err(e) => {
            return vec![
                Row::failed("B1", B1, format!("Huxley emulator: {e}")),
                Row::failed("B2", B2, format!("Huxley emulator: {e}")),
            ];
        }
    };
    let seen: Arc<Mutex<Seen>> = Arc::default();
    let port = match relay(hux.local_addr(), seen.clone()) {
        Ok(p) => p,
        Err(e) => {
            hux.shutdown().await;
            return vec![
                Row::failed("B1", B1, format!("relay: {e}")),
                Row::failed("B2", B2, format!("relay: {e}")),
            ];
        }
    };
    let mut cfg = InterfaceConfig {
        name: "bench-vehicle".into(),
        sim_warp_factor: plan.warp,
        ..InterfaceConfig::default()
    };
    cfg.driver.name = "bluefin".into();
    cfg.driver.bluefin.huxley_tcp_port = port;
    let rows = measure(plan, &fam, &seen, &cfg).await;
    hux.shutdown().await;
    rows
}

/// The relay between the Bluefin payload (it connects here) and the Huxley; ends when either
/// side closes. Its port.
fn relay(huxley: std::net::SocketAddr, seen: Arc<Mutex<Seen>>) -> std::io::Result<u16> {
    use std::io::{BufRead as _, Write as _};
    let listener = std::net::TcpListener::bind(("127.0.0.1", 0))?;
    let port = listener.local_addr()?.port();
    std::thread::spawn(move || {
        let Ok((payload, _)) = listener.accept() else {
            return;
        };
        let Ok(vehicle) = std::net::TcpStream::connect(huxley) else {
            return;
        };
        let _ = payload.set_nodelay(true);
        let _ = vehicle.set_nodelay(true);
        let (Ok(mut to_payload), Ok(from_vehicle)) = (payload.try_clone(), vehicle.try_clone())
        else {
            return;
        };
        let nav_seen = seen.clone();
        std::thread::spawn(move || {
            let mut lines = std::io::BufReader::new(from_vehicle);
            let mut line = Vec::new();
            while lines.read_until(b'\n', &mut line).is_ok_and(|n| n > 0) {
                if line.starts_with(b"$BFNVR") {
                    let now = Instant::now();
                    nav_seen
                        .lock()
                        .unwrap_or_else(|p| p.into_inner())
                        .navs
                        .push(now);
                }
                if to_payload.write_all(&line).is_err() {
                    return;
                }
                line.clear();
            }
        });
        let mut to_vehicle = vehicle;
        let mut lines = std::io::BufReader::new(payload);
        let mut line = Vec::new();
        while lines.read_until(b'\n', &mut line).is_ok_and(|n| n > 0) {
            let now = Instant::now();
            if line.starts_with(b"$BPRMB") {
                // $BPRMB,<time>,<heading>,...
                let heading = std::str::from_utf8(&line)
                    .ok()
                    .and_then(|l| l.split(',').nth(2))
                    .and_then(|h| h.parse::<f64>().ok());
                seen.lock()
                    .unwrap_or_else(|p| p.into_inner())
                    .cmds
                    .push((now, heading));
            }
            if to_vehicle.write_all(&line).is_err() {
                return;
            }
            line.clear();
        }
    });
    Ok(port)
}

/// One family: its emulator on `endpoint`, the interface with its driver there (`configure`
/// gets the config and the emulator's pty path or TCP address), then its rows.
async fn family<S, P>(
    plan: Plan,
    fam: &Family,
    session: Timed<S, P>,
    endpoint: Endpoint,
    configure: impl FnOnce(&mut InterfaceConfig, &str),
) -> Vec<Row>
where
    S: Session,
    P: Probe<S>,
{
    let fail = |why: String| {
        let mut v = vec![Row::failed(fam.nav.0, fam.nav.1, why.clone())];
        if let Some((id, what)) = fam.cmd {
            v.push(Row::failed(id, what, why));
        }
        v
    };
    let seen = session.seen.clone();
    let emu = match Emulator::start(session, endpoint, plan.warp).await {
        Ok(e) => e,
        Err(e) => return fail(format!("emulator: {e}")),
    };
    let at = emu
        .pty_path()
        .map(|p| p.display().to_string())
        .or(emu.tcp_addr().map(|a| a.to_string()))
        .unwrap_or_default();
    let mut cfg = InterfaceConfig {
        name: "bench-vehicle".into(),
        sim_warp_factor: plan.warp,
        ..InterfaceConfig::default()
    };
    configure(&mut cfg, &at);
    let rows = measure(plan, fam, &seen, &cfg).await;
    drop(emu);
    rows
}

/// The interface with `cfg`'s driver on `bus`, a helm driving, then the family's rows from
/// what `seen` stamps at the vehicle's end.
async fn measure(
    plan: Plan,
    fam: &Family,
    seen: &Arc<Mutex<Seen>>,
    cfg: &InterfaceConfig,
) -> Vec<Row> {
    let fail = |why: String| {
        let mut v = vec![Row::failed(fam.nav.0, fam.nav.1, why.clone())];
        if let Some((id, what)) = fam.cmd {
            v.push(Row::failed(id, what, why));
        }
        v
    };
    let capacity = cfg.bus.queue_capacity;
    let bus = Bus::new();
    let (_ns_sub, mut ns_rx) = node_status_channel(&bus, "bench-vehicle", capacity);
    let arrivals: Arc<Mutex<Vec<Instant>>> = Arc::default();
    let ns_task = {
        let arrivals = arrivals.clone();
        tokio::spawn(async move {
            while let Some(_env) = ns_rx.recv().await {
                let now = Instant::now();
                arrivals.lock().unwrap_or_else(|p| p.into_inner()).push(now);
            }
        })
    };
    let (_st_sub, mut st_rx) = status_channel(&bus, capacity);
    let helm = helm_drive(&bus);
    let service = match InterfaceService::start(cfg, &bus, frontseat_drivers::BUILT_IN).await {
        Ok(s) => s,
        Err(e) => {
            helm.abort();
            ns_task.abort();
            return fail(format!("interface: {e}"));
        }
    };
    // Only a family with a command row needs a helm in command; the others' navigation flows
    // as soon as the driver is connected.
    let in_command = fam.cmd.is_some() && reached_command(&mut st_rx).await;
    let mut rows = Vec::new();

    // <F>1: from the first node_status on (before it, the emulator wrote to nobody or to a
    // driver still connecting), every navigation write and every node_status.
    let first = tokio::time::timeout(Duration::from_secs(10), async {
        while arrivals
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .is_empty()
        {
            tokio::time::sleep(Duration::from_millis(5)).await;
        }
    })
    .await;
    if first.is_err() {
        rows.push(Row::failed(
            fam.nav.0,
            fam.nav.1,
            "no node_status within 10 s of the interface's start",
        ));
    }
    let t0 = Instant::now();
    let lock = |m: &Arc<Mutex<Seen>>| {
        let mut g = m.lock().unwrap_or_else(|p| p.into_inner());
        std::mem::take(&mut *g)
    };
    drop(lock(seen));
    arrivals.lock().unwrap_or_else(|p| p.into_inner()).clear();
    let bound = if first.is_err() {
        Duration::ZERO
    } else {
        Duration::from_secs(20)
    };
    while seen.lock().unwrap_or_else(|p| p.into_inner()).navs.len() < plan.nav_count
        && t0.elapsed() < bound
    {
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    // The last ones' node_status.
    tokio::time::sleep(Duration::from_millis(100)).await;
    let navs = lock(seen).navs;
    let got = std::mem::take(&mut *arrivals.lock().unwrap_or_else(|p| p.into_inner()));
    if first.is_ok() {
        rows.push(nav_row(fam.nav, &navs, &got, t0.elapsed(), plan));
    }

    if let Some(cmd) = fam.cmd {
        rows.push(if in_command {
            let lane0 = service
                .snapshot(Duration::from_secs(2))
                .await
                .map_or(0, |s| s.setpoints_direct);
            let mut row = cmd_row(cmd, fam.by_speed, plan, &bus, seen).await;
            let lane = service
                .snapshot(Duration::from_secs(2))
                .await
                .map_or(0, |s| s.setpoints_direct)
                .saturating_sub(lane0);
            row.detail
                .push_str(&format!("; {lane} through the setpoint lane"));
            if let serde_json::Value::Object(m) = &mut row.extra {
                m.insert("setpoint_lane".into(), json!(lane));
            }
            row
        } else {
            Row::failed(
                cmd.0,
                cmd.1,
                "the interface did not reach running:command within 10 s",
            )
        });
    }
    let _ = service.shutdown(Duration::from_secs(2)).await;
    helm.abort();
    ns_task.abort();
    rows
}

/// Each node_status matched to the newest navigation write at or before it, once.
fn nav_row(
    (id, what): (&'static str, &'static str),
    navs: &[Instant],
    got: &[Instant],
    took: Duration,
    plan: Plan,
) -> Row {
    let mut h = Hist::new();
    let mut used = vec![false; navs.len()];
    for &a in got {
        let i = navs.partition_point(|n| *n <= a);
        if let Some(i) = i.checked_sub(1)
            && !used[i]
        {
            used[i] = true;
            h.record(a.saturating_duration_since(navs[i]));
        }
    }
    let matched = used.iter().filter(|u| **u).count();
    let rate = navs.len() as f64 / took.as_secs_f64().max(1e-9);
    let detail = format!(
        "{} navigation writes at {rate:.0} Hz (the family's own rate, warp {}), {} node_status; {matched} matched, {} writes without one",
        navs.len(),
        plan.warp,
        got.len(),
        navs.len() - matched,
    );
    match h.latency() {
        Some(l) => Row {
            id,
            what: what.into(),
            figures: Figures::Latency(l),
            detail,
            extra: json!({ "writes": navs.len(), "node_status": got.len(), "matched": matched }),
        },
        None => Row::failed(id, what, format!("nothing matched; {detail}")),
    }
}

/// `plan.cmd_count` courses one at a time, each a new heading; each waits (at most
/// `plan.cmd_wait`) for the emulator to read a command with its heading.
async fn cmd_row(
    (id, what): (&'static str, &'static str),
    by_speed: bool,
    plan: Plan,
    bus: &Bus,
    seen: &Arc<Mutex<Seen>>,
) -> Row {
    let helm = BenchHelmPorts::new(bus);
    let period = Duration::from_secs_f64(1.0 / plan.cmd_rate_hz.max(1e-3));
    let mut h = Hist::new();
    let mut lost = 0;
    let start = tokio::time::Instant::now();
    for i in 0..plan.cmd_count {
        tokio::time::sleep_until(start + period.mul_f64(i as f64)).await;
        let heading = 10.0 + (i % 340) as f64;
        // Its own speed too (DUNE's key): 1.0 to 2.0 m/s, inside every envelope and vehicle.
        let speed = 1.0 + (i % 500) as f64 * 0.002;
        let (key, tolerance) = if by_speed {
            (speed, 1e-4)
        } else {
            (heading, 0.05)
        };
        seen.lock().unwrap_or_else(|p| p.into_inner()).cmds.clear();
        let sent = Instant::now();
        helm.publish_desired_course(DesiredCourse {
            time: 0.0,
            heading: Some(heading),
            speed: Some(speed),
            depth: Some(1.0),
            ..Default::default()
        });
        let until = tokio::time::Instant::now() + plan.cmd_wait;
        let read = loop {
            let hit = seen
                .lock()
                .unwrap_or_else(|p| p.into_inner())
                .cmds
                .iter()
                .find(|(_, k)| k.is_some_and(|k| (k - key).abs() < tolerance))
                .map(|(t, _)| *t);
            if let Some(t) = hit {
                break Some(t);
            }
            if tokio::time::Instant::now() >= until {
                break None;
            }
            tokio::time::sleep(Duration::from_micros(500)).await;
        };
        match read {
            Some(t) => h.record(t.saturating_duration_since(sent)),
            None => lost += 1,
        }
    }
    let detail = format!(
        "{} desired_course at {:.0} Hz, one at a time, each a new heading and speed; lost {lost} (no command within {:?})",
        plan.cmd_count, plan.cmd_rate_hz, plan.cmd_wait
    );
    match h.latency() {
        Some(l) => Row {
            id,
            what: what.into(),
            figures: Figures::Latency(l),
            detail,
            extra: json!({ "published": plan.cmd_count, "lost": lost }),
        },
        None => Row::failed(id, what, format!("no command read; {detail}")),
    }
}
