//! The run, top to bottom: check the options, start the system, wait for COMMAND, inject the
//! planned faults one after another (each checked for its recovery and, on the helm side, for
//! the vehicle link left alone), let the last one settle, shut everything down, and judge.

pub(crate) mod family;
mod faults;
pub(crate) mod invariants;
mod system;
mod tally;

use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::Duration;

use frontseat_actors::bus::{Bus, Subscription};
use frontseat_actors::chaos::{ChaosError, FaultPort, FaultTarget};
use frontseat_actors::interface::{InterfaceService, ServiceExit};
use frontseat_actors::ports::{ChaosMonkeyPorts, ChaosSimMonkeyPorts};
use frontseat_config::InterfaceConfig;
use tokio::time::Instant;

use self::invariants::End;
use self::system::Run;
use self::tally::Tally;
use crate::monitor::Monitor;
use crate::options::{ChaosHarnessError, ChaosOptions};
use crate::panics::PanicWatch;
use crate::plan::{FaultKind, PlannedFault, Planner};
use crate::report::ChaosReport;
use crate::resources::{Sample, rss_kib};
use crate::world::goby3::Goby;
use crate::world::helm::Helm;
use crate::world::moos::Moos;
use crate::world::sim::Sim;
use crate::world::web;

/// Runs the harness: `config` must enable chaos. `progress` gets a line now and then.
pub async fn run(
    mut config: InterfaceConfig,
    opts: ChaosOptions,
    mut progress: impl FnMut(&str) + Send,
) -> Result<ChaosReport, ChaosHarnessError> {
    let mut notes = check_options(&mut config, &opts)?;
    let panics = PanicWatch::install()?;
    let started = Instant::now();
    let bus = Bus::new();
    let monitor = Monitor::new(config.limits.navigation.clone());
    let monitor_subs = monitor.subscribe(&bus);
    let mut run = start(config, &opts, bus, monitor).await?;
    wait_for_command(&mut run).await?;
    // Warm: this is the baseline the resident set may not grow much beyond.
    let rss_baseline = rss_kib();
    let rss_task = watch_rss(&run.monitor);

    let Injected {
        count,
        last_cleared,
        mut samples,
    } = inject_faults(&mut run, &opts, started, &mut progress).await;
    let (final_recovery, sent) = settle(&mut run, last_cleared).await;

    let snapshot = run.snapshot().await;
    samples.push(Sample::take(started.elapsed(), count, &run.bus));
    rss_task.abort();
    let rss_max = run.monitor.rss_max_kib.load(Ordering::Relaxed);
    let (monitor, warp) = (run.monitor.clone(), run.warp);
    let (exit, tally) = shut_down(run, monitor_subs).await;
    drop(panics);

    let end = End {
        final_recovery,
        sent,
        snapshot,
        exit,
        rss_baseline,
        rss_max,
        samples: &samples,
    };
    let invariants = invariants::table(&tally, &monitor, &opts, &end, &mut notes);
    Ok(ChaosReport {
        seed: opts.seed,
        warp,
        faults: count,
        moos: opts.moos,
        wall: started.elapsed(),
        by_kind: tally.by_kind,
        invariants,
        violations: tally.violations,
        notes: notes.into_iter().chain(tally.notes).collect(),
        samples,
    })
}

/// Refuses a config without chaos and options out of range, and applies the warp. The notes it
/// returns open the report's.
fn check_options(
    config: &mut InterfaceConfig,
    opts: &ChaosOptions,
) -> Result<Vec<String>, ChaosHarnessError> {
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
    Ok(notes)
}

/// Starts, in this order, the simulator (and points the driver at it), the MOOS broker and
/// bridge, gobyd and the Goby3 gateway, the helm, the interface and the web commander.
async fn start(
    mut config: InterfaceConfig,
    opts: &ChaosOptions,
    bus: Bus,
    monitor: Arc<Monitor>,
) -> Result<Run, ChaosHarnessError> {
    let sim = Sim::start(&bus).await?;
    config.driver.basic_simulator.tcp_address = "127.0.0.1".into();
    config.driver.basic_simulator.tcp_port = sim.addr.port();

    // The gate: a fault port refuses unless the config enables chaos (the interface and the
    // driver open theirs themselves, from the same config).
    let translation_faults = FaultPort::open(&config, &bus, FaultTarget::Translation)?;
    let moos = if opts.moos {
        Some(Moos::start(&mut config, &bus, &translation_faults).await?)
    } else {
        config.moos = None;
        None
    };

    let goby = Some(Goby::start(&bus).await?);
    let service = InterfaceService::start(&config, &bus, frontseat_drivers::BUILT_IN).await?;
    // After the interface: a request published before it subscribed would reach nobody and
    // stay unanswered (request 1 did, at some seeds).
    let helm = Helm::start(&bus);
    let web = web::start_commander(&config, &bus).await?;

    let warp = config.sim_warp_factor;
    Ok(Run {
        monkey: ChaosMonkeyPorts::new(&bus),
        sim_monkey: ChaosSimMonkeyPorts::new(&bus),
        config,
        web: Some(web),
        bus,
        service,
        _translation_faults: translation_faults,
        sim,
        moos,
        goby,
        helm,
        monitor,
        warp,
        opts: opts.clone(),
        tally: Tally::default(),
    })
}

/// Waits for the interface's first COMMAND (without it there is no run) and records a MOOS
/// bridge or Goby3 gateway not joined by then.
async fn wait_for_command(run: &mut Run) -> Result<(), ChaosHarnessError> {
    let bound = run.opts.recovery_bound;
    if run
        .monitor
        .until_command(Duration::from_secs(10).max(bound))
        .await
        .is_none()
    {
        return Err(ChaosHarnessError::NoStart(
            Duration::from_secs(10).max(bound),
        ));
    }
    if let Some(m) = &run.moos
        && !m.wait_connected(bound).await
    {
        run.tally
            .violations
            .push("MOOS bridge not connected to the broker at start".into());
    }
    if let Some(g) = &run.goby
        && g.until_joined(0, bound).await.is_none()
    {
        run.tally
            .violations
            .push("Goby3 gateway not joined to gobyd at start".into());
    }
    Ok(())
}

/// Keeps the largest resident set seen in the monitor, every 100 ms, until aborted.
fn watch_rss(monitor: &Arc<Monitor>) -> tokio::task::JoinHandle<()> {
    let m = monitor.clone();
    tokio::spawn(async move {
        loop {
            if let Some(r) = rss_kib() {
                m.rss_max_kib.fetch_max(r, Ordering::Relaxed);
            }
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
    })
}

/// What the faults leave for the end of the run.
struct Injected {
    count: u32,
    /// When the last fault cleared: the final recovery is measured from here.
    last_cleared: Instant,
    samples: Vec<Sample>,
}

/// Injects the planned faults one after another — `opts.faults` of them, or as many as the
/// soak's time allows — each checked once it cleared unless it opens a burst; samples the
/// resources and reports progress between them.
async fn inject_faults(
    run: &mut Run,
    opts: &ChaosOptions,
    started: Instant,
    progress: &mut (impl FnMut(&str) + Send),
) -> Injected {
    let mut planner = Planner::new(
        opts.seed,
        opts.moos,
        run.config.driver.basic_simulator.nav_timeout,
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
        run.tally.by_kind.entry(f.kind).or_default().injected += 1;
        if !f.burst {
            check_recovery(run, i, f, injected_at, cleared).await;
            if let Some(before) = link_before {
                check_vehicle_link(run, i, f, before).await;
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
                run.tally.injected_panics + run.tally.injected_kills,
                run.tally.violations.len()
            ));
        }
    }
    Injected {
        count: i,
        last_cleared,
        samples,
    }
}

/// Waits for COMMAND after fault `i` cleared and records how long the interface was out of it
/// and how long it took back; not back within the bound is a violation.
async fn check_recovery(
    run: &mut Run,
    i: u32,
    f: &PlannedFault,
    injected_at: Instant,
    cleared: Instant,
) {
    let bound = run.opts.recovery_bound;
    recovery(
        &run.monitor,
        &mut run.tally,
        bound,
        i,
        f,
        injected_at,
        cleared,
    )
    .await;
}

/// The recovery check itself, over the monitor and the tally (the vehicle families' run shares
/// it).
async fn recovery(
    monitor: &Monitor,
    tally: &mut Tally,
    bound: Duration,
    i: u32,
    f: &PlannedFault,
    injected_at: Instant,
    cleared: Instant,
) {
    let back = monitor.until_command(bound).await;
    let now = Instant::now();
    let outage = monitor.outage(injected_at, now);
    let st = tally.by_kind.entry(f.kind).or_default();
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
                tally.process_restarts.push(back);
            }
        }
        None => tally.violations.push(format!(
            "fault #{i} ({}): not back in COMMAND within {:?} after it cleared (state {:?})",
            f.kind.name(),
            bound,
            monitor.state()
        )),
    }
}

/// After a helm-side fault: the vehicle link as it was `before` (the simulator's connections,
/// the driver's restarts) — a new connection or a restart is a violation.
async fn check_vehicle_link(
    run: &mut Run,
    i: u32,
    f: &PlannedFault,
    (conns, restarts): (u64, Option<u32>),
) {
    let after = run.sim.handle.stats().connections;
    let restarts_after = run.driver_restarts().await;
    run.tally.vehicle_link_checked += 1;
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
        run.tally.vehicle_link_unknown += 1;
    }
    if new_conns != 0 || restarted {
        run.tally.violations.push(format!(
            "fault #{i} ({}): a helm-side fault touched the vehicle link: {} new frontseat connection(s), driver restarts {restarts:?} -> {restarts_after:?}",
            f.kind.name(),
            new_conns
        ));
    }
}

/// After the last fault: back in COMMAND and staying there — the time from the fault's clearing,
/// or None past the bound. Then the helm stops, and every outstanding request gets its time to
/// be answered. Returns that recovery and how many requests the helm sent.
async fn settle(run: &mut Run, last_cleared: Instant) -> (Option<Duration>, i32) {
    settle_parts(
        &run.monitor,
        &run.helm,
        run.opts.recovery_bound,
        run.warp,
        last_cleared,
    )
    .await
}

/// `settle` over the parts it needs (the vehicle families' run shares it).
async fn settle_parts(
    monitor: &Monitor,
    helm: &Helm,
    bound: Duration,
    warp: f64,
    last_cleared: Instant,
) -> (Option<Duration>, i32) {
    let stable = Duration::from_millis(300);
    let called = Instant::now();
    let final_recovery = monitor
        .until_stable_command(bound, stable)
        .await
        .map(|reached| (called + reached).saturating_duration_since(last_cleared));

    // Stop commanding, then give every outstanding request its 5 s (sim) to be answered. The
    // helm may be past its `commanding` check when it is cleared and publish one more request:
    // so the last id is read again on every look and at the end, never from before the stop
    // (a request sent in that gap was counted as an unknown answer, at seed 9 under load).
    helm.commanding.store(false, Ordering::SeqCst);
    let answer_wait = Duration::from_secs_f64(5.0 / warp) + Duration::from_secs(3);
    let deadline = Instant::now() + answer_wait;
    loop {
        let sent = helm.last_id.load(Ordering::SeqCst);
        let answered = {
            let r = monitor.responses.lock().unwrap_or_else(|p| p.into_inner());
            (1..=sent).all(|id| r.answered(id))
        };
        if answered || Instant::now() >= deadline {
            break;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    // Late duplicates would arrive now.
    tokio::time::sleep(Duration::from_millis(200)).await;
    (final_recovery, helm.last_id.load(Ordering::SeqCst))
}

/// Stops everything: the web commander, the MOOS bridge and broker, the Goby3 gateway and gobyd,
/// the interface, the helm, the simulator, the monitor. What is left is the interface's exit and
/// the tally.
async fn shut_down(mut run: Run, monitor_subs: Vec<Subscription>) -> (ServiceExit, Tally) {
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
    (exit, run.tally)
}

#[cfg(test)]
mod tests {
    use super::*;

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
