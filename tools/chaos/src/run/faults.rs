//! Each fault, injected: what it does to the system, how long it is held, and when it counts
//! as cleared; a fault that must prove something on its own (a bridge back, a link untouched,
//! nothing hostile through) records its measurements and violations on the run.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use frontseat_actors::bus::Undeliverable;
use frontseat_actors::interface::InterfaceService;
use frontseat_actors::ports::ChaosStalledInbox;
use frontseat_actors::proto::frontseat::protobuf::{ChaosFault, chaos_fault, sim_fault};
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{HelmState, InterfaceState};
use frontseat_helm_side::goby3::standin::{StandinGobyd, StandinTransport};
use frontseat_moos::Broker;
use tokio::time::Instant;

use super::system::Run;
use super::tally::Tally;
use crate::plan::{FaultKind, PlannedFault};
use crate::world::rebind::rebind;
use crate::world::web::{WEB_FLOODERS, web_exchange, web_flood_request};
use frontseat_actors::ports::ChaosMonkeyPorts;

/// systemd's RestartSec in the service-manager model.
const SERVICE_RESTART_SEC: Duration = Duration::from_millis(100);

impl Run {
    /// A simulator fault that ends the connection: injected, then the interface leaves command
    /// and the driver reconnects; the injection is the moment.
    async fn connection_ending(&mut self, fault: sim_fault::Fault, f: &PlannedFault) -> Instant {
        let t = Instant::now();
        let before = self.connections();
        self.sim_fault(fault);
        self.monitor.until_left_command(f.hold).await;
        self.until_reconnected(before).await;
        t
    }

    /// Injects `f` and returns when it cleared: for a one-shot fault (a crash, a dropped
    /// connection, bad lines) the moment it happened — the hold is then only a window for the
    /// interface to notice; for a held fault (CTRL AUV, PARK, a stopped simulator or broker, a
    /// stall, NAV stopped) the moment it was lifted.
    pub(super) async fn inject(&mut self, i: u32, f: &PlannedFault) -> Instant {
        let one_shot = |t: Instant| t;
        match f.kind {
            FaultKind::DriverPanic | FaultKind::DriverKill => {
                // driver_crash returns once the new driver is up; the crash itself is the moment.
                let t = Instant::now();
                self.driver_crash(i, f.kind).await;
                one_shot(t)
            }
            FaultKind::DropConnection => {
                self.connection_ending(sim_fault::Fault::DropConnection(true), f)
                    .await
            }
            FaultKind::Garbage => {
                let t = Instant::now();
                self.sim_fault(sim_fault::Fault::GarbageLines(f.amount as u32));
                self.monitor.until_left_command(f.hold).await;
                one_shot(t)
            }
            FaultKind::Oversized => {
                self.connection_ending(sim_fault::Fault::OversizedLine(true), f)
                    .await
            }
            FaultKind::CtrlPayload => {
                let t = Instant::now();
                self.ctrl(sim_fault::Ctrl::Payload);
                self.monitor.until_left_command(f.hold).await;
                one_shot(t)
            }
            FaultKind::SimRestart => {
                if let Err(e) = self.sim.restart(&self.bus, f.hold).await {
                    self.tally
                        .violations
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
            // The vehicle families' faults: never planned for the basic simulator (`Planner::new`
            // draws from `FaultKind::ALL` only).
            FaultKind::LinkDrop
            | FaultKind::LinkGarbage
            | FaultKind::TruncatedFrame
            | FaultKind::SilentVehicle
            | FaultKind::SlowLink
            | FaultKind::VehicleRefuses
            | FaultKind::VehicleModeChange => {
                self.tally.notes.push(format!(
                    "fault #{i}: {} needs --vehicle <family>; skipped",
                    f.kind.name()
                ));
                Instant::now()
            }
        }
    }

    async fn driver_crash(&mut self, i: u32, kind: FaultKind) {
        driver_crash(
            &self.service,
            &self.monkey,
            &mut self.tally,
            self.opts.recovery_bound,
            i,
            kind,
        )
        .await;
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
                self.tally.violations.push(format!(
                    "fault #{i} (gobyd gone): the stand-in gobyd could not bind its port again: {e}"
                ));
                return;
            }
        }
        match g.until_joined(before.connects, bound).await {
            Some(d) => {
                self.tally.goby_returns.push(d);
                if lost {
                    self.tally.goby_losses_seen += 1;
                }
            }
            None => self.tally.violations.push(format!(
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
        self.tally.web_flood_requests += sent.load(Ordering::Relaxed);
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
            self.tally.web_floods_left_command += 1;
            if self.tally.web_floods_left_command <= 5 {
                self.tally.notes.push(format!(
                    "fault #{i} (web flood): the interface went through {states:?} (the link stayed; at a high warp NAV gaps of a loaded machine pass nav_timeout)"
                ));
            }
        }
        let after = self.sim.handle.stats().cmd_errors;
        if after != cmd_errors {
            self.tally.violations.push(format!(
                "fault #{i} (web flood): {} CMDs the simulator refused reached it during the flood",
                after - cmd_errors
            ));
        }
        if answered.load(Ordering::Relaxed) == 0 {
            self.tally.violations.push(format!(
                "fault #{i} (web flood): the web server answered none of {} requests",
                sent.load(Ordering::Relaxed)
            ));
        }
    }

    /// The MOOSDB crash-loops: up for a moment, killed, down a moment, again, for the whole
    /// fault; then it stays up and the bridge must reconnect within the bound. The interface
    /// must not leave COMMAND (its helm is on the bus) and its frontseat link must not move.
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
                    self.tally.violations.push(format!(
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
                self.tally.moos_reconnects.push(t0.elapsed());
                break;
            }
            if t0.elapsed() >= bound {
                self.tally.violations.push(format!(
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
                    self.tally.lost_to_restart.insert(id);
                }
            }
        }
        self.monkey.publish_fault(ChaosFault {
            fault: Some(chaos_fault::Fault::InterfacePanic(true)),
        });
        let exit = tokio::time::timeout(bound, self.service.wait()).await;
        let ended = Instant::now();
        if exit.is_err() {
            self.tally.violations.push(format!(
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
            Err(e) => self.tally.violations.push(format!(
                "fault #{i} (process restart): the service could not be started again: {e}"
            )),
        }
        self.tally.crash_base = self.tally.injected_panics + self.tally.injected_kills;
        let sent_after = self.helm.last_id.load(Ordering::SeqCst);
        self.tally
            .lost_to_restart
            .extend(sent_before + 1..=sent_after);
        ended
    }

    async fn stall(&mut self, i: u32, hold: Duration) {
        stall(
            &self.bus,
            &self.monitor,
            &mut self.tally,
            self.opts.recovery_bound,
            i,
            hold,
        )
        .await;
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
                self.tally.translation_restarts.push(t0.elapsed());
                break;
            }
            if Instant::now() >= deadline {
                self.tally.violations.push(format!(
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
                self.tally.violations.push(format!(
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
                self.tally.violations.push(format!(
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
            self.tally.violations.push(format!(
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
                self.tally.violations.push(format!(
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
                self.tally.moos_reconnects.push(t0.elapsed());
                break;
            }
            if Instant::now() >= deadline {
                self.tally.violations.push(format!(
                    "fault #{i} (MOOS restart): bridge not reconnected within {bound:?}"
                ));
                break;
            }
            tokio::time::sleep(Duration::from_millis(5)).await;
        }
    }
}

/// Crashes the driver (a panic in its handler, or the actor killed) once it is up with the
/// restarts injected so far, and waits for its restart: the basic simulator's run and the vehicle
/// families' share it.
pub(super) async fn driver_crash(
    service: &InterfaceService,
    monkey: &ChaosMonkeyPorts,
    tally: &mut Tally,
    bound: Duration,
    i: u32,
    kind: FaultKind,
) {
    let expected = (tally.injected_panics + tally.injected_kills - tally.crash_base) as u32;
    if !driver_up(service, bound, expected).await {
        tally.violations.push(format!(
            "fault #{i} ({}): driver not up with {expected} restarts within {bound:?} before injecting",
            kind.name(),
        ));
        return;
    }
    let fault = if kind == FaultKind::DriverPanic {
        tally.injected_panics += 1;
        chaos_fault::Fault::DriverPanic(true)
    } else {
        tally.injected_kills += 1;
        chaos_fault::Fault::KillDriver(true)
    };
    let t0 = Instant::now();
    monkey.publish_fault(ChaosFault { fault: Some(fault) });
    if driver_up(service, bound, expected + 1).await {
        tally.restart_waits.push(t0.elapsed());
    } else {
        tally.violations.push(format!(
            "fault #{i} ({}): driver not restarted within {bound:?}",
            kind.name(),
        ));
    }
}

/// Waits until the driver actor is up with `restarts` restarts behind it.
pub(super) async fn driver_up(service: &InterfaceService, bound: Duration, restarts: u32) -> bool {
    let deadline = Instant::now() + bound;
    while Instant::now() < deadline {
        match service.snapshot(Duration::from_secs(2)).await {
            Some(s) if s.driver_up && s.driver_restarts >= restarts => return true,
            Some(_) => tokio::time::sleep(Duration::from_millis(2)).await,
            None => return false,
        }
    }
    false
}

/// A subscriber to raw_in and node_status that never reads. The publishers (driver,
/// interface) must not block: node_status keeps reaching the monitor, and the stalled
/// queue's overflow is dropped and counted.
pub(super) async fn stall(
    bus: &frontseat_actors::bus::Bus,
    monitor: &crate::monitor::Monitor,
    tally: &mut Tally,
    bound: Duration,
    i: u32,
    hold: Duration,
) {
    if monitor.until_command(bound).await.is_none() {
        tally.violations.push(format!(
            "fault #{i} (stalled subscriber): not in COMMAND within {:?} before the stall",
            bound
        ));
    }
    // Never read: every delivery keeps its slot until the stall ends.
    let (tx, rx) = tokio::sync::mpsc::unbounded_channel();
    let stalled = ChaosStalledInbox::subscribe_all(bus, "chaos-stalled", 8, move |m| {
        tx.send(m).map_err(|_| Undeliverable)
    });
    let before_drops = bus.total_dropped();
    let before = monitor.node_status.load(Ordering::Relaxed);
    tokio::time::sleep(hold).await;
    let delivered = monitor.node_status.load(Ordering::Relaxed) - before;
    let dropped = bus.total_dropped() - before_drops;
    for s in stalled {
        s.cancel();
    }
    drop(rx);
    tally.stall_deliveries.push(delivered);
    tally.stall_drops += dropped;
    if delivered == 0 {
        tally.violations.push(format!(
            "fault #{i} (stalled subscriber): no node_status reached other subscribers during a {hold:?} stall"
        ));
    }
}
