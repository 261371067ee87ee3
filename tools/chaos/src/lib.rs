//! The chaos harness behind `frontseat chaos` and `tools/chaos/tests/chaos.rs`: the real simulator on
//! loopback TCP, the interface with its basic simulator driver, a helm on the bus and the MOOS
//! bridge against our broker; faults injected on a seeded schedule, invariants watched
//! throughout and reported at the end as a table.
//!
//! The seed fixes the sequence of faults, their parameters and hold times; how the system
//! reacts is timing and is what is measured. Runtime faults go through the chaos group to the
//! fault ports, so a config without `[chaos] enabled = true` is refused before anything starts.
//! Only one run per process at a time: counting panics needs the process-wide panic hook.
//!
//! A tool, not part of the runtime: it composes frontseat-actors, -sim and -moos from outside,
//! through their public API, as a deployment would. The runtime keeps only the hooks it must own
//! itself — the fault ports (`frontseat_actors::chaos`, opened only with `[chaos] enabled = true`)
//! of the interface, the driver and the translation; no production message carries a fault.
#![forbid(unsafe_code)]

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, AtomicI32, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use frontseat_config::InterfaceConfig;
use frontseat_moos::{Broker, BrokerHandle};
use frontseat_sim::{SimHandle, SimOptions, SimServer};
use tokio::sync::watch;
use tokio::time::Instant;

use frontseat_actors::bus::{Bus, Subscription, Undeliverable};
use frontseat_actors::chaos::{ChaosError, FaultPort, FaultTarget};
use frontseat_actors::interface::{InterfaceService, ServiceExit, Snapshot, error_code};
use frontseat_actors::ports::{
    ChaosHelmPorts, ChaosMonitorInbox, ChaosMonkeyPorts, ChaosSimMonkeyPorts, ChaosStalledInbox,
};
use frontseat_actors::proto::frontseat::protobuf::{ChaosFault, SimFault, chaos_fault, sim_fault};
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CommandRequest, DesiredCourse, HelmState, HelmStateReport, InterfaceState,
};
use frontseat_actors::sim_glue::{self, EmbeddedSimulator};
use frontseat_actors::supervisor::SupervisorHandle;
use frontseat_helm_side::GatewayOptions;
use frontseat_helm_side::goby3::{
    self, Goby3Handle,
    standin::{StandinGobyd, StandinTransport},
};
use frontseat_helm_side::translation;

/// The config `frontseat chaos` uses without `-c`: chaos enabled, warped, short reconnect and
/// restart delays, and a restart limit that a fault every few hundred milliseconds stays under.
pub const DEFAULT_CONFIG: &str = r#"# frontseat chaos: the embedded default config
name = "chaos-auv"
sim_warp_factor = 100.0
status_period = 1.0

[driver.basic_simulator]
reconnect_initial_ms = 10
reconnect_max_ms = 100
nav_timeout = 5.0

[supervision]
restart_initial_delay_ms = 10
restart_max_delay_ms = 100
max_restarts = 100
restart_window_s = 30.0

[chaos]
enabled = true
"#;

/// The embedded default config, parsed.
pub fn default_config() -> Result<InterfaceConfig, frontseat_config::ConfigError> {
    frontseat_config::parse::<InterfaceConfig>(DEFAULT_CONFIG, "<embedded chaos config>")
}

/// What to run.
#[derive(Clone, Debug)]
pub struct ChaosOptions {
    /// Seed of the fault schedule.
    pub seed: u64,
    /// Faults to inject.
    pub faults: u32,
    /// Overrides the config's sim_warp_factor.
    pub warp: Option<f64>,
    /// Wall time within which the interface must be back in COMMAND after a fault clears.
    pub recovery_bound: Duration,
    /// Largest allowed growth of the resident set over its value once the system is warm.
    pub rss_growth_limit_kib: u64,
    /// Run the MOOS bridge against a broker of ours and restart that broker as a fault.
    pub moos: bool,
    /// A soak: inject faults for this long (wall) instead of `faults` of them.
    pub soak: Option<Duration>,
    /// How often the resources (RSS, open fds, threads, tasks) are sampled and reported.
    pub sample_every: Duration,
    /// Only these fault kinds (empty: all). To find which fault a resource drift comes with.
    pub only: Vec<FaultKind>,
}

impl Default for ChaosOptions {
    fn default() -> Self {
        Self {
            seed: 1,
            faults: 200,
            warp: None,
            recovery_bound: Duration::from_secs(5),
            rss_growth_limit_kib: 64 * 1024,
            moos: true,
            soak: None,
            sample_every: Duration::from_secs(60),
            only: Vec::new(),
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum ChaosHarnessError {
    #[error(transparent)]
    Refused(#[from] ChaosError),
    #[error("bad chaos options: {0}")]
    Options(String),
    #[error("another chaos run is active in this process")]
    AlreadyRunning,
    #[error("simulator: {0}")]
    Sim(#[from] frontseat_sim::SimError),
    #[error("interface: {0}")]
    Start(#[from] frontseat_actors::interface::StartError),
    #[error("MOOS broker: {0}")]
    Moos(#[from] frontseat_moos::MoosError),
    #[error("MOOS bridge: {0}")]
    Translation(String),
    #[error("web commander: {0}")]
    Web(String),
    #[error("gobyd stand-in or Goby3 gateway: {0}")]
    Goby3(String),
    #[error("the interface did not reach COMMAND within {0:?} at start")]
    NoStart(Duration),
}

/// The faults the harness injects.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum FaultKind {
    DriverPanic,
    DriverKill,
    DropConnection,
    SimRestart,
    StopNav,
    Garbage,
    Oversized,
    CtrlAuv,
    CtrlIdle,
    CtrlPayload,
    HelmPark,
    StalledSubscriber,
    MoosRestart,
    TranslationPanic,
    VehiclePanic,
    MoosCrashLoop,
    WebFlood,
    ProcessRestart,
    GobydGone,
}

impl FaultKind {
    pub const ALL: [FaultKind; 19] = [
        FaultKind::DriverPanic,
        FaultKind::DriverKill,
        FaultKind::DropConnection,
        FaultKind::SimRestart,
        FaultKind::StopNav,
        FaultKind::Garbage,
        FaultKind::Oversized,
        FaultKind::CtrlAuv,
        FaultKind::CtrlIdle,
        FaultKind::CtrlPayload,
        FaultKind::HelmPark,
        FaultKind::StalledSubscriber,
        FaultKind::MoosRestart,
        FaultKind::TranslationPanic,
        FaultKind::VehiclePanic,
        FaultKind::MoosCrashLoop,
        FaultKind::WebFlood,
        FaultKind::ProcessRestart,
        FaultKind::GobydGone,
    ];

    /// Faults that need the MOOS bridge (left out with `--no-moos`).
    pub fn needs_moos(self) -> bool {
        matches!(
            self,
            FaultKind::MoosRestart | FaultKind::TranslationPanic | FaultKind::MoosCrashLoop
        )
    }

    /// Faults on the helm side only: the driver's connection to the frontseat must survive them.
    pub fn helm_side(self) -> bool {
        matches!(
            self,
            FaultKind::MoosRestart
                | FaultKind::TranslationPanic
                | FaultKind::MoosCrashLoop
                | FaultKind::WebFlood
                | FaultKind::StalledSubscriber
                | FaultKind::HelmPark
                | FaultKind::GobydGone
        )
    }

    /// Faults never overlapped with the next one.
    fn alone(self) -> bool {
        matches!(
            self,
            FaultKind::MoosCrashLoop
                | FaultKind::WebFlood
                | FaultKind::ProcessRestart
                | FaultKind::GobydGone
        )
    }

    /// The short name `--only` takes (`frontseat chaos --only moos-crash-loop,web-flood`).
    pub fn key(self) -> &'static str {
        match self {
            FaultKind::DriverPanic => "driver-panic",
            FaultKind::DriverKill => "driver-kill",
            FaultKind::DropConnection => "drop-connection",
            FaultKind::SimRestart => "sim-restart",
            FaultKind::StopNav => "stop-nav",
            FaultKind::Garbage => "garbage",
            FaultKind::Oversized => "oversized",
            FaultKind::CtrlAuv => "ctrl-auv",
            FaultKind::CtrlIdle => "ctrl-idle",
            FaultKind::CtrlPayload => "ctrl-payload",
            FaultKind::HelmPark => "helm-park",
            FaultKind::StalledSubscriber => "stalled-subscriber",
            FaultKind::MoosRestart => "moos-restart",
            FaultKind::TranslationPanic => "translation-panic",
            FaultKind::VehiclePanic => "vehicle-panic",
            FaultKind::MoosCrashLoop => "moos-crash-loop",
            FaultKind::WebFlood => "web-flood",
            FaultKind::ProcessRestart => "process-restart",
            FaultKind::GobydGone => "gobyd-gone",
        }
    }

    /// The kind a `key` names.
    pub fn from_key(key: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.key() == key)
    }

    pub fn name(self) -> &'static str {
        match self {
            FaultKind::DriverPanic => "driver panic",
            FaultKind::DriverKill => "driver actor killed",
            FaultKind::DropConnection => "sim connection dropped",
            FaultKind::SimRestart => "simulator restarted",
            FaultKind::StopNav => "NAV stopped",
            FaultKind::Garbage => "garbage lines",
            FaultKind::Oversized => "oversized line",
            FaultKind::CtrlAuv => "CTRL AUV (then PAYLOAD)",
            FaultKind::CtrlIdle => "CTRL IDLE (then restart)",
            FaultKind::CtrlPayload => "CTRL PAYLOAD",
            FaultKind::HelmPark => "helm PARK/DRIVE flap",
            FaultKind::StalledSubscriber => "stalled bus subscriber",
            FaultKind::MoosRestart => "MOOS broker restarted",
            FaultKind::TranslationPanic => "FrontSeatTranslation panic",
            FaultKind::VehiclePanic => "simulated vehicle panic",
            FaultKind::MoosCrashLoop => "MOOSDB crash-looping (60 s sim)",
            FaultKind::WebFlood => "web client flooding the commander (60 s sim)",
            FaultKind::ProcessRestart => "process ended, restarted by the service manager",
            FaultKind::GobydGone => "gobyd gone (60 s sim), then back",
        }
    }

    fn weight(self) -> u64 {
        match self {
            FaultKind::DriverPanic | FaultKind::DriverKill => 3,
            FaultKind::DropConnection | FaultKind::StopNav | FaultKind::Garbage => 3,
            FaultKind::HelmPark => 3,
            FaultKind::SimRestart | FaultKind::Oversized => 2,
            FaultKind::CtrlAuv | FaultKind::CtrlIdle => 2,
            FaultKind::StalledSubscriber | FaultKind::MoosRestart => 2,
            FaultKind::TranslationPanic | FaultKind::VehiclePanic => 2,
            FaultKind::CtrlPayload => 1,
            FaultKind::MoosCrashLoop | FaultKind::WebFlood | FaultKind::ProcessRestart => 1,
            FaultKind::GobydGone => 1,
        }
    }
}

/// splitmix64: a tiny PRNG whose whole state is the seed, so a schedule is reproducible
/// everywhere without a dependency.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in `0..n` (n > 0).
    pub fn below(&mut self, n: u64) -> u64 {
        self.next_u64() % n.max(1)
    }
    /// Uniform in `[lo, hi)`.
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        let u = (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
        lo + u * (hi - lo)
    }
    pub fn chance(&mut self, p: f64) -> bool {
        self.range(0.0, 1.0) < p
    }
}

/// One planned fault: what, how long it is held (wall), its size, and whether the next fault
/// follows without waiting for recovery (a burst: faults overlapping).
#[derive(Clone, Debug, PartialEq)]
pub struct PlannedFault {
    pub kind: FaultKind,
    pub hold: Duration,
    /// NAV stop seconds (sim time) or garbage line count; 0 otherwise.
    pub amount: f64,
    pub burst: bool,
    pub gap: Duration,
}

/// The schedule a seed gives: the same seed, options and warp give the same faults.
pub fn plan(seed: u64, faults: u32, moos: bool, nav_timeout_s: f64) -> Vec<PlannedFault> {
    let mut p = Planner::new(seed, moos, nav_timeout_s, &[]);
    (0..faults).map(|_| p.next_fault()).collect()
}

/// An endless seeded schedule: `plan` takes its first N faults, a soak takes as many as its
/// duration allows.
pub struct Planner {
    rng: Rng,
    kinds: Vec<FaultKind>,
    total: u64,
    nav_timeout_s: f64,
}

impl Planner {
    /// `only`: the kinds to draw from (empty: all). A kind that needs MOOS is left out
    /// without it; with none left, the planner falls back to a dropped connection.
    pub fn new(seed: u64, moos: bool, nav_timeout_s: f64, only: &[FaultKind]) -> Self {
        let mut kinds: Vec<FaultKind> = FaultKind::ALL
            .into_iter()
            .filter(|k| moos || !k.needs_moos())
            .filter(|k| only.is_empty() || only.contains(k))
            .collect();
        if kinds.is_empty() {
            kinds.push(FaultKind::DropConnection);
        }
        let total = kinds.iter().map(|k| k.weight()).sum();
        Self {
            rng: Rng::new(seed),
            kinds,
            total,
            nav_timeout_s,
        }
    }

    pub fn next_fault(&mut self) -> PlannedFault {
        let rng = &mut self.rng;
        let ms =
            |rng: &mut Rng, lo: f64, hi: f64| Duration::from_secs_f64(rng.range(lo, hi) / 1000.0);
        let mut pick = rng.below(self.total);
        let mut kind = self.kinds[0];
        for k in &self.kinds {
            if pick < k.weight() {
                kind = *k;
                break;
            }
            pick -= k.weight();
        }
        let (hold, amount) = match kind {
            // Sometimes shorter than nav_timeout (no error expected), sometimes longer.
            FaultKind::StopNav => (Duration::ZERO, rng.range(0.5, 2.5 * self.nav_timeout_s)),
            FaultKind::Garbage => (ms(rng, 5.0, 50.0), (1 + rng.below(200)) as f64),
            FaultKind::StalledSubscriber => (ms(rng, 100.0, 400.0), 0.0),
            FaultKind::SimRestart | FaultKind::MoosRestart => (ms(rng, 10.0, 300.0), 0.0),
            // The long helm-side faults: `amount` is their length in simulated seconds.
            FaultKind::MoosCrashLoop | FaultKind::WebFlood | FaultKind::GobydGone => {
                (ms(rng, 10.0, 100.0), 60.0)
            }
            _ => (ms(rng, 10.0, 200.0), 0.0),
        };
        PlannedFault {
            kind,
            hold,
            amount,
            // The long helm-side faults and process restarts are never overlapped: what they
            // prove (the vehicle link untouched, the time back after a restart) needs them alone.
            burst: !kind.alone() && rng.chance(0.2),
            gap: ms(rng, 0.0, 50.0),
        }
    }
}

/// One row of the invariants table.
#[derive(Clone, Debug, PartialEq)]
pub struct Invariant {
    pub name: &'static str,
    pub bound: String,
    pub measured: String,
    pub ok: bool,
}

/// Per fault kind: how often, how long until COMMAND again after the fault cleared, and how
/// long the interface was out of COMMAND from injection to recovery (non-burst faults only).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct KindStats {
    pub injected: u32,
    pub recoveries: Vec<Duration>,
    pub outages: Vec<Duration>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct ChaosReport {
    pub seed: u64,
    pub warp: f64,
    pub faults: u32,
    pub moos: bool,
    pub wall: Duration,
    pub by_kind: BTreeMap<FaultKind, KindStats>,
    pub invariants: Vec<Invariant>,
    /// Every violation, with the fault number and kind where it happened.
    pub violations: Vec<String>,
    pub notes: Vec<String>,
    /// Resource samples, one per `sample_every` (and one at the start and the end).
    pub samples: Vec<Sample>,
}

/// The process's resources at one moment of the run.
#[derive(Clone, Debug, PartialEq)]
pub struct Sample {
    pub at: Duration,
    pub faults: u32,
    pub rss_kib: Option<u64>,
    pub fds: Option<u64>,
    pub threads: Option<u64>,
    pub tasks: usize,
    /// Subscriptions on the bus: a crashed actor whose subscriptions stayed made this grow
    /// (and RSS with it) before issue 31's fix; counted, so a drift is seen without RSS noise.
    pub subscriptions: usize,
}

impl Sample {
    pub fn take(at: Duration, faults: u32, bus: &Bus) -> Self {
        Self {
            at,
            faults,
            subscriptions: bus.stats().len(),
            rss_kib: rss_kib(),
            fds: open_fds(),
            threads: threads(),
            tasks: tokio::runtime::Handle::try_current()
                .map_or(0, |h| h.metrics().num_alive_tasks()),
        }
    }

    pub fn line(&self) -> String {
        let o = |v: Option<u64>| v.map_or("?".to_string(), |v| v.to_string());
        format!(
            "t {:>6.0} s, {:>6} faults: RSS {} MiB, fds {}, threads {}, tasks {}, bus subscriptions {}",
            self.at.as_secs_f64(),
            self.faults,
            self.rss_kib
                .map_or("?".into(), |k| format!("{:.1}", k as f64 / 1024.0)),
            o(self.fds),
            o(self.threads),
            self.tasks,
            self.subscriptions
        )
    }
}

/// Open file descriptors of this process (Linux); None elsewhere.
pub fn open_fds() -> Option<u64> {
    Some(std::fs::read_dir("/proc/self/fd").ok()?.count() as u64)
}

/// Threads of this process (Linux); None elsewhere.
pub fn threads() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = text.lines().find(|l| l.starts_with("Threads:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

impl ChaosReport {
    pub fn passed(&self) -> bool {
        self.violations.is_empty() && self.invariants.iter().all(|i| i.ok)
    }

    /// The report as Markdown: run line, faults table, invariants table, violations.
    pub fn render(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "frontseat chaos: seed {}, {} faults, warp {}, MOOS {}, {:.1} s wall",
            self.seed,
            self.faults,
            self.warp,
            if self.moos { "on" } else { "off" },
            self.wall.as_secs_f64()
        );
        let _ = writeln!(s);
        let _ = writeln!(
            s,
            "| fault | injected | measured | left COMMAND | out of COMMAND p50 / max | back in COMMAND after clear p50 / max |"
        );
        let _ = writeln!(s, "|---|---:|---:|---:|---|---|");
        let pm = |v: &[Duration]| {
            let mut v = v.to_vec();
            v.sort();
            match v.last() {
                Some(max) => format!("{} / {}", fmt_ms(percentile(&v, 50.0)), fmt_ms(*max)),
                None => "—".to_string(),
            }
        };
        for (k, st) in &self.by_kind {
            let left = st.outages.iter().filter(|d| !d.is_zero()).count();
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} | {} |",
                k.name(),
                st.injected,
                st.recoveries.len(),
                left,
                pm(&st.outages),
                pm(&st.recoveries)
            );
        }
        let _ = writeln!(s);
        let _ = writeln!(s, "| invariant | bound | measured | result |");
        let _ = writeln!(s, "|---|---|---|---|");
        for i in &self.invariants {
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} |",
                i.name,
                i.bound,
                i.measured,
                if i.ok { "PASS" } else { "FAIL" }
            );
        }
        if !self.samples.is_empty() {
            let _ = writeln!(
                s,
                "\n| t (wall) | faults | RSS MiB | open fds | threads | tasks | bus subscriptions |"
            );
            let _ = writeln!(s, "|---:|---:|---:|---:|---:|---:|---:|");
            let o = |v: Option<u64>| v.map_or("?".to_string(), |v| v.to_string());
            for x in &self.samples {
                let _ = writeln!(
                    s,
                    "| {:.0} s | {} | {} | {} | {} | {} | {} |",
                    x.at.as_secs_f64(),
                    x.faults,
                    x.rss_kib
                        .map_or("?".into(), |k| format!("{:.1}", k as f64 / 1024.0)),
                    o(x.fds),
                    o(x.threads),
                    x.tasks,
                    x.subscriptions
                );
            }
        }
        for n in &self.notes {
            let _ = writeln!(s, "\nnote: {n}");
        }
        if !self.violations.is_empty() {
            let _ = writeln!(s, "\nviolations ({}):", self.violations.len());
            for v in self.violations.iter().take(50) {
                let _ = writeln!(s, "- {v}");
            }
        }
        let _ = writeln!(
            s,
            "\nresult: {}",
            if self.passed() { "PASS" } else { "FAIL" }
        );
        s
    }
}

fn percentile(sorted: &[Duration], p: f64) -> Duration {
    if sorted.is_empty() {
        return Duration::ZERO;
    }
    let i = ((p / 100.0) * (sorted.len() - 1) as f64).round() as usize;
    sorted[i.min(sorted.len() - 1)]
}

fn fmt_ms(d: Duration) -> String {
    format!("{:.0} ms", d.as_secs_f64() * 1000.0)
}

// ---- panic accounting -------------------------------------------------------------------

/// The message of the panic the DriverActor raises on a chaos DriverPanic.
const INJECTED_PANIC: &str = "chaos: injected driver panic";

static RUNNING: AtomicBool = AtomicBool::new(false);
static INJECTED_PANICS_SEEN: AtomicU64 = AtomicU64::new(0);
static OTHER_PANICS: AtomicU64 = AtomicU64::new(0);
/// Injected panics of the translation and of simulated vehicles ("chaos: … panic injected").
static INJECTED_OTHER_SEEN: AtomicU64 = AtomicU64::new(0);
static OTHER_PANIC_TEXT: Mutex<Vec<String>> = Mutex::new(Vec::new());

type Hook = dyn Fn(&std::panic::PanicHookInfo<'_>) + Send + Sync + 'static;

/// Counts panics for the run and restores the previous hook when dropped. The injected driver
/// panics are counted silently (hundreds of backtraces would bury the report); any other panic
/// is counted and passed to the previous hook as usual.
struct PanicWatch {
    prev: Arc<Hook>,
}

impl PanicWatch {
    fn install() -> Result<Self, ChaosHarnessError> {
        if RUNNING.swap(true, Ordering::SeqCst) {
            return Err(ChaosHarnessError::AlreadyRunning);
        }
        INJECTED_PANICS_SEEN.store(0, Ordering::SeqCst);
        OTHER_PANICS.store(0, Ordering::SeqCst);
        INJECTED_OTHER_SEEN.store(0, Ordering::SeqCst);
        OTHER_PANIC_TEXT
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .clear();
        let prev: Arc<Hook> = Arc::from(std::panic::take_hook());
        let chained = prev.clone();
        std::panic::set_hook(Box::new(move |info| {
            let p = info.payload();
            let msg = p
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| p.downcast_ref::<String>().cloned())
                .unwrap_or_default();
            if msg == INJECTED_PANIC {
                INJECTED_PANICS_SEEN.fetch_add(1, Ordering::SeqCst);
            } else if msg.starts_with("chaos: ") && msg.ends_with("panic injected") {
                INJECTED_OTHER_SEEN.fetch_add(1, Ordering::SeqCst);
            } else {
                OTHER_PANICS.fetch_add(1, Ordering::SeqCst);
                let at = info
                    .location()
                    .map(|l| format!(" at {}:{}", l.file(), l.line()))
                    .unwrap_or_default();
                if let Ok(mut v) = OTHER_PANIC_TEXT.lock()
                    && v.len() < 10
                {
                    v.push(format!("{msg}{at}"));
                }
                chained(info);
            }
        }));
        Ok(Self { prev })
    }
}

impl Drop for PanicWatch {
    fn drop(&mut self) {
        let prev = self.prev.clone();
        let _ = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| prev(info)));
        RUNNING.store(false, Ordering::SeqCst);
    }
}

/// Resident set size of this process in KiB (Linux); None elsewhere.
pub fn rss_kib() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = text.lines().find(|l| l.starts_with("VmRSS:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

// ---- what the monitor sees --------------------------------------------------------------

const FIVE: [InterfaceState; 5] = [
    InterfaceState::InterfaceStandby,
    InterfaceState::InterfaceListen,
    InterfaceState::InterfaceCommand,
    InterfaceState::InterfaceHelmError,
    InterfaceState::InterfaceFsError,
];

/// What one request got: answers seen, the code of the first (0: success) and whether that
/// first one was the interface's own (timeout, driver failed), after which the driver's late
/// answer is still right. Four bytes per request, so a soak's bookkeeping stays small.
#[derive(Clone, Copy, Default)]
struct Answer {
    count: u8,
    first: i16,
    interface_first: bool,
}

/// Our helm's request ids run 1, 2, 3…: an id this far past the highest seen is not ours.
const FAR_ID: usize = 1 << 16;

#[derive(Default)]
struct Responses {
    /// Indexed by request_id − 1.
    answers: Vec<Answer>,
    /// (request_id, first code, further code) of the first few requests answered again.
    dup_examples: Vec<(i32, i32, i32)>,
    /// Answers with an id that cannot be one of ours (< 1, or far past every id seen).
    unknown_ids: u64,
    without_id: u64,
    ok: u64,
    not_in_command: u64,
    timeout: u64,
    driver_failed: u64,
    shutting_down: u64,
    frontseat_refused: u64,
}

impl Responses {
    fn get(&self, id: i32) -> Answer {
        usize::try_from(id)
            .ok()
            .and_then(|i| i.checked_sub(1))
            .and_then(|i| self.answers.get(i).copied())
            .unwrap_or_default()
    }

    fn answered(&self, id: i32) -> bool {
        self.get(id).count > 0
    }

    fn record(&mut self, id: i32, code: i32) {
        let Some(i) = usize::try_from(id).ok().and_then(|i| i.checked_sub(1)) else {
            self.unknown_ids += 1;
            return;
        };
        if i >= self.answers.len() {
            if i >= self.answers.len() + FAR_ID {
                self.unknown_ids += 1;
                return;
            }
            self.answers.resize(i + 1, Answer::default());
        }
        let a = &mut self.answers[i];
        a.count = a.count.saturating_add(1);
        if a.count == 1 {
            a.first = i16::try_from(code).unwrap_or(i16::MAX);
            a.interface_first = code == error_code::TIMEOUT || code == error_code::DRIVER_FAILED;
        } else if self.dup_examples.len() < 10 {
            let first = i32::from(a.first);
            self.dup_examples.push((id, first, code));
        }
    }
}

/// State changes kept for measuring outages: the windows measured are seconds long, so the
/// older half is dropped past this many (a soak's bookkeeping stays bounded).
const MAX_CHANGES: usize = 8192;

fn push_change(v: &mut Vec<(Instant, InterfaceState)>, c: (Instant, InterfaceState)) {
    if v.len() >= MAX_CHANGES {
        v.drain(..MAX_CHANGES / 2);
    }
    v.push(c);
}

/// Counters fed by bus subscriptions whose delivery functions run on the publisher's thread:
/// nothing is queued, so the monitor itself can never drop a message.
struct Monitor {
    statuses: AtomicU64,
    invalid_states: AtomicU64,
    invalid_examples: Mutex<Vec<i32>>,
    node_status: AtomicU64,
    responses: Mutex<Responses>,
    state: watch::Sender<InterfaceState>,
    /// Every change of state with its wall time, to measure how long each fault kept the
    /// interface out of COMMAND.
    changes: Mutex<Vec<(Instant, InterfaceState)>>,
    rss_max_kib: AtomicU64,
}

impl Monitor {
    fn new() -> Arc<Self> {
        let (state, _) = watch::channel(InterfaceState::InterfaceStandby);
        Arc::new(Self {
            statuses: AtomicU64::new(0),
            invalid_states: AtomicU64::new(0),
            invalid_examples: Mutex::new(Vec::new()),
            node_status: AtomicU64::new(0),
            responses: Mutex::new(Responses::default()),
            state,
            changes: Mutex::new(Vec::new()),
            rss_max_kib: AtomicU64::new(0),
        })
    }

    fn subscribe(self: &Arc<Self>, bus: &Bus) -> Vec<Subscription> {
        let m = self.clone();
        ChaosMonitorInbox::subscribe_all(bus, "chaos-monitor", 1 << 20, move |msg| {
            match msg {
                ChaosMonitorInbox::Status(env) => {
                    m.statuses.fetch_add(1, Ordering::Relaxed);
                    let raw = env.msg.state.unwrap_or(0);
                    match InterfaceState::try_from(raw) {
                        Ok(s) if FIVE.contains(&s) => {
                            let changed = m.state.send_if_modified(|cur| {
                                let c = *cur != s;
                                *cur = s;
                                c
                            });
                            if changed && let Ok(mut v) = m.changes.lock() {
                                push_change(&mut v, (Instant::now(), s));
                            }
                        }
                        _ => {
                            m.invalid_states.fetch_add(1, Ordering::Relaxed);
                            if let Ok(mut v) = m.invalid_examples.lock()
                                && v.len() < 10
                            {
                                v.push(raw);
                            }
                        }
                    }
                }
                ChaosMonitorInbox::NodeStatus(_) => {
                    m.node_status.fetch_add(1, Ordering::Relaxed);
                }
                ChaosMonitorInbox::CommandResponse(env) => {
                    let mut r = m.responses.lock().unwrap_or_else(|p| p.into_inner());
                    match env.msg.request_id {
                        Some(id) => r.record(id, env.msg.error_code.unwrap_or(0)),
                        None => r.without_id += 1,
                    }
                    if env.msg.request_successful() {
                        r.ok += 1;
                    } else {
                        match env.msg.error_code {
                            Some(error_code::NOT_IN_COMMAND) => r.not_in_command += 1,
                            Some(error_code::TIMEOUT) => r.timeout += 1,
                            Some(error_code::DRIVER_FAILED) => r.driver_failed += 1,
                            Some(error_code::SHUTTING_DOWN) => r.shutting_down += 1,
                            _ => r.frontseat_refused += 1,
                        }
                    }
                }
            }
            Ok(())
        })
    }

    fn state(&self) -> InterfaceState {
        *self.state.borrow()
    }

    /// The process ended: no state until the new one publishes (it starts in STANDBY).
    fn process_gone(&self) {
        let s = InterfaceState::InterfaceStandby;
        if self.state.send_if_modified(|cur| {
            let c = *cur != s;
            *cur = s;
            c
        }) && let Ok(mut v) = self.changes.lock()
        {
            push_change(&mut v, (Instant::now(), s));
        }
    }

    /// Time spent outside COMMAND between `from` and `to`.
    fn outage(&self, from: Instant, to: Instant) -> Duration {
        let v = self.changes.lock().unwrap_or_else(|p| p.into_inner());
        // The state at `from`: the last change before it.
        let start = v.partition_point(|(t, _)| *t <= from);
        let mut state = if start == 0 {
            InterfaceState::InterfaceStandby
        } else {
            v[start - 1].1
        };
        let mut since = from;
        let mut out = Duration::ZERO;
        for (t, s) in v[start..].iter().take_while(|(t, _)| *t <= to) {
            if state != InterfaceState::InterfaceCommand {
                out += t.saturating_duration_since(since);
            }
            state = *s;
            since = *t;
        }
        if state != InterfaceState::InterfaceCommand {
            out += to.saturating_duration_since(since);
        }
        out
    }

    /// Waits up to `within` for the interface to leave COMMAND (a fault that takes effect).
    async fn until_left_command(&self, within: Duration) {
        let mut rx = self.state.subscribe();
        let _ = tokio::time::timeout(
            within,
            rx.wait_for(|s| *s != InterfaceState::InterfaceCommand),
        )
        .await;
    }

    /// Waits until the interface is in COMMAND; the time it took, or None past `within`.
    async fn until_command(&self, within: Duration) -> Option<Duration> {
        let start = Instant::now();
        let mut rx = self.state.subscribe();
        let r = tokio::time::timeout(
            within,
            rx.wait_for(|s| *s == InterfaceState::InterfaceCommand),
        )
        .await;
        matches!(r, Ok(Ok(_))).then(|| start.elapsed())
    }

    /// Waits until COMMAND has held for `stable`; the time from the call to the start of that
    /// stable stretch, or None past `within`.
    async fn until_stable_command(&self, within: Duration, stable: Duration) -> Option<Duration> {
        let start = Instant::now();
        let deadline = start + within;
        let mut rx = self.state.subscribe();
        loop {
            let left = deadline.checked_duration_since(Instant::now())?;
            let reached_command = matches!(
                tokio::time::timeout(
                    left,
                    rx.wait_for(|s| *s == InterfaceState::InterfaceCommand),
                )
                .await,
                Ok(Ok(_))
            );
            if !reached_command {
                return None;
            }
            let reached = start.elapsed();
            let left_command = tokio::time::timeout(
                stable,
                rx.wait_for(|s| *s != InterfaceState::InterfaceCommand),
            )
            .await;
            match left_command {
                Err(_) => return Some(reached),
                Ok(Err(_)) => return None,
                Ok(Ok(_)) => continue,
            }
        }
    }
}

// ---- the helm -----------------------------------------------------------------------------

/// A helm on the bus: helm_state every 50 ms (and at once on a change), and every 20 ms a
/// desired_course plus a CommandRequest with response_requested and a fresh request_id.
struct Helm {
    state: watch::Sender<HelmState>,
    commanding: Arc<AtomicBool>,
    last_id: Arc<AtomicI32>,
    task: tokio::task::JoinHandle<()>,
}

impl Helm {
    fn start(bus: &Bus) -> Self {
        let (state, mut rx) = watch::channel(HelmState::HelmDrive);
        let commanding = Arc::new(AtomicBool::new(true));
        let last_id = Arc::new(AtomicI32::new(0));
        let ports = ChaosHelmPorts::new(bus);
        let (c, ids) = (commanding.clone(), last_id.clone());
        let task = tokio::spawn(async move {
            let mut tick = tokio::time::interval(Duration::from_millis(20));
            tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
            let mut n: u64 = 0;
            loop {
                let publish_state = tokio::select! {
                    _ = tick.tick() => { n += 1; n.is_multiple_of(3) }
                    r = rx.changed() => { if r.is_err() { return } true }
                };
                if publish_state {
                    let s = *rx.borrow_and_update();
                    ports.publish_helm_state(HelmStateReport { state: s as i32 });
                }
                if c.load(Ordering::SeqCst) {
                    let heading = ((n * 37) % 360) as f64;
                    let course = DesiredCourse {
                        heading: Some(heading),
                        speed: Some(1.5),
                        depth: Some(0.0),
                        ..Default::default()
                    };
                    ports.publish_desired_course(course);
                    let id = ids.fetch_add(1, Ordering::SeqCst) + 1;
                    ports.publish_command_request(CommandRequest {
                        desired_course: Some(course),
                        response_requested: Some(true),
                        request_id: Some(id),
                        ..Default::default()
                    });
                }
            }
        });
        Self {
            state,
            commanding,
            last_id,
            task,
        }
    }
}

impl Drop for Helm {
    fn drop(&mut self) {
        self.task.abort();
    }
}

// ---- the simulator and the MOOS broker, restartable on the same port ----------------------

struct Sim {
    addr: SocketAddr,
    handle: SimHandle,
    embedded: Option<EmbeddedSimulator>,
}

impl Sim {
    async fn start(bus: &Bus) -> Result<Self, ChaosHarnessError> {
        let handle = SimServer::bind(([127, 0, 0, 1], 0).into(), SimOptions::default()).await?;
        let embedded = Some(sim_glue::embed(&handle, bus));
        Ok(Self {
            addr: handle.local_addr(),
            handle,
            embedded,
        })
    }

    async fn restart(&mut self, bus: &Bus, down: Duration) -> Result<(), ChaosHarnessError> {
        self.embedded = None;
        self.handle.shutdown().await;
        tokio::time::sleep(down).await;
        self.handle = rebind(|| SimServer::bind(self.addr, SimOptions::default())).await?;
        self.embedded = Some(sim_glue::embed(&self.handle, bus));
        Ok(())
    }
}

/// Concurrent clients of the web flood.
const WEB_FLOODERS: u64 = 8;
/// The token the harness's web commander requires.
const WEB_TOKEN: &str = "chaos-web-token-0123456789";
/// systemd's RestartSec in the service-manager model.
const SERVICE_RESTART_SEC: Duration = Duration::from_millis(100);

/// A web commander send of a desired_course (`time` set, as the commander requires), with the
/// heading and speed as written: the flood's and `tests/hostile_web.rs`' body.
pub fn course_body(heading: &str, speed: &str) -> String {
    format!(
        r#"{{"group":"goby::middleware::frontseat::desired_course","message":{{"time":1,"heading":{heading},"speed":{speed},"depth":0}}}}"#
    )
}

/// A POST of `body` to the web commander's `/api/send` on its own connection, with the bearer
/// `token` and the `Origin` header when given.
pub fn send_request(
    addr: SocketAddr,
    token: Option<&str>,
    origin: Option<&str>,
    body: &str,
) -> String {
    let mut req = format!(
        "POST /api/send HTTP/1.1\r\nHost: {addr}\r\nContent-Type: application/json\r\nConnection: close\r\nContent-Length: {}\r\n",
        body.len()
    );
    if let Some(t) = token {
        req.push_str(&format!("Authorization: Bearer {t}\r\n"));
    }
    if let Some(o) = origin {
        req.push_str(&format!("Origin: {o}\r\n"));
    }
    req.push_str("\r\n");
    req.push_str(body);
    req
}

/// The `n`th request of the flood: mostly hostile setpoints with the right token, and sends a
/// browser of another site, a client without the token, or a broken client would make.
fn web_flood_request(addr: SocketAddr, n: u64) -> String {
    let course = course_body;
    let (auth, origin, body) = match n % 6 {
        0 => (true, None, course("1e308", "1.5")),
        1 => (true, None, course("90", "1e308")),
        2 => (true, None, course("-5.1e307", "-1e20")),
        3 => (false, None, course("90", "1.5")),
        4 => (true, Some("http://evil.example"), course("90", "1.5")),
        _ => (true, None, "{\"group\": [1, 2, {".to_string()),
    };
    send_request(addr, auth.then_some(WEB_TOKEN), origin, &body)
}

/// One request on its own connection; true when an HTTP answer came within a second.
async fn web_exchange(addr: SocketAddr, req: &str) -> bool {
    use tokio::io::{AsyncReadExt, AsyncWriteExt};
    let go = async {
        let mut s = tokio::net::TcpStream::connect(addr).await.ok()?;
        s.write_all(req.as_bytes()).await.ok()?;
        let mut buf = Vec::new();
        let mut chunk = [0u8; 1024];
        // Bounded: an answer is a status line and a short JSON error.
        while buf.len() < 64 * 1024 {
            match s.read(&mut chunk).await {
                Ok(0) | Err(_) => break,
                Ok(n) => buf.extend_from_slice(&chunk[..n]),
            }
        }
        Some(buf.starts_with(b"HTTP/1.1 "))
    };
    matches!(
        tokio::time::timeout(Duration::from_secs(1), go).await,
        Ok(Some(true))
    )
}

/// Binds again on the same port; a few tries, since the old listener's socket may linger.
async fn rebind<T, E, F, Fut>(mut bind: F) -> Result<T, E>
where
    F: FnMut() -> Fut,
    Fut: std::future::Future<Output = Result<T, E>>,
{
    let mut tries = 0;
    loop {
        match bind().await {
            Ok(v) => return Ok(v),
            Err(e) if tries >= 40 => return Err(e),
            Err(_) => {
                tries += 1;
                tokio::time::sleep(Duration::from_millis(25)).await;
            }
        }
    }
}

struct Moos {
    addr: SocketAddr,
    broker: Option<BrokerHandle>,
    /// The translation runs under a supervisor, as in `frontseat interface`.
    root: SupervisorHandle,
    bridge: translation::TranslationObserver,
    app_name: String,
}

impl Moos {
    fn counters(&self) -> translation::TranslationCounters {
        self.bridge.counters().unwrap_or_default()
    }

    async fn restarts(&self, within: Duration) -> u32 {
        self.root
            .snapshot(within)
            .await
            .map_or(0, |s| s.children.iter().map(|c| c.restarts).sum())
    }

    fn connected(&self) -> bool {
        self.bridge
            .status()
            .is_some_and(|s| s.moos_connected == Some(true))
    }

    async fn wait_connected(&self, within: Duration) -> bool {
        let deadline = Instant::now() + within;
        while Instant::now() < deadline {
            if self.connected() {
                return true;
            }
            tokio::time::sleep(Duration::from_millis(5)).await;
        }
        false
    }
}

/// A gobyd (our stand-in, TCP on loopback) and this process's Goby3 gateway, joined to it as
/// `frontseat interface` is with `[goby3] enabled = true`. The gobyd can go away and come back
/// on the same manager port, as a restarted gobyd does.
struct Goby {
    port: u16,
    gobyd: Option<StandinGobyd>,
    gateway: Goby3Handle,
}

impl Goby {
    async fn start(bus: &Bus) -> Result<Self, ChaosHarnessError> {
        let e = |e: &dyn std::fmt::Display| ChaosHarnessError::Goby3(e.to_string());
        let gobyd = StandinGobyd::start(StandinTransport::Tcp { manager_port: 0 }, &[])
            .await
            .map_err(|x| e(&x))?;
        let port = gobyd
            .manager_port()
            .ok_or_else(|| ChaosHarnessError::Goby3("stand-in gobyd has no TCP port".into()))?;
        let cfg = frontseat_config::Goby3Config {
            enabled: true,
            transport: frontseat_config::Goby3Transport::Tcp,
            ip_address: "127.0.0.1".into(),
            tcp_port: port,
            settle_ms: 50,
            reconnect_initial_ms: 20,
            reconnect_max_ms: 200,
            manager_timeout_seconds: 1.0,
            ..Default::default()
        };
        let settings = goby3::Goby3Settings::from_config(&cfg, "chaos-auv").map_err(|x| e(&x))?;
        let gateway = goby3::start(
            bus,
            settings,
            &["FrontSeatInterface"],
            GatewayOptions::default(),
        )
        .map_err(|x| e(&x))?;
        Ok(Self {
            port,
            gobyd: Some(gobyd),
            gateway,
        })
    }

    /// Waits (bounded) until the gateway has joined gobyd more than `connects` times and the
    /// link is up; the time it took, or None.
    async fn until_joined(&self, connects: u64, within: Duration) -> Option<Duration> {
        let start = Instant::now();
        while start.elapsed() < within {
            let s = self.gateway.stats();
            if s.link_up && s.connects > connects {
                return Some(start.elapsed());
            }
            tokio::time::sleep(Duration::from_millis(5)).await;
        }
        None
    }
}

// ---- the run ------------------------------------------------------------------------------

struct Run {
    opts: ChaosOptions,
    config: InterfaceConfig,
    bus: Bus,
    monkey: ChaosMonkeyPorts,
    sim_monkey: ChaosSimMonkeyPorts,
    service: InterfaceService,
    /// Driver crashes injected before the current service instance started: its restart count
    /// starts from zero.
    crash_base: u64,
    /// Request ids a process restart may leave unanswered: in flight when the process ended,
    /// or sent while no process ran (a helm sees the same from a real restart).
    lost_to_restart: std::collections::HashSet<i32>,
    process_restarts: Vec<Duration>,
    web: Option<frontseat_web::WebService>,
    web_flood_requests: u64,
    web_floods_left_command: u32,
    notes: Vec<String>,
    /// Helm-side faults after which the driver's connection to the frontseat was found closed
    /// or the driver restarted.
    vehicle_link_checked: u32,
    /// Link checks where the interface answered no snapshot (driver restarts unknown) and the
    /// simulator saw no new connection.
    vehicle_link_unknown: u32,
    sim: Sim,
    moos: Option<Moos>,
    goby: Option<Goby>,
    /// Per gobyd outage: the time from its return to the gateway's link up again.
    goby_returns: Vec<Duration>,
    /// Outages during which the gateway reported its link lost.
    goby_losses_seen: u32,
    helm: Helm,
    monitor: Arc<Monitor>,
    warp: f64,
    injected_panics: u64,
    injected_kills: u64,
    restart_waits: Vec<Duration>,
    stall_deliveries: Vec<u64>,
    stall_drops: u64,
    moos_reconnects: Vec<Duration>,
    translation_restarts: Vec<Duration>,
    violations: Vec<String>,
    by_kind: BTreeMap<FaultKind, KindStats>,
}

impl Run {
    async fn snapshot(&self) -> Option<Snapshot> {
        self.service.snapshot(Duration::from_secs(2)).await
    }

    fn sim_fault(&self, f: sim_fault::Fault) {
        self.sim_monkey.publish_fault(SimFault {
            vehicle: None,
            fault: Some(f),
        });
    }

    fn ctrl(&self, c: sim_fault::Ctrl) {
        self.sim_fault(sim_fault::Fault::Ctrl(c as i32));
    }

    /// The driver's restart count; a snapshot not answered at once (a starved machine) is asked
    /// again within the recovery bound before it counts as unknown.
    async fn driver_restarts(&self) -> Option<u32> {
        let deadline = Instant::now() + self.opts.recovery_bound;
        loop {
            if let Some(s) = self.snapshot().await {
                return Some(s.driver_restarts);
            }
            if Instant::now() >= deadline {
                return None;
            }
        }
    }

    fn connections(&self) -> u64 {
        self.sim.handle.stats().connections
    }

    /// A fault that closes the frontseat connection takes effect a little later (the driver
    /// reads the oversized line, the simulator task ends): wait (bounded) until the driver has
    /// connected again, so the effect cannot land inside the next fault's window and be blamed
    /// on it. Not reconnecting is caught by the recovery check that follows.
    async fn until_reconnected(&self, before: u64) {
        let deadline = Instant::now() + self.opts.recovery_bound;
        while self.connections() <= before && Instant::now() < deadline {
            tokio::time::sleep(Duration::from_millis(2)).await;
        }
    }

    /// Waits until the driver actor is up with `restarts` restarts behind it.
    async fn driver_up(&self, restarts: u32) -> bool {
        let deadline = Instant::now() + self.opts.recovery_bound;
        while Instant::now() < deadline {
            match self.snapshot().await {
                Some(s) if s.driver_up && s.driver_restarts >= restarts => return true,
                Some(_) => tokio::time::sleep(Duration::from_millis(2)).await,
                None => return false,
            }
        }
        false
    }

    async fn driver_crash(&mut self, i: u32, kind: FaultKind) {
        let expected = (self.injected_panics + self.injected_kills - self.crash_base) as u32;
        if !self.driver_up(expected).await {
            self.violations.push(format!(
                "fault #{i} ({}): driver not up with {expected} restarts within {:?} before injecting",
                kind.name(),
                self.opts.recovery_bound
            ));
            return;
        }
        let fault = if kind == FaultKind::DriverPanic {
            self.injected_panics += 1;
            chaos_fault::Fault::DriverPanic(true)
        } else {
            self.injected_kills += 1;
            chaos_fault::Fault::KillDriver(true)
        };
        let t0 = Instant::now();
        self.monkey.publish_fault(ChaosFault { fault: Some(fault) });
        if self.driver_up(expected + 1).await {
            self.restart_waits.push(t0.elapsed());
        } else {
            self.violations.push(format!(
                "fault #{i} ({}): driver not restarted within {:?}",
                kind.name(),
                self.opts.recovery_bound
            ));
        }
    }

    /// Injects `f` and returns when it cleared: for a one-shot fault (a crash, a dropped
    /// connection, bad lines) the moment it happened — the hold is then only a window for the
    /// interface to notice; for a held fault (CTRL AUV, PARK, a stopped simulator or broker, a
    /// stall, NAV stopped) the moment it was lifted.
    async fn inject(&mut self, i: u32, f: &PlannedFault) -> Instant {
        let one_shot = |t: Instant| t;
        match f.kind {
            FaultKind::DriverPanic | FaultKind::DriverKill => {
                // driver_crash returns once the new driver is up; the crash itself is the moment.
                let t = Instant::now();
                self.driver_crash(i, f.kind).await;
                one_shot(t)
            }
            FaultKind::DropConnection => {
                let t = Instant::now();
                let before = self.connections();
                self.sim_fault(sim_fault::Fault::DropConnection(true));
                self.monitor.until_left_command(f.hold).await;
                self.until_reconnected(before).await;
                one_shot(t)
            }
            FaultKind::Garbage => {
                let t = Instant::now();
                self.sim_fault(sim_fault::Fault::GarbageLines(f.amount as u32));
                self.monitor.until_left_command(f.hold).await;
                one_shot(t)
            }
            FaultKind::Oversized => {
                let t = Instant::now();
                let before = self.connections();
                self.sim_fault(sim_fault::Fault::OversizedLine(true));
                self.monitor.until_left_command(f.hold).await;
                self.until_reconnected(before).await;
                one_shot(t)
            }
            FaultKind::CtrlPayload => {
                let t = Instant::now();
                self.ctrl(sim_fault::Ctrl::Payload);
                self.monitor.until_left_command(f.hold).await;
                one_shot(t)
            }
            FaultKind::SimRestart => {
                if let Err(e) = self.sim.restart(&self.bus, f.hold).await {
                    self.violations
                        .push(format!("fault #{i}: simulator could not be restarted: {e}"));
                }
                let t = Instant::now();
                self.until_reconnected(0).await;
                t
            }
            FaultKind::StopNav => {
                self.sim_fault(sim_fault::Fault::StopNavSeconds(f.amount));
                // NAV resumes by itself after `amount` simulated seconds.
                tokio::time::sleep(Duration::from_secs_f64(f.amount / self.warp)).await;
                Instant::now()
            }
            FaultKind::CtrlAuv => {
                self.ctrl(sim_fault::Ctrl::Auv);
                tokio::time::sleep(f.hold).await;
                self.ctrl(sim_fault::Ctrl::Payload);
                Instant::now()
            }
            FaultKind::CtrlIdle => {
                // IDLE ends the simulator's run; the operator's way back is a new START, which
                // the driver sends on reconnect.
                self.ctrl(sim_fault::Ctrl::Idle);
                tokio::time::sleep(f.hold).await;
                let before = self.connections();
                self.sim_fault(sim_fault::Fault::DropConnection(true));
                let t = Instant::now();
                self.until_reconnected(before).await;
                t
            }
            FaultKind::HelmPark => {
                self.helm.state.send_replace(HelmState::HelmPark);
                tokio::time::sleep(f.hold).await;
                self.helm.state.send_replace(HelmState::HelmDrive);
                Instant::now()
            }
            FaultKind::StalledSubscriber => {
                self.stall(i, f.hold).await;
                Instant::now()
            }
            FaultKind::MoosRestart => {
                self.moos_restart(i, f.hold).await;
                Instant::now()
            }
            FaultKind::TranslationPanic => {
                let t = Instant::now();
                self.translation_panic(i).await;
                one_shot(t)
            }
            FaultKind::VehiclePanic => {
                let before = self.connections();
                self.vehicle_panic(i).await;
                let t = Instant::now();
                self.monitor.until_left_command(f.hold).await;
                self.until_reconnected(before).await;
                one_shot(t)
            }
            FaultKind::MoosCrashLoop => {
                self.moos_crash_loop(i, f).await;
                Instant::now()
            }
            FaultKind::WebFlood => {
                self.web_flood(i, f).await;
                Instant::now()
            }
            FaultKind::ProcessRestart => self.process_restart(i).await,
            FaultKind::GobydGone => {
                self.gobyd_gone(i, f).await;
                Instant::now()
            }
        }
    }

    /// gobyd goes away for `amount` simulated seconds (every socket closed, nothing answering on
    /// its port) and comes back on the same port, as a restarted gobyd. The gateway must join
    /// again within the bound of its return; the vehicle link must not move (checked by the run
    /// around every helm-side fault).
    async fn gobyd_gone(&mut self, i: u32, f: &PlannedFault) {
        let bound = self.opts.recovery_bound;
        let away = self.warped(f.amount);
        let Some(g) = self.goby.as_mut() else { return };
        let before = g.gateway.stats();
        if let Some(d) = g.gobyd.take() {
            d.stop().await;
        }
        tokio::time::sleep(away).await;
        let lost = g.gateway.stats().link_losses > before.link_losses;
        let port = g.port;
        match rebind(|| StandinGobyd::start(StandinTransport::Tcp { manager_port: port }, &[]))
            .await
        {
            Ok(d) => g.gobyd = Some(d),
            Err(e) => {
                self.violations.push(format!(
                    "fault #{i} (gobyd gone): the stand-in gobyd could not bind its port again: {e}"
                ));
                return;
            }
        }
        match g.until_joined(before.connects, bound).await {
            Some(d) => {
                self.goby_returns.push(d);
                if lost {
                    self.goby_losses_seen += 1;
                }
            }
            None => self.violations.push(format!(
                "fault #{i} (gobyd gone {:.1} s wall): the Goby3 link not back within {bound:?} of gobyd's return ({:?})",
                away.as_secs_f64(),
                g.gateway.stats()
            )),
        }
    }

    /// A long helm-side fault lasts `amount` simulated seconds: at the run's warp that is
    /// `amount / warp` wall seconds, so a 60 s fault costs 0.6 s of CI at warp 100 (at least
    /// 0.5 s, so that even at a high warp it spans several reconnect attempts).
    fn warped(&self, sim_s: f64) -> Duration {
        Duration::from_secs_f64((sim_s / self.warp).max(0.5))
    }

    /// The MOOSDB crash-loops: up for a moment, killed, down a moment, again, for the whole
    /// fault; then it stays up and the bridge must reconnect within the bound. The interface
    /// must not leave COMMAND (its helm is on the bus) and its frontseat link must not move.
    /// Clients flood the web commander for the whole fault: hostile setpoints with the token
    /// (NaN, 1e308, headings past any turn), sends without the token or with garbage bodies,
    /// each on a new connection. Nothing of it may reach the vehicle (the simulator refuses
    /// nothing new: its CMD error count stays), and the frontseat link must not move.
    async fn web_flood(&mut self, i: u32, f: &PlannedFault) {
        let Some(addr) = self.web.as_ref().map(|w| w.local_addr()) else {
            return;
        };
        let t0 = Instant::now();
        let until = t0 + self.warped(f.amount);
        let cmd_errors = self.sim.handle.stats().cmd_errors;
        let sent = Arc::new(AtomicU64::new(0));
        let answered = Arc::new(AtomicU64::new(0));
        let mut tasks = tokio::task::JoinSet::new();
        for k in 0..WEB_FLOODERS {
            let (sent, answered) = (sent.clone(), answered.clone());
            tasks.spawn(async move {
                let mut n = k;
                while Instant::now() < until {
                    let req = web_flood_request(addr, n);
                    n += WEB_FLOODERS;
                    sent.fetch_add(1, Ordering::Relaxed);
                    if web_exchange(addr, &req).await {
                        answered.fetch_add(1, Ordering::Relaxed);
                    }
                }
            });
        }
        while tasks.join_next().await.is_some() {}
        self.web_flood_requests += sent.load(Ordering::Relaxed);
        let states: Vec<InterfaceState> = {
            let v = self
                .monitor
                .changes
                .lock()
                .unwrap_or_else(|p| p.into_inner());
            v.iter()
                .filter(|(t, _)| *t >= t0)
                .map(|(_, s)| *s)
                .collect()
        };
        if !states.is_empty() {
            self.web_floods_left_command += 1;
            if self.web_floods_left_command <= 5 {
                self.notes.push(format!(
                    "fault #{i} (web flood): the interface went through {states:?} (the link stayed; at a high warp NAV gaps of a loaded machine pass nav_timeout)"
                ));
            }
        }
        let after = self.sim.handle.stats().cmd_errors;
        if after != cmd_errors {
            self.violations.push(format!(
                "fault #{i} (web flood): {} CMDs the simulator refused reached it during the flood",
                after - cmd_errors
            ));
        }
        if answered.load(Ordering::Relaxed) == 0 {
            self.violations.push(format!(
                "fault #{i} (web flood): the web server answered none of {} requests",
                sent.load(Ordering::Relaxed)
            ));
        }
    }

    async fn moos_crash_loop(&mut self, i: u32, f: &PlannedFault) {
        let bound = self.opts.recovery_bound;
        let until = Instant::now() + self.warped(f.amount);
        let Some(m) = self.moos.as_mut() else { return };
        let addr = m.addr;
        let mut cycles = 0u32;
        while Instant::now() < until {
            if let Some(b) = m.broker.take() {
                b.shutdown().await;
            }
            tokio::time::sleep(f.hold).await;
            match rebind(|| Broker::bind(addr)).await {
                Ok(b) => m.broker = Some(b),
                Err(e) => {
                    self.violations.push(format!(
                        "fault #{i}: MOOS broker could not be restarted in its crash loop: {e}"
                    ));
                    return;
                }
            }
            // Up just long enough for a client to get half-way in, or not at all.
            tokio::time::sleep(f.hold / 2).await;
            cycles += 1;
        }
        let t0 = Instant::now();
        loop {
            let registered = m
                .broker
                .as_ref()
                .is_some_and(|b| b.client_names().contains(&m.app_name));
            if registered && m.connected() {
                self.moos_reconnects.push(t0.elapsed());
                break;
            }
            if t0.elapsed() >= bound {
                self.violations.push(format!(
                    "fault #{i} (MOOS crash loop, {cycles} crashes): bridge not reconnected within {bound:?} after it ended"
                ));
                break;
            }
            tokio::time::sleep(Duration::from_millis(5)).await;
        }
    }

    /// The process ends and the service manager starts it again. What ends the process is the
    /// vehicle side failing past its limit; here the FrontSeatInterface panics, and with no root
    /// supervisor in the harness the service ends at once, as `frontseat interface` does when
    /// [supervision.interface] gives up. The harness then does what systemd's
    /// `Restart=on-failure` with `RestartSec` does: waits, starts a new instance. Returns when the
    /// old process ended; the run then measures the time back in COMMAND.
    async fn process_restart(&mut self, i: u32) -> Instant {
        let bound = self.opts.recovery_bound;
        // What a real restart loses: every request not answered yet.
        let sent_before = self.helm.last_id.load(Ordering::SeqCst);
        {
            let r = self
                .monitor
                .responses
                .lock()
                .unwrap_or_else(|p| p.into_inner());
            // Only the last timeout's worth can be in flight; older ones are already missing.
            let from = sent_before.saturating_sub(4096).max(1);
            for id in from..=sent_before {
                if !r.answered(id) {
                    self.lost_to_restart.insert(id);
                }
            }
        }
        self.monkey.publish_fault(ChaosFault {
            fault: Some(chaos_fault::Fault::InterfacePanic(true)),
        });
        let exit = tokio::time::timeout(bound, self.service.wait()).await;
        let ended = Instant::now();
        if exit.is_err() {
            self.violations.push(format!(
                "fault #{i} (process restart): the service did not end within {bound:?} of its vehicle side failing"
            ));
        }
        // The old driver (and with it the frontseat connection) goes with the process.
        self.service
            .actor()
            .stop_children_and_wait(Some("process ended".into()), Some(bound))
            .await;
        self.monitor.process_gone();
        tokio::time::sleep(SERVICE_RESTART_SEC).await;
        match InterfaceService::start(&self.config, &self.bus, frontseat_drivers::BUILT_IN).await {
            Ok(new) => {
                let old = std::mem::replace(&mut self.service, new);
                let _ = old.shutdown(Duration::from_millis(100)).await;
            }
            Err(e) => self.violations.push(format!(
                "fault #{i} (process restart): the service could not be started again: {e}"
            )),
        }
        self.crash_base = self.injected_panics + self.injected_kills;
        let sent_after = self.helm.last_id.load(Ordering::SeqCst);
        self.lost_to_restart.extend(sent_before + 1..=sent_after);
        ended
    }

    /// A subscriber to raw_in and node_status that never reads. The publishers (driver,
    /// interface) must not block: node_status keeps reaching the monitor, and the stalled
    /// queue's overflow is dropped and counted.
    async fn stall(&mut self, i: u32, hold: Duration) {
        if self
            .monitor
            .until_command(self.opts.recovery_bound)
            .await
            .is_none()
        {
            self.violations.push(format!(
                "fault #{i} (stalled subscriber): not in COMMAND within {:?} before the stall",
                self.opts.recovery_bound
            ));
        }
        // Never read: every delivery keeps its slot until the stall ends.
        let (tx, rx) = tokio::sync::mpsc::unbounded_channel();
        let stalled = ChaosStalledInbox::subscribe_all(&self.bus, "chaos-stalled", 8, move |m| {
            tx.send(m).map_err(|_| Undeliverable)
        });
        let before_drops = self.bus.total_dropped();
        let before = self.monitor.node_status.load(Ordering::Relaxed);
        tokio::time::sleep(hold).await;
        let delivered = self.monitor.node_status.load(Ordering::Relaxed) - before;
        let dropped = self.bus.total_dropped() - before_drops;
        for s in stalled {
            s.cancel();
        }
        drop(rx);
        self.stall_deliveries.push(delivered);
        self.stall_drops += dropped;
        if delivered == 0 {
            self.violations.push(format!(
                "fault #{i} (stalled subscriber): no node_status reached other subscribers during a {hold:?} stall"
            ));
        }
    }

    /// The translation panics on its data path: its supervisor must restart it, and the new one
    /// must reconnect to the MOOSDB and post NAV again, within the recovery bound.
    async fn translation_panic(&mut self, i: u32) {
        let bound = self.opts.recovery_bound;
        let Some(m) = self.moos.as_mut() else { return };
        let before = m.restarts(bound).await;
        let t0 = Instant::now();
        self.monkey.publish_fault(ChaosFault {
            fault: Some(chaos_fault::Fault::TranslationPanic(true)),
        });
        let deadline = t0 + bound;
        loop {
            let restarted = m.restarts(bound).await > before;
            if restarted && m.connected() && m.counters().node_status_posted > 0 {
                self.translation_restarts.push(t0.elapsed());
                break;
            }
            if Instant::now() >= deadline {
                self.violations.push(format!(
                    "fault #{i} (translation panic): not restarted with NAV flowing to MOOS within {bound:?}"
                ));
                break;
            }
            tokio::time::sleep(Duration::from_millis(5)).await;
        }
    }

    /// Panics the connected vehicle. A burst may have left none connected (the driver still
    /// reconnecting), and a panic sent to nobody proves nothing: wait (bounded) for a vehicle,
    /// then for the simulator to count the panic.
    async fn vehicle_panic(&mut self, i: u32) {
        let bound = self.opts.recovery_bound;
        let deadline = Instant::now() + bound;
        while self.sim.handle.vehicles().is_empty() {
            if Instant::now() >= deadline {
                self.violations.push(format!(
                    "fault #{i} (vehicle panic): no vehicle connected within {bound:?}"
                ));
                return;
            }
            tokio::time::sleep(Duration::from_millis(2)).await;
        }
        let before = self.sim.handle.stats().vehicle_panics;
        self.sim_fault(sim_fault::Fault::Panic(true));
        while self.sim.handle.stats().vehicle_panics == before {
            if Instant::now() >= deadline {
                self.violations.push(format!(
                    "fault #{i} (vehicle panic): injected but not raised within {bound:?}"
                ));
                return;
            }
            tokio::time::sleep(Duration::from_millis(2)).await;
        }
    }

    async fn moos_restart(&mut self, i: u32, down: Duration) {
        let bound = self.opts.recovery_bound;
        let Some(m) = self.moos.as_mut() else { return };
        if !m.wait_connected(bound).await {
            self.violations.push(format!(
                "fault #{i} (MOOS restart): bridge not connected within {bound:?} before the restart"
            ));
        }

        if let Some(b) = m.broker.take() {
            b.shutdown().await;
        }
        tokio::time::sleep(down).await;
        let addr = m.addr;
        match rebind(|| Broker::bind(addr)).await {
            Ok(b) => m.broker = Some(b),
            Err(e) => {
                self.violations.push(format!(
                    "fault #{i}: MOOS broker could not be restarted: {e}"
                ));
                return;
            }
        }
        let t0 = Instant::now();
        let deadline = t0 + bound;
        loop {
            // Reconnected = registered with the new broker (whichever translation instance runs
            // now: one restarted meanwhile connects afresh, with its counters at zero).
            let registered = m
                .broker
                .as_ref()
                .is_some_and(|b| b.client_names().contains(&m.app_name));
            if registered && m.connected() {
                self.moos_reconnects.push(t0.elapsed());
                break;
            }
            if Instant::now() >= deadline {
                self.violations.push(format!(
                    "fault #{i} (MOOS restart): bridge not reconnected within {bound:?}"
                ));
                break;
            }
            tokio::time::sleep(Duration::from_millis(5)).await;
        }
    }
}

/// Runs the harness: `config` must enable chaos. `progress` gets a line now and then.
pub async fn run(
    mut config: InterfaceConfig,
    opts: ChaosOptions,
    mut progress: impl FnMut(&str) + Send,
) -> Result<ChaosReport, ChaosHarnessError> {
    if !config.chaos.enabled {
        return Err(ChaosError::NotEnabled.into());
    }
    if let Some(w) = opts.warp {
        if !(w.is_finite() && w > 0.0 && w <= frontseat_config::MAX_WARP) {
            return Err(ChaosHarnessError::Options(format!(
                "warp must be in (0, {}]",
                frontseat_config::MAX_WARP
            )));
        }
        config.sim_warp_factor = w;
    }
    if opts.recovery_bound.is_zero() {
        return Err(ChaosHarnessError::Options(
            "recovery bound must be > 0".into(),
        ));
    }
    let warp = config.sim_warp_factor;
    let mut notes = Vec::new();
    if config.exit_on_error {
        config.exit_on_error = false;
        notes.push(
            "exit_on_error turned off for the run (every fault would end the service)".into(),
        );
    }
    if !opts.only.is_empty() {
        let keys: Vec<&str> = opts.only.iter().map(|k| k.key()).collect();
        notes.push(format!("only these faults: {}", keys.join(", ")));
    }
    let panics = PanicWatch::install()?;
    let started = Instant::now();
    let bus = Bus::new();
    let monitor = Monitor::new();
    let monitor_subs = monitor.subscribe(&bus);

    let sim = Sim::start(&bus).await?;
    config.driver.basic_simulator.tcp_address = "127.0.0.1".into();
    config.driver.basic_simulator.tcp_port = sim.addr.port();

    // The gate: a fault port refuses unless the config enables chaos (the interface and the
    // driver open theirs themselves, from the same config).
    let translation_faults = FaultPort::open(&config, &bus, FaultTarget::Translation)?;
    let moos = if opts.moos {
        let broker = Broker::bind("127.0.0.1:0").await?;
        let addr = broker.local_addr();
        let mut mc = config.moos.clone().unwrap_or_default();
        mc.server = "127.0.0.1".into();
        mc.port = addr.port();
        mc.time_warp = 1.0;
        config.moos = Some(mc.clone());
        let bridge = translation::TranslationObserver::default();
        let root = SupervisorHandle::start(
            "root",
            vec![translation::child_spec(
                translation::TranslationArgs {
                    cfg: mc.clone(),
                    vehicle: config.name.clone(),
                    bus: bus.clone(),
                    faults: Some(translation_faults.clone()),
                    observer: bridge.clone(),
                },
                // The helm side, as in `frontseat interface`: restarted without end.
                frontseat_actors::supervisor::Policy::from(&config.supervision.translation)
                    .helm_side(),
            )],
            Some(&bus),
        )
        .await
        .map_err(ChaosHarnessError::Translation)?;
        Some(Moos {
            addr,
            broker: Some(broker),
            root,
            bridge,
            app_name: mc.app_name.clone(),
        })
    } else {
        config.moos = None;
        None
    };

    let goby = Some(Goby::start(&bus).await?);
    let helm = Helm::start(&bus);
    let service = InterfaceService::start(&config, &bus, frontseat_drivers::BUILT_IN).await?;
    // The web commander, for the flood: loopback, with a token (without one it refuses sends).
    let web_cfg = frontseat_config::WebConfig {
        enabled: true,
        listen: "127.0.0.1:0".into(),
        token: Some(WEB_TOKEN.into()),
        ..Default::default()
    };
    let web = frontseat_web::WebService::start_with(
        &web_cfg,
        &config.limits,
        Some(WEB_TOKEN.into()),
        &bus,
        &config.name,
    )
    .await
    .map_err(|e| ChaosHarnessError::Web(e.to_string()))?;

    let mut run = Run {
        monkey: ChaosMonkeyPorts::new(&bus),
        sim_monkey: ChaosSimMonkeyPorts::new(&bus),
        config: config.clone(),
        crash_base: 0,
        lost_to_restart: Default::default(),
        process_restarts: Vec::new(),
        vehicle_link_checked: 0,
        vehicle_link_unknown: 0,
        web: Some(web),
        web_flood_requests: 0,
        web_floods_left_command: 0,
        notes: Vec::new(),
        bus,
        service,
        sim,
        moos,
        goby,
        goby_returns: Vec::new(),
        goby_losses_seen: 0,
        helm,
        monitor,
        warp,
        injected_panics: 0,
        injected_kills: 0,
        restart_waits: Vec::new(),
        stall_deliveries: Vec::new(),
        stall_drops: 0,
        moos_reconnects: Vec::new(),
        translation_restarts: Vec::new(),
        violations: Vec::new(),
        by_kind: BTreeMap::new(),
        opts: opts.clone(),
    };

    if run
        .monitor
        .until_command(Duration::from_secs(10).max(opts.recovery_bound))
        .await
        .is_none()
    {
        return Err(ChaosHarnessError::NoStart(
            Duration::from_secs(10).max(opts.recovery_bound),
        ));
    }
    if let Some(m) = &run.moos
        && !m.wait_connected(opts.recovery_bound).await
    {
        run.violations
            .push("MOOS bridge not connected to the broker at start".into());
    }
    if let Some(g) = &run.goby
        && g.until_joined(0, opts.recovery_bound).await.is_none()
    {
        run.violations
            .push("Goby3 gateway not joined to gobyd at start".into());
    }
    // Warm: this is the baseline the resident set may not grow much beyond.
    let rss_baseline = rss_kib();
    let rss_task = {
        let m = run.monitor.clone();
        tokio::spawn(async move {
            loop {
                if let Some(r) = rss_kib() {
                    m.rss_max_kib.fetch_max(r, Ordering::Relaxed);
                }
                tokio::time::sleep(Duration::from_millis(100)).await;
            }
        })
    };

    let mut planner = Planner::new(
        opts.seed,
        opts.moos,
        config.driver.basic_simulator.nav_timeout,
        &opts.only,
    );
    let mut samples = vec![Sample::take(started.elapsed(), 0, &run.bus)];
    let mut next_sample = Instant::now() + opts.sample_every;
    let soak_until = opts.soak.map(|d| Instant::now() + d);
    let mut last_report = Instant::now();
    let mut last_cleared = Instant::now();
    let mut prev_burst = false;
    let mut i: u32 = 0;
    loop {
        match soak_until {
            Some(until) if Instant::now() >= until => break,
            None if i >= opts.faults => break,
            _ => {}
        }
        i += 1;
        let f = planner.next_fault();
        let f = &f;
        let injected_at = Instant::now();
        // The vehicle link before a helm-side fault that nothing overlaps.
        let link_before = if f.kind.helm_side() && !prev_burst && !f.burst {
            let restarts = run.driver_restarts().await;
            Some((run.sim.handle.stats().connections, restarts))
        } else {
            None
        };
        let cleared = run.inject(i, f).await;
        last_cleared = cleared;
        run.by_kind.entry(f.kind).or_default().injected += 1;
        if !f.burst {
            let back = run.monitor.until_command(opts.recovery_bound).await;
            let now = Instant::now();
            let outage = run.monitor.outage(injected_at, now);
            let st = run.by_kind.entry(f.kind).or_default();
            match back {
                Some(_) => {
                    // A fault that never took the interface out of COMMAND needed no recovery.
                    let back = if outage.is_zero() {
                        Duration::ZERO
                    } else {
                        now.saturating_duration_since(cleared)
                    };
                    st.recoveries.push(back);
                    st.outages.push(outage);
                    if f.kind == FaultKind::ProcessRestart {
                        run.process_restarts.push(back);
                    }
                }
                None => run.violations.push(format!(
                    "fault #{i} ({}): not back in COMMAND within {:?} after it cleared (state {:?})",
                    f.kind.name(),
                    opts.recovery_bound,
                    run.monitor.state()
                )),
            }
            if let Some((conns, restarts)) = link_before {
                let after = run.sim.handle.stats().connections;
                let restarts_after = run.driver_restarts().await;
                run.vehicle_link_checked += 1;
                let new_conns = after.saturating_sub(conns);
                // The simulator's accept count is the ground truth for the connection; the
                // driver's restart count comes from a snapshot the interface may not answer on
                // a starved machine. An unanswered snapshot with no new connection is "not
                // known", counted and reported, not a touched link.
                let restarted = match (restarts, restarts_after) {
                    (Some(a), Some(b)) => a != b,
                    _ => false,
                };
                if new_conns == 0 && (restarts.is_none() || restarts_after.is_none()) {
                    run.vehicle_link_unknown += 1;
                }
                if new_conns != 0 || restarted {
                    run.violations.push(format!(
                        "fault #{i} ({}): a helm-side fault touched the vehicle link: {} new frontseat connection(s), driver restarts {restarts:?} -> {restarts_after:?}",
                        f.kind.name(),
                        new_conns
                    ));
                }
            }
        }
        prev_burst = f.burst;
        tokio::time::sleep(f.gap).await;
        if Instant::now() >= next_sample {
            next_sample += opts.sample_every;
            let x = Sample::take(started.elapsed(), i, &run.bus);
            progress(&format!("resources: {}", x.line()));
            samples.push(x);
        }
        let last = soak_until.is_none() && i == opts.faults;
        if last_report.elapsed() >= Duration::from_secs(2) || last {
            last_report = Instant::now();
            progress(&format!(
                "{i}{} faults, state {}, driver restarts {}, violations {}",
                if soak_until.is_some() {
                    String::new()
                } else {
                    format!("/{}", opts.faults)
                },
                frontseat_actors::state_machine::state_words(run.monitor.state()),
                run.injected_panics + run.injected_kills,
                run.violations.len()
            ));
        }
    }
    let faults_injected = i;

    // After the last fault: back in COMMAND, and staying there.
    let stable = Duration::from_millis(300);
    let called = Instant::now();
    let final_recovery = run
        .monitor
        .until_stable_command(opts.recovery_bound, stable)
        .await
        .map(|reached| (called + reached).saturating_duration_since(last_cleared));

    // Stop commanding, then give every outstanding request its 5 s (sim) to be answered.
    run.helm.commanding.store(false, Ordering::SeqCst);
    let sent = run.helm.last_id.load(Ordering::SeqCst);
    let answer_wait = Duration::from_secs_f64(5.0 / warp) + Duration::from_secs(3);
    let deadline = Instant::now() + answer_wait;
    loop {
        let answered = {
            let r = run
                .monitor
                .responses
                .lock()
                .unwrap_or_else(|p| p.into_inner());
            (1..=sent).all(|id| r.answered(id))
        };
        if answered || Instant::now() >= deadline {
            break;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    // Late duplicates would arrive now.
    tokio::time::sleep(Duration::from_millis(200)).await;

    let snapshot = run.snapshot().await;
    samples.push(Sample::take(started.elapsed(), faults_injected, &run.bus));
    rss_task.abort();
    let rss_max = run.monitor.rss_max_kib.load(Ordering::Relaxed);

    if let Some(w) = run.web.take() {
        w.shutdown(Duration::from_secs(2)).await;
    }
    let moos_bridge = run.moos.take();
    if let Some(m) = moos_bridge {
        m.root.shutdown(Duration::from_secs(4)).await;
        if let Some(b) = m.broker {
            b.shutdown().await;
        }
    }
    if let Some(g) = run.goby.take() {
        g.gateway.close().await;
        if let Some(d) = g.gobyd {
            d.stop().await;
        }
    }
    let exit = run.service.shutdown(Duration::from_secs(3)).await;
    run.helm.task.abort();
    run.sim.embedded = None;
    run.sim.handle.shutdown().await;
    for s in monitor_subs {
        s.cancel();
    }
    drop(panics);

    // ---- the invariants table ----
    let bound = opts.recovery_bound;
    let mut inv = Vec::new();
    inv.push(Invariant {
        name: "back in COMMAND after the last fault cleared (and held 300 ms)",
        bound: format!("≤ {} wall", fmt_ms(bound)),
        measured: final_recovery.map_or_else(
            || format!("not within bound (state {:?})", run.monitor.state()),
            fmt_ms,
        ),
        ok: final_recovery.is_some(),
    });
    let mut all_rec: Vec<Duration> = run
        .by_kind
        .values()
        .flat_map(|k| k.recoveries.iter().copied())
        .collect();
    all_rec.sort();
    let late = run
        .violations
        .iter()
        .filter(|v| v.contains("not back in COMMAND"))
        .count()
        + all_rec.iter().filter(|d| **d > bound).count();
    inv.push(Invariant {
        name: "back in COMMAND after each non-burst fault",
        bound: format!("≤ {} wall", fmt_ms(bound)),
        measured: format!(
            "n {}, p50 {}, p99 {}, max {}; {} late",
            all_rec.len(),
            fmt_ms(percentile(&all_rec, 50.0)),
            fmt_ms(percentile(&all_rec, 99.0)),
            fmt_ms(all_rec.last().copied().unwrap_or_default()),
            late
        ),
        ok: late == 0,
    });
    let invalid = run.monitor.invalid_states.load(Ordering::Relaxed);
    let examples = run
        .monitor
        .invalid_examples
        .lock()
        .map(|v| v.clone())
        .unwrap_or_default();
    inv.push(Invariant {
        name: "every published state is one of the five",
        bound: "0 outside STANDBY/LISTEN/COMMAND/HELM_ERROR/FS_ERROR".into(),
        measured: format!(
            "{} statuses, {} outside{}",
            run.monitor.statuses.load(Ordering::Relaxed),
            invalid,
            if examples.is_empty() {
                String::new()
            } else {
                format!(" (raw {examples:?})")
            }
        ),
        ok: invalid == 0,
    });
    {
        let r = run
            .monitor
            .responses
            .lock()
            .unwrap_or_else(|p| p.into_inner());
        let missing = (1..=sent)
            .filter(|id| !r.answered(*id) && !run.lost_to_restart.contains(id))
            .count();
        let lost = (1..=sent)
            .filter(|id| !r.answered(*id) && run.lost_to_restart.contains(id))
            .count();
        // A second answer is right only after our own timeout (the driver's late answer, which
        // Goby3 forwards too); anything else answered twice is a duplicate.
        let late = r
            .answers
            .iter()
            .filter(|a| a.count == 2 && a.interface_first)
            .count();
        let dup = r.answers.iter().filter(|a| a.count > 1).count() - late;
        let beyond = r
            .answers
            .iter()
            .skip(usize::try_from(sent).unwrap_or(0))
            .filter(|a| a.count > 0)
            .count() as u64;
        let unknown = r.unknown_ids + beyond + r.without_id;
        inv.push(Invariant {
            name: "one CommandResponse per request with response_requested (and the driver's late one after our timeout or driver-failed answer)",
            bound: "0 missing, 0 duplicated, 0 unknown".into(),
            measured: format!(
                "{sent} sent: {} ok, {} not in COMMAND, {} timed out, {} driver failed, {} frontseat error, {} shutting down; {late} late after a timeout; {lost} unanswered across process restarts (in flight or sent while down); {missing} missing, {dup} duplicated, {unknown} unknown{}",
                r.ok,
                r.not_in_command,
                r.timeout,
                r.driver_failed,
                r.frontseat_refused,
                r.shutting_down,
                if dup > 0 {
                    format!(
                        " (request, first code, further code: {:?})",
                        r.dup_examples
                    )
                } else {
                    String::new()
                }
            ),
            ok: missing == 0 && dup == 0 && unknown == 0 && sent > 0,
        });
    }
    let limit = opts.rss_growth_limit_kib;
    match rss_baseline {
        Some(base) => {
            let growth = rss_max.saturating_sub(base);
            inv.push(Invariant {
                name: "resident set stays bounded",
                bound: format!("growth ≤ {} MiB over the warm baseline", limit / 1024),
                measured: format!(
                    "baseline {:.1} MiB, max {:.1} MiB (+{:.1} MiB)",
                    base as f64 / 1024.0,
                    rss_max as f64 / 1024.0,
                    growth as f64 / 1024.0
                ),
                ok: growth <= limit,
            });
        }
        None => notes.push("RSS not measured (no /proc/self/status)".into()),
    }
    let other = OTHER_PANICS.load(Ordering::SeqCst);
    let seen = INJECTED_PANICS_SEEN.load(Ordering::SeqCst);
    let seen_other = INJECTED_OTHER_SEEN.load(Ordering::SeqCst);
    let other_injected: u64 = [
        FaultKind::TranslationPanic,
        FaultKind::VehiclePanic,
        FaultKind::ProcessRestart,
    ]
    .iter()
    .map(|k| run.by_kind.get(k).map_or(0, |s| s.injected as u64))
    .sum();
    let texts = OTHER_PANIC_TEXT
        .lock()
        .map(|v| v.clone())
        .unwrap_or_default();
    inv.push(Invariant {
        name: "no panic escaped (injected driver, translation and vehicle panics absorbed by supervision)",
        bound: "0 other panics".into(),
        measured: format!(
            "{other} other panics{}; {seen} injected driver panics and {seen_other}/{other_injected} translation/vehicle panics raised and absorbed",
            if texts.is_empty() {
                String::new()
            } else {
                format!(" ({})", texts.join("; "))
            }
        ),
        ok: other == 0 && seen == run.injected_panics && seen_other == other_injected,
    });
    // The current process's restarts: the counter starts again with each process.
    let crashes = run.injected_panics + run.injected_kills - run.crash_base;
    let restarts = snapshot.as_ref().map(|s| u64::from(s.driver_restarts));
    let mut rw = run.restart_waits.clone();
    rw.sort();
    inv.push(Invariant {
        name: "driver restarts equal injected driver crashes",
        bound: "equal".into(),
        measured: format!(
            "{} restarts, {crashes} crashes since the last process start ({} panics + {} kills in all); restart p50 {}, max {}",
            restarts.map_or("?".into(), |r| r.to_string()),
            run.injected_panics,
            run.injected_kills,
            fmt_ms(percentile(&rw, 50.0)),
            fmt_ms(rw.last().copied().unwrap_or_default())
        ),
        ok: restarts == Some(crashes),
    });
    inv.push(Invariant {
        name: "the service ran to the end and shut down cleanly",
        bound: "clean exit".into(),
        measured: format!("{exit:?}"),
        ok: exit == ServiceExit::Clean && snapshot.is_some(),
    });
    if !run.stall_deliveries.is_empty() {
        let min = run.stall_deliveries.iter().min().copied().unwrap_or(0);
        inv.push(Invariant {
            name: "a stalled subscriber blocks no publisher",
            bound: "node_status keeps flowing during every stall".into(),
            measured: format!(
                "{} stalls, ≥ {min} node_status delivered during each, {} messages dropped and counted",
                run.stall_deliveries.len(),
                run.stall_drops
            ),
            ok: min > 0,
        });
    }
    if opts.moos {
        let mut mr = run.moos_reconnects.clone();
        mr.sort();
        let restarts = [FaultKind::MoosRestart, FaultKind::MoosCrashLoop]
            .iter()
            .map(|k| run.by_kind.get(k).map_or(0, |s| s.injected) as usize)
            .sum::<usize>();
        inv.push(Invariant {
            name: "MOOS bridge reconnects after every broker restart and crash loop",
            bound: format!("≤ {} wall each", fmt_ms(bound)),
            measured: format!(
                "{}/{} reconnected; p50 {}, max {}",
                mr.len(),
                restarts,
                fmt_ms(percentile(&mr, 50.0)),
                fmt_ms(mr.last().copied().unwrap_or_default())
            ),
            ok: mr.len() == restarts,
        });
    }

    if opts.moos {
        let mut tr = run.translation_restarts.clone();
        tr.sort();
        let panics = run
            .by_kind
            .get(&FaultKind::TranslationPanic)
            .map_or(0, |k| k.injected) as usize;
        inv.push(Invariant {
            name: "a panicked FrontSeatTranslation is restarted and posts NAV to MOOS again",
            bound: format!("≤ {} wall each", fmt_ms(bound)),
            measured: format!(
                "{}/{} restarted; p50 {}, max {}",
                tr.len(),
                panics,
                fmt_ms(percentile(&tr, 50.0)),
                fmt_ms(tr.last().copied().unwrap_or_default())
            ),
            ok: tr.len() == panics,
        });
    }

    {
        let mut pr = run.process_restarts.clone();
        pr.sort();
        let ended = run
            .by_kind
            .get(&FaultKind::ProcessRestart)
            .map_or(0, |k| k.injected) as usize;
        inv.push(Invariant {
            name: "back in COMMAND after a process restart (service manager: RestartSec 100 ms)",
            bound: format!("≤ {} wall each", fmt_ms(bound)),
            measured: format!(
                "{}/{} back; p50 {}, max {}",
                pr.len(),
                ended,
                fmt_ms(percentile(&pr, 50.0)),
                fmt_ms(pr.last().copied().unwrap_or_default())
            ),
            ok: pr.len() == ended && pr.iter().all(|d| *d <= bound),
        });
    }
    {
        let touched = run
            .violations
            .iter()
            .filter(|v| v.contains("touched the vehicle link"))
            .count();
        inv.push(Invariant {
            name: "the driver's connection to the frontseat is never closed by a helm-side fault",
            bound: "0 new connections at the simulator; 0 driver restarts where the interface answers its snapshot".into(),
            measured: format!(
                "{} helm-side faults checked (MOOS restarts and crash loops, translation panics, web floods, gobyd gone, stalls, PARK), {touched} touched it{}",
                run.vehicle_link_checked,
                if run.vehicle_link_unknown > 0 {
                    format!(
                        "; in {} the interface answered no snapshot (restart count unknown) and the simulator saw no new connection",
                        run.vehicle_link_unknown
                    )
                } else {
                    String::new()
                }
            ),
            ok: touched == 0,
        });
    }
    if let Some(k) = run.by_kind.get(&FaultKind::WebFlood) {
        let bad = run
            .violations
            .iter()
            .filter(|v| v.contains("(web flood)"))
            .count();
        inv.push(Invariant {
            name: "a web client flooding the commander reaches nothing bad and is answered",
            bound: "0 refused CMDs at the vehicle; answers given".into(),
            measured: format!(
                "{} floods, {} requests (hostile setpoints, no token, foreign origin, broken JSON), {bad} failed; {} left COMMAND meanwhile",
                k.injected, run.web_flood_requests, run.web_floods_left_command
            ),
            ok: bad == 0,
        });
    }
    if let Some(k) = run.by_kind.get(&FaultKind::GobydGone) {
        let mut gr = run.goby_returns.clone();
        gr.sort();
        inv.push(Invariant {
            name: "the Goby3 link is back after gobyd returns (gobyd gone 60 s sim)",
            bound: format!("≤ {} wall each", fmt_ms(bound)),
            measured: format!(
                "{}/{} back; p50 {}, max {}; the gateway saw its link lost in {} of them",
                gr.len(),
                k.injected,
                fmt_ms(percentile(&gr, 50.0)),
                fmt_ms(gr.last().copied().unwrap_or_default()),
                run.goby_losses_seen
            ),
            ok: gr.len() == k.injected as usize,
        });
    }
    if opts.soak.is_some() {
        inv.push(soak_invariant(&samples, opts.rss_growth_limit_kib));
    }

    Ok(ChaosReport {
        seed: opts.seed,
        warp,
        faults: faults_injected,
        moos: opts.moos,
        wall: started.elapsed(),
        by_kind: run.by_kind,
        invariants: inv,
        violations: run.violations,
        notes: notes.into_iter().chain(run.notes).collect(),
        samples,
    })
}

/// Fds, threads and tasks may move while faults come and go, but not drift: over the second
/// half of the soak none may exceed its first-half peak by more than the slack, and RSS stays
/// within the growth limit over the first sample after warm-up.
pub fn soak_invariant(samples: &[Sample], rss_limit_kib: u64) -> Invariant {
    const FD_SLACK: u64 = 32;
    const THREAD_SLACK: u64 = 4;
    const TASK_SLACK: usize = 64;
    // A stall adds one subscriber for its length; a leak adds several per crash, thousands.
    const SUB_SLACK: u64 = 16;
    let half = samples.len() / 2;
    let (first, second) = samples.split_at(half.max(1).min(samples.len()));
    let peak = |v: &[Sample], f: &dyn Fn(&Sample) -> Option<u64>| v.iter().filter_map(f).max();
    let mut problems = Vec::new();
    let fd = |x: &Sample| x.fds;
    let th = |x: &Sample| x.threads;
    let tk = |x: &Sample| Some(x.tasks as u64);
    let sb = |x: &Sample| Some(x.subscriptions as u64);
    for (name, f, slack) in [
        ("open fds", &fd as &dyn Fn(&Sample) -> Option<u64>, FD_SLACK),
        ("threads", &th, THREAD_SLACK),
        ("tasks", &tk, TASK_SLACK as u64),
        ("bus subscriptions", &sb, SUB_SLACK),
    ] {
        if let (Some(a), Some(b)) = (peak(first, f), peak(second, f))
            && b > a + slack
        {
            problems.push(format!("{name} {a} -> {b}"));
        }
    }
    let base = samples.get(1).or(samples.first()).and_then(|x| x.rss_kib);
    let rss_max = samples.iter().filter_map(|x| x.rss_kib).max();
    if let (Some(b), Some(m)) = (base, rss_max)
        && m.saturating_sub(b) > rss_limit_kib
    {
        problems.push(format!("RSS {} -> {} KiB", b, m));
    }
    let last = samples.last().map(Sample::line).unwrap_or_default();
    Invariant {
        name: "soak: RSS, open fds, threads, tasks and bus subscriptions stay flat",
        bound: format!(
            "second-half peak ≤ first-half peak + {FD_SLACK} fds / {THREAD_SLACK} threads / {TASK_SLACK} tasks / {SUB_SLACK} bus subscriptions; RSS growth ≤ {} MiB",
            rss_limit_kib / 1024
        ),
        measured: if problems.is_empty() {
            format!("{} samples; last: {last}", samples.len())
        } else {
            format!("{} samples; drift: {}", samples.len(), problems.join(", "))
        },
        ok: problems.is_empty() && samples.len() >= 2,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn embedded_config_enables_chaos_and_parses() {
        let c = default_config().unwrap();
        assert!(c.chaos.enabled);
        assert!(c.sim_warp_factor > 1.0);
    }

    #[test]
    fn same_seed_same_schedule_other_seed_other_schedule() {
        let a = plan(7, 300, true, 5.0);
        assert_eq!(a, plan(7, 300, true, 5.0));
        assert_ne!(a, plan(8, 300, true, 5.0));
        // Every kind shows up in a schedule of this length.
        for k in FaultKind::ALL {
            assert!(a.iter().any(|f| f.kind == k), "{k:?} never planned");
        }
        assert!(
            plan(7, 300, false, 5.0)
                .iter()
                .all(|f| f.kind != FaultKind::MoosRestart)
        );
    }

    #[test]
    fn soak_invariant_sees_a_drift_and_passes_a_flat_run() {
        let at = |i: u64, fds: u64, rss: u64| Sample {
            at: Duration::from_secs(i),
            faults: i as u32,
            rss_kib: Some(rss),
            fds: Some(fds),
            threads: Some(8),
            tasks: 40,
            subscriptions: 60,
        };
        let flat: Vec<Sample> = (0..10).map(|i| at(i, 30 + i % 3, 10_000)).collect();
        assert!(soak_invariant(&flat, 1024).ok);
        let leak: Vec<Sample> = (0..10).map(|i| at(i, 30 + 10 * i, 10_000)).collect();
        let inv = soak_invariant(&leak, 1024);
        assert!(
            !inv.ok && inv.measured.contains("open fds"),
            "{}",
            inv.measured
        );
        let grow: Vec<Sample> = (0..10).map(|i| at(i, 30, 10_000 + 500 * i)).collect();
        assert!(!soak_invariant(&grow, 1024).ok);
        // Subscriptions left behind by crashed actors: 7 more every sample.
        let subs: Vec<Sample> = (0..10)
            .map(|i| Sample {
                subscriptions: 60 + 7 * i as usize,
                ..at(i, 30, 10_000)
            })
            .collect();
        let inv = soak_invariant(&subs, 1024);
        assert!(
            !inv.ok && inv.measured.contains("bus subscriptions"),
            "{}",
            inv.measured
        );
    }

    #[test]
    fn long_helm_side_faults_and_restarts_are_never_overlapped() {
        let p = plan(3, 2000, true, 5.0);
        for k in [
            FaultKind::MoosCrashLoop,
            FaultKind::WebFlood,
            FaultKind::ProcessRestart,
            FaultKind::GobydGone,
        ] {
            assert!(p.iter().any(|f| f.kind == k), "{k:?}");
        }
        assert!(p.iter().filter(|f| f.kind.alone()).all(|f| !f.burst));
    }

    #[test]
    fn rng_range_stays_in_bounds() {
        let mut r = Rng::new(1);
        for _ in 0..10_000 {
            let x = r.range(2.0, 3.0);
            assert!((2.0..3.0).contains(&x));
            assert!(r.below(7) < 7);
        }
    }

    #[tokio::test]
    async fn refused_without_chaos_enabled() {
        let cfg = InterfaceConfig::default();
        let r = run(cfg, ChaosOptions::default(), |_| {}).await;
        assert!(
            matches!(r, Err(ChaosHarnessError::Refused(ChaosError::NotEnabled))),
            "{:?}",
            r.err()
        );
    }
}
