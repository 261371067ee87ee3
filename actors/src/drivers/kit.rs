//! The driver kit: the glue every built-in driver needs and used to copy — the I/O task that dies
//! with its driver ([`OwnedTask`]), the link as the driver sees it (its writer while open, the
//! frontseat state, whether data flows: [`LinkState`], with the "frontseat providing data"
//! watchdog [`DataWatch`]), handing a line or a frame to the link and mirroring it on raw_out
//! ([`send_line`], [`send_bytes`]), answering a request ([`Asker`], [`refuse`], [`failure`]),
//! the commands waiting for the vehicle's acknowledgement with a deadline and a bound
//! ([`AckQueue`]), taking the one extension type a driver speaks ([`own_extension`]), a vehicle
//! mirror's base request ([`base_command!`]), a timeout read from the config ([`config_secs`]),
//! and the rate-limit check before a bad-input warning. Each piece is small on purpose: a driver
//! keeps its own counters, its own error codes and its own log lines (their text and their
//! `tracing` target are what operators filter on), and takes from here only what was identical.

use std::collections::VecDeque;
use std::time::Duration;

use tokio::task::JoinHandle;

use crate::driver::{SignalSink, raw_ascii};
use crate::link::{LineWriter, WriteError};
use crate::proto::goby::middleware::frontseat::protobuf::{
    CommandRequest, CommandResponse, FrontSeatState, Raw, raw::RawType,
};
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

/// Hands `frame` to the link and, once it is queued, publishes it on raw_out as binary: the
/// frame-link twin of [`send_line`].
pub fn send_bytes(
    w: &LineWriter,
    frame: Vec<u8>,
    sig: &mut dyn SignalSink,
) -> Result<(), WriteError> {
    w.write_bytes(frame.clone())?;
    sig.raw_to_frontseat(raw_binary(frame));
    Ok(())
}

/// A Raw binary message as published on raw_in / raw_out (the frame as read or written).
pub fn raw_binary(bytes: Vec<u8>) -> Raw {
    let mut r = Raw {
        raw: Some(bytes),
        ..Default::default()
    };
    r.set_type(RawType::RawBinary);
    r
}

/// The vehicle link as a driver sees it: the writer while the link is open, the frontseat state
/// the driver reports, and whether the vehicle is providing data. Opening and losing the link
/// change all three together, so no driver forgets one of them.
#[derive(Debug)]
pub struct LinkState {
    writer: Option<LineWriter>,
    pub state: FrontSeatState,
    pub data: DataWatch,
}

impl Default for LinkState {
    fn default() -> Self {
        Self {
            writer: None,
            state: FrontSeatState::FrontseatNotConnected,
            data: DataWatch::default(),
        }
    }
}

impl LinkState {
    /// The link opened: its writer, and the state the vehicle is in until it says otherwise.
    pub fn opened(&mut self, w: LineWriter, state: FrontSeatState) {
        self.writer = Some(w);
        self.state = state;
    }

    /// The link went down: nothing to write to, not connected, no data until it comes again.
    pub fn lost(&mut self) {
        self.writer = None;
        self.state = FrontSeatState::FrontseatNotConnected;
        self.data.lost();
    }

    /// Drops the writer (the link flushes and shuts down) and keeps the rest: the driver stops.
    pub fn close(&mut self) {
        self.writer = None;
    }

    pub fn writer(&self) -> Option<&LineWriter> {
        self.writer.as_ref()
    }

    pub fn is_open(&self) -> bool {
        self.writer.is_some()
    }
}

/// Who asked for a command and whether they want its answer: what a driver keeps of a request
/// it answers later.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Asker {
    pub request_id: Option<i32>,
    pub respond: bool,
}

impl Asker {
    pub fn of(req: &CommandRequest) -> Self {
        Self {
            request_id: req.request_id,
            respond: req.response_requested(),
        }
    }

    /// Answers, when an answer was asked for: Goby3's `CommandResponse` with the driver's code
    /// (sent on success too) and the reason, if any.
    pub fn answer(&self, sig: &mut dyn SignalSink, ok: bool, code: i32, why: Option<String>) {
        if self.respond {
            sig.command_response(CommandResponse {
                request_successful: Some(ok),
                request_id: self.request_id,
                error_code: Some(code),
                error_string: why,
            });
        }
    }

    /// Answers as failed ([`failure`]), when an answer was asked for.
    pub fn fail(&self, sig: &mut dyn SignalSink, code: i32, why: impl Into<String>) {
        if self.respond {
            sig.command_response(failure(self.request_id, code, why));
        }
    }
}

/// The error code of a request a driver refuses at once (it cannot send it as asked).
pub const REFUSED: i32 = 1;
/// The error code of a request given up because too many were waiting for the vehicle.
pub const OVERFLOWED: i32 = 2;
/// The error code of a request the vehicle did not acknowledge in time.
pub const TIMED_OUT: i32 = 3;

/// Refuses `req` at once ([`REFUSED`]), answering it when it asked for a response.
pub fn refuse(req: &CommandRequest, why: impl Into<String>, sig: &mut dyn SignalSink) {
    Asker::of(req).fail(sig, REFUSED, why);
}

/// A command written to the vehicle, waiting for its acknowledgement until `deadline`
/// (simulated time); `what` is the driver's own key to match the acknowledgement with.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Awaiting<T> {
    pub asker: Asker,
    pub deadline: Duration,
    pub what: T,
}

/// The commands waiting for the vehicle's acknowledgement, oldest first, at most `max` of them: a
/// vehicle that stopped answering cannot make it grow, and every command in it is answered once —
/// by its acknowledgement, its deadline, or being pushed out.
#[derive(Debug)]
pub struct AckQueue<T> {
    waiting: VecDeque<Awaiting<T>>,
    max: usize,
}

impl<T> AckQueue<T> {
    /// A queue for `max` commands (at least one: a command written is always awaited).
    pub fn new(max: usize) -> Self {
        Self {
            waiting: VecDeque::new(),
            max: max.max(1),
        }
    }

    /// Waits for `a`; with `max` already waiting, the oldest is given up first and answered as
    /// failed ([`OVERFLOWED`], `overflow` as the reason).
    pub fn push(&mut self, a: Awaiting<T>, overflow: &str, sig: &mut dyn SignalSink) {
        if self.waiting.len() >= self.max
            && let Some(old) = self.waiting.pop_front()
        {
            old.asker.fail(sig, OVERFLOWED, overflow);
        }
        self.waiting.push_back(a);
    }

    /// Where the oldest command `matches` waits, if any.
    pub fn position(&self, mut matches: impl FnMut(&T) -> bool) -> Option<usize> {
        self.waiting.iter().position(|a| matches(&a.what))
    }

    pub fn remove(&mut self, i: usize) -> Option<Awaiting<T>> {
        self.waiting.remove(i)
    }

    /// The oldest command `matches`, no longer waiting.
    pub fn take(&mut self, matches: impl FnMut(&T) -> bool) -> Option<Awaiting<T>> {
        let i = self.position(matches)?;
        self.waiting.remove(i)
    }

    /// The oldest command, when its deadline is `now` or past; called until None on every
    /// tick. Only the oldest is looked at (as the drivers always did): one behind it with an
    /// earlier deadline waits for it.
    pub fn due(&mut self, now: Duration) -> Option<Awaiting<T>> {
        if self.waiting.front()?.deadline <= now {
            self.waiting.pop_front()
        } else {
            None
        }
    }

    /// Every command `matches`, oldest first, no longer waiting; the others keep their order.
    pub fn take_all(&mut self, mut matches: impl FnMut(&T) -> bool) -> Vec<Awaiting<T>> {
        let mut taken = Vec::new();
        let mut keep = VecDeque::with_capacity(self.waiting.len());
        for a in self.waiting.drain(..) {
            if matches(&a.what) {
                taken.push(a);
            } else {
                keep.push_back(a);
            }
        }
        self.waiting = keep;
        taken
    }

    pub fn len(&self) -> usize {
        self.waiting.len()
    }

    pub fn is_empty(&self) -> bool {
        self.waiting.is_empty()
    }
}

/// The base `CommandRequest` of a vehicle's mirror of it (the extension's request with Goby3's
/// base fields): what the driver hands to its own `send_command_to_frontseat`.
#[macro_export]
macro_rules! base_command {
    ($req:expr) => {{
        let r = &$req;
        $crate::proto::goby::middleware::frontseat::protobuf::CommandRequest {
            desired_course: r.desired_course,
            response_requested: r.response_requested,
            request_id: r.request_id,
            cancel_request_id: r.cancel_request_id,
        }
    }};
}
pub use crate::base_command;

/// The longest time a driver takes from its config (about 31 years): longer is taken as this,
/// so a deadline `now + it` cannot overflow.
pub const MAX_CONFIG_SECS: f64 = 1e9;

/// Seconds from the config as a Duration: negative or NaN is zero, anything past
/// [`MAX_CONFIG_SECS`] (infinity too) is that. Validation only asks for finite values, and
/// `Duration::from_secs_f64` panics on a finite 1e20.
pub fn config_secs(s: f64) -> Duration {
    Duration::try_from_secs_f64(s.clamp(0.0, MAX_CONFIG_SECS)).unwrap_or(Duration::ZERO)
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
pub use frontseat_telemetry::metrics::bad_line;
/// A line cut to a length fit for a log line.
pub use frontseat_telemetry::truncate;

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

/// The extension a driver takes when it is of the one `type_name` it speaks, decoded; any other
/// type, or bytes that do not decode, refused as an unknown one (a command that asked for a
/// response is answered) and None.
pub fn own_extension<M: prost::Message + Default>(
    ext: &crate::driver::DriverExtension,
    type_name: &str,
    sig: &mut dyn SignalSink,
    driver: &str,
) -> Option<M> {
    if ext.type_name() == type_name {
        decoded(ext, sig, driver)
    } else {
        crate::driver::refuse_extension(sig, ext, driver);
        None
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

    fn asked(id: i32) -> Asker {
        Asker {
            request_id: Some(id),
            respond: true,
        }
    }

    fn waiting(id: i32, deadline: Duration, what: char) -> Awaiting<char> {
        Awaiting {
            asker: asked(id),
            deadline,
            what,
        }
    }

    fn answers(sink: &RecordingSink) -> Vec<(Option<i32>, Option<bool>, Option<i32>)> {
        sink.responses
            .iter()
            .map(|r| (r.request_id, r.request_successful, r.error_code))
            .collect()
    }

    #[test]
    fn ack_queue_gives_up_the_oldest_when_full_and_answers_it_once() {
        let mut q = AckQueue::new(2);
        let mut sink = RecordingSink::default();
        q.push(waiting(1, S(5), 'a'), "too many", &mut sink);
        q.push(waiting(2, S(5), 'b'), "too many", &mut sink);
        assert!(sink.responses.is_empty(), "room for two");
        q.push(waiting(3, S(5), 'c'), "too many", &mut sink);
        assert_eq!(
            answers(&sink),
            vec![(Some(1), Some(false), Some(OVERFLOWED))]
        );
        assert_eq!(sink.responses[0].error_string.as_deref(), Some("too many"));
        assert_eq!(q.len(), 2);
        // One that asked for no answer is pushed out silently.
        q.push(
            Awaiting {
                asker: Asker::default(),
                deadline: S(5),
                what: 'd',
            },
            "too many",
            &mut sink,
        );
        q.push(waiting(5, S(5), 'e'), "too many", &mut sink);
        q.push(waiting(6, S(5), 'f'), "too many", &mut sink);
        assert_eq!(
            answers(&sink),
            vec![
                (Some(1), Some(false), Some(OVERFLOWED)),
                (Some(2), Some(false), Some(OVERFLOWED)),
                (Some(3), Some(false), Some(OVERFLOWED)),
            ],
            "d went unanswered"
        );
        let left: Vec<_> = std::iter::from_fn(|| q.due(S(5))).map(|a| a.what).collect();
        assert_eq!(left, ['e', 'f']);
    }

    #[test]
    fn ack_queue_times_out_from_the_oldest_at_its_deadline() {
        let mut q = AckQueue::new(8);
        let mut sink = RecordingSink::default();
        q.push(waiting(1, Duration::from_millis(4_000), 'a'), "", &mut sink);
        q.push(waiting(2, Duration::from_millis(4_500), 'b'), "", &mut sink);
        // Behind b, an earlier deadline waits for b (only the oldest is looked at).
        q.push(waiting(3, Duration::from_millis(1_000), 'c'), "", &mut sink);
        assert_eq!(q.due(Duration::from_millis(3_999)), None);
        assert_eq!(
            q.due(Duration::from_millis(4_000)).map(|a| a.what),
            Some('a')
        );
        assert_eq!(q.due(Duration::from_millis(4_000)), None);
        let mut late = Vec::new();
        while let Some(a) = q.due(Duration::from_millis(4_500)) {
            late.push(a.what);
        }
        assert_eq!(late, ['b', 'c']);
        assert!(q.is_empty());
    }

    #[test]
    fn ack_queue_matches_the_oldest_and_takes_all_in_order() {
        let mut q = AckQueue::new(8);
        let mut sink = RecordingSink::default();
        for (id, w) in [(1, 'x'), (2, 'y'), (3, 'x'), (4, 'z'), (5, 'x')] {
            q.push(waiting(id, S(1), w), "", &mut sink);
        }
        assert_eq!(
            q.take(|w| *w == 'x').map(|a| a.asker.request_id),
            Some(Some(1))
        );
        assert_eq!(q.take(|w| *w == 'q'), None);
        assert_eq!(q.position(|w| *w == 'z'), Some(2));
        let xs: Vec<_> = q
            .take_all(|w| *w == 'x')
            .into_iter()
            .map(|a| a.asker.request_id)
            .collect();
        assert_eq!(xs, [Some(3), Some(5)]);
        let rest: Vec<_> = std::iter::from_fn(|| q.due(S(1))).map(|a| a.what).collect();
        assert_eq!(rest, ['y', 'z'], "the others keep their order");
        assert!(
            sink.responses.is_empty(),
            "matching answers nothing by itself"
        );
    }

    #[test]
    fn an_asker_answers_only_when_asked_with_its_code() {
        let mut sink = RecordingSink::default();
        asked(7).answer(&mut sink, true, 0, None);
        Asker::default().answer(&mut sink, false, 4, Some("x".into()));
        asked(8).fail(&mut sink, TIMED_OUT, "late");
        let req = CommandRequest {
            request_id: Some(9),
            response_requested: Some(true),
            ..Default::default()
        };
        assert_eq!(Asker::of(&req), asked(9));
        refuse(&req, "no course", &mut sink);
        refuse(&CommandRequest::default(), "unasked", &mut sink);
        assert_eq!(
            answers(&sink),
            vec![
                (Some(7), Some(true), Some(0)),
                (Some(8), Some(false), Some(TIMED_OUT)),
                (Some(9), Some(false), Some(REFUSED)),
            ]
        );
        assert_eq!(sink.responses[0].error_string, None);
        assert_eq!(sink.responses[2].error_string.as_deref(), Some("no course"));
    }

    #[test]
    fn link_state_opens_and_loses_writer_state_and_data_together() {
        let mut l = LinkState::default();
        assert_eq!(l.state, FrontSeatState::FrontseatNotConnected);
        assert!(!l.is_open());
        let (w, mut rx) = LineWriter::for_test();
        l.opened(w, FrontSeatState::FrontseatIdle);
        l.data.fresh(S(1));
        assert!(l.is_open());
        assert_eq!(l.state, FrontSeatState::FrontseatIdle);
        l.writer().unwrap().write_line("x").unwrap();
        assert_eq!(rx.try_recv().unwrap(), b"x\r\n");
        l.close();
        assert!(!l.is_open());
        assert!(l.data.providing(), "closing keeps what the driver knew");
        let (w, _rx) = LineWriter::for_test();
        l.opened(w, FrontSeatState::FrontseatAcceptingCommands);
        l.lost();
        assert!(!l.is_open());
        assert_eq!(l.state, FrontSeatState::FrontseatNotConnected);
        assert!(!l.data.providing());
    }

    #[test]
    fn a_frame_is_published_as_binary_only_once_the_link_took_it() {
        let (tx, mut rx) = tokio::sync::mpsc::channel(1);
        let w = LineWriter::from_sender(tx);
        let mut sink = RecordingSink::default();
        send_bytes(&w, vec![0xFE, 0, 1], &mut sink).unwrap();
        assert_eq!(rx.try_recv().unwrap(), [0xFE, 0, 1]);
        assert_eq!(sink.raw_out.len(), 1);
        assert_eq!(sink.raw_out[0].r#type(), RawType::RawBinary);
        assert_eq!(sink.raw_out[0].raw.as_deref(), Some(&[0xFE, 0, 1][..]));
        send_bytes(&w, vec![1], &mut sink).unwrap();
        assert_eq!(send_bytes(&w, vec![2], &mut sink), Err(WriteError::Full));
        assert_eq!(sink.raw_out.len(), 2, "a refused frame is not on raw_out");
    }

    #[test]
    fn a_mirror_gives_its_base_fields() {
        use crate::proto::frontseat::protobuf::iver::CommandRequest as Mirror;
        use crate::proto::goby::middleware::frontseat::protobuf::DesiredCourse;
        let m = Mirror {
            desired_course: Some(DesiredCourse {
                heading: Some(90.0),
                ..Default::default()
            }),
            response_requested: Some(true),
            request_id: Some(4),
            cancel_request_id: Some(3),
            ..Default::default()
        };
        let b = base_command!(m);
        assert_eq!(b.desired_course, m.desired_course);
        assert_eq!(
            (b.response_requested, b.request_id, b.cancel_request_id),
            (Some(true), Some(4), Some(3))
        );
    }

    #[test]
    fn own_extension_decodes_its_type_and_refuses_the_rest() {
        use crate::driver::DriverExtension;
        use crate::proto::frontseat::protobuf::iver::CommandRequest as Iver;
        const MINE: &str = "frontseat.protobuf.iver.CommandRequest";
        let mut sink = RecordingSink::default();
        let asked = Iver {
            request_id: Some(5),
            response_requested: Some(true),
            ..Default::default()
        };
        let ext = DriverExtension::encode(MINE, "Iver3", &asked);
        let got: Option<Iver> = own_extension(&ext, MINE, &mut sink, "iver3");
        assert_eq!(got.as_ref(), Some(&asked));
        assert!(sink.responses.is_empty());
        // Another vehicle's command: refused and answered.
        let other = DriverExtension::encode("x.bluefin.CommandRequest", "Bluefin", &asked);
        assert_eq!(
            own_extension::<Iver>(&other, MINE, &mut sink, "iver3"),
            None
        );
        // Its own type whose extension field (1001) does not decode, though the base does:
        // refused and answered too.
        let mut bytes = prost::Message::encode_to_vec(&asked);
        bytes.extend([0xCA, 0x3E, 0x01, 0x07]);
        let broken = DriverExtension {
            type_name: Some(MINE.into()),
            value: Some(bytes),
            vehicle: Some("Iver3".into()),
        };
        assert_eq!(
            own_extension::<Iver>(&broken, MINE, &mut sink, "iver3"),
            None
        );
        assert_eq!(
            answers(&sink),
            vec![
                (Some(5), Some(false), Some(REFUSED)),
                (Some(5), Some(false), Some(REFUSED))
            ]
        );
    }

    #[test]
    fn config_seconds_are_clamped_never_a_panic() {
        assert_eq!(config_secs(2.5), Duration::from_millis(2_500));
        assert_eq!(config_secs(0.0), Duration::ZERO);
        assert_eq!(config_secs(-3.0), Duration::ZERO);
        assert_eq!(config_secs(f64::NAN), Duration::ZERO);
        let cap = Duration::from_secs(1_000_000_000);
        assert_eq!(config_secs(1e20), cap, "finite, passes validation");
        assert_eq!(config_secs(f64::INFINITY), cap);
        assert!(S(1_000_000).checked_add(config_secs(1e300)).is_some());
    }
}
