//! FrontSeatTranslation: the bridge between our bus and a MOOSDB where pHelmIvP runs, as Goby3's
//! `goby::moos::FrontSeatTranslation`. node_status goes out as NAV_* (each one posted exactly
//! once), DESIRED_* come back as DesiredCourse (triggered by DESIRED_SPEED), IVPHELM_STATE as
//! HelmStateReport; our own health (MOOSDB link, helm in DRIVE, DESIRED_* freshness) goes out on
//! `frontseat::translation::status`. The translation never posts IVPHELM_STATE (a foreign
//! IVPHELM_STATE makes pHelmIvP disable itself).
//!
//! It runs as one tokio task, not a ractor actor: the MOOS client already delivers its events on
//! an mpsc channel from its own task and reconnects by itself, so an actor would need a pump task
//! in front of its mailbox (one more hop on the latency path) and there is nothing a supervisor
//! restart could repair. The conversions are pure functions, tested on their own.

use std::time::Duration;

use frontseat_config::MoosConfig;
use frontseat_moos::{DataType, MoosClient, MoosClientConfig, MoosError, MoosEvent, MoosMessage};
use std::sync::Arc;

use ractor::{Actor, ActorProcessingErr, ActorRef};
use tokio::sync::{mpsc, watch};
use tokio::time::Instant;

use frontseat_actors::bus::{Bus, Subscription, Undeliverable};
use frontseat_actors::chaos::FaultPort;
use frontseat_actors::ports::{FrontSeatTranslationInbox, FrontSeatTranslationPorts};
use frontseat_actors::proto::frontseat::protobuf::TranslationStatus;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    DesiredCourse, HelmState, HelmStateReport, NodeStatus, source,
};

/// How often the status is published even when nothing changed.
pub const STATUS_PERIOD: Duration = Duration::from_secs(1);
/// node_status envelopes the translation may hold unread before the bus drops newer ones.
const INBOX_CAPACITY: usize = 64;
/// Notifications kept while the MOOSDB is away (about 2 s of 10 Hz navigation): only fresh
/// navigation is of use to the helm, and a long backlog would be flushed at it on reconnect.
const MOOS_QUEUE_LIMIT: usize = 256;
/// How long `shutdown` waits for the task (the MOOS client flushes within 3 s itself).
const SHUTDOWN_BOUND: Duration = Duration::from_secs(4);

/// Why the translation could not start.
#[derive(Debug, thiserror::Error)]
pub enum TranslationError {
    #[error("moos config: {0}")]
    Config(String),
    #[error("moos client: {0}")]
    Moos(#[from] MoosError),
}

/// One DESIRED_* variable pHelmIvP posts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DesiredVar {
    Speed,
    Heading,
    Depth,
    Pitch,
    Roll,
    ZRate,
    Altitude,
}

impl DesiredVar {
    pub const ALL: [DesiredVar; 7] = [
        DesiredVar::Speed,
        DesiredVar::Heading,
        DesiredVar::Depth,
        DesiredVar::Pitch,
        DesiredVar::Roll,
        DesiredVar::ZRate,
        DesiredVar::Altitude,
    ];

    pub fn key(self) -> &'static str {
        match self {
            DesiredVar::Speed => "DESIRED_SPEED",
            DesiredVar::Heading => "DESIRED_HEADING",
            DesiredVar::Depth => "DESIRED_DEPTH",
            DesiredVar::Pitch => "DESIRED_PITCH",
            DesiredVar::Roll => "DESIRED_ROLL",
            DesiredVar::ZRate => "DESIRED_Z_RATE",
            DesiredVar::Altitude => "DESIRED_ALTITUDE",
        }
    }

    pub fn from_key(key: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|v| v.key() == key)
    }
}

/// The MOOS variable carrying the helm's state.
pub const IVPHELM_STATE: &str = "IVPHELM_STATE";

/// The DESIRED_* values received since the last course, as Goby3 buffers them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DesiredBuffer {
    /// The DESIRED_SPEED of the packet being read (value, MOOS time): the trigger.
    speed: Option<(f64, f64)>,
    heading: Option<f64>,
    depth: Option<f64>,
    pitch: Option<f64>,
    roll: Option<f64>,
    z_rate: Option<f64>,
    altitude: Option<f64>,
}

impl DesiredBuffer {
    /// Takes one DESIRED_* value posted at MOOS time `time`; the last value of a variable wins.
    /// Nothing is published yet: Goby3 buffers the whole mail of one packet before
    /// DESIRED_SPEED triggers the course, so a course carries the heading pHelmIvP posted in the
    /// same iteration (it posts DEPTH, SPEED, HEADING, in that order, in one packet).
    pub fn on_value(&mut self, var: DesiredVar, value: f64, time: f64) {
        let slot = match var {
            DesiredVar::Speed => {
                self.speed = Some((value, time));
                return;
            }
            DesiredVar::Heading => &mut self.heading,
            DesiredVar::Depth => &mut self.depth,
            DesiredVar::Pitch => &mut self.pitch,
            DesiredVar::Roll => &mut self.roll,
            DesiredVar::ZRate => &mut self.z_rate,
            DesiredVar::Altitude => &mut self.altitude,
        };
        *slot = Some(value);
    }

    /// The end of one packet's mail: if it carried a DESIRED_SPEED, the DesiredCourse to publish
    /// (the speed's time, the speed, and every other value buffered since the last course, each
    /// used once). A value that arrives without a speed waits for the next one.
    pub fn on_packet_end(&mut self) -> Option<DesiredCourse> {
        let (speed, time) = self.speed.take()?;
        Some(DesiredCourse {
            time,
            speed: Some(speed),
            heading: self.heading.take(),
            depth: self.depth.take(),
            pitch: self.pitch.take(),
            roll: self.roll.take(),
            z_rate: self.z_rate.take(),
            altitude: self.altitude.take(),
        })
    }
}

/// IVPHELM_STATE, trimmed and case-insensitive: "drive" → DRIVE, "park" → PARK, anything else
/// (STANDBY, DISABLED, MALCONFIG, DRIVE+, ...) → NOT_RUNNING, as Goby3 maps it.
pub fn parse_helm_state(value: &str) -> HelmState {
    let v = value.trim();
    if v.eq_ignore_ascii_case("drive") {
        HelmState::HelmDrive
    } else if v.eq_ignore_ascii_case("park") {
        HelmState::HelmPark
    } else {
        HelmState::HelmNotRunning
    }
}

/// One MOOS post of a node_status.
#[derive(Clone, Debug, PartialEq)]
pub enum NavValue {
    Double(f64),
    Text(String),
}

/// The NAV_* posts of one node_status, in the order Goby3 posts them. Units: metres, degrees for
/// NAV_HEADING / LAT / LONG, radians for NAV_YAW / PITCH / ROLL, m/s for NAV_SPEED.
///
/// NAV_X / NAV_Y are left out when the node_status has no local_fix (Goby3 would post 0, 0 —
/// a position the helm would steer by); the interface fills local_fix whenever its datum is
/// valid, so this only matters for a bad datum.
pub fn nav_posts(ns: &NodeStatus) -> Vec<(&'static str, NavValue)> {
    use NavValue::Double;
    let mut out = Vec::with_capacity(13);
    if let Some(l) = &ns.local_fix {
        out.push(("NAV_X", Double(l.x)));
        out.push(("NAV_Y", Double(l.y)));
    }
    out.push(("NAV_LAT", Double(ns.global_fix.lat)));
    out.push(("NAV_LONG", Double(ns.global_fix.lon)));
    if let Some(z) = ns.local_fix.as_ref().and_then(|l| l.z) {
        out.push(("NAV_Z", Double(z)));
    }
    if let Some(d) = ns.global_fix.depth {
        out.push(("NAV_DEPTH", Double(d)));
    }
    if let Some(h) = ns.pose.heading {
        out.push(("NAV_HEADING", Double(h)));
        out.push(("NAV_YAW", Double(yaw_from_heading(h))));
    }
    out.push(("NAV_SPEED", Double(ns.speed.over_ground)));
    if let Some(p) = ns.pose.pitch {
        out.push(("NAV_PITCH", Double(p.to_radians())));
    }
    if let Some(r) = ns.pose.roll {
        out.push(("NAV_ROLL", Double(r.to_radians())));
    }
    if let Some(a) = ns.global_fix.altitude {
        out.push(("NAV_ALTITUDE", Double(a)));
    }
    let gps = ns
        .source
        .as_ref()
        .and_then(|s| s.position)
        .is_some_and(|p| p == source::Sensor::Gps as i32);
    if gps {
        out.push((
            "GPS_UPDATE_RECEIVED",
            NavValue::Text(format!("Timestamp={}", format_g15(ns.time))),
        ));
    }
    out
}

/// uSimMarine's yaw: −heading folded into (−180°, 180°], in radians (0 = north, positive
/// counter-clockwise).
pub fn yaw_from_heading(heading_deg: f64) -> f64 {
    let mut y = (-heading_deg) % 360.0;
    if y <= -180.0 {
        y += 360.0;
    } else if y > 180.0 {
        y -= 360.0;
    }
    y.to_radians()
}

/// A double as C++ `ostream << setprecision(15)` prints it (`%.15g`), the form Goby3 gives the
/// GPS_UPDATE_RECEIVED timestamp.
pub fn format_g15(x: f64) -> String {
    const P: i32 = 15;
    if !x.is_finite() {
        return if x.is_nan() {
            "nan".into()
        } else if x > 0.0 {
            "inf".into()
        } else {
            "-inf".into()
        };
    }
    if x == 0.0 {
        return if x.is_sign_negative() { "-0" } else { "0" }.into();
    }
    // The exponent after rounding to P significant digits decides the style, as in C.
    let sci = format!("{:.*e}", (P - 1) as usize, x);
    let (mantissa, exp) = sci.split_once('e').unwrap_or((sci.as_str(), "0"));
    let exp: i32 = exp.parse().unwrap_or(0);
    if !(-4..P).contains(&exp) {
        let m = trim_fraction(mantissa);
        let sign = if exp < 0 { '-' } else { '+' };
        format!("{m}e{sign}{:02}", exp.abs())
    } else {
        let decimals = (P - 1 - exp).max(0) as usize;
        trim_fraction(&format!("{x:.decimals$}")).to_owned()
    }
}

fn trim_fraction(s: &str) -> &str {
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.')
    } else {
        s
    }
}

/// The MOOS client configuration for `cfg`: its name, the DB address and the community's
/// MOOSTimeWarp (every time stamp we send is Unix time × warp).
pub fn client_config(cfg: &MoosConfig) -> MoosClientConfig {
    // An IPv6 literal needs brackets in host:port.
    let server = if cfg.server.contains(':') && !cfg.server.starts_with('[') {
        format!("[{}]:{}", cfg.server, cfg.port)
    } else {
        format!("{}:{}", cfg.server, cfg.port)
    };
    MoosClientConfig {
        server,
        // 0 = the service's warp; a config not resolved by the service (with_warp) runs unwarped.
        time_warp: if cfg.time_warp > 0.0 {
            cfg.time_warp
        } else {
            1.0
        },
        queue_limit: MOOS_QUEUE_LIMIT,
        mail_by_packet: true,
        ..MoosClientConfig::new(cfg.app_name.clone())
    }
}

/// What the translation has done since it started.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TranslationCounters {
    /// node_status messages converted and posted to MOOS.
    pub node_status_posted: u64,
    /// Individual NAV_* / GPS_UPDATE_RECEIVED notifications.
    pub nav_notifies: u64,
    /// Notifications the MOOS client refused (shut down, too large).
    pub notify_failures: u64,
    pub desired_course_published: u64,
    pub helm_state_published: u64,
    /// DESIRED_* that were not doubles (ignored; the DB's type lock makes this a misconfigured
    /// poster).
    pub bad_mail: u64,
    /// MOOSDB connections after the first.
    pub reconnects: u64,
}

/// The translation's view of its health, turned into a TranslationStatus on demand.
#[derive(Clone, Debug)]
pub struct Health {
    pub connected: bool,
    pub helm_state: HelmState,
    pub last_helm_state: Option<Instant>,
    pub last_desired: Option<Instant>,
    pub started: Instant,
    pub reconnects: u64,
    /// 0 = never report staleness.
    pub desired_timeout: Duration,
}

impl Health {
    pub fn new(now: Instant, desired_timeout_s: f64) -> Self {
        let desired_timeout = if desired_timeout_s.is_finite() && desired_timeout_s > 0.0 {
            Duration::from_secs_f64(desired_timeout_s)
        } else {
            Duration::ZERO
        };
        Self {
            connected: false,
            helm_state: HelmState::HelmNotRunning,
            last_helm_state: None,
            last_desired: None,
            started: now,
            reconnects: 0,
            desired_timeout,
        }
    }

    /// The status at `now`. The helm counts as NOT_RUNNING when the DB link is down or when
    /// IVPHELM_STATE (a 4 Hz heartbeat of pHelmIvP) has not been heard for `desired_timeout`;
    /// DESIRED_* are stale when none arrived for `desired_timeout` (counting from start when
    /// none ever did).
    pub fn status(&self, now: Instant) -> TranslationStatus {
        let timeout = self.desired_timeout;
        let silent = |last: Option<Instant>| {
            !timeout.is_zero() && now.duration_since(last.unwrap_or(self.started)) > timeout
        };
        let helm_heard = self.last_helm_state.is_some() && !silent(self.last_helm_state);
        let helm_state = if !self.connected || !helm_heard {
            HelmState::HelmNotRunning
        } else {
            self.helm_state
        };
        TranslationStatus {
            moos_connected: Some(self.connected),
            helm_state: Some(helm_state as i32),
            helm_driving: Some(helm_state == HelmState::HelmDrive),
            seconds_since_desired: self
                .last_desired
                .map(|t| now.duration_since(t).as_secs_f64()),
            desired_stale: Some(silent(self.last_desired)),
            reconnects: Some(self.reconnects),
        }
    }
}

/// Whether two statuses differ in what a user acts on (not in the ticking age).
fn status_changed(a: &TranslationStatus, b: &TranslationStatus) -> bool {
    a.moos_connected != b.moos_connected
        || a.helm_state != b.helm_state
        || a.helm_driving != b.helm_driving
        || a.desired_stale != b.desired_stale
        || a.reconnects != b.reconnects
}

/// The running translation.
pub struct TranslationHandle {
    stop: watch::Sender<bool>,
    status: watch::Receiver<TranslationStatus>,
    counters: watch::Receiver<TranslationCounters>,
    task: Option<tokio::task::JoinHandle<()>>,
}

impl TranslationHandle {
    /// Stops: unsubscribes from the bus, flushes what the MOOS client holds and disconnects.
    pub async fn shutdown(mut self) {
        let _ = self.stop.send(true);
        if let Some(mut task) = self.task.take()
            && tokio::time::timeout(SHUTDOWN_BOUND, &mut task)
                .await
                .is_err()
        {
            task.abort();
        }
    }

    /// Receivers of the status and counters, for an observer that outlives this handle.
    pub fn watch(&self) -> TranslationWatch {
        TranslationWatch {
            status: self.status.clone(),
            counters: self.counters.clone(),
        }
    }

    /// The latest status (the one last published, or the initial one).
    pub fn status(&self) -> TranslationStatus {
        *self.status.borrow()
    }

    pub fn counters(&self) -> TranslationCounters {
        *self.counters.borrow()
    }
}

impl Drop for TranslationHandle {
    fn drop(&mut self) {
        // Dropping without shutdown still ends the task (it unsubscribes and closes MOOS).
        let _ = self.stop.send(true);
    }
}

/// Connects to the MOOSDB of `cfg` (retrying in the background until it is there), subscribes to
/// node_status and starts translating. `vehicle_name` only labels the logs.
pub async fn spawn(
    cfg: &MoosConfig,
    vehicle_name: &str,
    bus: &Bus,
) -> Result<TranslationHandle, TranslationError> {
    spawn_with_faults(cfg, vehicle_name, bus, None).await
}

/// [`spawn`] with a fault port (`[chaos] enabled` only, frontseat_actors::chaos): a `translation_panic`
/// fault panics the running translation on its data path.
pub async fn spawn_with_faults(
    cfg: &MoosConfig,
    vehicle_name: &str,
    bus: &Bus,
    faults: Option<FaultPort>,
) -> Result<TranslationHandle, TranslationError> {
    if cfg.app_name.is_empty() {
        return Err(TranslationError::Config(
            "app_name must not be empty".into(),
        ));
    }
    if !(cfg.desired_timeout_s.is_finite() && cfg.desired_timeout_s >= 0.0) {
        return Err(TranslationError::Config(
            "desired_timeout_s must be >= 0".into(),
        ));
    }
    let (moos, events) = MoosClient::start(client_config(cfg))?;
    moos.register(IVPHELM_STATE, 0.0)?;
    for v in DesiredVar::ALL {
        moos.register(v.key(), 0.0)?;
    }
    let (tx, inbox) = mpsc::unbounded_channel();
    let subs = FrontSeatTranslationInbox::subscribe_all(
        bus,
        "FrontSeatTranslation",
        INBOX_CAPACITY,
        move |m| tx.send(m).map_err(|_| Undeliverable),
    );
    let now = Instant::now();
    let health = Health::new(now, cfg.desired_timeout_s);
    let first = health.status(now);
    let ports = FrontSeatTranslationPorts::new(bus);
    ports.publish_status(first);
    let (status_tx, status_rx) = watch::channel(first);
    let (counters_tx, counters_rx) = watch::channel(TranslationCounters::default());
    let (stop_tx, stop_rx) = watch::channel(false);
    let task = Task {
        moos,
        ports,
        health,
        buffer: DesiredBuffer::default(),
        counters: TranslationCounters::default(),
        bad_mail_log: frontseat_actors::ratelog::RateLimitedLog::for_bad_input(),
        connects: 0,
        community: cfg.community.clone(),
        status_tx,
        counters_tx,
        last_nav_trace: String::new(),
    };
    tracing::info!(
        vehicle = vehicle_name,
        moosdb = %format!("{}:{}", cfg.server, cfg.port),
        app = %cfg.app_name,
        time_warp = cfg.time_warp,
        "FrontSeatTranslation starting"
    );
    let task = tokio::spawn(task.run(events, inbox, subs, stop_rx, faults));
    Ok(TranslationHandle {
        stop: stop_tx,
        status: status_rx,
        counters: counters_rx,
        task: Some(task),
    })
}

struct Task {
    moos: MoosClient,
    ports: FrontSeatTranslationPorts,
    health: Health,
    buffer: DesiredBuffer,
    counters: TranslationCounters,
    /// A helm posting DESIRED_* as strings would log one WARN per mail without it.
    bad_mail_log: frontseat_actors::ratelog::RateLimitedLog,
    connects: u64,
    community: String,
    status_tx: watch::Sender<TranslationStatus>,
    counters_tx: watch::Sender<TranslationCounters>,
    /// Trace id of the last node_status posted: a MOOS message carries no trace context, so the
    /// helm's next DESIRED_* starts a new trace that names this one (`after_nav_trace_id`).
    last_nav_trace: String,
}

impl Task {
    async fn run(
        mut self,
        mut events: mpsc::Receiver<MoosEvent>,
        mut inbox: mpsc::UnboundedReceiver<FrontSeatTranslationInbox>,
        subs: Vec<Subscription>,
        mut stop: watch::Receiver<bool>,
        faults: Option<FaultPort>,
    ) {
        let fault = async {
            match &faults {
                Some(port) => port.fired().await,
                None => std::future::pending().await,
            }
        };
        tokio::pin!(fault);
        let mut tick = tokio::time::interval(STATUS_PERIOD);
        tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
        loop {
            tokio::select! {
                biased;
                r = stop.changed() => if r.is_err() || *stop.borrow() { break },
                _ = &mut fault => {
                    panic!("chaos: FrontSeatTranslation panic injected");
                }
                m = inbox.recv() => match m {
                    Some(FrontSeatTranslationInbox::NodeStatus(env)) => {
                        let span = tracing::trace_span!(
                            target: "frontseat_actors",
                            "moos.notify_nav",
                            actor = "FrontSeatTranslation",
                            nav_time = env.msg.time,
                        );
                        frontseat_telemetry::set_parent(&span, env.trace.as_ref());
                        let _g = span.enter();
                        if let Some(t) = frontseat_telemetry::current_trace() {
                            self.last_nav_trace = t.trace_id().to_string();
                        }
                        self.post_node_status(&env.msg)
                    }
                    None => break,
                },
                ev = events.recv() => match ev {
                    Some(ev) => self.on_event(ev),
                    None => {
                        tracing::warn!("MOOS client ended; FrontSeatTranslation stops");
                        break;
                    }
                },
                _ = tick.tick() => {
                    self.log_due_summary();
                    self.publish_status(true);
                }
            }
        }
        for s in subs {
            s.cancel();
        }
        self.moos.shutdown().await;
        self.health.connected = false;
        self.publish_status(true);
        tracing::info!(counters = ?self.counters, "FrontSeatTranslation stopped");
    }

    fn post_node_status(&mut self, ns: &NodeStatus) {
        for (key, value) in nav_posts(ns) {
            let r = match &value {
                NavValue::Double(v) => self.moos.notify_double(key, *v, None),
                NavValue::Text(s) => self.moos.notify_string(key, s, None),
            };
            match r {
                Ok(()) => self.counters.nav_notifies += 1,
                Err(e) => {
                    self.counters.notify_failures += 1;
                    tracing::warn!(key, error = %e, "cannot post to MOOS");
                }
            }
        }
        self.counters.node_status_posted += 1;
        self.counters_tx.send_replace(self.counters);
    }

    fn on_event(&mut self, ev: MoosEvent) {
        match ev {
            MoosEvent::Mail(m) => self.on_mail(&m),
            MoosEvent::Packet(mail) => {
                for m in &mail {
                    self.on_mail(m);
                }
                self.on_packet_end();
            }
            MoosEvent::Connected => {
                self.connects += 1;
                if self.connects > 1 {
                    self.counters.reconnects += 1;
                    self.health.reconnects = self.counters.reconnects;
                }
                self.health.connected = true;
                let welcome = self.moos.welcome();
                let community = welcome.as_ref().map(|w| w.community.as_str());
                if !self.community.is_empty() && community != Some(self.community.as_str()) {
                    tracing::warn!(
                        expected = %self.community,
                        announced = ?community,
                        "the MOOSDB announces another community"
                    );
                }
                tracing::info!(?community, "connected to the MOOSDB");
                self.counters_tx.send_replace(self.counters);
                self.publish_status(false);
            }
            MoosEvent::Disconnected(reason) => {
                tracing::warn!(%reason, "MOOSDB connection lost; reconnecting");
                self.health.connected = false;
                self.publish_status(false);
            }
        }
    }

    fn on_mail(&mut self, m: &MoosMessage) {
        let now = Instant::now();
        let key = m.key.to_string_lossy();
        // Root of a setpoint's trace (MOOS carries no trace context); searchable by the MOOS
        // variable, source and time, and by the trace of the NAV the helm last saw.
        let _span = tracing::trace_span!(
            target: "frontseat_actors",
            "moos.mail",
            actor = "FrontSeatTranslation",
            moos.variable = %key,
            moos.source = %m.source.to_string_lossy(),
            moos.time = m.time,
            after_nav_trace_id = self.last_nav_trace.as_str(),
        )
        .entered();
        if key == IVPHELM_STATE {
            // Goby3 reads it with GetString(): a double reads as "" and maps to NOT_RUNNING.
            let text = if m.data_type == DataType::String {
                String::from_utf8_lossy(&m.string_val)
            } else {
                "".into()
            };
            let state = parse_helm_state(&text);
            self.health.helm_state = state;
            self.health.last_helm_state = Some(now);
            self.ports.publish_helm_state(HelmStateReport {
                state: state as i32,
            });
            self.counters.helm_state_published += 1;
            self.counters_tx.send_replace(self.counters);
            self.publish_status(false);
            return;
        }
        let Some(var) = DesiredVar::from_key(&key) else {
            tracing::debug!(%key, "mail for a variable we did not register; ignored");
            return;
        };
        let Some(value) = m.as_double() else {
            self.counters.bad_mail += 1;
            self.counters_tx.send_replace(self.counters);
            if let frontseat_actors::ratelog::LogDecision::Log { suppressed_before } =
                self.bad_mail_log.decide(tokio::time::Instant::now())
            {
                tracing::warn!(
                    %key,
                    data_type = ?m.data_type,
                    "DESIRED_* is not a double; ignored{}",
                    frontseat_actors::ratelog::more(
                        suppressed_before,
                        "bad DESIRED_* mails",
                        self.bad_mail_log.window()
                    )
                );
            }
            return;
        };
        self.health.last_desired = Some(now);
        self.buffer.on_value(var, value, m.time);
    }

    /// All mail of one packet is in: publish the course its DESIRED_SPEED triggered, if any.
    fn on_packet_end(&mut self) {
        if let Some(course) = self.buffer.on_packet_end() {
            let _span = tracing::trace_span!(
                target: "frontseat_actors",
                "moos.mail",
                actor = "FrontSeatTranslation",
                moos.variable = "DESIRED_SPEED",
                moos.time = course.time,
                after_nav_trace_id = self.last_nav_trace.as_str(),
            )
            .entered();
            self.ports.publish_desired_course(course);
            self.counters.desired_course_published += 1;
            self.counters_tx.send_replace(self.counters);
        }
        self.publish_status(false);
    }

    /// The bad-mail burst's summary once its window has ended, with no further bad mail to
    /// carry it.
    fn log_due_summary(&mut self) {
        if let Some(n) = self.bad_mail_log.summary_due(Instant::now()) {
            let line = frontseat_actors::ratelog::summary(
                n,
                "bad DESIRED_* mails",
                self.bad_mail_log.window(),
            );
            tracing::warn!(
                suppressed = n,
                bad_mail_total = self.counters.bad_mail,
                "{line}"
            );
        }
    }

    /// Publishes the status when `always`, or when it changed in substance.
    fn publish_status(&mut self, always: bool) {
        let s = self.health.status(Instant::now());
        let changed = status_changed(&self.status_tx.borrow(), &s);
        if always || changed {
            self.ports.publish_status(s);
        }
        self.status_tx.send_replace(s);
    }
}

/// The status and counters of one running translation.
#[derive(Clone, Debug)]
pub struct TranslationWatch {
    status: watch::Receiver<TranslationStatus>,
    counters: watch::Receiver<TranslationCounters>,
}

impl TranslationWatch {
    pub fn status(&self) -> TranslationStatus {
        *self.status.borrow()
    }
    pub fn counters(&self) -> TranslationCounters {
        *self.counters.borrow()
    }
}

/// The watch of whichever translation runs now: its supervisor replaces the translation on a
/// restart, and with it the counters (they start again from zero).
#[derive(Clone, Debug, Default)]
pub struct TranslationObserver(Arc<std::sync::Mutex<Option<TranslationWatch>>>);

impl TranslationObserver {
    fn set(&self, w: TranslationWatch) {
        *self.0.lock().unwrap_or_else(|p| p.into_inner()) = Some(w);
    }
    pub fn current(&self) -> Option<TranslationWatch> {
        self.0.lock().unwrap_or_else(|p| p.into_inner()).clone()
    }
    pub fn status(&self) -> Option<TranslationStatus> {
        self.current().map(|w| w.status())
    }
    pub fn counters(&self) -> Option<TranslationCounters> {
        self.current().map(|w| w.counters())
    }
}

/// The FrontSeatTranslation as a supervised actor of the root supervisor: it owns one running
/// translation (MOOS client, registrations, bus subscriptions, the data-path task). The data path
/// stays a task fed directly by the MOOS client and the bus (no extra hop through a mailbox); the
/// actor watches it, so a panic on the data path fails the actor and its supervisor restarts it,
/// which reconnects and re-registers with the MOOSDB.
pub struct TranslationActor;

#[derive(Clone)]
pub struct TranslationArgs {
    pub cfg: MoosConfig,
    pub vehicle: String,
    pub bus: Bus,
    /// Only with `[chaos] enabled`; survives restarts: a fault panics whichever translation
    /// runs now.
    pub faults: Option<FaultPort>,
    /// Survives restarts: sees the status and counters of whichever translation runs now.
    pub observer: TranslationObserver,
}

pub enum TranslationMsg {
    /// The data-path task ended: `Some(why)` when it panicked or ended on its own.
    TaskEnded(String),
}

pub struct TranslationActorState {
    handle: Option<TranslationHandle>,
}

impl Actor for TranslationActor {
    type Msg = TranslationMsg;
    type State = TranslationActorState;
    type Arguments = TranslationArgs;

    async fn pre_start(
        &self,
        myself: ActorRef<Self::Msg>,
        args: TranslationArgs,
    ) -> Result<Self::State, ActorProcessingErr> {
        let mut handle =
            spawn_with_faults(&args.cfg, &args.vehicle, &args.bus, args.faults).await?;
        args.observer.set(handle.watch());
        if let Some(task) = handle.task.take() {
            tokio::spawn(async move {
                let why = match task.await {
                    Ok(()) => "the translation task ended by itself".to_string(),
                    Err(e) if e.is_panic() => {
                        let p = e.into_panic();
                        p.downcast_ref::<&str>()
                            .map(|s| s.to_string())
                            .or_else(|| p.downcast_ref::<String>().cloned())
                            .unwrap_or_else(|| "panic".into())
                    }
                    Err(e) => e.to_string(),
                };
                // Gone already when the actor itself is stopping: nothing to report then.
                let _ = myself.cast(TranslationMsg::TaskEnded(why));
            });
        }
        Ok(TranslationActorState {
            handle: Some(handle),
        })
    }

    async fn handle(
        &self,
        _myself: ActorRef<Self::Msg>,
        msg: Self::Msg,
        _st: &mut Self::State,
    ) -> Result<(), ActorProcessingErr> {
        match msg {
            TranslationMsg::TaskEnded(why) => {
                Err(format!("FrontSeatTranslation data path ended: {why}").into())
            }
        }
    }

    async fn post_stop(
        &self,
        _myself: ActorRef<Self::Msg>,
        st: &mut Self::State,
    ) -> Result<(), ActorProcessingErr> {
        if let Some(h) = st.handle.take() {
            h.shutdown().await;
        }
        Ok(())
    }
}

/// The supervisor's child spec of the translation.
pub fn child_spec(
    args: TranslationArgs,
    policy: frontseat_actors::supervisor::Policy,
) -> frontseat_actors::supervisor::ChildSpec {
    frontseat_actors::supervisor::ChildSpec {
        name: "FrontSeatTranslation".into(),
        policy,
        about: Default::default(),
        start: Arc::new(move |sup| {
            let args = args.clone();
            Box::pin(async move {
                let (actor, _join) = Actor::spawn_linked(None, TranslationActor, args, sup)
                    .await
                    .map_err(|e| e.to_string())?;
                Ok(actor.get_cell())
            })
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
        CartesianCoordinate, EulerAngles, Source, Speed,
    };
    use frontseat_actors::proto::goby::middleware::protobuf::LatLonPoint;

    fn d(posts: &[(&'static str, NavValue)], key: &str) -> Option<f64> {
        posts
            .iter()
            .find(|(k, _)| *k == key)
            .and_then(|(_, v)| match v {
                NavValue::Double(x) => Some(*x),
                NavValue::Text(_) => None,
            })
    }

    #[test]
    fn helm_state_is_trimmed_and_case_insensitive() {
        assert_eq!(parse_helm_state("DRIVE"), HelmState::HelmDrive);
        assert_eq!(parse_helm_state("  drive\n"), HelmState::HelmDrive);
        assert_eq!(parse_helm_state("Park"), HelmState::HelmPark);
        assert_eq!(parse_helm_state("\tPARK "), HelmState::HelmPark);
        for other in [
            "",
            "STANDBY",
            "DISABLED",
            "MALCONFIG",
            "DRIVE+",
            "PARK+",
            "driv",
        ] {
            assert_eq!(
                parse_helm_state(other),
                HelmState::HelmNotRunning,
                "{other}"
            );
        }
    }

    #[test]
    fn a_packet_is_one_helm_iteration() {
        let mut b = DesiredBuffer::default();
        // pHelmIvP's order within one packet: DEPTH, SPEED, HEADING.
        b.on_value(DesiredVar::Depth, 5.0, 10.0);
        b.on_value(DesiredVar::Speed, 1.5, 10.25);
        b.on_value(DesiredVar::Heading, 90.0, 10.26);
        let c = b.on_packet_end().unwrap();
        assert_eq!(
            (c.time, c.speed, c.heading, c.depth),
            (10.25, Some(1.5), Some(90.0), Some(5.0)),
            "the heading of the same iteration, though it came after the speed"
        );
        // A packet without DESIRED_SPEED publishes nothing; its values wait for the speed.
        b.on_value(DesiredVar::Heading, 91.0, 10.5);
        assert_eq!(b.on_packet_end(), None);
        b.on_value(DesiredVar::Speed, 1.6, 10.75);
        let c = b.on_packet_end().unwrap();
        assert_eq!((c.speed, c.heading), (Some(1.6), Some(91.0)));
        // Each value was used once: a speed-only packet gives a course without a heading
        // (the command gate keeps the last commanded heading for it).
        b.on_value(DesiredVar::Speed, 0.0, 11.0);
        assert_eq!(
            b.on_packet_end(),
            Some(DesiredCourse {
                time: 11.0,
                speed: Some(0.0),
                ..Default::default()
            })
        );
        assert_eq!(b.on_packet_end(), None, "one course per trigger");
    }

    #[test]
    fn every_desired_variable_is_buffered_and_the_last_value_wins() {
        let mut b = DesiredBuffer::default();
        for (i, v) in DesiredVar::ALL.iter().enumerate() {
            b.on_value(*v, 100.0 + i as f64, 1.0);
        }
        b.on_value(DesiredVar::Heading, 7.0, 1.0);
        b.on_value(DesiredVar::Speed, 2.0, 3.0);
        let c = b.on_packet_end().unwrap();
        assert_eq!(
            c,
            DesiredCourse {
                time: 3.0,
                speed: Some(2.0),
                heading: Some(7.0),
                depth: Some(102.0),
                pitch: Some(103.0),
                roll: Some(104.0),
                z_rate: Some(105.0),
                altitude: Some(106.0),
            }
        );
        assert_eq!(b, DesiredBuffer::default());
    }

    #[test]
    fn desired_keys_round_trip_and_others_are_not_desired() {
        for v in DesiredVar::ALL {
            assert_eq!(DesiredVar::from_key(v.key()), Some(v));
        }
        assert_eq!(DesiredVar::from_key("DESIRED_THRUST"), None);
        assert_eq!(DesiredVar::from_key("desired_speed"), None);
    }

    fn full_status() -> NodeStatus {
        NodeStatus {
            time: 1_718_000_000.123_45,
            global_fix: LatLonPoint {
                lat: 41.5,
                lon: -70.25,
                depth: Some(3.5),
                altitude: Some(20.0),
            },
            local_fix: Some(CartesianCoordinate {
                x: 12.5,
                y: -7.0,
                z: Some(-3.5),
            }),
            pose: EulerAngles {
                heading: Some(270.0),
                pitch: Some(10.0),
                roll: Some(-5.0),
                ..Default::default()
            },
            speed: Speed {
                over_ground: 1.25,
                over_water: Some(9.0),
            },
            source: Some(Source {
                position: Some(source::Sensor::Gps as i32),
                ..Default::default()
            }),
            ..Default::default()
        }
    }

    #[test]
    fn node_status_becomes_every_nav_variable_in_goby_order() {
        let posts = nav_posts(&full_status());
        let keys: Vec<_> = posts.iter().map(|(k, _)| *k).collect();
        assert_eq!(
            keys,
            [
                "NAV_X",
                "NAV_Y",
                "NAV_LAT",
                "NAV_LONG",
                "NAV_Z",
                "NAV_DEPTH",
                "NAV_HEADING",
                "NAV_YAW",
                "NAV_SPEED",
                "NAV_PITCH",
                "NAV_ROLL",
                "NAV_ALTITUDE",
                "GPS_UPDATE_RECEIVED"
            ]
        );
        assert_eq!(d(&posts, "NAV_X"), Some(12.5));
        assert_eq!(d(&posts, "NAV_Y"), Some(-7.0));
        assert_eq!(d(&posts, "NAV_LAT"), Some(41.5));
        assert_eq!(d(&posts, "NAV_LONG"), Some(-70.25));
        assert_eq!(d(&posts, "NAV_Z"), Some(-3.5));
        assert_eq!(d(&posts, "NAV_DEPTH"), Some(3.5));
        assert_eq!(d(&posts, "NAV_HEADING"), Some(270.0));
        // Heading 270 (west) is yaw +90° (counter-clockwise from north).
        let yaw = d(&posts, "NAV_YAW").unwrap();
        assert!((yaw - std::f64::consts::FRAC_PI_2).abs() < 1e-12, "{yaw}");
        assert_eq!(d(&posts, "NAV_SPEED"), Some(1.25), "over ground, not water");
        assert!((d(&posts, "NAV_PITCH").unwrap() - 10f64.to_radians()).abs() < 1e-15);
        assert!((d(&posts, "NAV_ROLL").unwrap() - (-5f64).to_radians()).abs() < 1e-15);
        assert_eq!(d(&posts, "NAV_ALTITUDE"), Some(20.0));
        assert_eq!(
            posts.last().unwrap().1,
            NavValue::Text("Timestamp=1718000000.12345".into())
        );
    }

    #[test]
    fn optional_fields_are_only_posted_when_present() {
        let ns = NodeStatus {
            time: 5.0,
            global_fix: LatLonPoint {
                lat: 1.0,
                lon: 2.0,
                depth: None,
                altitude: None,
            },
            local_fix: Some(CartesianCoordinate {
                x: 3.0,
                y: 4.0,
                z: None,
            }),
            speed: Speed {
                over_ground: 0.5,
                over_water: None,
            },
            source: Some(Source {
                position: Some(source::Sensor::Usbl as i32),
                ..Default::default()
            }),
            ..Default::default()
        };
        let keys: Vec<_> = nav_posts(&ns).into_iter().map(|(k, _)| k).collect();
        assert_eq!(keys, ["NAV_X", "NAV_Y", "NAV_LAT", "NAV_LONG", "NAV_SPEED"]);
        let no_local = NodeStatus {
            local_fix: None,
            ..ns
        };
        let keys: Vec<_> = nav_posts(&no_local).into_iter().map(|(k, _)| k).collect();
        assert_eq!(keys, ["NAV_LAT", "NAV_LONG", "NAV_SPEED"]);
    }

    #[test]
    fn yaw_is_minus_heading_in_the_half_open_range() {
        let cases = [
            (0.0, 0.0),
            (90.0, -90.0),
            (180.0, 180.0),
            (181.0, 179.0),
            (270.0, 90.0),
            (359.0, 1.0),
            (360.0, 0.0),
            (-90.0, 90.0),
            (540.0, 180.0),
        ];
        for (h, yaw_deg) in cases {
            let y = yaw_from_heading(h);
            assert!(
                (y - f64::to_radians(yaw_deg)).abs() < 1e-12,
                "heading {h}: {} vs {yaw_deg}",
                y.to_degrees()
            );
            assert!(y > -std::f64::consts::PI && y <= std::f64::consts::PI);
        }
    }

    #[test]
    fn g15_formats_like_cpp_setprecision_15() {
        assert_eq!(format_g15(1_718_000_000.123_45), "1718000000.12345");
        assert_eq!(format_g15(1_718_000_000.123_457), "1718000000.12346");
        assert_eq!(format_g15(1_718_000_000.0), "1718000000");
        assert_eq!(format_g15(0.0), "0");
        assert_eq!(format_g15(12.5), "12.5");
        assert_eq!(format_g15(-0.000_125), "-0.000125");
        assert_eq!(format_g15(0.000_012_5), "1.25e-05");
        assert_eq!(format_g15(1e15), "1e+15");
        assert_eq!(format_g15(123_456_789_012_345.0), "123456789012345");
        assert_eq!(format_g15(f64::NAN), "nan");
    }

    #[test]
    fn client_config_carries_address_name_and_time_warp() {
        let cfg = MoosConfig {
            server: "10.0.0.2".into(),
            port: 9001,
            community: "auv".into(),
            app_name: "iFrontSeat".into(),
            time_warp: 5.0,
            desired_timeout_s: 1.0,
        };
        let c = client_config(&cfg);
        assert_eq!(c.server, "10.0.0.2:9001");
        assert_eq!(c.name, "iFrontSeat");
        assert_eq!(c.time_warp, 5.0);
        assert!(c.validate().is_ok());
        let v6 = client_config(&MoosConfig {
            server: "::1".into(),
            ..cfg
        });
        assert_eq!(v6.server, "[::1]:9001");
    }

    #[test]
    fn health_reports_link_helm_and_desired_staleness() {
        let t0 = Instant::now();
        let mut h = Health::new(t0, 2.0);
        let s = h.status(t0);
        assert_eq!(s.moos_connected, Some(false));
        assert_eq!(s.helm_state(), HelmState::HelmNotRunning);
        assert_eq!(s.helm_driving, Some(false));
        assert_eq!(s.desired_stale, Some(false), "not stale before the timeout");
        assert_eq!(s.seconds_since_desired, None);
        assert_eq!(
            h.status(t0 + Duration::from_secs(3)).desired_stale,
            Some(true)
        );

        h.connected = true;
        h.helm_state = HelmState::HelmDrive;
        let t1 = t0 + Duration::from_secs(4);
        h.last_helm_state = Some(t1);
        h.last_desired = Some(t1);
        let s = h.status(t1 + Duration::from_millis(500));
        assert_eq!(s.helm_state(), HelmState::HelmDrive);
        assert_eq!(s.helm_driving, Some(true));
        assert_eq!(s.desired_stale, Some(false));
        assert_eq!(s.seconds_since_desired, Some(0.5));

        // The helm went quiet: neither driving nor fresh.
        let s = h.status(t1 + Duration::from_secs(3));
        assert_eq!(s.helm_state(), HelmState::HelmNotRunning);
        assert_eq!(s.helm_driving, Some(false));
        assert_eq!(s.desired_stale, Some(true));

        // PARK is not driving; a lost link is not driving either.
        h.helm_state = HelmState::HelmPark;
        assert_eq!(h.status(t1).helm_driving, Some(false));
        h.helm_state = HelmState::HelmDrive;
        h.connected = false;
        assert_eq!(h.status(t1).helm_driving, Some(false));

        // Timeout 0 = never stale.
        let never = Health::new(t0, 0.0);
        assert_eq!(
            never.status(t0 + Duration::from_secs(1000)).desired_stale,
            Some(false)
        );
    }

    #[test]
    fn status_change_ignores_the_ticking_age() {
        let t0 = Instant::now();
        let mut h = Health::new(t0, 2.0);
        h.last_desired = Some(t0);
        let a = h.status(t0);
        let b = h.status(t0 + Duration::from_millis(100));
        assert!(!status_changed(&a, &b));
        h.connected = true;
        assert!(status_changed(&a, &h.status(t0)));
    }
}
