//! The running translation: `spawn` connects the MOOS client, registers for the helm's mail and
//! subscribes to node_status; one tokio task then carries the data path both ways (node_status →
//! NAV_* posts, the helm's mail → desired_course / helm_state), handles the MOOSDB connection
//! coming and going, and publishes the status. The handle stops it and shows its status and
//! counters.

use std::time::Duration;

use frontseat_config::MoosConfig;
use frontseat_moos::{DataType, MoosClient, MoosError, MoosEvent, MoosMessage, MoosValue};

use tokio::sync::{mpsc, watch};
use tokio::time::Instant;

use frontseat_actors::bus::{Bus, Subscription, Undeliverable};
use frontseat_actors::chaos::FaultPort;
use frontseat_actors::ports::{FrontSeatTranslationInbox, FrontSeatTranslationPorts};
use frontseat_actors::proto::frontseat::protobuf::TranslationStatus;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{HelmStateReport, NodeStatus};

use super::config::client_config;
use super::health::{Health, status_changed};
use super::helm_mail::{DesiredBuffer, DesiredVar, IVPHELM_STATE, parse_helm_state};
use super::nav::{NavValue, nav_posts};

/// How often the status is published even when nothing changed.
pub const STATUS_PERIOD: Duration = Duration::from_secs(1);
/// node_status envelopes the translation may hold unread before the bus drops newer ones.
const INBOX_CAPACITY: usize = 64;
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

/// The running translation.
pub struct TranslationHandle {
    stop: watch::Sender<bool>,
    status: watch::Receiver<TranslationStatus>,
    counters: watch::Receiver<TranslationCounters>,
    pub(super) task: Option<tokio::task::JoinHandle<()>>,
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
        move |m| {
            crate::hops::hop("translation.delivered", "");
            tx.send(m).map_err(|_| Undeliverable)
        },
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
        target: super::LOG_TARGET,
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
                        crate::hops::hop("translation.nav_woke", "");
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
                    Some(ev) => {
                        crate::hops::hop("translation.mail_woke", "");
                        self.on_event(ev)
                    }
                    None => {
                        tracing::warn!(target: super::LOG_TARGET, "MOOS client ended; FrontSeatTranslation stops");
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
        tracing::info!(target: super::LOG_TARGET, counters = ?self.counters, "FrontSeatTranslation stopped");
    }

    fn post_node_status(&mut self, ns: &NodeStatus) {
        let posts = nav_posts(ns);
        let values: Vec<(&str, MoosValue<'_>)> = posts
            .iter()
            .map(|(key, value)| match value {
                NavValue::Double(v) => (*key, MoosValue::Double(*v)),
                NavValue::Text(s) => (*key, MoosValue::String(s.as_bytes())),
            })
            .collect();
        // One batch: the posts of one node_status leave in one packet, with one wake of the
        // client's writer (issue 49: one per post cost M1 a wake-up and a packet each).
        match self.moos.notify_values(&values, None) {
            Ok(()) => self.counters.nav_notifies += values.len() as u64,
            Err(e) => {
                self.counters.notify_failures += values.len() as u64;
                tracing::warn!(target: super::LOG_TARGET, posts = values.len(), error = %e, "cannot post to MOOS");
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
                        target: super::LOG_TARGET,
                        expected = %self.community,
                        announced = ?community,
                        "the MOOSDB announces another community"
                    );
                }
                tracing::info!(target: super::LOG_TARGET, ?community, "connected to the MOOSDB");
                self.counters_tx.send_replace(self.counters);
                self.publish_status(false);
            }
            MoosEvent::Disconnected(reason) => {
                tracing::warn!(target: super::LOG_TARGET, %reason, "MOOSDB connection lost; reconnecting");
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
            tracing::debug!(target: super::LOG_TARGET, %key, "mail for a variable we did not register; ignored");
            return;
        };
        let Some(value) = m.as_double() else {
            self.counters.bad_mail += 1;
            self.counters_tx.send_replace(self.counters);
            if let frontseat_actors::ratelog::LogDecision::Log { suppressed_before } =
                self.bad_mail_log.decide(tokio::time::Instant::now())
            {
                tracing::warn!(
                    target: super::LOG_TARGET,
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
            crate::hops::hop("translation.course", "");
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
                target: super::LOG_TARGET,
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
