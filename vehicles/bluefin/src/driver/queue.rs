//! The stop-and-wait write queue to the Huxley: one sentence in flight until its `$BFACK`,
//! sentences answered "pending" kept (bounded) until their final answer, resends after
//! `nmea_resend_interval`, a drop and a demerit after `nmea_resend_attempts`, and a re-opened
//! connection past `allowed_nmea_demerits`. Every request that entered the queue is answered
//! exactly once: by the Huxley, by a drop, a cancel, an overflow or a lost connection.

use std::collections::VecDeque;
use std::time::Duration;

use super::{BluefinDriver, MAX_PENDING, MAX_QUEUE, Outgoing, error_code};
use crate::codec::{Ack, AckStatus, FromPayload};
use frontseat_actors::driver::SignalSink;
use frontseat_actors::drivers::kit::send_line;
use frontseat_actors::link;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::FrontSeatState;

impl BluefinDriver {
    /// Queues a sentence, answering its request at once if it cannot be queued.
    pub(super) fn enqueue(
        &mut self,
        msg: FromPayload,
        request: Option<Option<i32>>,
        now: Duration,
        sig: &mut dyn SignalSink,
    ) {
        if self.queue.len() >= MAX_QUEUE {
            self.stats.queue_full += 1;
            self.problem("Bluefin write queue full; sentence refused", msg.id());
            if let Some(id) = request {
                Self::answer(sig, id, false, error_code::QUEUE_FULL, "write queue full");
            }
            return;
        }
        let line = msg.to_sentence().format();
        self.queue.push_back(Outgoing {
            ack_id: msg.id().to_string(),
            line,
            request,
            written_at: None,
            writes: 0,
        });
        self.try_send(now, sig);
    }

    fn write(&mut self, line: &str, sig: &mut dyn SignalSink) -> bool {
        let Some(w) = self.link.writer() else {
            return false;
        };
        match send_line(w, line, sig) {
            Ok(()) => true,
            Err(e) => {
                self.stats.write_failures += 1;
                tracing::warn!(target: super::LOG_TARGET, line, error = %e, "line to the Huxley not sent");
                false
            }
        }
    }

    /// Writes the head of the queue if nothing is in flight (stop-and-wait); with acks disabled,
    /// writes everything.
    pub(super) fn try_send(&mut self, now: Duration, sig: &mut dyn SignalSink) {
        if !self.link.is_open() {
            return;
        }
        if self.settings.disable_ack {
            while let Some(o) = self.queue.pop_front() {
                let sent = self.write(&o.line, sig);
                if let Some(id) = o.request {
                    if sent {
                        Self::answer(sig, id, true, 0, "");
                    } else {
                        Self::answer(sig, id, false, error_code::CONNECTION_LOST, "not written");
                    }
                }
            }
            return;
        }
        // Under the lane's lock: its `$BPRMB` written since this message began is taken in as
        // the head first (then the head is in flight and nothing more is written), and the lane
        // sees `busy` before this write can reach the Huxley.
        let wire = self.wire.clone();
        let mut w = wire.lock();
        if let Some(o) = w.lane_head.take() {
            self.queue.push_front(o);
        }
        let line = match self.queue.front_mut() {
            Some(head) if head.written_at.is_none() => {
                head.written_at = Some(now);
                head.writes = 1;
                head.line.clone()
            }
            _ => return,
        };
        w.busy = true;
        self.write(&line, sig);
    }

    /// Answers (as failed) every request still queued or pending, and empties both queues.
    pub(super) fn fail_all(&mut self, why: &str, sig: &mut dyn SignalSink) {
        for o in self.queue.drain(..).chain(self.pending.drain(..)) {
            if let Some(id) = o.request {
                Self::answer(sig, id, false, error_code::CONNECTION_LOST, why);
            }
        }
    }

    pub(super) fn handle_ack(&mut self, a: Ack, now: Duration, sig: &mut dyn SignalSink) {
        let head_in_flight = self
            .queue
            .front()
            .is_some_and(|h| h.written_at.is_some() && h.ack_id.eq_ignore_ascii_case(&a.command));
        if a.status == AckStatus::Pending {
            if head_in_flight && let Some(h) = self.queue.pop_front() {
                if self.pending.len() >= MAX_PENDING
                    && let Some(old) = self.pending.pop_front()
                {
                    self.stats.pending_overflow += 1;
                    let what = format!(
                        "{MAX_PENDING} sentences are pending at the Huxley; giving up the oldest ({}) without its final answer",
                        old.ack_id
                    );
                    self.problem(&what, &old.line);
                    if let Some(id) = old.request {
                        Self::answer(sig, id, false, error_code::PENDING_OVERFLOW, what);
                    }
                }
                self.pending.push_back(h);
            } else {
                self.unmatched(&a);
            }
            self.try_send(now, sig);
            return;
        }
        let done = if head_in_flight {
            self.queue.pop_front()
        } else if let Some(i) = self
            .pending
            .iter()
            .position(|p| p.ack_id.eq_ignore_ascii_case(&a.command))
        {
            // The final answer to a pending command: the sentence in flight (if any) keeps
            // waiting for its own ack.
            self.pending.remove(i)
        } else {
            None
        };
        let Some(done) = done else {
            self.unmatched(&a);
            return;
        };
        if let Some(id) = done.request {
            let ok = a.status == AckStatus::Success;
            let code = match a.status {
                AckStatus::Invalid => error_code::INVALID,
                _ => error_code::FAILED,
            };
            let why = if a.text.is_empty() {
                format!(
                    "Huxley answered {} with status {}",
                    done.ack_id, a.status as i32
                )
            } else {
                a.text.clone()
            };
            Self::answer(sig, id, ok, code, why);
        }
        self.try_send(now, sig);
    }

    fn unmatched(&mut self, a: &Ack) {
        self.stats.unmatched_acks += 1;
        let what = format!(
            "$BFACK for {} (status {}) matches nothing in flight or pending; ignored",
            a.command, a.status as i32
        );
        self.problem(&what, &a.command);
    }

    /// Drops the connection and opens a new one: the Huxley stopped acknowledging.
    fn reset_connection(&mut self, sig: &mut dyn SignalSink) {
        self.stats.unresponsive_resets += 1;
        tracing::warn!(
            target: super::LOG_TARGET,
            demerits = self.demerits,
            "the Huxley is ignoring our sentences; re-opening the connection"
        );
        // Not lost: the navigation received stays fresh until its own timeout.
        self.drop_direct();
        self.link.close();
        self.link.state = FrontSeatState::FrontseatNotConnected;
        self.fail_all("the Huxley stopped acknowledging", sig);
        self.demerits = 0;
        if self.link_task.is_running()
            && let Some(io) = self.io.clone()
        {
            self.link_task
                .set(link::spawn(self.settings.link.clone(), io));
        }
    }

    pub(super) fn resend_or_drop(&mut self, now: Duration, sig: &mut dyn SignalSink) {
        let Some(head) = self.queue.front_mut() else {
            return;
        };
        let Some(at) = head.written_at else {
            return;
        };
        if now.saturating_sub(at) < self.settings.resend_interval {
            return;
        }
        if head.writes < self.settings.resend_attempts {
            head.writes += 1;
            head.written_at = Some(now);
            let line = head.line.clone();
            self.stats.resends += 1;
            self.write(&line, sig);
            return;
        }
        let Some(dropped) = self.queue.pop_front() else {
            return;
        };
        self.stats.dropped_unacked += 1;
        self.demerits += 1;
        tracing::warn!(
            target: super::LOG_TARGET,
            line = %dropped.line,
            writes = dropped.writes,
            demerits = self.demerits,
            "no $BFACK for a sentence; dropped"
        );
        if let Some(id) = dropped.request {
            Self::answer(
                sig,
                id,
                false,
                error_code::NOT_ACKNOWLEDGED,
                format!("no acknowledgement after {} writes", dropped.writes),
            );
        }
        if self.demerits > self.settings.allowed_demerits {
            self.reset_connection(sig);
        } else {
            self.try_send(now, sig);
        }
    }

    /// Forgets the request `id`: a sentence not yet written is removed, one in flight or pending
    /// stays but will not answer. The cancelled request is answered as cancelled.
    pub(super) fn cancel(&mut self, id: i32, sig: &mut dyn SignalSink) -> bool {
        let mut found = false;
        let mut keep = VecDeque::with_capacity(self.queue.len());
        for mut o in self.queue.drain(..) {
            if o.request == Some(Some(id)) {
                found = true;
                o.request = None;
                if o.written_at.is_none() {
                    continue;
                }
            }
            keep.push_back(o);
        }
        self.queue = keep;
        for p in self.pending.iter_mut() {
            if p.request == Some(Some(id)) {
                found = true;
                p.request = None;
            }
        }
        if found {
            Self::answer(
                sig,
                Some(id),
                false,
                error_code::CANCELLED,
                "cancelled by cancel_request_id",
            );
        }
        found
    }
}
