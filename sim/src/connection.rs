//! One connection = one vehicle: the task that owns the socket, the bounded line buffer, the
//! vehicle run (START parameters, model, tick schedule) and the faults aimed at it.
//!
//! The task selects over the tick deadline, its fault mailbox and the socket; everything a
//! wake-up produces is written in one `write_all`, so a slow reader stalls only its own vehicle
//! (and its ticks become skipped, not buffered).

use std::net::SocketAddr;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::time::Duration;

use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;
use tokio::sync::{mpsc, oneshot};
use tokio::time::Instant;

use crate::codec::{self, CtrlState, Inbound, LineError, Nav};
use crate::run::Run;
use crate::schedule::LATE_AFTER;
use crate::shared::{Counters, Detached, Shared};
use crate::vehicle::Setpoint;
use crate::{Fault, Truth};

/// Problems logged at warn level per connection before the rest go to debug, so a client that
/// floods garbage cannot flood the log.
const LOUD_PROBLEMS: u32 = 20;
/// Size of the line a [`Fault::OversizedLine`] sends.
pub const OVERSIZED_FAULT_BYTES: usize = 64 * 1024;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Flow {
    Continue,
    Close,
}

/// Whether a connection has sent its first valid START, and the server-wide count of those that
/// have (what `max_vehicles` limits; the waiting ones are limited by `max_pending`).
pub(crate) struct StartMark {
    started: AtomicBool,
    running: Arc<AtomicUsize>,
}

impl StartMark {
    pub fn new(running: Arc<AtomicUsize>) -> Self {
        Self {
            started: AtomicBool::new(false),
            running,
        }
    }

    fn mark(&self) {
        if !self.started.swap(true, Ordering::Relaxed) {
            self.running.fetch_add(1, Ordering::Relaxed);
        }
    }

    pub fn is_started(&self) -> bool {
        self.started.load(Ordering::Relaxed)
    }

    /// The connection is gone: it no longer holds a vehicle slot.
    pub fn release(&self) {
        if self.started.swap(false, Ordering::Relaxed) {
            self.running.fetch_sub(1, Ordering::Relaxed);
        }
    }
}

pub(crate) struct Connection {
    stream: TcpStream,
    faults: mpsc::Receiver<Fault>,
    /// Fires when the server needs this connection's slot while it has sent no START yet.
    evict: Option<oneshot::Receiver<()>>,
    session: Session,
}

/// Everything of a connection but its socket and mailbox, so the select loop can borrow those
/// while a branch mutates this.
struct Session {
    id: u64,
    /// The id the server deregisters at the end; changes when a vehicle is resumed.
    id_cell: Arc<AtomicU64>,
    peer: SocketAddr,
    shared: Arc<Shared>,
    run: Option<Run>,
    line: Vec<u8>,
    out: Vec<u8>,
    scratch: String,
    problems: u32,
    fired: Vec<Fault>,
    /// Set at the first valid START; from then on neither `start_timeout` nor eviction apply
    /// (a run ended by IDLE or DURATION keeps its connection, as before).
    started: Arc<StartMark>,
}

macro_rules! problem {
    ($self:ident, $($arg:tt)+) => {{
        $self.problems += 1;
        if $self.problems <= LOUD_PROBLEMS {
            tracing::warn!(vehicle = $self.id, peer = %$self.peer, $($arg)+);
            if $self.problems == LOUD_PROBLEMS {
                tracing::warn!(vehicle = $self.id, peer = %$self.peer,
                    "further problems on this connection are logged at debug level");
            }
        } else {
            tracing::debug!(vehicle = $self.id, peer = %$self.peer, $($arg)+);
        }
    }};
}

impl Connection {
    pub fn new(
        id_cell: Arc<AtomicU64>,
        peer: SocketAddr,
        stream: TcpStream,
        shared: Arc<Shared>,
        faults: mpsc::Receiver<Fault>,
    ) -> Self {
        Self {
            stream,
            faults,
            evict: None,
            session: Session {
                id: id_cell.load(Ordering::Relaxed),
                id_cell,
                peer,
                shared,
                run: None,
                line: Vec::new(),
                out: Vec::new(),
                scratch: String::new(),
                problems: 0,
                fired: Vec::new(),
                started: Arc::new(StartMark::new(Arc::default())),
            },
        }
    }

    /// The server's view of whether this connection has started, and its eviction signal.
    pub fn awaiting_start(mut self, started: Arc<StartMark>, evict: oneshot::Receiver<()>) -> Self {
        self.session.started = started;
        self.evict = Some(evict);
        self
    }

    pub async fn run(self) {
        let Connection {
            stream,
            mut faults,
            evict,
            session: mut s,
        } = self;
        let start_timeout = s.shared.opts.start_timeout;
        let start_deadline = tokio::time::sleep(if start_timeout.is_zero() {
            Duration::from_secs(86_400 * 365)
        } else {
            start_timeout
        });
        tokio::pin!(start_deadline);
        // A connection the server never queued cannot be evicted: a receiver that never fires.
        let (_keep, never) = oneshot::channel::<()>();
        let mut evict = evict.unwrap_or(never);
        if let Err(e) = stream.set_nodelay(true) {
            tracing::debug!(vehicle = s.id, error = %e, "cannot set TCP_NODELAY");
        }
        tracing::info!(vehicle = s.id, peer = %s.peer, "vehicle connected");
        let (mut rd, mut wr) = stream.into_split();
        let mut buf = vec![0u8; 8192];
        let far = Duration::from_secs(86_400 * 365);
        let sleep = tokio::time::sleep_until(Instant::now() + far);
        tokio::pin!(sleep);
        let mut armed: Option<Instant> = None;
        loop {
            let want = s.run.as_ref().map(Run::next_deadline);
            if want != armed {
                sleep
                    .as_mut()
                    .reset(want.unwrap_or_else(|| Instant::now() + far));
                armed = want;
            }
            let flow = tokio::select! {
                biased;
                () = &mut sleep, if armed.is_some() => {
                    armed = None;
                    s.tick(Instant::now())
                }
                Some(fault) = faults.recv() => s.apply_fault(fault),
                () = &mut start_deadline, if !s.started.is_started() => {
                    let n = s.shared.counters.start_timeouts.fetch_add(1, Ordering::Relaxed) + 1;
                    // Counted server-wide and logged rate-limited: a flood of silent clients
                    // must not flood the log.
                    if n == 1 || n.is_multiple_of(100) {
                        tracing::warn!(vehicle = s.id, peer = %s.peer, timeout = ?start_timeout,
                            start_timeouts = n, "no START within the start timeout; closing this connection");
                    }
                    Flow::Close
                }
                _ = &mut evict, if !s.started.is_started() => {
                    tracing::debug!(vehicle = s.id, peer = %s.peer,
                        "no START yet and a new client needs the slot; closing this connection");
                    Flow::Close
                }
                read = rd.read(&mut buf) => match read {
                    Ok(0) => {
                        tracing::info!(vehicle = s.id, peer = %s.peer, "vehicle disconnected");
                        Flow::Close
                    }
                    Ok(n) => s.on_bytes(&buf[..n]),
                    Err(e) => {
                        tracing::info!(vehicle = s.id, peer = %s.peer, error = %e,
                            "vehicle connection failed");
                        Flow::Close
                    }
                },
            };
            if !s.out.is_empty() {
                if let Err(e) = wr.write_all(&s.out).await {
                    tracing::info!(vehicle = s.id, peer = %s.peer, error = %e,
                        "cannot write to vehicle connection");
                    break;
                }
                s.out.clear();
            }
            if flow == Flow::Close {
                break;
            }
        }
        let _ = wr.shutdown().await;
        // A dropped connection is not a lost vehicle: keep it for the client to come back to.
        if let Some(run) = s.run.take() {
            tracing::info!(
                vehicle = s.id,
                grace = ?s.shared.opts.resume_grace,
                "vehicle kept for its client to reconnect"
            );
            s.shared.detach(Detached {
                id: s.id,
                at: Instant::now(),
                run,
            });
        }
    }
}

impl Session {
    fn push_line(&mut self, line: &str) {
        self.out.extend_from_slice(line.as_bytes());
        self.out.extend_from_slice(b"\r\n");
    }

    fn on_bytes(&mut self, mut bytes: &[u8]) -> Flow {
        let max = self.shared.opts.max_line_bytes;
        while let Some(pos) = bytes.iter().position(|&b| b == b'\n') {
            let (head, rest) = bytes.split_at(pos);
            bytes = &rest[1..];
            if self.line.len() + head.len() > max + 1 {
                return self.oversized(self.line.len() + head.len());
            }
            let mut line = std::mem::take(&mut self.line);
            line.extend_from_slice(head);
            if line.last() == Some(&b'\r') {
                line.pop();
            }
            if line.len() > max {
                return self.oversized(line.len());
            }
            self.on_line(&line);
            line.clear();
            self.line = line;
            // A START processes its tick 0 at once, so its NAV follows its CTRL line.
            if self.tick(Instant::now()) == Flow::Close {
                return Flow::Close;
            }
        }
        if self.line.len() + bytes.len() > max + 1 {
            return self.oversized(self.line.len() + bytes.len());
        }
        self.line.extend_from_slice(bytes);
        Flow::Continue
    }

    fn oversized(&mut self, seen: usize) -> Flow {
        Counters::add(&self.shared.counters.oversized, 1);
        problem!(
            self,
            seen,
            max = self.shared.opts.max_line_bytes,
            "input line longer than the limit; closing this connection"
        );
        Flow::Close
    }

    fn on_line(&mut self, bytes: &[u8]) {
        let shared = self.shared.clone();
        let c = &shared.counters;
        let Ok(text) = std::str::from_utf8(bytes) else {
            Counters::add(&c.bad_lines, 1);
            problem!(
                self,
                bytes = bytes.len(),
                "input line is not valid UTF-8; ignored"
            );
            match codec::reply_due_for_bytes(bytes) {
                Some("CMD") => {
                    Counters::add(&self.shared.counters.cmd_errors, 1);
                    self.push_line(codec::format_cmd_result(false));
                }
                Some(_) => {
                    Counters::add(&self.shared.counters.start_errors, 1);
                    self.push_line(&codec::format_error(
                        "invalid START: line is not valid UTF-8",
                    ));
                }
                None => {}
            }
            return;
        };
        match codec::parse_inbound(text) {
            Ok(Inbound::Start(p)) => {
                let now = Instant::now();
                let resumed = if self.run.is_none() {
                    self.shared.take_detached(&p, now)
                } else {
                    None
                };
                if let Some(d) = resumed {
                    tracing::info!(
                        vehicle = d.id,
                        connection = self.id,
                        peer = %self.peer,
                        away = ?now.saturating_duration_since(d.at),
                        "START repeated after a reconnect: the same vehicle continues"
                    );
                    self.shared.rekey(self.id, d.id);
                    self.id = d.id;
                    self.id_cell.store(d.id, Ordering::Relaxed);
                    let ctrl = d.run.ctrl;
                    self.run = Some(d.run);
                    self.started.mark();
                    self.push_line(&codec::format_ctrl(ctrl));
                    // Where the vehicle is now, at once, as a fresh START's tick 0 gives it: the
                    // client need not wait up to a NAV period (a whole second at FREQ 1) to
                    // know its navigation is back.
                    if self.push_nav() {
                        Counters::add(&self.shared.counters.nav_lines, 1);
                    }
                } else {
                    tracing::info!(vehicle = self.id, peer = %self.peer, line = text, "START");
                    self.run = Some(Run::new(p, &self.shared.opts, now));
                    self.started.mark();
                    self.push_line(&codec::format_ctrl(CtrlState::Payload));
                }
            }
            Ok(Inbound::Cmd(cmd)) => {
                let refusal = match &self.run {
                    None => Some("CMD before START (or after the run ended)"),
                    Some(r) if r.ctrl == CtrlState::Auv => {
                        Some("CMD while the frontseat is in control (AUV)")
                    }
                    Some(_) => None,
                };
                if let Some(why) = refusal {
                    Counters::add(&self.shared.counters.cmd_errors, 1);
                    problem!(self, why, "CMD refused");
                    self.push_line(codec::format_cmd_result(false));
                } else if let Some(run) = self.run.as_mut() {
                    run.vehicle.set_setpoint(Setpoint {
                        heading: cmd.heading,
                        speed: cmd.speed,
                        depth: cmd.depth,
                    });
                    self.push_line(codec::format_cmd_result(true));
                }
            }
            Err(e) => match &e {
                LineError::Empty | LineError::UnknownKey(_) => {
                    Counters::add(&c.bad_lines, 1);
                    problem!(self, problem = %e, "input line ignored");
                }
                LineError::Start(_) => {
                    Counters::add(&c.start_errors, 1);
                    problem!(self, problem = %e, "START refused; vehicle unchanged");
                    self.push_line(&codec::format_error(&e.to_string()));
                }
                LineError::Cmd(_) => {
                    Counters::add(&c.cmd_errors, 1);
                    problem!(self, problem = %e, "CMD refused");
                    self.push_line(codec::format_cmd_result(false));
                }
            },
        }
    }

    /// Process every tick due at `now`.
    fn tick(&mut self, now: Instant) -> Flow {
        let Some(run) = self.run.as_mut() else {
            return Flow::Continue;
        };
        let Some(due) = run.schedule.due(now.saturating_duration_since(run.started)) else {
            return Flow::Continue;
        };
        let shared = self.shared.clone();
        let c = &shared.counters;
        Counters::add(&c.skipped_ticks, due.skipped());
        if due.dropped > 0 {
            Counters::add(&c.dropped_ticks, due.dropped);
            tracing::warn!(
                vehicle = self.id,
                ticks = due.dropped,
                "far behind schedule (process suspended?): ticks given up, schedule re-anchored"
            );
        }
        let mut navs = 0;
        let mut integrated = 0;
        let mut in_window = 0;
        let mut window_navs = 0;
        for n in due.first..=due.last {
            let Some(run) = self.run.as_mut() else { break };
            let counted = shared.window.holds(run.started + run.schedule.deadline(n));
            in_window += u64::from(counted);
            let dt = 1.0 / run.params.freq;
            if n > 0 {
                run.vehicle.step(dt);
            }
            integrated += 1;
            run.sim_time = n as f64 * dt;
            if run.end_tick.is_some_and(|end| n >= end) {
                tracing::info!(
                    vehicle = self.id,
                    sim_time = run.sim_time,
                    "DURATION is up: IDLE"
                );
                self.run = None;
                self.push_line(&codec::format_ctrl(CtrlState::Idle));
                break;
            }
            while run.next_fault < run.faults.len()
                && run.faults[run.next_fault].at_s <= run.sim_time + 1e-9
            {
                self.fired.push(run.faults[run.next_fault].fault.clone());
                run.next_fault += 1;
            }
            if !self.fired.is_empty() {
                let fired = std::mem::take(&mut self.fired);
                for f in fired {
                    if self.apply_fault(f) == Flow::Close {
                        Counters::add(&self.shared.counters.nav_lines, navs);
                        Counters::add(&self.shared.counters.integrated_ticks, integrated);
                        Counters::add(&self.shared.counters.window_ticks, in_window);
                        Counters::add(&self.shared.counters.window_navs, window_navs);
                        return Flow::Close;
                    }
                }
            }
            if n >= due.report_from && self.report(n, now) {
                navs += 1;
                window_navs += u64::from(counted);
            }
        }
        Counters::add(&self.shared.counters.nav_lines, navs);
        Counters::add(&self.shared.counters.integrated_ticks, integrated);
        Counters::add(&self.shared.counters.window_ticks, in_window);
        Counters::add(&self.shared.counters.window_navs, window_navs);
        Flow::Continue
    }

    /// Report tick `n`: truth always, NAV unless stopped. True when a NAV line was sent.
    fn report(&mut self, n: u64, now: Instant) -> bool {
        let Some(run) = self.run.as_mut() else {
            return false;
        };
        let lateness = now.saturating_duration_since(run.started + run.schedule.deadline(n));
        let shared = self.shared.clone();
        let c = &shared.counters;
        let ns = u64::try_from(lateness.as_nanos()).unwrap_or(u64::MAX);
        c.worst_lateness_ns.fetch_max(ns, Ordering::Relaxed);
        if lateness > LATE_AFTER {
            Counters::add(&c.late_ticks, 1);
        }
        if self.shared.truth.receiver_count() > 0 {
            let (lat, lon) = run.vehicle.lat_lon();
            let v = &run.vehicle;
            let _ = self.shared.truth.send(Truth {
                vehicle: self.id,
                sim_time: run.sim_time,
                lat,
                lon,
                depth: v.depth,
                heading: v.heading,
                speed: v.speed,
                x: v.x,
                y: v.y,
            });
        }
        self.push_nav()
    }

    /// The vehicle's NAV line as of its last tick, unless its NAV is stopped (a fault). True when
    /// a line was queued.
    fn push_nav(&mut self) -> bool {
        let Some(run) = self.run.as_mut() else {
            return false;
        };
        if run.sim_time + 1e-9 < run.nav_resume_at {
            return false;
        }
        let (lat, lon) = run.vehicle.lat_lon();
        let v = &run.vehicle;
        let nav = Nav {
            lat,
            lon,
            depth: v.depth,
            heading: v.heading,
            speed: v.speed,
        };
        self.scratch.clear();
        codec::push_nav(&mut self.scratch, &nav);
        self.out.extend_from_slice(self.scratch.as_bytes());
        self.out.extend_from_slice(b"\r\n");
        true
    }

    fn apply_fault(&mut self, fault: Fault) -> Flow {
        Counters::add(&self.shared.counters.faults, 1);
        tracing::info!(vehicle = self.id, peer = %self.peer, ?fault, "fault");
        match fault {
            Fault::DropConnection => return Flow::Close,
            Fault::StopNav { seconds } => match self.run.as_mut() {
                Some(run) if seconds.is_finite() && seconds >= 0.0 => {
                    run.nav_resume_at = run.sim_time + seconds;
                }
                Some(_) => tracing::warn!(vehicle = self.id, seconds, "StopNav needs seconds >= 0"),
                None => tracing::info!(vehicle = self.id, "StopNav ignored: vehicle not started"),
            },
            Fault::Garbage { lines } => {
                for i in 0..lines {
                    match i % 4 {
                        0 => self
                            .out
                            .extend_from_slice(format!("#GARBAGE~{i}~!@$%^&*()\r\n").as_bytes()),
                        1 => self
                            .out
                            .extend_from_slice(b"NAV,LAT:not-a-number,LON:,DEPTH\r\n"),
                        2 => self
                            .out
                            .extend_from_slice(b"\xff\xfe\x00\x80GARBAGE\xc3\x28\r\n"),
                        _ => self.out.extend_from_slice(b"\r\n"),
                    }
                }
            }
            Fault::Panic => panic!("chaos: simulated vehicle {} panic injected", self.id),
            Fault::OversizedLine => {
                self.out
                    .resize(self.out.len() + OVERSIZED_FAULT_BYTES, b'X');
                self.out.extend_from_slice(b"\r\n");
            }
            Fault::Ctrl(state) => {
                self.push_line(&codec::format_ctrl(state));
                match (state, self.run.as_mut()) {
                    (CtrlState::Idle, _) => self.run = None,
                    (s, Some(run)) => run.ctrl = s,
                    (_, None) => {}
                }
            }
        }
        Flow::Continue
    }
}

/// Tell a connection over `max_vehicles` why, then close it.
pub(crate) async fn refuse(mut stream: TcpStream, max: usize) {
    let line = codec::format_error(&format!("too many vehicles (max {max})"));
    let _ = stream.write_all(format!("{line}\r\n").as_bytes()).await;
    let _ = stream.shutdown().await;
}
