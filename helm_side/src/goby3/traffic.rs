//! What crosses the Goby3 link, without the sockets: the counters and link flag, who we are on
//! the wire (pid and thread id), outgoing envelopes turned into frames and received frames
//! turned into bus publications (or counted refusals).

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use frontseat_actors::bus::{Bus, Origin, PublishMeta};
use frontseat_actors::generated::{EncodedEnvelope, EncodedError, interprocess_publish_encoded};

use super::frame;
use crate::wire;

/// Counters and the link flag, for status, metrics and tests.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Goby3Stats {
    /// Whether the handshake is done, the hold released and the sockets connected.
    pub link_up: bool,
    /// Completed joins (handshake + hold + settle), the first one included.
    pub connects: u64,
    /// Times an up link went down (gobyd stopped or restarted).
    pub link_losses: u64,
    /// Join attempts that failed (gobyd absent, no answer, a bad answer).
    pub connect_failures: u64,
    /// Frames published to gobyd.
    pub exported: u64,
    /// Local deliveries not exported because they had been imported (no echo).
    pub not_echoed: u64,
    /// Local publications dropped because gobyd was not reachable (Goby3 loses these too).
    pub dropped_link_down: u64,
    /// Publications the PUB socket refused.
    pub export_errors: u64,
    /// Frames decoded and published on the bus.
    pub imported: u64,
    /// Our own frames coming back through gobyd, dropped.
    pub own_echo: u64,
    /// Received messages that are not a frame (see [`frame::FrameError`]) or have several parts.
    pub malformed: u64,
    /// Frames whose payload does not decode as the group's type.
    pub undecodable: u64,
    /// Well-formed frames of a group, type or scheme we do not import.
    pub unexpected: u64,
    /// Connections to gobyd closed by the length guard: a frame or message over
    /// `max_message_bytes` was coming.
    pub oversized: u64,
}

impl Goby3Stats {
    /// Every refused inbound message.
    pub fn rejected(&self) -> u64 {
        self.malformed + self.undecodable + self.unexpected
    }
}

#[derive(Default)]
pub(crate) struct Counters {
    pub(crate) link_up: AtomicBool,
    pub(crate) connects: AtomicU64,
    pub(crate) link_losses: AtomicU64,
    pub(crate) connect_failures: AtomicU64,
    pub(crate) exported: AtomicU64,
    pub(crate) not_echoed: AtomicU64,
    pub(crate) dropped_link_down: AtomicU64,
    pub(crate) export_errors: AtomicU64,
    pub(crate) imported: AtomicU64,
    pub(crate) own_echo: AtomicU64,
    pub(crate) malformed: AtomicU64,
    pub(crate) undecodable: AtomicU64,
    pub(crate) unexpected: AtomicU64,
    pub(crate) oversized: AtomicU64,
}

pub(crate) fn bump(c: &AtomicU64) -> u64 {
    c.fetch_add(1, Ordering::Relaxed) + 1
}

impl Counters {
    pub(crate) fn snapshot(&self) -> Goby3Stats {
        let g = |c: &AtomicU64| c.load(Ordering::Relaxed);
        Goby3Stats {
            link_up: self.link_up.load(Ordering::Relaxed),
            connects: g(&self.connects),
            link_losses: g(&self.link_losses),
            connect_failures: g(&self.connect_failures),
            exported: g(&self.exported),
            not_echoed: g(&self.not_echoed),
            dropped_link_down: g(&self.dropped_link_down),
            export_errors: g(&self.export_errors),
            imported: g(&self.imported),
            own_echo: g(&self.own_echo),
            malformed: g(&self.malformed),
            undecodable: g(&self.undecodable),
            unexpected: g(&self.unexpected),
            oversized: g(&self.oversized),
        }
    }
}

/// Who we are on the wire: the pid and "thread" every frame of ours carries.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Origin3 {
    pub pid: i32,
    pub thread: u64,
}

impl Origin3 {
    /// This process. The thread id only has to be hex, stable for the process and unlikely to
    /// collide with another client's (Goby3 hashes its main thread's id), so a hash of the pid
    /// and the start time will do.
    pub fn this_process() -> Self {
        use std::hash::{BuildHasher, Hash, Hasher};
        let pid = i32::try_from(std::process::id()).unwrap_or(i32::MAX);
        let mut h = std::collections::hash_map::RandomState::new().build_hasher();
        pid.hash(&mut h);
        std::time::SystemTime::now().hash(&mut h);
        Self {
            pid,
            thread: h.finish().max(1),
        }
    }
}

/// Turns outgoing envelopes into frames.
pub(crate) struct Exporter {
    pub(crate) routes: Vec<(String, &'static str)>,
    pub(crate) me: Origin3,
}

impl Exporter {
    pub(crate) fn encode(&self, i: usize, env: &EncodedEnvelope) -> Option<Vec<u8>> {
        let (group, ty) = self.routes.get(i)?;
        Some(frame::encode(
            group,
            ty,
            self.me.pid,
            self.me.thread,
            &env.bytes,
        ))
    }
}

/// Turns received messages into bus publications, or counts why not.
pub(crate) struct Importer {
    pub(crate) bus: Bus,
    /// (wire group, type, bus group)
    pub(crate) routes: Vec<(String, &'static str, &'static str)>,
    pub(crate) me: Origin3,
    pub(crate) max: usize,
    pub(crate) counters: Arc<Counters>,
}

impl Importer {
    /// The ZeroMQ prefixes to subscribe: exactly the imported (group, type) pairs.
    pub(crate) fn prefixes(&self) -> Vec<String> {
        self.routes
            .iter()
            .map(|(g, t, _)| frame::subscription_prefix(g, t))
            .collect()
    }

    pub(crate) fn handle_parts(&self, parts: &[&[u8]]) {
        match parts {
            [one] => self.handle(one),
            _ => {
                // Goby3 would parse every part as a frame of its own (and likely abort).
                let n = bump(&self.counters.malformed);
                if wire::worth_logging(n) {
                    tracing::warn!(
                        parts = parts.len(),
                        count = n,
                        "multi-part message from gobyd refused"
                    );
                }
            }
        }
    }

    /// One frame from gobyd.
    pub fn handle(&self, bytes: &[u8]) {
        let c = &self.counters;
        let f = match frame::decode(bytes, self.max) {
            Ok(f) => f,
            Err(e) => {
                let n = bump(&c.malformed);
                if wire::worth_logging(n) {
                    let head: String = String::from_utf8_lossy(&bytes[..bytes.len().min(120)])
                        .chars()
                        .filter(|c| !c.is_control())
                        .collect();
                    tracing::warn!(error = %e, len = bytes.len(), %head, count = n, "malformed Goby3 frame refused");
                }
                return;
            }
        };
        if f.pid == self.me.pid && f.thread == self.me.thread {
            c.own_echo.fetch_add(1, Ordering::Relaxed);
            return;
        }
        let route = self
            .routes
            .iter()
            .find(|(g, t, _)| g == f.group && *t == f.type_name);
        let Some((_, ty, group)) = route.filter(|_| f.scheme == frame::SCHEME_PROTOBUF) else {
            let n = bump(&c.unexpected);
            if wire::worth_logging(n) {
                tracing::warn!(
                    group = f.group,
                    scheme = f.scheme,
                    r#type = f.type_name,
                    count = n,
                    "Goby3 frame of a group/type we do not import"
                );
            }
            return;
        };
        crate::hops::hop("goby3.import", group);
        let meta = PublishMeta {
            trace: None,
            origin: Origin::Goby3,
        };
        match interprocess_publish_encoded(&self.bus, group, f.payload, meta) {
            Ok(_) => {
                c.imported.fetch_add(1, Ordering::Relaxed);
            }
            Err(EncodedError::Decode { reason, .. }) => {
                let n = bump(&c.undecodable);
                if wire::worth_logging(n) {
                    tracing::warn!(group, r#type = *ty, pid = f.pid, len = f.payload.len(), %reason, count = n, "undecodable Goby3 payload refused");
                }
            }
            Err(EncodedError::UnknownGroup(g)) => {
                let n = bump(&c.undecodable);
                tracing::error!(group = %g, count = n, "imported group has no decoder");
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn our_thread_id_is_never_zero() {
        assert_ne!(Origin3::this_process().thread, 0);
    }
}
