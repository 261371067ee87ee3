//! The in-process bus: typed publish/subscribe on the groups the interface compiler generates.
//!
//! A published message is wrapped once in an `Arc` and shared by every subscriber. Each subscriber
//! has a bounded number of envelopes in flight (delivered but not yet dropped by the receiver); past
//! that bound the publisher does not wait — the envelope is dropped for that subscriber and counted.
//! The bound is kept with a ticket inside the envelope, so it works with any delivery mechanism
//! (a ractor mailbox, a channel) without an extra hop.
//!
//! Publishing and subscribing are private to this crate: outside it, an actor reaches the bus
//! only through the ports generated for it from `interface_yaml/` (`generated::ports`), and a
//! process-wide observer or bridge only through the generated, declared-groups-only doors
//! (`subscribe_encoded` for the recorder and the web scope, `interprocess_publish_encoded` for
//! the gateways and the replay). Tests reach the raw API through [`test_util::UntypedBus`], which
//! exists only with the `test-util` feature (a dev-dependency feature; no binary enables it).

use std::any::Any;
use std::collections::HashMap;
use std::marker::PhantomData;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, RwLock};
use std::time::Instant;

/// Where a group travels: in this process only, or also to other processes (Zenoh).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Layer {
    Interthread,
    Interprocess,
}

/// A typed group: the name is Goby3's group name; the type parameter is the message it carries.
pub struct Group<T> {
    name: &'static str,
    type_name: &'static str,
    layer: Layer,
    _msg: PhantomData<fn() -> T>,
}

impl<T> Clone for Group<T> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<T> Copy for Group<T> {}

impl<T> std::fmt::Debug for Group<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Group({} : {})", self.name, self.type_name)
    }
}

impl<T> Group<T> {
    pub const fn new(name: &'static str, type_name: &'static str, layer: Layer) -> Self {
        Self {
            name,
            type_name,
            layer,
            _msg: PhantomData,
        }
    }
    pub fn name(&self) -> &'static str {
        self.name
    }
    /// Const, so a vehicle crate can name its extension's type by its declared group.
    pub const fn type_name(&self) -> &'static str {
        self.type_name
    }
    pub fn layer(&self) -> Layer {
        self.layer
    }
}

/// Anything that can travel on the bus: a prost message that can be shared across threads.
pub trait BusMessage: prost::Message + Default + Clone + Send + Sync + 'static {}
impl<T: prost::Message + Default + Clone + Send + Sync + 'static> BusMessage for T {}

/// The trace context an envelope carries (defined with the telemetry, which makes it).
pub use frontseat_telemetry::TraceContext;

/// Whether a message was published in this process or imported from another (so the gateway
/// does not export it again), and through which door (so the interface can decide who may use
/// `raw_send_request`), or replayed from a recording (`frontseat replay`: it never meets a live
/// driver, see [`Bus::claim`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Origin {
    #[default]
    Local,
    /// From another process over Zenoh.
    Imported,
    /// From a Goby3 application through gobyd.
    Goby3,
    /// Published in this process by the web commander on behalf of a browser.
    Web,
    /// Replayed from a recording (exported like a local message: the replay stands in for the
    /// vehicle's interface).
    Replayed,
}

impl Origin {
    /// Came from another process (and so is not exported again).
    pub fn is_imported(self) -> bool {
        matches!(self, Origin::Imported | Origin::Goby3)
    }

    pub fn name(self) -> &'static str {
        match self {
            Origin::Local => "local",
            Origin::Imported => "zenoh",
            Origin::Goby3 => "goby3",
            Origin::Web => "web",
            Origin::Replayed => "replayed",
        }
    }
}

/// What a process's bus is for; the two exclude each other so recorded messages never reach a
/// real vehicle through the same bus.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BusRole {
    /// A driver talks to a vehicle (or its simulator) on this bus.
    LiveDriver,
    /// A recording is replayed onto this bus.
    Replay,
}

#[derive(Clone, Debug, Default)]
pub struct PublishMeta {
    pub trace: Option<TraceContext>,
    pub origin: Origin,
}

/// Returns the in-flight slot of its subscriber when the envelope is dropped.
struct Ticket(Arc<AtomicUsize>);

impl Drop for Ticket {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::AcqRel);
    }
}

/// Something kept alive as long as a delivery, and as long as the deliveries of what the
/// receiver re-publishes from it with [`Bus::publish_held`]: the setpoint lane's fence
/// (`crate::setpoint_lane`) learns from its drop that a message has left the actors.
#[derive(Clone)]
pub struct Held(#[allow(dead_code)] Arc<dyn Any + Send + Sync>);

impl Held {
    pub(crate) fn new(what: impl Any + Send + Sync) -> Self {
        Self(Arc::new(what))
    }
}

/// One delivery of one message to one subscriber.
pub struct Envelope<T> {
    pub group: &'static str,
    pub msg: Arc<T>,
    pub published_at: Instant,
    pub trace: Option<TraceContext>,
    pub origin: Origin,
    _ticket: Ticket,
    held: Option<Held>,
}

impl<T> Envelope<T> {
    /// The same delivery carrying another message (e.g. a DesiredCourse wrapped into a
    /// CommandRequest): keeps the trace, origin, publish time and the queue slot.
    pub fn rewrap<U>(env: Envelope<T>, msg: U) -> Envelope<U> {
        Envelope {
            group: env.group,
            msg: Arc::new(msg),
            published_at: env.published_at,
            trace: env.trace,
            origin: env.origin,
            _ticket: env._ticket,
            held: env.held,
        }
    }

    /// What this delivery keeps alive (see [`Held`]).
    pub(crate) fn held(&self) -> Option<Held> {
        self.held.clone()
    }

    /// The same delivery, keeping `held` alive until it is dropped.
    pub(crate) fn holding(mut self, held: Held) -> Self {
        self.held = Some(held);
        self
    }

    /// The publish metadata, to pass the trace on when re-publishing.
    pub fn meta(&self) -> PublishMeta {
        PublishMeta {
            trace: self.trace.clone(),
            origin: self.origin,
        }
    }
}

impl<T: std::fmt::Debug> std::fmt::Debug for Envelope<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Envelope")
            .field("group", &self.group)
            .field("msg", &self.msg)
            .field("origin", &self.origin)
            .finish()
    }
}

/// What one publish did: how many subscribers got the message, how many were full and missed it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PublishReport {
    pub delivered: usize,
    pub dropped: usize,
}

/// Returned by a delivery function when its receiver is gone; the subscription is then removed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Undeliverable;

/// Counters of one subscriber, for status and metrics.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SubscriberStats {
    pub group: &'static str,
    pub subscriber: String,
    pub delivered: u64,
    pub dropped: u64,
    pub in_flight: usize,
}

type DeliverFn<T> = dyn Fn(Envelope<T>) -> Result<(), Undeliverable> + Send + Sync;

struct Subscriber<T> {
    id: u64,
    name: String,
    capacity: usize,
    in_flight: Arc<AtomicUsize>,
    delivered: AtomicU64,
    dropped: AtomicU64,
    deliver: Box<DeliverFn<T>>,
}

/// The subscribers of one group; stored type-erased in the bus map.
struct Slot<T> {
    subs: RwLock<Vec<Arc<Subscriber<T>>>>,
}

trait AnySlot: Send + Sync {
    fn as_any(&self) -> &dyn Any;
    fn stats(&self, group: &'static str, out: &mut Vec<SubscriberStats>);
    fn remove(&self, id: u64);
}

impl<T: BusMessage> AnySlot for Slot<T> {
    fn as_any(&self) -> &dyn Any {
        self
    }
    fn stats(&self, group: &'static str, out: &mut Vec<SubscriberStats>) {
        let subs = self.subs.read().unwrap_or_else(|p| p.into_inner());
        for s in subs.iter() {
            out.push(SubscriberStats {
                group,
                subscriber: s.name.clone(),
                delivered: s.delivered.load(Ordering::Relaxed),
                dropped: s.dropped.load(Ordering::Relaxed),
                in_flight: s.in_flight.load(Ordering::Relaxed),
            });
        }
    }
    fn remove(&self, id: u64) {
        let mut subs = self.subs.write().unwrap_or_else(|p| p.into_inner());
        subs.retain(|s| s.id != id);
    }
}

/// The name under which the Goby3 (gobyd) transport reports its link.
pub const GOBY3_LINK: &str = "goby3";

struct Inner {
    slots: RwLock<HashMap<&'static str, Arc<dyn AnySlot>>>,
    next_id: AtomicU64,
    dropped_total: AtomicU64,
    /// Up/down of this process's links to other processes (e.g. "goby3"), set by the gateways
    /// that own them and read by whoever reports status: neither depends on the other.
    links: RwLock<Vec<(&'static str, bool)>>,
    role: std::sync::Mutex<Option<BusRole>>,
}

/// The bus. Cheap to clone; every clone is the same bus.
#[derive(Clone)]
pub struct Bus {
    inner: Arc<Inner>,
}

impl Default for Bus {
    fn default() -> Self {
        Self::new()
    }
}

impl std::fmt::Debug for Bus {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Bus")
    }
}

/// A live subscription. Dropping it leaves the subscription in place (actors hold it implicitly
/// for their lifetime); `cancel` removes it. A subscription whose receiver is gone is removed at
/// the next publish anyway.
pub struct Subscription {
    bus: std::sync::Weak<Inner>,
    group: &'static str,
    id: u64,
}

impl Subscription {
    pub fn group(&self) -> &'static str {
        self.group
    }
    pub fn cancel(self) {
        if let Some(inner) = self.bus.upgrade() {
            let slots = inner.slots.read().unwrap_or_else(|p| p.into_inner());
            if let Some(slot) = slots.get(self.group) {
                slot.remove(self.id);
            }
        }
    }
}

impl Bus {
    pub fn new() -> Self {
        Self {
            inner: Arc::new(Inner {
                slots: RwLock::new(HashMap::new()),
                next_id: AtomicU64::new(1),
                dropped_total: AtomicU64::new(0),
                links: RwLock::new(Vec::new()),
                role: std::sync::Mutex::new(None),
            }),
        }
    }

    fn slot<T: BusMessage>(&self, group: &Group<T>) -> Option<Arc<dyn AnySlot>> {
        let slots = self.inner.slots.read().unwrap_or_else(|p| p.into_inner());
        slots.get(group.name).cloned()
    }

    fn slot_or_insert<T: BusMessage>(&self, group: &Group<T>) -> Arc<dyn AnySlot> {
        if let Some(s) = self.slot(group) {
            return s;
        }
        let mut slots = self.inner.slots.write().unwrap_or_else(|p| p.into_inner());
        slots
            .entry(group.name)
            .or_insert_with(|| {
                Arc::new(Slot::<T> {
                    subs: RwLock::new(Vec::new()),
                })
            })
            .clone()
    }

    pub(crate) fn publish<T: BusMessage>(&self, group: &Group<T>, msg: T) -> PublishReport {
        self.publish_with(group, Arc::new(msg), PublishMeta::default())
    }

    /// Publishes to every subscriber of `group` without ever waiting: a subscriber with
    /// `capacity` envelopes in flight misses this one, and the miss is counted.
    pub(crate) fn publish_with<T: BusMessage>(
        &self,
        group: &Group<T>,
        msg: Arc<T>,
        meta: PublishMeta,
    ) -> PublishReport {
        self.publish_held(group, msg, meta, None)
    }

    /// As [`Bus::publish_with`], and every delivery keeps `held` alive until it is dropped.
    pub(crate) fn publish_held<T: BusMessage>(
        &self,
        group: &Group<T>,
        msg: Arc<T>,
        meta: PublishMeta,
        held: Option<Held>,
    ) -> PublishReport {
        let mut report = PublishReport::default();
        let Some(slot) = self.slot(group) else {
            return report;
        };
        // The generated groups give one type per name, so this only fails if two hand-made
        // groups disagree; such a publish reaches nobody rather than the wrong type.
        let Some(slot) = slot.as_any().downcast_ref::<Slot<T>>() else {
            tracing::error!(
                group = group.name,
                "publish with a type other than the group's"
            );
            return report;
        };
        let published_at = Instant::now();
        let mut gone = Vec::new();
        // Hop spans exist only while traces are exported; otherwise the envelope just passes
        // on whatever context the publisher was given (e.g. imported from another process).
        let telemetry = frontseat_telemetry::enabled();
        let publish_span = telemetry.then(|| {
            let s = tracing::trace_span!(
                target: "frontseat_actors",
                "bus.publish",
                group = group.name,
                message_type = group.type_name,
            );
            if tracing::Span::current().is_none() {
                frontseat_telemetry::set_parent(&s, meta.trace.as_ref());
            }
            s
        });
        let _publish_guard = publish_span.as_ref().map(|s| s.enter());
        {
            let subs = slot.subs.read().unwrap_or_else(|p| p.into_inner());
            for sub in subs.iter() {
                let prev = sub.in_flight.fetch_add(1, Ordering::AcqRel);
                if prev >= sub.capacity {
                    sub.in_flight.fetch_sub(1, Ordering::AcqRel);
                    sub.dropped.fetch_add(1, Ordering::Relaxed);
                    self.inner.dropped_total.fetch_add(1, Ordering::Relaxed);
                    report.dropped += 1;
                    continue;
                }
                let deliver_span = telemetry.then(|| {
                    tracing::trace_span!(
                        target: "frontseat_actors",
                        "bus.deliver",
                        group = group.name,
                        message_type = group.type_name,
                        subscriber = sub.name.as_str(),
                    )
                });
                let _deliver_guard = deliver_span.as_ref().map(|s| s.enter());
                let trace = if telemetry {
                    frontseat_telemetry::current_trace()
                } else {
                    meta.trace.clone()
                };
                let env = Envelope {
                    group: group.name,
                    msg: msg.clone(),
                    published_at,
                    trace,
                    origin: meta.origin,
                    _ticket: Ticket(sub.in_flight.clone()),
                    held: held.clone(),
                };
                match (sub.deliver)(env) {
                    Ok(()) => {
                        sub.delivered.fetch_add(1, Ordering::Relaxed);
                        report.delivered += 1;
                    }
                    Err(Undeliverable) => gone.push(sub.id),
                }
            }
        }
        for id in gone {
            tracing::debug!(
                group = group.name,
                id,
                "removing subscriber whose receiver is gone"
            );
            slot.remove(id);
        }
        report
    }

    /// Subscribes `deliver` to `group`. `deliver` runs on the publisher's thread and must not
    /// block: hand the envelope to a mailbox or channel.
    pub(crate) fn subscribe<T: BusMessage>(
        &self,
        group: &Group<T>,
        subscriber: &str,
        capacity: usize,
        deliver: impl Fn(Envelope<T>) -> Result<(), Undeliverable> + Send + Sync + 'static,
    ) -> Subscription {
        let slot = self.slot_or_insert(group);
        let id = self.inner.next_id.fetch_add(1, Ordering::Relaxed);
        if let Some(slot) = slot.as_any().downcast_ref::<Slot<T>>() {
            let mut subs = slot.subs.write().unwrap_or_else(|p| p.into_inner());
            subs.push(Arc::new(Subscriber {
                id,
                name: subscriber.to_string(),
                capacity: capacity.max(1),
                in_flight: Arc::new(AtomicUsize::new(0)),
                delivered: AtomicU64::new(0),
                dropped: AtomicU64::new(0),
                deliver: Box::new(deliver),
            }));
        } else {
            tracing::error!(
                group = group.name,
                "subscribe with a type other than the group's"
            );
        }
        Subscription {
            bus: Arc::downgrade(&self.inner),
            group: group.name,
            id,
        }
    }

    /// Subscribes with a channel. At most `capacity` envelopes are held unread; more are dropped
    /// and counted. Only the runtime's tests and [`test_util`] use it.
    #[cfg(any(test, feature = "test-util"))]
    pub(crate) fn subscribe_channel<T: BusMessage>(
        &self,
        group: &Group<T>,
        subscriber: &str,
        capacity: usize,
    ) -> (
        Subscription,
        tokio::sync::mpsc::UnboundedReceiver<Envelope<T>>,
    ) {
        let (tx, rx) = tokio::sync::mpsc::unbounded_channel();
        let sub = self.subscribe(group, subscriber, capacity, move |env| {
            tx.send(env).map_err(|_| Undeliverable)
        });
        (sub, rx)
    }

    pub fn stats(&self) -> Vec<SubscriberStats> {
        let mut out = Vec::new();
        let slots = self.inner.slots.read().unwrap_or_else(|p| p.into_inner());
        for (name, slot) in slots.iter() {
            slot.stats(name, &mut out);
        }
        out.sort_by(|a, b| (a.group, &a.subscriber).cmp(&(b.group, &b.subscriber)));
        out
    }

    pub fn total_dropped(&self) -> u64 {
        self.inner.dropped_total.load(Ordering::Relaxed)
    }

    /// Claims the bus for `role`: refused (with the role already held) when the other role has
    /// it, so a replay and a live driver can never share a bus. Claiming a held role again is
    /// fine (a restarted driver).
    pub fn claim(&self, role: BusRole) -> Result<(), BusRole> {
        let mut r = self.inner.role.lock().unwrap_or_else(|p| p.into_inner());
        match *r {
            Some(held) if held != role => Err(held),
            _ => {
                *r = Some(role);
                Ok(())
            }
        }
    }

    /// Records whether the link `name` (a transport to other processes) is up.
    pub fn set_link_up(&self, name: &'static str, up: bool) {
        let mut links = self.inner.links.write().unwrap_or_else(|p| p.into_inner());
        match links.iter_mut().find(|(n, _)| *n == name) {
            Some(l) => l.1 = up,
            None => links.push((name, up)),
        }
    }

    /// Whether link `name` is up; `None` when this process runs no such link.
    pub fn link_up(&self, name: &str) -> Option<bool> {
        let links = self.inner.links.read().unwrap_or_else(|p| p.into_inner());
        links.iter().find(|(n, _)| *n == name).map(|l| l.1)
    }
}

/// The untyped bus for tests and test helms: any group, any subscriber name, a channel per
/// subscription. Compiled only with `cfg(test)` or the `test-util` feature, which the workspace
/// enables for dev-dependencies only, so no production binary can use it.
#[cfg(any(test, feature = "test-util"))]
pub mod test_util {
    use std::sync::Arc;

    use super::Undeliverable;
    use super::{Bus, BusMessage, Envelope, Group, PublishMeta, PublishReport, Subscription};

    /// `use frontseat_actors::bus::test_util::UntypedBus as _;` and a test publishes or
    /// subscribes any group by hand, as the generated ports do.
    pub trait UntypedBus {
        fn publish<T: BusMessage>(&self, group: &Group<T>, msg: T) -> PublishReport;
        fn publish_with<T: BusMessage>(
            &self,
            group: &Group<T>,
            msg: Arc<T>,
            meta: PublishMeta,
        ) -> PublishReport;
        fn subscribe<T: BusMessage>(
            &self,
            group: &Group<T>,
            subscriber: &str,
            capacity: usize,
            deliver: impl Fn(Envelope<T>) -> Result<(), Undeliverable> + Send + Sync + 'static,
        ) -> Subscription;
        #[allow(clippy::type_complexity)]
        fn subscribe_channel<T: BusMessage>(
            &self,
            group: &Group<T>,
            subscriber: &str,
            capacity: usize,
        ) -> (
            Subscription,
            tokio::sync::mpsc::UnboundedReceiver<Envelope<T>>,
        );
    }

    impl UntypedBus for Bus {
        fn publish<T: BusMessage>(&self, group: &Group<T>, msg: T) -> PublishReport {
            Bus::publish(self, group, msg)
        }
        fn publish_with<T: BusMessage>(
            &self,
            group: &Group<T>,
            msg: Arc<T>,
            meta: PublishMeta,
        ) -> PublishReport {
            Bus::publish_with(self, group, msg, meta)
        }
        fn subscribe<T: BusMessage>(
            &self,
            group: &Group<T>,
            subscriber: &str,
            capacity: usize,
            deliver: impl Fn(Envelope<T>) -> Result<(), Undeliverable> + Send + Sync + 'static,
        ) -> Subscription {
            Bus::subscribe(self, group, subscriber, capacity, deliver)
        }
        fn subscribe_channel<T: BusMessage>(
            &self,
            group: &Group<T>,
            subscriber: &str,
            capacity: usize,
        ) -> (
            Subscription,
            tokio::sync::mpsc::UnboundedReceiver<Envelope<T>>,
        ) {
            Bus::subscribe_channel(self, group, subscriber, capacity)
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A bus message for the runtime's own unit tests (the bus's and the setpoint lane's).
    #[derive(Clone, PartialEq, prost::Message)]
    pub(crate) struct Ping {
        #[prost(uint32, tag = "1")]
        pub(crate) n: u32,
    }

    const PING: Group<Ping> = Group::new("test::ping", "test.Ping", Layer::Interthread);

    #[tokio::test]
    async fn fan_out_shares_one_allocation() {
        let bus = Bus::new();
        let (_a, mut ra) = bus.subscribe_channel(&PING, "a", 4);
        let (_b, mut rb) = bus.subscribe_channel(&PING, "b", 4);
        let r = bus.publish(&PING, Ping { n: 7 });
        assert_eq!(
            r,
            PublishReport {
                delivered: 2,
                dropped: 0
            }
        );
        let ea = ra.recv().await.unwrap();
        let eb = rb.recv().await.unwrap();
        assert!(Arc::ptr_eq(&ea.msg, &eb.msg));
        assert_eq!(ea.msg.n, 7);
        assert_eq!(ea.group, "test::ping");
    }

    #[tokio::test]
    async fn full_subscriber_drops_and_counts_without_blocking_others() {
        let bus = Bus::new();
        let (_slow, mut slow) = bus.subscribe_channel(&PING, "slow", 2);
        let (_fast, mut fast) = bus.subscribe_channel(&PING, "fast", 100);
        for n in 0..10 {
            bus.publish(&PING, Ping { n });
        }
        let mut got_fast = 0;
        while let Ok(e) = fast.try_recv() {
            assert_eq!(e.msg.n, got_fast);
            got_fast += 1;
        }
        assert_eq!(got_fast, 10);
        let mut got_slow = Vec::new();
        while let Ok(e) = slow.try_recv() {
            got_slow.push(e.msg.n);
        }
        assert_eq!(got_slow, vec![0, 1]);
        assert_eq!(bus.total_dropped(), 8);
        let stats = bus.stats();
        let s = stats.iter().find(|s| s.subscriber == "slow").unwrap();
        assert_eq!((s.delivered, s.dropped, s.in_flight), (2, 8, 0));
        // Once read, the slow subscriber has room again.
        assert_eq!(bus.publish(&PING, Ping { n: 99 }).delivered, 2);
    }

    #[tokio::test]
    async fn gone_receiver_is_removed_and_cancel_unsubscribes() {
        let bus = Bus::new();
        let (_s, rx) = bus.subscribe_channel(&PING, "gone", 4);
        drop(rx);
        assert_eq!(bus.publish(&PING, Ping { n: 1 }).delivered, 0);
        assert!(bus.stats().is_empty());
        let (s, mut rx) = bus.subscribe_channel(&PING, "c", 4);
        s.cancel();
        assert_eq!(bus.publish(&PING, Ping { n: 1 }).delivered, 0);
        assert!(rx.try_recv().is_err());
    }

    #[test]
    fn publish_without_subscribers_is_a_no_op() {
        let bus = Bus::new();
        assert_eq!(bus.publish(&PING, Ping { n: 1 }), PublishReport::default());
    }

    #[test]
    fn replay_and_live_driver_exclude_each_other() {
        let bus = Bus::new();
        assert_eq!(bus.claim(BusRole::LiveDriver), Ok(()));
        assert_eq!(bus.claim(BusRole::LiveDriver), Ok(()));
        assert_eq!(bus.claim(BusRole::Replay), Err(BusRole::LiveDriver));
        let other = Bus::new();
        assert_eq!(other.claim(BusRole::Replay), Ok(()));
        assert_eq!(
            other.clone().claim(BusRole::LiveDriver),
            Err(BusRole::Replay)
        );
    }

    #[tokio::test]
    async fn meta_travels_with_the_envelope() {
        let bus = Bus::new();
        let (_s, mut rx) = bus.subscribe_channel(&PING, "m", 4);
        let meta = PublishMeta {
            trace: Some(TraceContext {
                traceparent: "00-0af7651916cd43dd8448eb211c80319c-b7ad6b7169203331-01".into(),
            }),
            origin: Origin::Imported,
        };
        bus.publish_with(&PING, Arc::new(Ping { n: 3 }), meta.clone());
        let e = rx.recv().await.unwrap();
        assert_eq!(e.origin, Origin::Imported);
        assert_eq!(e.meta().trace, meta.trace);
    }
}
