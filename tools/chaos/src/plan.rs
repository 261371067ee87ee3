//! The fault schedule: the kinds of fault, their weights and hold times, drawn from a seeded
//! PRNG so that a seed names the same faults, in the same order, everywhere.

use std::time::Duration;

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
    // The vehicle families' faults (`frontseat chaos --vehicle <family>`): injected in the link
    // between the vehicle's emulator and its real driver, or through the emulator's own hooks.
    // Not in `ALL`, so the basic simulator's schedules are what they were.
    LinkDrop,
    LinkGarbage,
    TruncatedFrame,
    SilentVehicle,
    SlowLink,
    VehicleRefuses,
    VehicleModeChange,
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

    /// The vehicle families' own faults; a family draws from these, the crashes and the
    /// helm-side faults it supports ([`crate::family::Family::kinds`]).
    pub const VEHICLE: [FaultKind; 7] = [
        FaultKind::LinkDrop,
        FaultKind::LinkGarbage,
        FaultKind::TruncatedFrame,
        FaultKind::SilentVehicle,
        FaultKind::SlowLink,
        FaultKind::VehicleRefuses,
        FaultKind::VehicleModeChange,
    ];

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
            FaultKind::LinkDrop => "link-drop",
            FaultKind::LinkGarbage => "link-garbage",
            FaultKind::TruncatedFrame => "truncated-frame",
            FaultKind::SilentVehicle => "silent-vehicle",
            FaultKind::SlowLink => "slow-link",
            FaultKind::VehicleRefuses => "vehicle-refuses",
            FaultKind::VehicleModeChange => "vehicle-mode-change",
        }
    }

    /// The kind a `key` names.
    pub fn from_key(key: &str) -> Option<Self> {
        Self::ALL
            .into_iter()
            .chain(Self::VEHICLE)
            .find(|k| k.key() == key)
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
            FaultKind::LinkDrop => "vehicle link dropped",
            FaultKind::LinkGarbage => "garbage frames in the vehicle's protocol",
            FaultKind::TruncatedFrame => "truncated frames",
            FaultKind::SilentVehicle => "vehicle silent",
            FaultKind::SlowLink => "slow link",
            FaultKind::VehicleRefuses => "vehicle refuses commands",
            FaultKind::VehicleModeChange => "vehicle changes mode on its own",
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
            FaultKind::LinkDrop | FaultKind::LinkGarbage | FaultKind::TruncatedFrame => 3,
            FaultKind::SilentVehicle | FaultKind::SlowLink => 2,
            FaultKind::VehicleRefuses | FaultKind::VehicleModeChange => 2,
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

    /// A schedule over exactly `kinds` (a vehicle family's), narrowed by `only` when it is not
    /// empty; with none left, a dropped vehicle link.
    pub fn with_kinds(
        seed: u64,
        kinds: &[FaultKind],
        nav_timeout_s: f64,
        only: &[FaultKind],
    ) -> Self {
        let mut kinds: Vec<FaultKind> = kinds
            .iter()
            .copied()
            .filter(|k| only.is_empty() || only.contains(k))
            .collect();
        if kinds.is_empty() {
            kinds.push(FaultKind::LinkDrop);
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
            // `amount`: garbage or truncated frames written.
            FaultKind::LinkGarbage | FaultKind::TruncatedFrame => {
                (ms(rng, 5.0, 50.0), (1 + rng.below(40)) as f64)
            }
            // `amount`: simulated seconds of silence, shorter and longer than the driver's
            // timeout for a silent vehicle (`nav_timeout_s` for a family).
            FaultKind::SilentVehicle => (Duration::ZERO, rng.range(0.2, 2.5 * self.nav_timeout_s)),
            // `amount`: the link's added latency each way, simulated seconds.
            FaultKind::SlowLink => (ms(rng, 100.0, 600.0), rng.range(0.05, 1.5)),
            // Held long enough that a command let through would be seen (the check's grace
            // is 300 ms wall).
            FaultKind::VehicleRefuses | FaultKind::VehicleModeChange => {
                (ms(rng, 400.0, 900.0), 0.0)
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

#[cfg(test)]
mod tests {
    use super::*;

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
}
