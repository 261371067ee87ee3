//! The soak's RSS creep, pinned down as counts: a DriverActor that panics or is killed runs no
//! `post_stop` (ractor skips it then), so the bus subscriptions it made in `pre_start` stayed on
//! the bus — and with them, through their delivery closures, the dead actor's cell. A group
//! that is published keeps its list clean (a gone receiver is removed at the next publish), but
//! the driver also subscribes to groups nobody publishes in a run (raw sends, the Bluefin, Iver
//! and ArduPilot commands): there, one subscription per crash piled up for ever.
//!
//! Real simulator on loopback, real interface and driver, faults through the fault group (the
//! actors' fault ports, opened because the chaos config enables them; a dropped port cancels its
//! subscription too, so it is counted here as well). After
//! N crashes the number of subscriptions on the bus is back to what it was before the first.

use std::time::Duration;

use frontseat_actors::bus::Bus;
use frontseat_actors::interface::InterfaceService;
use frontseat_actors::ports::ChaosMonkeyPorts;
use frontseat_actors::proto::frontseat::protobuf::{ChaosFault, chaos_fault};
use frontseat_sim::{SimOptions, SimServer};
use tokio::time::Instant;

/// Waits (bounded) until the driver is up with at least `restarts` restarts behind it.
async fn driver_up(service: &InterfaceService, restarts: u32) {
    let deadline = Instant::now() + Duration::from_secs(10);
    loop {
        if let Some(s) = service.snapshot(Duration::from_secs(2)).await
            && s.driver_up
            && s.driver_restarts >= restarts
        {
            return;
        }
        assert!(
            Instant::now() < deadline,
            "driver not up with {restarts} restarts within 10 s"
        );
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
}

/// Subscriptions per (group, subscriber) on the bus, for a readable failure.
fn subscriptions(bus: &Bus) -> Vec<(String, usize)> {
    let mut v: Vec<(String, usize)> = Vec::new();
    for s in bus.stats() {
        let key = format!("{} / {}", s.group, s.subscriber);
        match v.iter_mut().find(|(k, _)| *k == key) {
            Some((_, n)) => *n += 1,
            None => v.push((key, 1)),
        }
    }
    v
}

/// The real simulator on loopback, the interface on the embedded chaos config (fault ports
/// open), and the driver up.
struct Stack {
    sim: frontseat_sim::SimHandle,
    bus: Bus,
    service: InterfaceService,
    monkey: ChaosMonkeyPorts,
}

impl Stack {
    async fn start() -> Self {
        let sim = SimServer::bind(([127, 0, 0, 1], 0).into(), SimOptions::default())
            .await
            .unwrap();
        let mut cfg = frontseat_chaos::default_config().unwrap();
        cfg.driver.basic_simulator.tcp_address = "127.0.0.1".into();
        cfg.driver.basic_simulator.tcp_port = sim.local_addr().port();
        let bus = Bus::new();
        let service = InterfaceService::start(&cfg, &bus, frontseat_drivers::BUILT_IN)
            .await
            .unwrap();
        let monkey = ChaosMonkeyPorts::new(&bus);
        driver_up(&service, 0).await;
        Self {
            sim,
            bus,
            service,
            monkey,
        }
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn driver_crashes_leave_no_subscription_behind() {
    let Stack {
        sim,
        bus,
        service,
        monkey,
    } = Stack::start().await;
    let before = subscriptions(&bus);

    const CRASHES: u32 = 12;
    for n in 0..CRASHES {
        // Both ways a driver ends without post_stop: a panic in its handler and a kill.
        let fault = if n % 2 == 0 {
            chaos_fault::Fault::DriverPanic(true)
        } else {
            chaos_fault::Fault::KillDriver(true)
        };
        monkey.publish_fault(ChaosFault { fault: Some(fault) });
        driver_up(&service, n + 1).await;
    }
    let after = subscriptions(&bus);
    assert_eq!(
        after, before,
        "subscriptions per group and subscriber after {CRASHES} driver crashes (left) vs before (right)"
    );

    service.shutdown(Duration::from_secs(5)).await;
    sim.shutdown().await;
}

/// The interface itself panicking (its vehicle side failing: in `frontseat interface` a
/// supervisor restarts it in the same process) runs no cleanup either: its subscriptions must
/// still leave the bus with it.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_interface_panic_leaves_no_subscription_behind() {
    let Stack {
        sim,
        bus,
        mut service,
        monkey,
    } = Stack::start().await;
    let interface_subs = |bus: &Bus| {
        bus.stats()
            .iter()
            .filter(|s| s.subscriber == "FrontSeatInterface")
            .count()
    };
    assert!(interface_subs(&bus) > 0, "{:?}", subscriptions(&bus));

    monkey.publish_fault(ChaosFault {
        fault: Some(chaos_fault::Fault::InterfacePanic(true)),
    });
    tokio::time::timeout(Duration::from_secs(10), service.wait())
        .await
        .expect("the interface ends after its panic");
    assert_eq!(
        interface_subs(&bus),
        0,
        "the panicked interface's subscriptions are still on the bus: {:?}",
        subscriptions(&bus)
    );

    service.shutdown(Duration::from_secs(5)).await;
    sim.shutdown().await;
}
