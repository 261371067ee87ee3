//! Drivers loaded at run time from a shared library speaking frontseat_driver.h
//! (actors/driver_sdk). By default the library runs in a `frontseat driver-host` child process:
//! a panic, abort or segfault there ends only the child, and [`PluginDriver`] turns the child's
//! end into a driver failure (a panic on the DriverActor), which the interface supervises as any
//! other: FS_ERROR(NOT_CONNECTED), restart with backoff. `FRONTSEAT_DRIVER_ISOLATION=in-process`
//! loads a trusted library into the interface itself instead.
//!
//! The driver's events (signals, state, the child's end) arrive on other tasks or threads; they
//! queue here and a `DriverIoEvent::Line(WAKE)` in the actor's mailbox makes the actor drain them,
//! so they are handled on the actor like any driver I/O.

use std::collections::VecDeque;
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use frontseat_config::InterfaceConfig;
use frontseat_driver_sdk::abi;
use frontseat_driver_sdk::driver::{LogLevel, SignalKind};
use frontseat_driver_sdk::frame::to_host::Op;
use frontseat_driver_sdk::isolate::{self, HostEvent, HostProcess, SendError};
use frontseat_driver_sdk::loader::{Instance, Plugin, Signal};
use prost::Message;

/// The SDK, for the `frontseat driver-host` subcommand (its child side lives there).
pub use frontseat_driver_sdk as sdk;
pub use frontseat_driver_sdk::Error as PluginError;

use crate::driver::{Driver, DriverContext, DriverIoEvent, IoSender, SignalSink};
use crate::proto::goby::middleware::frontseat::protobuf::{
    CommandRequest, CommandResponse, FrontSeatState, InterfaceData, Raw,
};

/// The wake-up line a plugin driver's mailbox gets when events are queued.
pub const WAKE: &str = "plugin-driver:events";
/// Events queued beyond this are dropped (and counted): a flooding driver cannot exhaust memory.
pub const QUEUE_CAP: usize = 65_536;
/// How long the child may leave a loop() unanswered before it counts as hung.
pub const TICK_DEADLINE: Duration = Duration::from_secs(5);
/// How long the pre-flight `driver-host --check` may take.
pub const PROBE_DEADLINE: Duration = Duration::from_secs(10);

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Isolation {
    /// In a `driver-host` child process (the default).
    Process,
    /// In the interface process: only for trusted drivers; a crash takes the interface down.
    InProcess,
}

#[derive(Clone, Debug)]
pub struct PluginSettings {
    pub library: PathBuf,
    /// The executable run as `HOST driver-host --library PATH`.
    pub host_exe: PathBuf,
    pub isolation: Isolation,
    /// What `frontseat_driver_load` gets: the interface config as JSON.
    pub config: Arc<Vec<u8>>,
}

impl PluginSettings {
    /// The plugin the environment or the config selects, if any: FRONTSEAT_DRIVER_LIBRARY (as in
    /// Goby3) wins over `driver.library`. FRONTSEAT_DRIVER_HOST names the hosting executable
    /// (default: this one); FRONTSEAT_DRIVER_ISOLATION is `process` (default) or `in-process`.
    pub fn select(
        cfg: &InterfaceConfig,
        env: &dyn Fn(&str) -> Option<String>,
    ) -> Result<Option<Self>, PluginError> {
        // One of Goby3's own driver libraries is not a plugin: it selects our built-in driver
        // of that vehicle (InterfaceConfig::select_goby3_driver).
        let is_goby3 =
            |l: &String| frontseat_config::goby3_import::goby3_driver_for_library(l).is_some();
        let library = env("FRONTSEAT_DRIVER_LIBRARY")
            .filter(|s| !s.is_empty())
            .or_else(|| cfg.driver.library.clone().filter(|s| !s.is_empty()))
            .filter(|l| !is_goby3(l));
        let Some(library) = library else {
            return Ok(None);
        };
        let isolation = match env("FRONTSEAT_DRIVER_ISOLATION").as_deref() {
            None | Some("") | Some("process") => Isolation::Process,
            Some("in-process") => Isolation::InProcess,
            Some(other) => {
                return Err(PluginError::Host(format!(
                    "FRONTSEAT_DRIVER_ISOLATION={other:?}: expected \"process\" or \"in-process\""
                )));
            }
        };
        let config = serde_json::to_vec(cfg)
            .map_err(|e| PluginError::Host(format!("cannot encode the config as JSON: {e}")))?;
        Ok(Some(Self {
            library: PathBuf::from(library),
            host_exe: isolate::default_host_exe(env)?,
            isolation,
            config: Arc::new(config),
        }))
    }

    /// Tells a missing file, a missing symbol or an ABI mismatch before the interface starts;
    /// in process isolation the library is opened only in a child (`driver-host --check`).
    pub fn preflight(&self) -> Result<(), PluginError> {
        match self.isolation {
            Isolation::Process => isolate::probe(&self.host_exe, &self.library, PROBE_DEADLINE),
            Isolation::InProcess => Plugin::open(&self.library).map(drop),
        }
    }
}

#[derive(Default)]
struct Queue {
    events: Mutex<VecDeque<HostEvent>>,
    dropped: AtomicU64,
}

impl Queue {
    fn lock(&self) -> MutexGuard<'_, VecDeque<HostEvent>> {
        match self.events.lock() {
            Ok(g) => g,
            Err(p) => p.into_inner(),
        }
    }
    /// Queues `ev` and wakes the actor; false once the actor is gone.
    fn push(&self, io: &IoSender, ev: HostEvent) -> bool {
        {
            let mut q = self.lock();
            // The end of the child is never dropped: it is what makes the failure visible.
            if q.len() >= QUEUE_CAP && !matches!(ev, HostEvent::Exited(_)) {
                self.dropped.fetch_add(1, Ordering::Relaxed);
                return true;
            }
            q.push_back(ev);
        }
        io.send(DriverIoEvent::Line(WAKE.to_string()))
    }
}

enum Backend {
    NotStarted,
    Process(HostProcess),
    InProcess(Instance),
    Stopped,
}

pub struct PluginDriver {
    settings: PluginSettings,
    name: String,
    backend: Backend,
    queue: Arc<Queue>,
    state: FrontSeatState,
    providing_data: bool,
    /// When the oldest loop() the child has not answered was sent.
    tick_pending_since: Option<Instant>,
    pub bad_messages: u64,
    pub refused_ops: u64,
    pub send_overflows: u64,
}

impl PluginDriver {
    pub fn new(settings: PluginSettings) -> Self {
        let file = settings
            .library
            .file_name()
            .map(|f| f.to_string_lossy().into_owned())
            .unwrap_or_default();
        Self {
            name: format!("plugin:{file}"),
            settings,
            backend: Backend::NotStarted,
            queue: Arc::new(Queue::default()),
            state: FrontSeatState::FrontseatNotConnected,
            providing_data: false,
            tick_pending_since: None,
            bad_messages: 0,
            refused_ops: 0,
            send_overflows: 0,
        }
    }

    /// A driver failure: the DriverActor fails, the interface restarts the driver.
    fn fail(&mut self, why: String) -> ! {
        self.state = FrontSeatState::FrontseatNotConnected;
        self.providing_data = false;
        panic!("driver {} failed: {why}", self.name);
    }

    fn decode<M: Message + Default>(&mut self, kind: SignalKind, bytes: &[u8]) -> Option<M> {
        match M::decode(bytes) {
            Ok(m) => Some(m),
            Err(e) => {
                self.bad_messages += 1;
                tracing::warn!(driver = %self.name, ?kind, error = %e, "undecodable signal from the driver");
                None
            }
        }
    }

    fn on_code(&mut self, op: &str, code: i32) {
        match code {
            abi::OK => {}
            abi::ERR_FATAL => self.fail(format!("{op} returned FSD_ERR_FATAL")),
            other => {
                self.refused_ops += 1;
                tracing::warn!(driver = %self.name, op, code = other, "the driver refused an operation");
            }
        }
    }

    fn handle_event(&mut self, ev: HostEvent, sig: &mut dyn SignalSink) {
        match ev {
            HostEvent::Loaded => tracing::info!(driver = %self.name, "driver loaded"),
            HostEvent::LoadFailed(e) => self.fail(e.to_string()),
            HostEvent::Signal(Signal::Bytes(kind, b)) => match kind {
                SignalKind::CommandResponse => {
                    if let Some(m) = self.decode::<CommandResponse>(kind, &b) {
                        sig.command_response(m);
                    }
                }
                SignalKind::DataFromFrontseat => {
                    if let Some(m) = self.decode::<InterfaceData>(kind, &b) {
                        sig.data_from_frontseat(m);
                    }
                }
                SignalKind::RawFromFrontseat => {
                    if let Some(m) = self.decode::<Raw>(kind, &b) {
                        sig.raw_from_frontseat(m);
                    }
                }
                SignalKind::RawToFrontseat => {
                    if let Some(m) = self.decode::<Raw>(kind, &b) {
                        sig.raw_to_frontseat(m);
                    }
                }
            },
            HostEvent::Signal(Signal::State {
                state,
                providing_data,
            }) => self.set_state(state, providing_data),
            HostEvent::Signal(Signal::Log { level, message }) => {
                let d = &self.name;
                match level {
                    LogLevel::Error => tracing::error!(driver = %d, "{message}"),
                    LogLevel::Warn => tracing::warn!(driver = %d, "{message}"),
                    LogLevel::Info => tracing::info!(driver = %d, "{message}"),
                    LogLevel::Debug => tracing::debug!(driver = %d, "{message}"),
                }
            }
            HostEvent::OpFailed { op, code } => self.on_code(&op, code),
            HostEvent::TickDone(_) => self.tick_pending_since = None,
            HostEvent::ProtocolError(e) => {
                tracing::warn!(driver = %self.name, error = %e, "driver host spoke garbage; stopping it")
            }
            HostEvent::Exited(how) => self.fail(format!("driver host exited: {how}")),
        }
    }

    fn set_state(&mut self, state: i32, providing_data: bool) {
        self.state = FrontSeatState::try_from(state).unwrap_or_else(|_| {
            self.bad_messages += 1;
            tracing::warn!(driver = %self.name, state, "unknown frontseat state from the driver");
            FrontSeatState::FrontseatNotConnected
        });
        self.providing_data = providing_data;
    }

    /// Handles everything queued so far, in order.
    fn drain(&mut self, sig: &mut dyn SignalSink) {
        let dropped = self.queue.dropped.swap(0, Ordering::Relaxed);
        if dropped > 0 {
            tracing::warn!(driver = %self.name, dropped, "driver events dropped: queue full");
        }
        loop {
            let next = self.queue.lock().pop_front();
            match next {
                Some(ev) => self.handle_event(ev, sig),
                None => break,
            }
        }
    }

    fn refresh_in_process_state(&mut self) {
        if let Backend::InProcess(inst) = &mut self.backend {
            let (s, p) = (inst.frontseat_state(), inst.frontseat_providing_data());
            self.set_state(s, p);
        }
    }

    /// One operation: to the child as a frame, or straight into the in-process driver.
    fn op(&mut self, name: &str, op: Op, sig: &mut dyn SignalSink) {
        let code = match (&mut self.backend, op) {
            (Backend::Process(p), op) => {
                match p.send(op) {
                    Ok(()) => {}
                    Err(SendError::Full) => {
                        self.send_overflows += 1;
                        tracing::warn!(driver = %self.name, op = name, "driver host is not reading; operation dropped");
                    }
                    // The child is gone; its Exited event is on its way.
                    Err(SendError::Closed) => {}
                }
                abi::OK
            }
            (Backend::InProcess(i), Op::Command(b)) => i.send_command(&b),
            (Backend::InProcess(i), Op::Data(b)) => i.send_data(&b),
            (Backend::InProcess(i), Op::Raw(b)) => i.send_raw(&b),
            (Backend::InProcess(i), Op::Tick(now)) => i.do_loop(now),
            (Backend::InProcess(_), Op::Load(_) | Op::Unload(_)) => abi::OK,
            (Backend::NotStarted | Backend::Stopped, _) => abi::OK,
        };
        self.refresh_in_process_state();
        self.on_code(name, code);
        self.drain(sig);
    }
}

impl Driver for PluginDriver {
    fn name(&self) -> &str {
        &self.name
    }

    fn start(&mut self, ctx: DriverContext) {
        let queue = self.queue.clone();
        let io = ctx.io;
        let s = &self.settings;
        self.backend = match s.isolation {
            Isolation::Process => {
                let on_event = Arc::new(move |ev| queue.push(&io, ev));
                match HostProcess::spawn(&s.host_exe, &s.library, s.config.to_vec(), on_event) {
                    Ok(p) => {
                        tracing::info!(driver = %self.name, pid = ?p.pid(), "driver host started");
                        Backend::Process(p)
                    }
                    // Reported on the first message, as a failure of the running driver.
                    Err(e) => {
                        self.queue.lock().push_back(HostEvent::LoadFailed(e));
                        Backend::Stopped
                    }
                }
            }
            Isolation::InProcess => {
                let sink = Arc::new(move |sig| {
                    queue.push(&io, HostEvent::Signal(sig));
                });
                match Plugin::open(&s.library).and_then(|p| p.load(&s.config, sink)) {
                    Ok(i) => Backend::InProcess(i),
                    Err(e) => {
                        self.queue.lock().push_back(HostEvent::LoadFailed(e));
                        Backend::Stopped
                    }
                }
            }
        };
        self.refresh_in_process_state();
    }

    fn handle_io(&mut self, ev: DriverIoEvent, _now: Duration, sig: &mut dyn SignalSink) {
        if !matches!(&ev, DriverIoEvent::Line(l) if l == WAKE) {
            tracing::debug!(driver = %self.name, ?ev, "unexpected I/O event for a plugin driver");
        }
        self.drain(sig);
    }

    fn send_command_to_frontseat(
        &mut self,
        req: &CommandRequest,
        _now: Duration,
        sig: &mut dyn SignalSink,
    ) {
        self.op("send_command", Op::Command(req.encode_to_vec()), sig);
    }

    fn send_data_to_frontseat(
        &mut self,
        data: &InterfaceData,
        _now: Duration,
        sig: &mut dyn SignalSink,
    ) {
        self.op("send_data", Op::Data(data.encode_to_vec()), sig);
    }

    fn send_raw_to_frontseat(&mut self, raw: &Raw, _now: Duration, sig: &mut dyn SignalSink) {
        self.op("send_raw", Op::Raw(raw.encode_to_vec()), sig);
    }

    fn do_loop(&mut self, now: Duration, sig: &mut dyn SignalSink) {
        if let Some(t) = self.tick_pending_since
            && t.elapsed() > TICK_DEADLINE
        {
            self.fail(format!(
                "driver host unresponsive: loop() unanswered for {:?}",
                t.elapsed()
            ));
        }
        if matches!(self.backend, Backend::Process(_)) && self.tick_pending_since.is_none() {
            self.tick_pending_since = Some(Instant::now());
        }
        let now_us = u64::try_from(now.as_micros()).unwrap_or(u64::MAX);
        self.op("loop", Op::Tick(now_us), sig);
    }

    fn frontseat_state(&self) -> FrontSeatState {
        self.state
    }

    fn frontseat_providing_data(&self) -> bool {
        self.providing_data
    }

    fn stop(&mut self) {
        if let Backend::Process(p) = &self.backend {
            let _ = p.send(Op::Unload(true));
        }
        // Dropping the instance unloads an in-process driver; dropping the process handle
        // closes the child's stdin (it unloads and exits, or is killed after a grace period).
        self.backend = Backend::Stopped;
    }
}
