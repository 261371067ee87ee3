//! The running gateway: one DDS participant (rustdds) per interface process, its writers fed from
//! the bus and its readers publishing onto the bus through the generated type-erased helpers, as
//! the Zenoh gateway does for its imports — so a ROS 2 helm's course crosses the same command gate
//! and state machine as any helm's. Owns the threads and tasks around rustdds: one writer thread
//! (rustdds writes are synchronous; no tokio worker ever waits on DDS), one reader task per
//! subscribed topic, the graph announcement on `ros_discovery_info`, and the counters.
//!
//! Every sample read is checked before it reaches the bus: the writer must be known from
//! discovery, carry our DDS type name (and, when it announces one, our type hash), and — unless
//! `allow_remote_peers` — announce only loopback locators; the command rate is bounded; the bytes
//! decode (bounded, finite, enums in range). Each refusal is counted, logged rate-limited, never a
//! panic. rustdds keeps at most `depth` samples per reader (keep-last), so a flooding peer costs
//! the helm side CPU, never memory, and the vehicle thread not at all (it only sees what passes).

use std::collections::HashMap;
use std::net::{IpAddr, Ipv4Addr};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, mpsc};
use std::time::{Duration, Instant};

use bytes::Bytes;
use frontseat_actors::bus::{Bus, Origin, PublishMeta, Subscription, Undeliverable};
use frontseat_actors::generated::proto::frontseat::protobuf::InterfaceDetail;
use frontseat_actors::generated::proto::goby::middleware::frontseat::protobuf as fs;
use frontseat_actors::generated::{
    EncodedEnvelope, EncodedError, interprocess_publish_encoded, subscribe_encoded,
};
use frontseat_actors::service_child::{BoxFuture, Service};
use frontseat_actors::supervisor::ChildFailure;
use frontseat_config::{Ros2Config, Ros2Group, Ros2Reliability};
use futures::StreamExt;
use prost::Message;
use rustdds::no_key::{DataReader, DataWriter, DeserializerAdapter, SerializerAdapter};
use rustdds::policy::{Durability, History, Reliability};
use rustdds::{
    DomainParticipant, DomainParticipantBuilder, GUID, QosPolicies, QosPolicyBuilder, RTPSEntity,
    RepresentationIdentifier, TopicKind,
};
use tokio::sync::mpsc as tmpsc;

use crate::msgs::{self, Frames, InputError};
use crate::types::{self, RosType};

/// Why the gateway could not start.
#[derive(Debug, thiserror::Error)]
pub enum Ros2Error {
    #[error("[ros2] namespace: {0}")]
    Namespace(String),
    #[error("cannot join DDS domain {domain}: {reason}")]
    Participant { domain: u16, reason: String },
    #[error("cannot create the DDS {what} on `{topic}`: {reason}")]
    Endpoint {
        what: &'static str,
        topic: String,
        reason: String,
    },
    #[error("bus group `{0}` has no type-erased helper: interface_yaml/ and the gateway disagree")]
    Group(&'static str),
    #[error("cannot start the ROS 2 writer thread: {0}")]
    Thread(String),
}

/// A sample's bytes as rustdds hands them over: the encapsulation header rebuilt in front, so the
/// decoders see the payload as it was on the wire. Longer payloads keep only their length.
#[derive(Debug, Clone)]
pub struct RawSample {
    pub payload: Vec<u8>,
    pub oversized_len: Option<usize>,
}

/// rustdds adapter: our payloads are already XCDR1 bytes (header included, stripped here since
/// rustdds writes the header from `output_encoding`).
pub struct RawAdapter;

#[derive(Debug, thiserror::Error)]
#[error("unreachable")]
pub struct NoError;

impl SerializerAdapter<Vec<u8>> for RawAdapter {
    type Error = NoError;
    fn output_encoding() -> RepresentationIdentifier {
        RepresentationIdentifier::CDR_LE
    }
    fn to_bytes(value: &Vec<u8>) -> Result<Bytes, NoError> {
        Ok(Bytes::copy_from_slice(value.get(4..).unwrap_or_default()))
    }
}

impl DeserializerAdapter<RawSample> for RawAdapter {
    type Error = NoError;
    type Decoded = RawSample;
    fn supported_encodings() -> &'static [RepresentationIdentifier] {
        &[
            RepresentationIdentifier::CDR_LE,
            RepresentationIdentifier::CDR_BE,
        ]
    }
    fn transform_decoded(decoded: RawSample) -> RawSample {
        decoded
    }
}

impl rustdds::no_key::DefaultDecoder<RawSample> for RawAdapter {
    type Decoder = RawDecoder;
    const DECODER: RawDecoder = RawDecoder;
}

#[derive(Clone)]
pub struct RawDecoder;

impl<'de> rustdds::no_key::Decode<'de, RawSample> for RawDecoder {
    type Error = NoError;
    fn decode_bytes(
        self,
        input: &'de [u8],
        encoding: RepresentationIdentifier,
    ) -> Result<RawSample, NoError> {
        if input.len() + 4 > msgs::MAX_INPUT_BYTES {
            return Ok(RawSample {
                payload: Vec::new(),
                oversized_len: Some(input.len() + 4),
            });
        }
        let mut payload = Vec::with_capacity(input.len() + 4);
        payload.extend_from_slice(&encoding.to_bytes());
        payload.extend_from_slice(&[0, 0]);
        payload.extend_from_slice(input);
        Ok(RawSample {
            payload,
            oversized_len: None,
        })
    }
}

/// The gateway's counters, by name (for `/diagnostics`, logs and tests).
#[derive(Default)]
struct Counters {
    published: AtomicU64,
    write_errors: AtomicU64,
    received: AtomicU64,
    imported: AtomicU64,
    refused_oversized: AtomicU64,
    refused_malformed: AtomicU64,
    refused_not_finite: AtomicU64,
    refused_bad_enum: AtomicU64,
    refused_wrong_type: AtomicU64,
    refused_remote_peer: AtomicU64,
    refused_unknown_writer: AtomicU64,
    refused_rate: AtomicU64,
}

fn bump(c: &AtomicU64) -> u64 {
    c.fetch_add(1, Ordering::Relaxed) + 1
}

/// Log the first ten, then at powers of two (as the Zenoh gateway does).
fn worth_logging(n: u64) -> bool {
    n <= 10 || n.is_power_of_two()
}

impl Counters {
    fn snapshot(&self) -> Vec<(&'static str, u64)> {
        let g = |c: &AtomicU64| c.load(Ordering::Relaxed);
        vec![
            ("published", g(&self.published)),
            ("write_errors", g(&self.write_errors)),
            ("received", g(&self.received)),
            ("imported", g(&self.imported)),
            ("refused_oversized", g(&self.refused_oversized)),
            ("refused_malformed", g(&self.refused_malformed)),
            ("refused_not_finite", g(&self.refused_not_finite)),
            ("refused_bad_enum", g(&self.refused_bad_enum)),
            ("refused_wrong_type", g(&self.refused_wrong_type)),
            ("refused_remote_peer", g(&self.refused_remote_peer)),
            ("refused_unknown_writer", g(&self.refused_unknown_writer)),
            ("refused_rate", g(&self.refused_rate)),
        ]
    }
    fn refusal(&self, kind: &str) -> &AtomicU64 {
        match kind {
            "oversized" => &self.refused_oversized,
            "not_finite" => &self.refused_not_finite,
            "bad_enum" => &self.refused_bad_enum,
            "wrong_type" => &self.refused_wrong_type,
            "remote_peer" => &self.refused_remote_peer,
            "unknown_writer" => &self.refused_unknown_writer,
            "rate" => &self.refused_rate,
            _ => &self.refused_malformed,
        }
    }
}

/// Counters of a running gateway.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Ros2Stats(pub Vec<(&'static str, u64)>);

impl Ros2Stats {
    pub fn get(&self, name: &str) -> u64 {
        self.0
            .iter()
            .find(|(k, _)| *k == name)
            .map_or(0, |(_, v)| *v)
    }
    /// Every refused input sample.
    pub fn refused(&self) -> u64 {
        self.0
            .iter()
            .filter(|(k, _)| k.starts_with("refused"))
            .map(|(_, v)| v)
            .sum()
    }
}

/// What the writer thread is handed.
enum Out {
    NodeStatus(EncodedEnvelope),
    Status(EncodedEnvelope),
    CommandResponse(EncodedEnvelope),
    Detail(EncodedEnvelope),
    Stop,
}

type Writer = DataWriter<Vec<u8>, RawAdapter>;
type Reader = DataReader<RawSample, RawAdapter>;

fn qos(rel: Ros2Reliability, depth: u32) -> QosPolicies {
    let b = QosPolicyBuilder::new()
        .durability(Durability::Volatile)
        .history(History::KeepLast {
            depth: i32::try_from(depth).unwrap_or(1000),
        });
    match rel {
        // rmw_cyclonedds sets an infinite blocking time; ours never blocks: keep-last history
        // replaces the oldest sample instead.
        Ros2Reliability::Reliable => b.reliability(Reliability::Reliable {
            max_blocking_time: rustdds::Duration::ZERO,
        }),
        Ros2Reliability::BestEffort => b.reliability(Reliability::BestEffort),
    }
    .build()
}

/// The fully qualified ROS topic `<ns>/frontseat/<leaf>`.
fn topic_of(ns: &str, leaf: &str) -> String {
    format!("{ns}/{}/{leaf}", types::NODE_NAME)
}

struct Endpoints {
    participant: DomainParticipant,
    pubr: rustdds::Publisher,
    subr: rustdds::Subscriber,
    writers: Vec<[u8; 16]>,
    readers: Vec<[u8; 16]>,
}

impl Endpoints {
    fn writer(&mut self, ros_topic: &str, t: RosType, q: QosPolicies) -> Result<Writer, Ros2Error> {
        let name = if ros_topic == types::DISCOVERY_TOPIC {
            ros_topic.to_string()
        } else {
            types::dds_topic(ros_topic)
        };
        let err = |what, e: String| Ros2Error::Endpoint {
            what,
            topic: name.clone(),
            reason: e,
        };
        let topic = self
            .participant
            .create_topic(name.clone(), t.dds_name(), &q, TopicKind::NoKey)
            .map_err(|e| err("topic", e.to_string()))?;
        let w = self
            .pubr
            .create_datawriter_no_key::<Vec<u8>, RawAdapter>(&topic, Some(q))
            .map_err(|e| err("writer", e.to_string()))?;
        self.writers.push(w.guid().to_bytes());
        Ok(w)
    }
    fn reader(&mut self, ros_topic: &str, t: RosType, q: QosPolicies) -> Result<Reader, Ros2Error> {
        let name = types::dds_topic(ros_topic);
        let err = |what, e: String| Ros2Error::Endpoint {
            what,
            topic: name.clone(),
            reason: e,
        };
        let topic = self
            .participant
            .create_topic(name.clone(), t.dds_name(), &q, TopicKind::NoKey)
            .map_err(|e| err("topic", e.to_string()))?;
        let r = self
            .subr
            .create_datareader_no_key::<RawSample, RawAdapter>(&topic, Some(q))
            .map_err(|e| err("reader", e.to_string()))?;
        self.readers.push(r.guid().to_bytes());
        Ok(r)
    }
}

/// The running gateway; a helm-side child of the interface's root supervisor.
pub struct Ros2Gateway {
    namespace: String,
    participant: DomainParticipant,
    counters: Arc<Counters>,
    bus_subs: Vec<Subscription>,
    out: mpsc::Sender<Out>,
    writer_thread: Option<std::thread::JoinHandle<()>>,
    tasks: Vec<tokio::task::JoinHandle<()>>,
    failed: tmpsc::UnboundedReceiver<String>,
}

impl std::fmt::Debug for Ros2Gateway {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Ros2Gateway")
            .field("namespace", &self.namespace)
            .field("stats", &self.stats())
            .finish()
    }
}

/// One subscribed topic: where its samples go.
#[derive(Clone, Copy)]
enum Input {
    DesiredCourse,
    HelmState,
    CommandRequest,
}

impl Input {
    fn ros_type(self) -> RosType {
        match self {
            Input::DesiredCourse => types::DESIRED_COURSE,
            Input::HelmState => types::HELM_STATE_REPORT,
            Input::CommandRequest => types::COMMAND_REQUEST,
        }
    }
    fn leaf(self) -> &'static str {
        match self {
            Input::DesiredCourse => "desired_course",
            Input::HelmState => "helm_state",
            Input::CommandRequest => "command_request",
        }
    }
    fn group(self) -> &'static str {
        match self {
            Input::DesiredCourse => "goby::middleware::frontseat::desired_course",
            Input::HelmState => "goby::middleware::frontseat::helm_state",
            Input::CommandRequest => "goby::middleware::frontseat::command_request",
        }
    }
    fn decode(self, payload: &[u8]) -> Result<Vec<u8>, InputError> {
        Ok(match self {
            Input::DesiredCourse => msgs::decode_desired_course(payload)?.encode_to_vec(),
            Input::HelmState => msgs::decode_helm_state(payload)?.encode_to_vec(),
            Input::CommandRequest => msgs::decode_command_request(payload)?.encode_to_vec(),
        })
    }
}

/// A bucket of `rate` tokens a second, `rate` deep: the command rate bound shared by every
/// command topic.
struct Bucket {
    rate: f64,
    tokens: f64,
    last: Instant,
}

impl Bucket {
    fn new(rate: f64) -> Self {
        Self {
            rate,
            tokens: rate,
            last: Instant::now(),
        }
    }
    fn take(&mut self) -> bool {
        let now = Instant::now();
        let dt = now.duration_since(self.last).as_secs_f64();
        self.last = now;
        self.tokens = (self.tokens + dt * self.rate).min(self.rate);
        if self.tokens >= 1.0 {
            self.tokens -= 1.0;
            true
        } else {
            false
        }
    }
}

/// What the reader tasks know of the writers that discovery reported.
struct Peers {
    participant: DomainParticipant,
    allow_remote: bool,
    /// writer GUID → Ok(()) or the refusal kind. Bounded: cleared when full.
    known: HashMap<GUID, Result<(), &'static str>>,
}

const MAX_KNOWN_WRITERS: usize = 1024;

impl Peers {
    fn judge(&mut self, writer: GUID, t: RosType) -> Result<(), &'static str> {
        if let Some(v) = self.known.get(&writer) {
            return *v;
        }
        // Discovery runs on rustdds's thread; a sample can come before we asked: ask now.
        let found = self
            .participant
            .discovered_writers()
            .into_iter()
            .find(|w| w.writer_proxy.remote_writer_guid == writer);
        let Some(w) = found else {
            return Err("unknown_writer");
        };
        let verdict = if w.publication_topic_data.type_name != t.dds_name()
            || RosType::hash_in_user_data(&w.user_data).is_some_and(|h| h != t.hash)
        {
            Err("wrong_type")
        } else if !self.allow_remote
            && !w
                .writer_proxy
                .unicast_locator_list
                .iter()
                .chain(&w.writer_proxy.multicast_locator_list)
                .all(|l| l.is_loopback())
        {
            Err("remote_peer")
        } else {
            Ok(())
        };
        if self.known.len() >= MAX_KNOWN_WRITERS {
            self.known.clear();
        }
        self.known.insert(writer, verdict);
        verdict
    }
}

impl Ros2Gateway {
    pub fn stats(&self) -> Ros2Stats {
        Ros2Stats(self.counters.snapshot())
    }
    /// `/<platform>` or the configured namespace.
    pub fn namespace(&self) -> &str {
        &self.namespace
    }
    /// The participant's GUID (its `gid` in `ros_discovery_info`).
    pub fn participant_guid(&self) -> [u8; 16] {
        self.participant.guid().to_bytes()
    }

    /// Resolves when a part of the gateway ended by itself: the reason.
    pub async fn ended(&mut self) -> String {
        self.failed
            .recv()
            .await
            .unwrap_or_else(|| "the ROS 2 gateway's tasks ended".into())
    }

    /// Unsubscribes from the bus, stops the writer thread and the reader tasks, leaves DDS.
    pub fn close(mut self) {
        self.shut();
    }

    fn shut(&mut self) {
        for s in std::mem::take(&mut self.bus_subs) {
            s.cancel();
        }
        for t in self.tasks.drain(..) {
            t.abort();
        }
        let _ = self.out.send(Out::Stop);
        if let Some(t) = self.writer_thread.take() {
            // The thread only writes to rustdds's channels and wakes once a second at most.
            let _ = t.join();
        }
    }
}

impl Drop for Ros2Gateway {
    fn drop(&mut self) {
        self.shut();
    }
}

impl Service for Ros2Gateway {
    fn ended(&mut self) -> BoxFuture<'_, Result<(), ChildFailure>> {
        Box::pin(async move { Err(ChildFailure::new(Ros2Gateway::ended(self).await)) })
    }
    fn stop(self: Box<Self>, _within: Duration) -> BoxFuture<'static, ()> {
        Box::pin(async move {
            let stats = self.stats();
            (*self).close();
            tracing::info!(?stats, "ROS 2 gateway stopped");
        })
    }
}

/// Bus capacity per exported group: envelopes in flight to the writer thread before the bus drops
/// (and counts) new ones.
const EXPORT_CAPACITY: usize = 256;
/// How often `/diagnostics` is published (rqt_runtime_monitor shows a status as stale after 5 s).
const DIAGNOSTICS_PERIOD: Duration = Duration::from_secs(1);

/// Joins DDS and starts the gateway for the interface whose platform name is `platform`.
pub fn start(bus: &Bus, cfg: &Ros2Config, platform: &str) -> Result<Ros2Gateway, Ros2Error> {
    let namespace = cfg
        .resolve_namespace(platform)
        .map_err(|why| Ros2Error::Namespace(format!("{platform:?} {why}")))?;
    let mut b = DomainParticipantBuilder::new(cfg.domain_id);
    if !cfg.allow_remote_peers {
        b = b.with_only_networks([IpAddr::V4(Ipv4Addr::LOCALHOST)]);
    }
    let participant = b.build().map_err(|e| Ros2Error::Participant {
        domain: cfg.domain_id,
        reason: e.to_string(),
    })?;
    let err = |e: rustdds::dds::CreateError| Ros2Error::Participant {
        domain: cfg.domain_id,
        reason: e.to_string(),
    };
    let pubr = participant
        .create_publisher(&QosPolicies::qos_none())
        .map_err(err)?;
    let subr = participant
        .create_subscriber(&QosPolicies::qos_none())
        .map_err(err)?;
    let mut ep = Endpoints {
        participant: participant.clone(),
        pubr,
        subr,
        writers: Vec::new(),
        readers: Vec::new(),
    };
    let nav_q = qos(cfg.qos.navigation, cfg.qos.navigation_depth);
    let cmd_q = qos(cfg.qos.commands, cfg.qos.commands_depth);
    let t = |leaf| topic_of(&namespace, leaf);

    let nav = if cfg.has(Ros2Group::Navigation) {
        Some((
            ep.writer(&t("odom"), types::ODOMETRY, nav_q.clone())?,
            ep.writer(&t("fix"), types::NAV_SAT_FIX, nav_q.clone())?,
            ep.writer(&t("node_status"), types::NODE_STATUS, nav_q)?,
        ))
    } else {
        None
    };
    let status = if cfg.has(Ros2Group::Status) {
        Some(ep.writer(&t("status"), types::INTERFACE_STATUS, cmd_q.clone())?)
    } else {
        None
    };
    let diagnostics = if cfg.has(Ros2Group::Diagnostics) {
        Some(ep.writer("/diagnostics", types::DIAGNOSTIC_ARRAY, cmd_q.clone())?)
    } else {
        None
    };
    let mut inputs = Vec::new();
    let response = if cfg.has(Ros2Group::Commands) {
        for i in [
            Input::HelmState,
            Input::DesiredCourse,
            Input::CommandRequest,
        ] {
            inputs.push((i, ep.reader(&t(i.leaf()), i.ros_type(), cmd_q.clone())?));
        }
        Some(ep.writer(
            &t("command_response"),
            types::COMMAND_RESPONSE,
            cmd_q.clone(),
        )?)
    } else {
        None
    };
    // ros_discovery_info: reliable, transient-local, keep-last 1 (facts file §2). Its own writer
    // is not listed (the rmws do not list theirs either).
    let disc_q = QosPolicyBuilder::new()
        .durability(Durability::TransientLocal)
        .history(History::KeepLast { depth: 1 })
        .reliability(Reliability::Reliable {
            max_blocking_time: rustdds::Duration::ZERO,
        })
        .build();
    let listed_writers = ep.writers.clone();
    let discovery = ep.writer(
        types::DISCOVERY_TOPIC,
        types::PARTICIPANT_ENTITIES_INFO,
        disc_q,
    )?;
    let info = msgs::participant_entities_info(
        participant.guid().to_bytes(),
        &namespace,
        types::NODE_NAME,
        &ep.readers,
        &listed_writers,
    );
    if let Err(e) = discovery.write(info, None) {
        tracing::warn!(error = ?e, "cannot announce the node on ros_discovery_info");
    }

    let counters = Arc::new(Counters::default());
    let (failed_tx, failed) = tmpsc::unbounded_channel::<String>();

    // Export: bus → the writer thread.
    let (out, out_rx) = mpsc::channel::<Out>();
    let mut bus_subs = Vec::new();
    let mut sub =
        |group: &'static str, wrap: fn(EncodedEnvelope) -> Out| -> Result<(), Ros2Error> {
            let tx = out.clone();
            let s = subscribe_encoded(bus, group, "ros2-gateway", EXPORT_CAPACITY, move |env| {
                if env.meta.origin.is_imported() {
                    return Ok(());
                }
                tx.send(wrap(env)).map_err(|_| Undeliverable)
            })
            .ok_or(Ros2Error::Group(group))?;
            bus_subs.push(s);
            Ok(())
        };
    if nav.is_some() {
        sub("goby::middleware::frontseat::node_status", Out::NodeStatus)?;
    }
    if status.is_some() {
        sub("goby::middleware::frontseat::status", Out::Status)?;
    }
    if response.is_some() {
        sub(
            "goby::middleware::frontseat::command_response",
            Out::CommandResponse,
        )?;
    }
    if diagnostics.is_some() {
        sub("frontseat::interface::detail", Out::Detail)?;
    }
    let frames = Frames {
        odom: cfg.odom_frame.clone(),
        base: cfg.base_frame.clone(),
    };
    let writers = ThreadWriters {
        nav,
        status,
        response,
        diagnostics,
        _discovery: discovery,
    };
    let c = counters.clone();
    let ns = namespace.clone();
    let ftx = failed_tx.clone();
    let writer_thread = std::thread::Builder::new()
        .name("frontseat-ros2-out".into())
        .spawn(move || {
            write_loop(out_rx, writers, &frames, &ns, &c);
            let _ = ftx.send("the ROS 2 writer thread ended".into());
        })
        .map_err(|e| Ros2Error::Thread(e.to_string()))?;

    // Import: one task per reader; one command rate bound for all of them.
    let bucket = Arc::new(std::sync::Mutex::new(Bucket::new(cfg.max_command_rate_hz)));
    let peers = Arc::new(std::sync::Mutex::new(Peers {
        participant: participant.clone(),
        allow_remote: cfg.allow_remote_peers,
        known: HashMap::new(),
    }));
    let stopping = Arc::new(AtomicBool::new(false));
    let mut tasks = Vec::new();
    for (input, reader) in inputs {
        let (bus, c, bucket, peers, ftx, ns) = (
            bus.clone(),
            counters.clone(),
            bucket.clone(),
            peers.clone(),
            failed_tx.clone(),
            namespace.clone(),
        );
        let stopping = stopping.clone();
        tasks.push(tokio::spawn(async move {
            let mut stream = reader.async_sample_stream();
            while let Some(r) = stream.next().await {
                match r {
                    Ok(s) => {
                        let writer = s.sample_info().writer_guid();
                        import(&bus, input, &ns, s.into_value(), writer, &c, &bucket, &peers);
                    }
                    Err(e) => {
                        let n = bump(&c.refused_malformed);
                        if worth_logging(n) {
                            tracing::warn!(topic = input.leaf(), error = ?e, count = n, "DDS read error");
                        }
                    }
                }
            }
            if !stopping.load(Ordering::Relaxed) {
                let _ = ftx.send(format!("the ROS 2 reader of {} ended", input.leaf()));
            }
        }));
    }

    tracing::info!(
        domain = cfg.domain_id,
        namespace = %namespace,
        node = %format!("{namespace}/{}", types::NODE_NAME),
        loopback_only = !cfg.allow_remote_peers,
        groups = ?cfg.groups,
        "ROS 2 gateway running"
    );
    Ok(Ros2Gateway {
        namespace,
        participant,
        counters,
        bus_subs,
        out,
        writer_thread: Some(writer_thread),
        tasks,
        failed,
    })
}

#[allow(clippy::too_many_arguments)]
fn import(
    bus: &Bus,
    input: Input,
    ns: &str,
    sample: RawSample,
    writer: GUID,
    c: &Counters,
    bucket: &std::sync::Mutex<Bucket>,
    peers: &std::sync::Mutex<Peers>,
) {
    c.received.fetch_add(1, Ordering::Relaxed);
    let topic = topic_of(ns, input.leaf());
    let refuse = |kind: &'static str, why: &dyn std::fmt::Display| {
        let n = bump(c.refusal(kind));
        if worth_logging(n) {
            tracing::warn!(topic = %topic, kind, count = n, "ROS 2 sample refused: {why}");
        }
    };
    let verdict = peers
        .lock()
        .map(|mut p| p.judge(writer, input.ros_type()))
        .unwrap_or(Err("unknown_writer"));
    if let Err(kind) = verdict {
        let why = match kind {
            "wrong_type" => "its writer announced another type name or type hash",
            "remote_peer" => {
                "its participant announced a non-loopback address ([ros2] allow_remote_peers = false)"
            }
            _ => "its writer is not (yet) known from discovery",
        };
        refuse(kind, &why);
        return;
    }
    if let Some(len) = sample.oversized_len {
        refuse(
            "oversized",
            &format!("{len} bytes, more than {}", msgs::MAX_INPUT_BYTES),
        );
        return;
    }
    let bytes = match input.decode(&sample.payload) {
        Ok(b) => b,
        Err(e) => {
            refuse(e.kind(), &e);
            return;
        }
    };
    let allowed = bucket.lock().map(|mut b| b.take()).unwrap_or(false);
    if !allowed {
        refuse("rate", &"over [ros2] max_command_rate_hz");
        return;
    }
    let meta = PublishMeta {
        trace: None,
        origin: Origin::Imported,
    };
    match interprocess_publish_encoded(bus, input.group(), &bytes, meta) {
        Ok(_) => {
            c.imported.fetch_add(1, Ordering::Relaxed);
        }
        Err(EncodedError::Decode { reason, .. }) => refuse("malformed", &reason),
        Err(e) => refuse("malformed", &e),
    }
}

struct ThreadWriters {
    nav: Option<(Writer, Writer, Writer)>,
    status: Option<Writer>,
    response: Option<Writer>,
    diagnostics: Option<Writer>,
    /// Kept alive: its one transient-local sample answers late joiners.
    _discovery: Writer,
}

fn write_loop(rx: mpsc::Receiver<Out>, w: ThreadWriters, frames: &Frames, ns: &str, c: &Counters) {
    let put = |writer: &Writer, bytes: Vec<u8>, what: &str| match writer.write(bytes, None) {
        Ok(()) => {
            c.published.fetch_add(1, Ordering::Relaxed);
        }
        Err(e) => {
            let n = bump(&c.write_errors);
            if worth_logging(n) {
                tracing::warn!(topic = what, error = ?e, count = n, "DDS write failed");
            }
        }
    };
    let mut detail: Option<InterfaceDetail> = None;
    let mut next_diag = Instant::now() + DIAGNOSTICS_PERIOD;
    loop {
        let wait = next_diag.saturating_duration_since(Instant::now());
        let msg = match rx.recv_timeout(wait) {
            Ok(Out::Stop) | Err(mpsc::RecvTimeoutError::Disconnected) => return,
            Ok(m) => Some(m),
            Err(mpsc::RecvTimeoutError::Timeout) => None,
        };
        match msg {
            Some(Out::NodeStatus(env)) => {
                if let (Some((odom, fix, nsw)), Ok(n)) =
                    (&w.nav, fs::NodeStatus::decode(env.bytes.as_slice()))
                {
                    put(odom, msgs::odometry(&n, frames), "odom");
                    put(fix, msgs::nav_sat_fix(&n, frames), "fix");
                    put(nsw, msgs::node_status(&n), "node_status");
                }
            }
            Some(Out::Status(env)) => {
                if let (Some(sw), Ok(s)) =
                    (&w.status, fs::InterfaceStatus::decode(env.bytes.as_slice()))
                {
                    put(sw, msgs::interface_status(&s), "status");
                }
            }
            Some(Out::CommandResponse(env)) => {
                if let (Some(rw), Ok(r)) = (
                    &w.response,
                    fs::CommandResponse::decode(env.bytes.as_slice()),
                ) {
                    put(rw, msgs::command_response(&r), "command_response");
                }
            }
            Some(Out::Detail(env)) => {
                if let Ok(d) = InterfaceDetail::decode(env.bytes.as_slice()) {
                    detail = Some(d);
                }
            }
            Some(Out::Stop) => return,
            None => {}
        }
        if Instant::now() >= next_diag {
            next_diag = Instant::now() + DIAGNOSTICS_PERIOD;
            if let (Some(dw), Some(d)) = (&w.diagnostics, &detail) {
                let now = std::time::SystemTime::now()
                    .duration_since(std::time::UNIX_EPOCH)
                    .map_or(0.0, |d| d.as_secs_f64());
                let statuses = msgs::diagnostics(ns, d, &c.snapshot());
                put(dw, msgs::diagnostic_array(now, &statuses), "diagnostics");
            }
        }
    }
}
