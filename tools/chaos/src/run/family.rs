//! The run over one vehicle family (`frontseat chaos --vehicle <family>`): the family's emulator
//! behind the chaos link, the interface with the family's real driver pointed at the link, a
//! helm on the bus. The same seeded schedule as the basic simulator's run, over the family's
//! faults: the driver's crashes, the link dropped, garbage and truncated frames of the vehicle's
//! protocol, a silent vehicle, a slow link, the vehicle refusing commands or changing mode on its
//! own, and the helm side's PARK and stalled subscriber. Beside the invariants the basic run
//! checks (recovery, the five states, one answer per request, bounded memory, no escaped panic,
//! restarts as injected, a clean end), the command gate (no command reaches the vehicle while
//! the interface is out of COMMAND), nothing absurd handed to the helm, commands reaching the
//! vehicle again after each fault, and the link untouched by the helm side's faults.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use frontseat_actors::bus::Bus;
use frontseat_actors::interface::{InterfaceService, ServiceExit};
use frontseat_actors::ports::ChaosMonkeyPorts;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{HelmState, InterfaceState};
use frontseat_config::InterfaceConfig;
use tokio::time::Instant;

use super::faults::{driver_crash, stall};
use super::invariants::{self, End};
use super::tally::Tally;
use super::{check_options, recovery, settle_parts, watch_rss};
use crate::family::{Family, Vehicle};
use crate::link::ChaosLink;
use crate::monitor::Monitor;
use crate::options::{ChaosHarnessError, ChaosOptions};
use crate::panics::PanicWatch;
use crate::plan::{FaultKind, PlannedFault, Planner, Rng};
use crate::report::{ChaosReport, Invariant, fmt_ms, percentile};
use crate::resources::{Sample, rss_kib};
use crate::world::helm::Helm;

/// A command reaching the vehicle this long (wall) after the interface left COMMAND was let
/// through by the gate, not in flight when it closed.
const GATE_GRACE: Duration = Duration::from_millis(300);
/// How often the command gate is read.
const GATE_EVERY: Duration = Duration::from_millis(10);
/// The shortest PARK of the helm in a family run: long enough for the gate's check to see a
/// command let through.
const MIN_PARK: Duration = Duration::from_millis(400);

/// The family's run: what it holds while faults are injected.
struct FamilyRun {
    family: Family,
    opts: ChaosOptions,
    bus: Bus,
    monkey: ChaosMonkeyPorts,
    service: InterfaceService,
    vehicle: Arc<Vehicle>,
    link: Arc<ChaosLink>,
    helm: Helm,
    monitor: Arc<Monitor>,
    warp: f64,
    tally: Tally,
    /// Commands seen flowing to the vehicle again after each fault, and the time it took.
    flows: Vec<Duration>,
    /// Refusals the vehicle counted during the refusal faults.
    refusals_seen: u64,
    link_checked: u32,
    /// The pilot of an ArduPilot (arms, selects GUIDED), paused while the vehicle is taken
    /// from the backseat on purpose.
    pilot: Option<Pilot>,
}

/// Commands the vehicle got so far: its emulator's count, or the link's.
fn commands(vehicle: &Vehicle, link: &ChaosLink) -> u64 {
    vehicle.commands().unwrap_or_else(|| link.marker_count())
}

/// Runs `family` under the seeded faults. `config` must enable chaos; its driver is pointed at
/// the family's emulator here.
pub async fn run_family(
    family: Family,
    mut config: InterfaceConfig,
    opts: ChaosOptions,
    mut progress: impl FnMut(&str) + Send,
) -> Result<ChaosReport, ChaosHarnessError> {
    let mut notes = check_options(&mut config, &opts)?;
    notes.insert(0, format!("vehicle family: {}", family.key()));
    if opts.soak.is_some() {
        return Err(ChaosHarnessError::Options(
            "--soak runs the basic simulator only".into(),
        ));
    }
    let panics = PanicWatch::install()?;
    let started = Instant::now();
    let bus = Bus::new();
    let monitor = Monitor::new(config.limits.navigation.clone());
    let monitor_subs = monitor.subscribe(&bus);
    config.moos = None;
    let vehicle = Arc::new(Vehicle::start(family, &config).await?);
    let link = Arc::new(
        ChaosLink::start(vehicle.addr(), family.command_marker())
            .await
            .map_err(|e| ChaosHarnessError::Vehicle(format!("chaos link: {e}")))?,
    );
    family.point_driver(&mut config, link.addr());
    let service = InterfaceService::start(&config, &bus, frontseat_drivers::BUILT_IN).await?;
    // After the interface: a request published before it subscribed would reach nobody and
    // stay unanswered (request 1 did, at some seeds).
    let helm = Helm::start(&bus);
    let warp = config.sim_warp_factor;
    let silence_s = family.silence_timeout(&config);
    let mut run = FamilyRun {
        family,
        opts: opts.clone(),
        monkey: ChaosMonkeyPorts::new(&bus),
        bus,
        service,
        vehicle,
        link,
        helm,
        monitor,
        warp,
        tally: Tally::default(),
        flows: Vec::new(),
        refusals_seen: 0,
        link_checked: 0,
        pilot: None,
    };
    if family.needs_pilot() {
        run.pilot = Some(Pilot::start(&run.bus, run.vehicle.clone()));
    }
    let start_bound = Duration::from_secs(10).max(opts.recovery_bound);
    if run.monitor.until_command(start_bound).await.is_none() {
        progress(&format!(
            "not in COMMAND at start: state {:?}",
            run.monitor.state()
        ));
        shut_down(run).await;
        return Err(ChaosHarnessError::NoStart(start_bound));
    }
    let rss_baseline = rss_kib();
    let rss_task = watch_rss(&run.monitor);
    let gate = Gate::start(&run);

    let mut planner = Planner::with_kinds(opts.seed, &family.kinds(), silence_s, &opts.only);
    let mut samples = vec![Sample::take(started.elapsed(), 0, &run.bus)];
    let mut last_cleared = Instant::now();
    let mut last_report = Instant::now();
    let mut count = 0;
    // (fault, kind, burst, the helm's last request id when it was injected): to say which
    // fault a request left unanswered came with.
    let mut id_marks: Vec<(u32, FaultKind, bool, i32)> = Vec::new();
    for i in 1..=opts.faults {
        count = i;
        let f = planner.next_fault();
        id_marks.push((i, f.kind, f.burst, run.helm.last_id.load(Ordering::SeqCst)));
        let injected_at = Instant::now();
        let conns_before = f.kind.helm_side().then(|| run.link.stats().connections);
        let cmds_before = commands(&run.vehicle, &run.link);
        let cleared = run.inject(i, &f).await;
        last_cleared = cleared;
        run.tally.by_kind.entry(f.kind).or_default().injected += 1;
        if !f.burst {
            let bound = run.opts.recovery_bound;
            let violations_before = run.tally.violations.len();
            recovery(
                &run.monitor,
                &mut run.tally,
                bound,
                i,
                &f,
                injected_at,
                cleared,
            )
            .await;
            if run.tally.violations.len() > violations_before {
                // What the interface says of itself, for whoever reads the failure.
                let snap = run.service.snapshot(Duration::from_secs(2)).await;
                run.tally.notes.push(format!(
                    "fault #{i}: not back; the interface's status {:?}, providing data {:?}, driver up {:?}; link {:?}",
                    snap.as_ref().map(|s| &s.status),
                    snap.as_ref().map(|s| s.providing_data),
                    snap.as_ref().map(|s| s.driver_up),
                    run.link.stats()
                ));
            }
            run.commands_flow(i, &f, cmds_before).await;
            if let Some(before) = conns_before {
                run.link_checked += 1;
                let after = run.link.stats().connections;
                if after != before {
                    run.tally.violations.push(format!(
                        "fault #{i} ({}): a helm-side fault touched the vehicle link: {} new connection(s)",
                        f.kind.name(),
                        after - before
                    ));
                }
            }
        }
        tokio::time::sleep(f.gap).await;
        if last_report.elapsed() >= Duration::from_secs(2) || i == opts.faults {
            last_report = Instant::now();
            progress(&format!(
                "{i}/{} faults, state {}, violations {}",
                opts.faults,
                frontseat_actors::state_machine::state_words(run.monitor.state()),
                run.tally.violations.len()
            ));
        }
    }
    let (final_recovery, sent) = settle_parts(
        &run.monitor,
        &run.helm,
        opts.recovery_bound,
        warp,
        last_cleared,
    )
    .await;
    {
        let r = run
            .monitor
            .responses
            .lock()
            .unwrap_or_else(|p| p.into_inner());
        for id in (1..=sent).filter(|id| !r.answered(*id)).take(5) {
            let during = id_marks.iter().rev().find(|m| m.3 < id);
            notes.push(match during {
                Some((i, k, burst, _)) => format!(
                    "request {id} unanswered: sent during or after fault #{i} ({}{})",
                    k.name(),
                    if *burst { ", a burst" } else { "" }
                ),
                None => format!("request {id} unanswered: sent before the first fault"),
            });
        }
    }
    let snapshot = run.service.snapshot(Duration::from_secs(2)).await;
    samples.push(Sample::take(started.elapsed(), count, &run.bus));
    rss_task.abort();
    let gate = gate.stop().await;
    let rss_max = run.monitor.rss_max_kib.load(Ordering::Relaxed);
    let monitor = run.monitor.clone();
    let link_stats = run.link.stats();
    let (flows, refusals, link_checked) = (run.flows.clone(), run.refusals_seen, run.link_checked);
    let (exit, mut tally) = shut_down(run).await;
    for s in monitor_subs {
        s.cancel();
    }
    drop(panics);
    tally.violations.extend(gate.violations.iter().cloned());

    let end = End {
        final_recovery,
        sent,
        snapshot,
        exit,
        rss_baseline,
        rss_max,
        samples: &samples,
    };
    let mut inv = invariants::common(&tally, &monitor, &opts, &end, &mut notes);
    inv.extend(invariants::stalls(&tally));
    inv.push(gate.invariant());
    inv.push(flow_invariant(&tally, &flows, opts.recovery_bound));
    inv.push(Invariant {
        name: "the vehicle link is never closed by a helm-side fault",
        bound: "0 new connections at the chaos link".into(),
        measured: format!(
            "{link_checked} helm-side faults checked (PARK, stalled subscriber), {} touched it",
            tally
                .violations
                .iter()
                .filter(|v| v.contains("touched the vehicle link"))
                .count()
        ),
        ok: !tally
            .violations
            .iter()
            .any(|v| v.contains("touched the vehicle link")),
    });
    if let Some(k) = tally.by_kind.get(&FaultKind::VehicleRefuses) {
        inv.push(Invariant {
            name: "the vehicle's refusals were real (its emulator refused our commands)",
            bound: "≥ 1 refusal counted by the vehicle per refusal fault".into(),
            measured: format!("{} refusal faults, {refusals} refusals counted", k.injected),
            ok: refusals >= u64::from(k.injected),
        });
    }
    if let Some(k) = tally.by_kind.get(&FaultKind::VehicleModeChange) {
        let left = k.outages.iter().filter(|d| !d.is_zero()).count();
        inv.push(Invariant {
            name: "a vehicle taking control on its own takes the interface out of COMMAND",
            bound: "every non-burst mode change left COMMAND".into(),
            measured: format!(
                "{} mode changes, {} measured, {left} left COMMAND",
                k.injected,
                k.outages.len()
            ),
            ok: left == k.outages.len(),
        });
    }
    notes.push(format!(
        "chaos link: {} connections, {} drops, {} bytes injected, {} bytes discarded while silent",
        link_stats.connections,
        link_stats.drops,
        link_stats.injected_bytes,
        link_stats.discarded_bytes
    ));
    Ok(ChaosReport {
        seed: opts.seed,
        warp,
        faults: count,
        moos: false,
        wall: started.elapsed(),
        by_kind: tally.by_kind,
        invariants: inv,
        violations: tally.violations,
        notes: notes.into_iter().chain(tally.notes).collect(),
        samples,
    })
}

async fn shut_down(run: FamilyRun) -> (ServiceExit, Tally) {
    if let Some(p) = &run.pilot {
        p.task.abort();
    }
    let exit = run.service.shutdown(Duration::from_secs(3)).await;
    run.helm.task.abort();
    // The gate has stopped: these are the last holders.
    drop(run.link);
    run.vehicle.shutdown().await;
    (exit, run.tally)
}

fn flow_invariant(t: &Tally, flows: &[Duration], bound: Duration) -> Invariant {
    let mut v = flows.to_vec();
    v.sort();
    let late = t
        .violations
        .iter()
        .filter(|v| v.contains("no command reached the vehicle"))
        .count();
    Invariant {
        name: "commands reach the vehicle again after each non-burst fault",
        bound: format!("≤ {} wall after COMMAND is back", fmt_ms(bound)),
        measured: format!(
            "n {}, p50 {}, max {}; {late} never",
            v.len(),
            fmt_ms(percentile(&v, 50.0)),
            fmt_ms(v.last().copied().unwrap_or_default())
        ),
        ok: late == 0,
    }
}

impl FamilyRun {
    fn pilot_on(&self, on: bool) {
        if let Some(p) = &self.pilot {
            p.enabled.store(on, Ordering::SeqCst);
        }
    }

    fn warped(&self, sim_s: f64) -> Duration {
        Duration::from_secs_f64((sim_s / self.warp).max(0.0))
    }

    /// After a fault and the recovery check: commands reach the vehicle again (the helm keeps
    /// commanding), within the bound.
    async fn commands_flow(&mut self, i: u32, f: &PlannedFault, before: u64) {
        let bound = self.opts.recovery_bound;
        let t0 = Instant::now();
        let base = before.max(commands(&self.vehicle, &self.link));
        loop {
            if commands(&self.vehicle, &self.link) > base {
                self.flows.push(t0.elapsed());
                return;
            }
            if t0.elapsed() >= bound {
                self.tally.violations.push(format!(
                    "fault #{i} ({}): no command reached the vehicle within {bound:?} after it was back in COMMAND (state {:?})",
                    f.kind.name(),
                    self.monitor.state()
                ));
                return;
            }
            tokio::time::sleep(Duration::from_millis(2)).await;
        }
    }

    /// Waits (bounded) until the driver is connected through the link again after a drop.
    async fn until_reconnected(&self, before: u64) {
        let deadline = Instant::now() + self.opts.recovery_bound;
        while self.link.stats().connections <= before && Instant::now() < deadline {
            tokio::time::sleep(Duration::from_millis(2)).await;
        }
    }

    /// Frames of the vehicle's protocol, broken: single frames cut from the vehicle's recent
    /// stream (from one frame start to the next), each with one byte changed — its checksum or
    /// CRC no longer matches — or cut short (`truncate`).
    fn broken_frames(&self, n: usize, truncate: bool, rng: &mut Rng) -> Vec<u8> {
        let recent = self.link.recent();
        let start = self.family.frame_start();
        let mut out = Vec::new();
        for _ in 0..n {
            let frame = recent
                .get(rng.below(recent.len() as u64) as usize)
                .and_then(|chunk| one_frame(chunk, start, rng));
            let Some(frame) = frame else {
                // Nothing seen yet: noise.
                out.extend((0..16).map(|_| rng.below(256) as u8));
                continue;
            };
            let mut f = frame.to_vec();
            if truncate {
                let cut = 1 + rng.below(f.len().max(2) as u64 - 1) as usize;
                f.truncate(cut.min(f.len()));
            } else {
                let at = rng.below(f.len() as u64) as usize;
                f[at] ^= 1 + rng.below(255) as u8;
            }
            out.extend_from_slice(&f);
        }
        out
    }

    /// Injects `f` and returns when it cleared (as the basic run's faults).
    async fn inject(&mut self, i: u32, f: &PlannedFault) -> Instant {
        // The fault's own randomness, fixed by the seed, the fault's number and kind.
        let mut rng = Rng::new(self.opts.seed ^ (u64::from(i) << 32) ^ f.kind as u64);
        match f.kind {
            FaultKind::DriverPanic | FaultKind::DriverKill => {
                let t = Instant::now();
                let bound = self.opts.recovery_bound;
                driver_crash(
                    &self.service,
                    &self.monkey,
                    &mut self.tally,
                    bound,
                    i,
                    f.kind,
                )
                .await;
                t
            }
            FaultKind::LinkDrop => {
                let before = self.link.stats().connections;
                let t = Instant::now();
                self.link.drop_connection();
                self.monitor.until_left_command(f.hold).await;
                self.until_reconnected(before).await;
                t
            }
            FaultKind::LinkGarbage | FaultKind::TruncatedFrame => {
                let t = Instant::now();
                let bytes = self.broken_frames(
                    f.amount as usize,
                    f.kind == FaultKind::TruncatedFrame,
                    &mut rng,
                );
                if !self.link.inject(bytes) {
                    self.tally.notes.push(format!(
                        "fault #{i} ({}): no link up to write into",
                        f.kind.name()
                    ));
                }
                self.monitor.until_left_command(f.hold).await;
                t
            }
            FaultKind::SilentVehicle => {
                let d = self.warped(f.amount);
                self.link.silence(d);
                tokio::time::sleep(d).await;
                Instant::now()
            }
            FaultKind::SlowLink => {
                self.link.set_delay(self.warped(f.amount));
                tokio::time::sleep(f.hold).await;
                self.link.set_delay(Duration::ZERO);
                // What was queued behind the latency is delivered by now.
                tokio::time::sleep(self.warped(f.amount)).await;
                Instant::now()
            }
            FaultKind::VehicleRefuses => {
                let before = self.vehicle.refused().unwrap_or(0);
                self.vehicle.refuse(true);
                tokio::time::sleep(f.hold).await;
                self.refusals_seen += self.vehicle.refused().unwrap_or(0) - before;
                self.vehicle.refuse(false);
                Instant::now()
            }
            FaultKind::VehicleModeChange => {
                self.pilot_on(false);
                self.vehicle.take_control(true);
                tokio::time::sleep(f.hold).await;
                self.vehicle.take_control(false);
                self.pilot_on(true);
                Instant::now()
            }
            FaultKind::HelmPark => {
                self.helm.state.send_replace(HelmState::HelmPark);
                tokio::time::sleep(f.hold.max(MIN_PARK)).await;
                self.helm.state.send_replace(HelmState::HelmDrive);
                Instant::now()
            }
            FaultKind::StalledSubscriber => {
                let bound = self.opts.recovery_bound;
                stall(&self.bus, &self.monitor, &mut self.tally, bound, i, f.hold).await;
                Instant::now()
            }
            other => {
                self.tally.notes.push(format!(
                    "fault #{i}: {} is not a fault of the {} family; skipped",
                    other.name(),
                    self.family.key()
                ));
                Instant::now()
            }
        }
    }
}

/// One frame of `chunk`, drawn at random: from an occurrence of `start` to the next (or the
/// chunk's end); None when the chunk holds no frame start.
fn one_frame<'a>(chunk: &'a [u8], start: &[u8], rng: &mut Rng) -> Option<&'a [u8]> {
    let at: Vec<usize> = chunk
        .windows(start.len())
        .enumerate()
        .filter(|(_, w)| *w == start)
        .map(|(i, _)| i)
        .collect();
    let k = rng.below(at.len() as u64) as usize;
    let from = *at.get(k)?;
    let to = at.get(k + 1).copied().unwrap_or(chunk.len());
    chunk.get(from..to)
}

/// The person at an ArduPilot's ground station: whenever the vehicle is not armed in GUIDED,
/// asks (every 50 ms) through the interface's ArduPilot CommandRequest extension to arm it,
/// then to select GUIDED — what `frontseat demo --vehicle ardupilot` does once. Its request
/// ids are the monitor's reserved ones.
struct Pilot {
    enabled: Arc<AtomicBool>,
    task: tokio::task::JoinHandle<()>,
}

impl Pilot {
    fn start(bus: &Bus, vehicle: Arc<Vehicle>) -> Self {
        use frontseat_actors::ports::ArdupilotPilotPorts;
        use frontseat_actors::proto::frontseat::protobuf::ardupilot::{
            ArdupilotCommand, CommandRequest, ardupilot_command::Action,
        };
        let enabled = Arc::new(AtomicBool::new(true));
        let on = enabled.clone();
        let ports = ArdupilotPilotPorts::new(bus);
        let task = tokio::spawn(async move {
            let mut id = crate::monitor::PILOT_IDS;
            loop {
                tokio::time::sleep(Duration::from_millis(50)).await;
                let Some((armed, guided)) = vehicle.armed_guided() else {
                    return;
                };
                if !on.load(Ordering::SeqCst) || (armed && guided) {
                    continue;
                }
                id = id.checked_add(1).unwrap_or(crate::monitor::PILOT_IDS);
                let action = if armed { Action::Guided } else { Action::Arm };
                ports.publish_ardupilot_command_request(CommandRequest {
                    response_requested: Some(true),
                    request_id: Some(id),
                    ardupilot_command: Some(ArdupilotCommand {
                        action: Some(action as i32),
                    }),
                    ..Default::default()
                });
            }
        });
        Self { enabled, task }
    }
}

/// The command gate, watched: every 10 ms the vehicle's command count is read inside one
/// unbroken stretch of a state other than COMMAND that began more than [`GATE_GRACE`] ago; a
/// count that grew between two such readings of the same stretch is a command the interface
/// let through outside COMMAND.
struct Gate {
    stop: Arc<AtomicBool>,
    task: tokio::task::JoinHandle<GateResult>,
}

struct GateResult {
    violations: Vec<String>,
    /// Readings taken inside a stretch out of COMMAND (past the grace).
    readings: u64,
    /// Stretches out of COMMAND that were read at least twice.
    stretches: u64,
}

impl Gate {
    fn start(run: &FamilyRun) -> Self {
        let stop = Arc::new(AtomicBool::new(false));
        let monitor = run.monitor.clone();
        let counter = CommandCounter::of(run);
        let s = stop.clone();
        let task = tokio::spawn(async move {
            let mut r = GateResult {
                violations: Vec::new(),
                readings: 0,
                stretches: 0,
            };
            // (stretch, count at its first reading, readings of it)
            let mut prev: Option<(u64, u64, u32)> = None;
            while !s.load(Ordering::Relaxed) {
                tokio::time::sleep(GATE_EVERY).await;
                let (state, stretch, since) = monitor.stretch();
                if state == InterfaceState::InterfaceCommand || since.elapsed() < GATE_GRACE {
                    prev = None;
                    continue;
                }
                let c = counter.read();
                if monitor.change_count() != stretch {
                    prev = None;
                    continue;
                }
                r.readings += 1;
                match prev {
                    Some((p, first, n)) if p == stretch => {
                        if n == 1 {
                            r.stretches += 1;
                        }
                        if c > first {
                            if r.violations.len() < 20 {
                                r.violations.push(format!(
                                    "{} command(s) reached the vehicle {} ms into {:?} (out of COMMAND since then, {} ms grace)",
                                    c - first,
                                    since.elapsed().as_millis(),
                                    state,
                                    GATE_GRACE.as_millis()
                                ));
                            }
                            prev = Some((stretch, c, n + 1));
                        } else {
                            prev = Some((p, first, n + 1));
                        }
                    }
                    _ => prev = Some((stretch, c, 1)),
                }
            }
            r
        });
        Self { stop, task }
    }

    async fn stop(self) -> GateResult {
        self.stop.store(true, Ordering::Relaxed);
        self.task.await.unwrap_or(GateResult {
            violations: vec!["the command-gate watcher ended early".into()],
            readings: 0,
            stretches: 0,
        })
    }
}

impl GateResult {
    fn invariant(&self) -> Invariant {
        Invariant {
            name: "no command reaches the vehicle while the interface is out of COMMAND",
            bound: format!(
                "0 commands counted at the vehicle in a stretch out of COMMAND, past {} ms",
                GATE_GRACE.as_millis()
            ),
            measured: format!(
                "{} stretches out of COMMAND watched ({} readings), {} let a command through",
                self.stretches,
                self.readings,
                self.violations.len()
            ),
            ok: self.violations.is_empty(),
        }
    }
}

/// Reads the vehicle's command count from the gate's task: the emulator's session (behind
/// its lock) or the link's counter.
struct CommandCounter {
    vehicle: Arc<Vehicle>,
    link: Arc<ChaosLink>,
}

impl CommandCounter {
    fn of(run: &FamilyRun) -> Self {
        Self {
            vehicle: run.vehicle.clone(),
            link: run.link.clone(),
        }
    }

    fn read(&self) -> u64 {
        commands(&self.vehicle, &self.link)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_frame_is_one_frame() {
        let chunk = b"junk$A,1*00\r\n$B,2*00\r\n";
        let mut rng = Rng::new(3);
        for _ in 0..50 {
            let f = one_frame(chunk, b"$", &mut rng).unwrap();
            assert!(f == b"$A,1*00\r\n" || f == b"$B,2*00\r\n", "{f:?}");
        }
        assert_eq!(one_frame(b"no start", b"$", &mut rng), None);
    }
}
