//! The web hub: a bus subscriber like any other (bounded, drop-and-count), subscribed to every
//! group of `interface_yaml/`. It decodes each message once to JSON, keeps the newest and a
//! bounded history per group (plus the local-grid track for the map), and fans the event out to
//! the browser tabs, each through a bounded queue: a full tab misses events (counted), the bus
//! and the other tabs never wait for it.

use std::collections::{BTreeMap, VecDeque};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{SystemTime, UNIX_EPOCH};

use frontseat_actors::bus::{Bus, BusMessage, Layer, Origin, Subscription, Undeliverable};
use frontseat_actors::generated::{EncodedEnvelope, groups, subscribe_encoded};
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::NodeStatus;
use ractor::{Actor, ActorProcessingErr, ActorRef, RpcReplyPort};
use serde_json::{Value as Json, json};
use tokio::sync::mpsc;

use crate::reflect;

fn decode<T: BusMessage>(bytes: &[u8]) -> Option<T> {
    T::decode(bytes).ok()
}

/// Name of the hub's subscriptions in bus statistics.
pub const SUBSCRIBER: &str = "WebScope";

/// Points of the map's track kept (a new point only after 0.5 m of travel).
const TRACK_POINTS: usize = 5000;
const TRACK_STEP_M: f64 = 0.5;
/// Commander sends remembered for the log shown to a newly opened tab.
const SENT_LOG: usize = 100;

/// Counters shared with the HTTP side (statistics events, `/api/stats`).
#[derive(Debug, Default)]
pub struct HubCounters {
    pub messages: AtomicU64,
    pub decode_errors: AtomicU64,
    pub clients_refused: AtomicU64,
    pub events_dropped: AtomicU64,
}

/// One browser tab's end of the fan-out.
pub struct Joined {
    /// Groups, newest messages, track, status history and commander log, as one JSON text.
    pub snapshot: Arc<str>,
    pub events: mpsc::Receiver<Arc<str>>,
    /// Events this tab missed because its queue was full.
    pub dropped: Arc<AtomicU64>,
}

pub enum HubMsg {
    Bus(Box<EncodedEnvelope>),
    Join(RpcReplyPort<Option<Joined>>),
    History(String, RpcReplyPort<Option<Json>>),
    /// A commander send and what it did, for every tab's log.
    Sent(Json),
}

#[derive(Clone, Debug)]
pub struct HubArgs {
    pub bus: Bus,
    pub queue_capacity: usize,
    pub history: usize,
    pub max_clients: usize,
    pub client_queue: usize,
    pub counters: Arc<HubCounters>,
}

struct GroupState {
    info: &'static groups::GroupInfo,
    latest: Option<Arc<str>>,
    history: VecDeque<Arc<str>>,
    count: u64,
}

struct Client {
    tx: mpsc::Sender<Arc<str>>,
    dropped: Arc<AtomicU64>,
}

pub struct HubState {
    args: HubArgs,
    groups: BTreeMap<&'static str, GroupState>,
    track: VecDeque<(f64, f64)>,
    sent: VecDeque<Json>,
    clients: Vec<Client>,
    seq: u64,
    subs: Vec<Subscription>,
}

pub struct Hub;

fn layer_name(l: Layer) -> &'static str {
    match l {
        Layer::Interthread => "interthread",
        Layer::Interprocess => "interprocess",
    }
}

fn unix_ms(t: SystemTime) -> f64 {
    t.duration_since(UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64() * 1000.0)
}

impl HubState {
    /// The event of one message, as JSON text (its decoded message, if any, under "msg"),
    /// written once: the head's fields, then the message's JSON as the reflection writes it.
    fn event(&mut self, env: &EncodedEnvelope) -> String {
        self.seq += 1;
        let published = SystemTime::now()
            .checked_sub(env.published_at.elapsed())
            .unwrap_or_else(SystemTime::now);
        let decoded = reflect::to_json_text(env.type_name, &env.bytes);
        let head = json!({
            "kind": "msg",
            "seq": self.seq,
            "group": env.group,
            "type": env.type_name,
            "time": unix_ms(published),
            "origin": match env.meta.origin { Origin::Local => "local", Origin::Web => "web", Origin::Replayed => "replayed", Origin::Imported | Origin::Goby3 => "imported" },
            "bytes": env.bytes.len(),
        });
        // A JSON object's text ends with its '}': the last field goes in before it.
        let mut ev = head.to_string();
        ev.pop();
        match decoded {
            Ok(m) => {
                ev.push_str(",\"msg\":");
                ev.push_str(&m);
            }
            Err(e) => {
                self.args
                    .counters
                    .decode_errors
                    .fetch_add(1, Ordering::Relaxed);
                ev.push_str(",\"error\":");
                ev.push_str(&Json::String(e.to_string()).to_string());
            }
        }
        ev.push('}');
        ev
    }

    fn record(&mut self, env: Box<EncodedEnvelope>) {
        self.args.counters.messages.fetch_add(1, Ordering::Relaxed);
        let text: Arc<str> = Arc::from(self.event(&env));
        if env.group == groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS.name()
            && let Some(ns) = decode::<NodeStatus>(&env.bytes)
            && let Some(l) = &ns.local_fix
        {
            self.track_point(l.x, l.y);
        }
        if let Some(g) = self.groups.get_mut(env.group) {
            g.count += 1;
            g.latest = Some(text.clone());
            if g.history.len() >= self.args.history {
                g.history.pop_front();
            }
            g.history.push_back(text.clone());
        }
        self.fan_out(text);
    }

    fn fan_out(&mut self, text: Arc<str>) {
        crate::hops::hop("web.fanout", "");
        let counters = &self.args.counters;
        self.clients.retain(|c| match c.tx.try_send(text.clone()) {
            Ok(()) => true,
            Err(mpsc::error::TrySendError::Full(_)) => {
                c.dropped.fetch_add(1, Ordering::Relaxed);
                counters.events_dropped.fetch_add(1, Ordering::Relaxed);
                true
            }
            Err(mpsc::error::TrySendError::Closed(_)) => false,
        });
    }

    fn track_point(&mut self, x: f64, y: f64) {
        if let Some(&(lx, ly)) = self.track.back()
            && (x - lx).hypot(y - ly) < TRACK_STEP_M
        {
            return;
        }
        if self.track.len() >= TRACK_POINTS {
            self.track.pop_front();
        }
        self.track.push_back((x, y));
    }

    fn snapshot(&self) -> Json {
        let groups: Vec<Json> = self
            .groups
            .values()
            .map(|g| {
                json!({
                    "group": g.info.name,
                    "type": g.info.type_name,
                    "layer": layer_name(g.info.layer),
                    "publishers": g.info.publishers,
                    "subscribers": g.info.subscribers,
                    "count": g.count,
                })
            })
            .collect();
        let latest: Vec<Json> = self
            .groups
            .values()
            .filter_map(|g| g.latest.as_ref())
            .filter_map(|t| serde_json::from_str(t).ok())
            .collect();
        let status: Vec<Json> = self
            .groups
            .get(groups::GOBY_MIDDLEWARE_FRONTSEAT_STATUS.name())
            .map(|g| {
                g.history
                    .iter()
                    .filter_map(|t| serde_json::from_str(t).ok())
                    .collect()
            })
            .unwrap_or_default();
        let track: Vec<[f64; 2]> = self.track.iter().map(|&(x, y)| [x, y]).collect();
        json!({
            "kind": "snapshot",
            "groups": groups,
            "latest": latest,
            "status_history": status,
            "track": track,
            "sent": self.sent,
        })
    }

    fn join(&mut self) -> Option<Joined> {
        self.clients.retain(|c| !c.tx.is_closed());
        if self.clients.len() >= self.args.max_clients {
            self.args
                .counters
                .clients_refused
                .fetch_add(1, Ordering::Relaxed);
            return None;
        }
        let (tx, rx) = mpsc::channel(self.args.client_queue.max(1));
        let dropped = Arc::new(AtomicU64::new(0));
        self.clients.push(Client {
            tx,
            dropped: dropped.clone(),
        });
        Some(Joined {
            snapshot: Arc::from(self.snapshot().to_string()),
            events: rx,
            dropped,
        })
    }

    fn history(&self, group: &str) -> Option<Json> {
        let g = self.groups.get(group)?;
        let items: Vec<Json> = g
            .history
            .iter()
            .filter_map(|t| serde_json::from_str(t).ok())
            .collect();
        Some(json!({"group": g.info.name, "type": g.info.type_name, "history": items}))
    }
}

impl Actor for Hub {
    type Msg = HubMsg;
    type State = HubState;
    type Arguments = HubArgs;

    async fn pre_start(
        &self,
        myself: ActorRef<HubMsg>,
        args: HubArgs,
    ) -> Result<HubState, ActorProcessingErr> {
        let mut subs = Vec::new();
        let mut group_states = BTreeMap::new();
        for info in groups::ALL {
            let me = myself.clone();
            let sub = subscribe_encoded(
                &args.bus,
                info.name,
                SUBSCRIBER,
                args.queue_capacity,
                move |env| {
                    crate::hops::hop("web.delivered", env.group);
                    me.cast(HubMsg::Bus(Box::new(env)))
                        .map_err(|_| Undeliverable)
                },
            );
            match sub {
                Some(s) => subs.push(s),
                None => tracing::warn!(group = info.name, "web scope cannot subscribe"),
            }
            group_states.insert(
                info.name,
                GroupState {
                    info,
                    latest: None,
                    history: VecDeque::new(),
                    count: 0,
                },
            );
        }
        Ok(HubState {
            args,
            groups: group_states,
            track: VecDeque::new(),
            sent: VecDeque::new(),
            clients: Vec::new(),
            seq: 0,
            subs,
        })
    }

    async fn post_stop(
        &self,
        _myself: ActorRef<HubMsg>,
        st: &mut HubState,
    ) -> Result<(), ActorProcessingErr> {
        for s in st.subs.drain(..) {
            s.cancel();
        }
        // Dropping the senders ends every tab's event stream, which closes its connection.
        st.clients.clear();
        Ok(())
    }

    async fn handle(
        &self,
        _myself: ActorRef<HubMsg>,
        msg: HubMsg,
        st: &mut HubState,
    ) -> Result<(), ActorProcessingErr> {
        match msg {
            HubMsg::Bus(env) => {
                crate::hops::hop("web.hub", env.group);
                st.record(env)
            }
            HubMsg::Join(reply) => {
                let _ = reply.send(st.join());
            }
            HubMsg::History(group, reply) => {
                let _ = reply.send(st.history(&group));
            }
            HubMsg::Sent(entry) => {
                if st.sent.len() >= SENT_LOG {
                    st.sent.pop_front();
                }
                st.sent.push_back(entry.clone());
                let ev = json!({"kind": "sent", "entry": entry});
                st.fan_out(Arc::from(ev.to_string()));
            }
        }
        Ok(())
    }
}
