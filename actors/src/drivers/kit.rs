//! The driver kit: the glue every built-in driver needs and used to copy — the I/O task that dies
//! with its driver, the "frontseat providing data" watchdog, handing a line to the link and
//! mirroring it on raw_out, and the rate-limit check before a bad-input warning. Each piece is
//! small on purpose: a driver keeps its own counters and its own log lines (their text and their
//! `tracing` target are what operators filter on), and takes from here only what was identical.

use std::time::Duration;

use tokio::task::JoinHandle;

use crate::driver::{SignalSink, raw_ascii};
use crate::link::{LineWriter, WriteError};
use crate::proto::goby::middleware::frontseat::protobuf::{CommandResponse, FrontSeatState};
use crate::ratelog::{LogDecision, RateLimitedLog};

/// A driver's I/O task (link, NTP copy, …), aborted when replaced, cleared or dropped, so a
/// driver that is restarted or dropped never leaves a task holding its port.
#[derive(Debug, Default)]
pub struct OwnedTask(Option<JoinHandle<()>>);

impl OwnedTask {
    /// Owns `task`, aborting the one it replaces.
    pub fn set(&mut self, task: JoinHandle<()>) {
        if let Some(old) = self.0.replace(task) {
            old.abort();
        }
    }

    /// Aborts the task, if any; whether there was one.
    pub fn abort(&mut self) -> bool {
        match self.0.take() {
            Some(t) => {
                t.abort();
                true
            }
            None => false,
        }
    }

    pub fn is_running(&self) -> bool {
        self.0.is_some()
    }
}

impl Drop for OwnedTask {
    fn drop(&mut self) {
        self.abort();
    }
}

/// Goby3's `frontseat_providing_data()`: true from the first fresh data until none came for a
/// timeout (simulated time) or the link went down.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct DataWatch {
    last: Option<Duration>,
    providing: bool,
}

impl DataWatch {
    /// Data the vehicle sent just now.
    pub fn fresh(&mut self, now: Duration) {
        self.last = Some(now);
        self.providing = true;
    }

    /// The link is gone: no data until fresh data comes again.
    pub fn lost(&mut self) {
        self.last = None;
        self.providing = false;
    }

    /// Whether the data stopped just now: true once, on the tick where the last fresh data is
    /// more than `timeout` old, so the driver logs the change once.
    pub fn expired(&mut self, now: Duration, timeout: Duration) -> bool {
        let stale = self.providing && self.last.is_some_and(|t| now.saturating_sub(t) > timeout);
        if stale {
            self.providing = false;
        }
        stale
    }

    pub fn providing(&self) -> bool {
        self.providing
    }
}

/// Hands `line` to the link and, once it is queued, publishes it on raw_out (as Goby3's
/// `signal_raw_to_frontseat`): a line the link refused was not sent and is not published.
pub fn send_line(w: &LineWriter, line: &str, sig: &mut dyn SignalSink) -> Result<(), WriteError> {
    w.write_line(line)?;
    sig.raw_to_frontseat(raw_ascii(line, ""));
    Ok(())
}

/// The failed answer to a request: Goby3's `CommandResponse` with `request_successful = false`,
/// an error code of the driver's own and the reason in words.
pub fn failure(request_id: Option<i32>, code: i32, why: impl Into<String>) -> CommandResponse {
    CommandResponse {
        request_successful: Some(false),
        request_id,
        error_code: Some(code),
        error_string: Some(why.into()),
    }
}

/// Whether a warning may be logged now (wall clock), and how many were held back before it.
pub fn log_due(log: &mut RateLimitedLog) -> Option<u64> {
    match log.decide(tokio::time::Instant::now()) {
        LogDecision::Log { suppressed_before } => Some(suppressed_before),
        LogDecision::Suppress => None,
    }
}

/// The counter every driver bumps for a line or frame it could not read (one metric for all
/// drivers, so an operator's alert does not name the vehicle).
pub use crate::metrics::bad_line;
/// A line cut to a length fit for a log line.
pub use crate::telemetry::truncate;

pub fn state_of(name: frontseat_config::FrontSeatStateName) -> FrontSeatState {
    match name {
        frontseat_config::FrontSeatStateName::FrontseatNotConnected => {
            FrontSeatState::FrontseatNotConnected
        }
        frontseat_config::FrontSeatStateName::FrontseatIdle => FrontSeatState::FrontseatIdle,
        frontseat_config::FrontSeatStateName::FrontseatInControl => {
            FrontSeatState::FrontseatInControl
        }
        frontseat_config::FrontSeatStateName::FrontseatAcceptingCommands => {
            FrontSeatState::FrontseatAcceptingCommands
        }
    }
}

/// An extension of the driver's own vehicle decoded, or None after refusing it as an unknown
/// one (answering a command that asked for a response) when its bytes do not decode.
pub fn decoded<M: prost::Message + Default>(
    ext: &crate::driver::DriverExtension,
    sig: &mut dyn SignalSink,
    driver: &str,
) -> Option<M> {
    match M::decode(ext.value()) {
        Ok(m) => Some(m),
        Err(e) => {
            tracing::warn!(type_name = ext.type_name(), error = %e, "{driver}: extension does not decode; refused");
            crate::driver::refuse_extension(sig, ext, driver);
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::driver::RecordingSink;

    const S: fn(u64) -> Duration = Duration::from_secs;

    #[test]
    fn a_failure_carries_the_request_its_code_and_its_reason() {
        let r = failure(Some(7), 3, "no $ACK");
        assert_eq!(r.request_successful, Some(false));
        assert_eq!(r.request_id, Some(7));
        assert_eq!(r.error_code, Some(3));
        assert_eq!(r.error_string.as_deref(), Some("no $ACK"));
    }

    #[test]
    fn data_watch_expires_once_after_the_timeout_and_recovers() {
        let mut w = DataWatch::default();
        assert!(!w.providing());
        assert!(!w.expired(S(100), S(1)), "never fresh: nothing to expire");
        w.fresh(S(10));
        assert!(w.providing());
        assert!(
            !w.expired(S(11), S(1)),
            "exactly the timeout is not over it"
        );
        assert!(w.expired(S(12), S(1)));
        assert!(!w.providing());
        assert!(!w.expired(S(13), S(1)), "reported once");
        w.fresh(S(14));
        assert!(w.providing());
        w.lost();
        assert!(!w.providing());
        assert!(!w.expired(S(100), S(1)));
    }

    #[tokio::test]
    async fn owned_task_is_aborted_when_replaced_or_dropped() {
        let (a, b) = (
            tokio::spawn(std::future::pending::<()>()),
            tokio::spawn(std::future::pending::<()>()),
        );
        let (abort_a, abort_b) = (a.abort_handle(), b.abort_handle());
        let mut t = OwnedTask::default();
        assert!(!t.is_running());
        t.set(a);
        t.set(b);
        tokio::task::yield_now().await;
        assert!(abort_a.is_finished(), "the replaced task is aborted");
        assert!(!abort_b.is_finished());
        drop(t);
        tokio::time::timeout(S(5), async {
            while !abort_b.is_finished() {
                tokio::task::yield_now().await;
            }
        })
        .await
        .expect("the owned task ends with its owner");
    }

    #[test]
    fn a_line_is_published_only_once_the_link_took_it() {
        let (tx, mut rx) = tokio::sync::mpsc::channel(1);
        let w = LineWriter::from_sender(tx);
        let mut sink = RecordingSink::default();
        send_line(&w, "a line", &mut sink).unwrap();
        assert_eq!(rx.try_recv().unwrap(), b"a line\r\n");
        assert_eq!(sink.raw_out.len(), 1);
        send_line(&w, "first", &mut sink).unwrap();
        assert_eq!(
            send_line(&w, "queue full", &mut sink),
            Err(WriteError::Full)
        );
        drop(rx);
        assert_eq!(send_line(&w, "gone", &mut sink), Err(WriteError::Closed));
        assert_eq!(sink.raw_out.len(), 2, "refused lines are not on raw_out");
    }
}
