//! OpenCPN's autopilot output as one vehicle's helm, on the interface's bus through its
//! generated ports (`OpenCpnHelm`, interface_yaml/opencpn.yaml), so its course crosses the same
//! state machine and command gate as any helm's. It reads UDP datagrams (loopback unless the
//! config opts in: NMEA carries no token), checks each sentence's checksum (bad ones counted,
//! logged at a bounded rate), follows the active leg of APB/RMB — heading to the waypoint's
//! bearing at the configured speed and depth — and publishes `frontseat::opencpn::waypoint`
//! (arrival included). It drives only while it hears a valid leg within `timeout_s`; then it
//! stops publishing helm_state, and the interface's helm_state_timeout ends COMMAND. It stands
//! down while any other helm's helm_state or desired_course is heard on the bus.

use std::collections::VecDeque;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use frontseat_actors::bus::{Bus, PublishMeta, Subscription, Undeliverable};
use frontseat_actors::ports::{OpenCpnHelmInbox, OpenCpnHelmPorts};
use frontseat_actors::proto::frontseat::protobuf::OpenCpnWaypoint;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    DesiredCourse, HelmState, HelmStateReport,
};
use frontseat_config::OpenCpnHelmConfig;
use tokio::net::UdpSocket;
use tokio::sync::mpsc;
use tokio::time::Instant;

use crate::autopilot::{self, AutopilotError, Leg, Said};
use crate::nmea::{self, NmeaError};

/// How often the helm repeats its helm_state and course while it drives.
const REPEAT: Duration = Duration::from_secs(1);
/// Our own recent publications, told apart from another helm's by pointer.
const OURS_KEPT: usize = 32;
/// Largest datagram read (OpenCPN's own read buffer).
const MAX_DATAGRAM: usize = 4096;

/// What the helm read and did.
#[derive(Debug, Default)]
pub struct HelmCounters {
    pub sentences: AtomicU64,
    pub legs: AtomicU64,
    pub bad_checksum: AtomicU64,
    pub unreadable: AtomicU64,
    pub void: AtomicU64,
    pub arrivals: AtomicU64,
    pub courses: AtomicU64,
    pub other_helm: AtomicU64,
    pub timeouts: AtomicU64,
}

fn bump(c: &AtomicU64, what: &str, detail: &dyn std::fmt::Display) {
    let n = c.fetch_add(1, Ordering::Relaxed) + 1;
    if n <= 10 || n.is_power_of_two() {
        tracing::warn!(count = n, "OpenCPN helm: {what}: {detail}");
    }
}

/// The running helm input.
pub struct OpenCpnHelm {
    addr: std::net::SocketAddr,
    task: tokio::task::JoinHandle<()>,
    _subs: Vec<Subscription>,
    pub counters: Arc<HelmCounters>,
}

impl OpenCpnHelm {
    /// Binds `cfg.listen` and starts following.
    pub async fn start(cfg: &OpenCpnHelmConfig, bus: &Bus) -> std::io::Result<Self> {
        let sock = UdpSocket::bind(&cfg.listen).await?;
        let addr = sock.local_addr()?;
        if !addr.ip().is_loopback() && !cfg.allow_non_loopback {
            return Err(std::io::Error::new(
                std::io::ErrorKind::PermissionDenied,
                format!("{addr} is beyond loopback and allow_non_loopback is not set"),
            ));
        }
        let (tx, rx) = mpsc::channel(256);
        let subs = OpenCpnHelmInbox::subscribe_all(bus, "OpenCpnHelm", 256, move |m| {
            // Only what tells of another helm matters here; a full queue drops (bounded).
            let keep = matches!(
                m,
                OpenCpnHelmInbox::DesiredCourse(_) | OpenCpnHelmInbox::HelmState(_)
            );
            if keep {
                tx.try_send(m).map_err(|_| Undeliverable)
            } else {
                Ok(())
            }
        });
        let counters = Arc::new(HelmCounters::default());
        let h = Helm {
            cfg: cfg.clone(),
            ports: OpenCpnHelmPorts::new(bus),
            counters: counters.clone(),
            leg: None,
            other_until: None,
            ours_course: VecDeque::new(),
            ours_state: VecDeque::new(),
            driving: false,
        };
        let task = tokio::spawn(h.run(sock, rx));
        tracing::info!(%addr, "OpenCPN helm: listening for APB/RMB");
        Ok(Self {
            addr,
            task,
            _subs: subs,
            counters,
        })
    }

    pub fn local_addr(&self) -> std::net::SocketAddr {
        self.addr
    }
}

impl frontseat_actors::service_child::Service for OpenCpnHelm {
    fn ended(
        &mut self,
    ) -> frontseat_actors::service_child::BoxFuture<
        '_,
        Result<(), frontseat_actors::supervisor::ChildFailure>,
    > {
        Box::pin(async move {
            let r = (&mut self.task).await;
            Err(frontseat_actors::supervisor::ChildFailure::new(format!(
                "the OpenCPN helm ended: {r:?}"
            )))
        })
    }
    fn stop(
        self: Box<Self>,
        _within: Duration,
    ) -> frontseat_actors::service_child::BoxFuture<'static, ()> {
        Box::pin(async move { self.task.abort() })
    }
}

struct Helm {
    cfg: OpenCpnHelmConfig,
    ports: OpenCpnHelmPorts,
    counters: Arc<HelmCounters>,
    /// The newest valid leg and when it was heard.
    leg: Option<(Leg, Instant)>,
    /// Another helm was heard; stand down until then.
    other_until: Option<Instant>,
    ours_course: VecDeque<Arc<DesiredCourse>>,
    ours_state: VecDeque<Arc<HelmStateReport>>,
    driving: bool,
}

impl Helm {
    async fn run(mut self, sock: UdpSocket, mut inbox: mpsc::Receiver<OpenCpnHelmInbox>) {
        let mut buf = vec![0u8; MAX_DATAGRAM];
        let mut tick = tokio::time::interval(REPEAT);
        tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
        loop {
            // Biased, the bus first: another helm heard before a datagram is read makes this
            // one stand down before it could act on that datagram.
            tokio::select! {
                biased;
                Some(m) = inbox.recv() => self.on_bus(m),
                _ = tick.tick() => self.on_tick(),
                r = sock.recv_from(&mut buf) => match r {
                    Ok((n, _from)) => {
                        let text = String::from_utf8_lossy(&buf[..n]).into_owned();
                        for line in nmea::split(&text) {
                            self.on_line(line);
                        }
                    }
                    Err(e) => {
                        tracing::warn!(error = %e, "OpenCPN helm: UDP receive failed");
                        tokio::time::sleep(Duration::from_millis(50)).await;
                    }
                },
            }
        }
    }

    fn on_line(&mut self, line: &str) {
        let c = &self.counters;
        c.sentences.fetch_add(1, Ordering::Relaxed);
        match autopilot::read(line) {
            Ok(Said::Leg(leg)) => {
                c.legs.fetch_add(1, Ordering::Relaxed);
                let new_leg = self
                    .leg
                    .as_ref()
                    .is_none_or(|(l, _)| l.destination_id != leg.destination_id);
                if leg.arrived {
                    let was = self
                        .leg
                        .as_ref()
                        .is_some_and(|(l, _)| l.arrived && l.destination_id == leg.destination_id);
                    if !was {
                        c.arrivals.fetch_add(1, Ordering::Relaxed);
                        tracing::info!(waypoint = %leg.destination_id, "OpenCPN helm: arrived");
                    }
                }
                if new_leg {
                    tracing::info!(waypoint = %leg.destination_id, bearing = leg.bearing, "OpenCPN helm: steering to a new waypoint");
                }
                // RMB tells the origin and position that APB does not: keep them across the pair.
                let mut leg = leg;
                if let Some((prev, _)) = &self.leg
                    && prev.destination_id == leg.destination_id
                {
                    leg.origin_id = leg.origin_id.or_else(|| prev.origin_id.clone());
                    leg.destination = leg.destination.or(prev.destination);
                    leg.range_nm = leg.range_nm.or(prev.range_nm);
                }
                let bearing_changed = self
                    .leg
                    .as_ref()
                    .is_none_or(|(l, _)| (l.bearing - leg.bearing).abs() > 1e-6);
                self.leg = Some((leg, Instant::now()));
                self.publish_waypoint();
                if new_leg || bearing_changed || !self.driving {
                    self.drive();
                }
            }
            Ok(_) => {}
            Err(AutopilotError::Nmea(e @ NmeaError::BadChecksum { .. })) => {
                bump(&c.bad_checksum, "bad checksum", &e)
            }
            Err(e @ (AutopilotError::Void(_) | AutopilotError::Magnetic)) => {
                bump(&c.void, "sentence not used", &e)
            }
            Err(e) => bump(&c.unreadable, "unreadable sentence", &e),
        }
    }

    fn on_bus(&mut self, m: OpenCpnHelmInbox) {
        let foreign = match &m {
            OpenCpnHelmInbox::DesiredCourse(e) => {
                !self.ours_course.iter().any(|o| Arc::ptr_eq(o, &e.msg))
            }
            OpenCpnHelmInbox::HelmState(e) => {
                // A helm saying it is not running does not drive.
                e.msg.state() != HelmState::HelmNotRunning
                    && !self.ours_state.iter().any(|o| Arc::ptr_eq(o, &e.msg))
            }
            _ => false,
        };
        if foreign {
            let now = Instant::now();
            if self.other_until.is_none_or(|t| t <= now) {
                bump(
                    &self.counters.other_helm,
                    "another helm is driving this vehicle; standing down",
                    &format!("for {} s after it is last heard", self.cfg.standdown_s),
                );
            }
            self.other_until = Some(now + Duration::from_secs_f64(self.cfg.standdown_s));
            self.driving = false;
        }
    }

    fn on_tick(&mut self) {
        let fresh = self
            .leg
            .as_ref()
            .is_some_and(|(_, at)| at.elapsed() <= Duration::from_secs_f64(self.cfg.timeout_s));
        if fresh {
            self.drive();
        } else if self.driving {
            self.driving = false;
            self.counters.timeouts.fetch_add(1, Ordering::Relaxed);
            tracing::warn!(
                timeout_s = self.cfg.timeout_s,
                "OpenCPN helm: no valid APB/RMB; no longer driving (helm_state_timeout takes the vehicle out of COMMAND)"
            );
            self.publish_waypoint();
        }
    }

    fn standing_down(&self) -> bool {
        self.other_until.is_some_and(|t| t > Instant::now())
    }

    /// helm_state DRIVE and the course toward the active waypoint, unless another helm drives.
    fn drive(&mut self) {
        let Some((leg, _)) = &self.leg else { return };
        if self.standing_down() {
            return;
        }
        let state = Arc::new(HelmStateReport {
            state: HelmState::HelmDrive as i32,
        });
        let course = Arc::new(DesiredCourse {
            time: frontseat_actors::clock::SimClock::unix_now(),
            heading: Some(leg.bearing),
            speed: Some(self.cfg.speed),
            depth: Some(self.cfg.depth),
            ..Default::default()
        });
        if self.ours_state.len() >= OURS_KEPT {
            self.ours_state.pop_front();
        }
        self.ours_state.push_back(state.clone());
        if self.ours_course.len() >= OURS_KEPT {
            self.ours_course.pop_front();
        }
        self.ours_course.push_back(course.clone());
        self.ports
            .publish_helm_state_with(state, PublishMeta::default());
        self.ports
            .publish_desired_course_with(course, PublishMeta::default());
        self.counters.courses.fetch_add(1, Ordering::Relaxed);
        self.driving = true;
    }

    fn publish_waypoint(&self) {
        let Some((l, _)) = &self.leg else { return };
        self.ports.publish_waypoint(OpenCpnWaypoint {
            time: Some(frontseat_actors::clock::SimClock::unix_now()),
            origin_id: l.origin_id.clone(),
            destination_id: Some(l.destination_id.clone()),
            destination_lat: l.destination.map(|d| d.0),
            destination_lon: l.destination.map(|d| d.1),
            bearing: Some(l.bearing),
            range_nm: l.range_nm,
            cross_track_nm: l.cross_track_nm,
            arrived: Some(l.arrived),
            steering: Some(self.driving && !self.standing_down()),
        });
    }
}
