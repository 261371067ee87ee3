//! DriverActor: one driver inside a ractor actor, spawned linked under FrontSeatInterface.
//!
//! It turns bus deliveries (what passed the interface's gate) into the driver's operations, the
//! driver's I/O events into handler calls the moment they arrive, and the driver's signals into
//! publications on the interthread driver groups. After every message it compares the driver's
//! state queries with what it last published and publishes a DriverStatus on change, so the
//! interface's state machine is driven by events, not by polling.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use ractor::{Actor, ActorProcessingErr, ActorRef};

use crate::bus::{Bus, Subscription, Undeliverable};
use crate::chaos::{Fault, FaultPort};
use crate::clock::SimClock;
use crate::driver::{
    DirectCommand, Driver, DriverContext, DriverFactory, DriverIoEvent, IoSender, SignalSink,
};
use crate::ports::{DriverActorInbox, DriverActorPorts};
use crate::proto::frontseat::protobuf::DriverStatus;
use crate::proto::goby::middleware::frontseat::protobuf::{
    CommandResponse, FrontSeatState, InterfaceData, Raw,
};
use crate::setpoint_lane::SetpointLane;

pub enum DriverMsg {
    Bus(DriverActorInbox),
    Io(DriverIoEvent),
    Tick,
}

impl DriverMsg {
    fn kind(&self) -> &'static str {
        match self {
            DriverMsg::Bus(m) => m.group(),
            DriverMsg::Io(DriverIoEvent::Line(_)) => "io.line",
            DriverMsg::Io(_) => "io.event",
            DriverMsg::Tick => "tick",
        }
    }
}

pub struct DriverArgs {
    /// Set to the supervisor's clock reading at every handled loop tick: a driver actor stuck in
    /// a handler stops moving it, which the watchdog probe sees.
    pub heartbeat: Arc<AtomicU64>,
    pub factory: DriverFactory,
    pub bus: Bus,
    pub clock: SimClock,
    pub restarts: u32,
    pub queue_capacity: usize,
    /// Only with `[chaos] enabled` (crate::chaos).
    pub faults: Option<FaultPort>,
    /// Where the driver's [`crate::driver::DirectCommand`] is installed while it has one.
    pub lane: SetpointLane,
}

pub struct DriverActor;

pub struct DriverActorState {
    heartbeat: Arc<AtomicU64>,
    driver: Box<dyn Driver>,
    ports: DriverActorPorts,
    clock: SimClock,
    restarts: u32,
    last: Option<(FrontSeatState, bool)>,
    subs: Vec<Subscription>,
    ticker: Option<tokio::task::JoinHandle<()>>,
    faults: Option<FaultPort>,
    /// The links' sender: told of each event handled, so they read on (flow control).
    io: IoSender,
    lane: SetpointLane,
    /// The DirectCommand last installed in the lane (compared by pointer).
    installed: Option<Arc<dyn DirectCommand>>,
}

/// A driver that panics or is killed runs no `post_stop` (ractor skips it then), but its state is
/// dropped: the bus subscriptions go here, or each crash would leave them on the bus — holding
/// the dead actor's cell through their closures — on every group nobody publishes (issue 31's
/// soak creep; `tools/chaos/tests/restart_leak.rs`). After an orderly stop both are empty.
impl Drop for DriverActorState {
    fn drop(&mut self) {
        if let Some(t) = self.ticker.take() {
            t.abort();
        }
        for s in self.subs.drain(..) {
            s.cancel();
        }
        // A crashed driver's connection takes no more courses from the lane.
        self.lane.uninstall(self.restarts);
    }
}

/// The driver's signals as publications, in the order the driver gives them, but for one: the
/// raw copy of what the vehicle sent (raw_from_frontseat) goes out after what the driver decoded
/// from it in the same handling (when the sink is dropped). The interface hands each on to the helm
/// side in that order, and the first hand-over to the helm side's runtime pays for waking one of
/// its threads (half the floor on a small VM): the navigation a helm steers by should not wait
/// behind its raw copy.
struct PortSink<'a> {
    ports: &'a DriverActorPorts,
    raw_in: Vec<Raw>,
}

impl<'a> PortSink<'a> {
    fn new(ports: &'a DriverActorPorts) -> Self {
        Self {
            ports,
            raw_in: Vec::new(),
        }
    }
}

/// The raw copies held back go out when the handling ends — also when the driver panicked in it:
/// the line that crashed a driver is the one an operator most needs to see on raw_in.
impl Drop for PortSink<'_> {
    fn drop(&mut self) {
        for raw in self.raw_in.drain(..) {
            self.ports.publish_raw_from_frontseat(raw);
        }
    }
}

impl SignalSink for PortSink<'_> {
    fn command_response(&mut self, response: CommandResponse) {
        self.ports.publish_command_response(response);
    }
    fn data_from_frontseat(&mut self, data: InterfaceData) {
        self.ports.publish_data_from_frontseat(data);
    }
    fn raw_from_frontseat(&mut self, raw: Raw) {
        self.raw_in.push(raw);
    }
    fn raw_to_frontseat(&mut self, raw: Raw) {
        self.ports.publish_raw_to_frontseat(raw);
    }
    fn extension_from_frontseat(&mut self, ext: crate::driver::DriverExtension) {
        self.ports.publish_extension_from_frontseat(ext);
    }
}

impl DriverActorState {
    /// Installs the driver's DirectCommand in the lane when it changed (connected, lost).
    fn sync_direct(&mut self) {
        let now = self.driver.direct_command();
        let same = match (&now, &self.installed) {
            (Some(a), Some(b)) => Arc::ptr_eq(a, b),
            (None, None) => true,
            _ => false,
        };
        if !same {
            self.lane.install(self.restarts, now.clone(), &self.ports);
            self.installed = now;
        }
    }

    fn publish_status_if_changed(&mut self, force: bool) {
        let now = (
            self.driver.frontseat_state(),
            self.driver.frontseat_providing_data(),
        );
        if force || self.last != Some(now) {
            self.last = Some(now);
            let mut s = DriverStatus {
                providing_data: Some(now.1),
                restarts: Some(self.restarts),
                detail: Some(self.driver.name().to_string()),
                ..Default::default()
            };
            s.set_frontseat_state(now.0);
            self.ports.publish_status(s);
        }
    }
}

impl Actor for DriverActor {
    type Msg = DriverMsg;
    type State = DriverActorState;
    type Arguments = DriverArgs;

    async fn pre_start(
        &self,
        myself: ActorRef<DriverMsg>,
        args: DriverArgs,
    ) -> Result<DriverActorState, ActorProcessingErr> {
        let me = myself.clone();
        let subs = DriverActorInbox::subscribe_all(
            &args.bus,
            "DriverActor",
            args.queue_capacity,
            move |m| me.cast(DriverMsg::Bus(m)).map_err(|_| Undeliverable),
        );
        let mut driver = (args.factory)();
        let me = myself.clone();
        let io = IoSender::bounded(crate::link::MAX_IO_IN_FLIGHT, move |ev| {
            me.cast(DriverMsg::Io(ev)).is_ok()
        });
        driver.start(DriverContext {
            io: io.clone(),
            clock: args.clock,
        });
        let ticker = myself.send_interval(args.clock.wall(Duration::from_millis(100)), || {
            DriverMsg::Tick
        });
        tracing::info!(
            driver = driver.name(),
            restarts = args.restarts,
            "driver started"
        );
        let mut state = DriverActorState {
            heartbeat: args.heartbeat,
            driver,
            ports: DriverActorPorts::new(&args.bus),
            clock: args.clock,
            restarts: args.restarts,
            last: None,
            subs,
            ticker: Some(ticker),
            faults: args.faults,
            io,
            lane: args.lane,
            installed: None,
        };
        state.sync_direct();
        state.publish_status_if_changed(true);
        Ok(state)
    }

    async fn handle(
        &self,
        myself: ActorRef<DriverMsg>,
        msg: DriverMsg,
        state: &mut DriverActorState,
    ) -> Result<(), ActorProcessingErr> {
        let now = state.clock.now();
        let mut sink = PortSink::new(&state.ports);
        let _span = tracing::trace_span!(
            target: "frontseat_actors",
            "actor.handle",
            actor = "DriverActor",
            message = msg.kind(),
        )
        .entered();
        match crate::chaos::take(&state.faults) {
            Some(Fault::Panic) => panic!("chaos: injected driver panic"),
            Some(Fault::Kill) => {
                tracing::warn!("chaos: killing the driver actor");
                myself.kill();
                return Ok(());
            }
            None => {}
        }
        match msg {
            DriverMsg::Bus(inbox) => match inbox {
                DriverActorInbox::CommandRequest(env) => state
                    .driver
                    .send_command_to_frontseat(&env.msg, now, &mut sink),
                DriverActorInbox::DataToFrontseat(env) => state
                    .driver
                    .send_data_to_frontseat(&env.msg, now, &mut sink),
                DriverActorInbox::RawSendRequest(env) => {
                    state.driver.send_raw_to_frontseat(&env.msg, now, &mut sink)
                }
                DriverActorInbox::ExtensionToFrontseat(env) => {
                    state.driver.send_extension(&env.msg, now, &mut sink)
                }
                DriverActorInbox::InterfaceStatus(env) => state.driver.interface_status(&env.msg),
            },
            DriverMsg::Io(ev) => {
                state.driver.handle_io(ev, now, &mut sink);
                state.io.handled();
            }
            DriverMsg::Tick => {
                state.driver.do_loop(now, &mut sink);
                state
                    .heartbeat
                    .store(crate::clock::heartbeat_now(), Ordering::Relaxed);
            }
        }
        drop(sink);
        state.sync_direct();
        state.publish_status_if_changed(false);
        Ok(())
    }

    async fn post_stop(
        &self,
        _myself: ActorRef<DriverMsg>,
        state: &mut DriverActorState,
    ) -> Result<(), ActorProcessingErr> {
        // An orderly stop (its supervisor stopping it, or the interface stopping that supervisor)
        // closes the frontseat connection cleanly; a driver's stop may run twice.
        state.driver.stop();
        state.lane.uninstall(state.restarts);
        state.installed = None;
        if let Some(t) = state.ticker.take() {
            t.abort();
        }
        for s in state.subs.drain(..) {
            s.cancel();
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::groups;
    use std::sync::Mutex;

    /// Which of the two groups each publication went to, in order.
    fn watch(bus: &Bus) -> (Vec<Subscription>, Arc<Mutex<Vec<&'static str>>>) {
        let seen = Arc::new(Mutex::new(Vec::new()));
        let (a, b) = (seen.clone(), seen.clone());
        let subs = vec![
            bus.subscribe(
                &groups::FRONTSEAT_DRIVER_DATA_FROM_FRONTSEAT,
                "t",
                8,
                move |_| {
                    a.lock().unwrap().push("data");
                    Ok(())
                },
            ),
            bus.subscribe(
                &groups::FRONTSEAT_DRIVER_RAW_FROM_FRONTSEAT,
                "t",
                8,
                move |_| {
                    b.lock().unwrap().push("raw");
                    Ok(())
                },
            ),
        ];
        (subs, seen)
    }

    #[test]
    fn a_lines_raw_copy_goes_out_after_what_was_decoded_from_it() {
        let bus = Bus::new();
        let (_subs, seen) = watch(&bus);
        let ports = DriverActorPorts::new(&bus);
        let mut sink = PortSink::new(&ports);
        sink.raw_from_frontseat(Raw::default());
        sink.data_from_frontseat(InterfaceData::default());
        assert_eq!(*seen.lock().unwrap(), ["data"], "the raw copy is held");
        drop(sink);
        assert_eq!(*seen.lock().unwrap(), ["data", "raw"]);
    }

    #[test]
    fn a_driver_that_panics_on_a_line_still_gets_its_raw_copy_out() {
        let bus = Bus::new();
        let (_subs, seen) = watch(&bus);
        let ports = DriverActorPorts::new(&bus);
        let crashed = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            let mut sink = PortSink::new(&ports);
            sink.raw_from_frontseat(Raw::default());
            panic!("a driver bug on this line");
        }));
        assert!(crashed.is_err());
        assert_eq!(*seen.lock().unwrap(), ["raw"]);
    }
}
