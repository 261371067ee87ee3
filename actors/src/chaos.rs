//! Fault ports: how a fault published on `frontseat::chaos::fault` reaches the actor it breaks,
//! without a chaos variant in any production message. Each actor that can be faulted
//! (FrontSeatInterface, DriverActor, FrontSeatTranslation) is declared in
//! `interface_yaml/chaos.yaml` as a subscriber of its own (`InterfaceFaults`, `DriverFaults`,
//! `TranslationFaults`); its [`FaultPort`] is that subscription, and it exists only when the config
//! says `[chaos] enabled = true` — [`FaultPort::open`] refuses otherwise, so a vehicle's config
//! can never be driven into faults by a stray publisher. The port arms a latch; the actor takes it
//! at its next message (every one of them ticks at least every 100 ms) and fails there, in its own
//! handler, as a buggy actor would.

use std::sync::Arc;
use std::sync::atomic::{AtomicU8, Ordering};

use frontseat_config::InterfaceConfig;
use tokio::sync::Notify;

use crate::bus::{Bus, Subscription, Undeliverable};
use crate::ports::{DriverFaultsInbox, InterfaceFaultsInbox, TranslationFaultsInbox};
use crate::proto::frontseat::protobuf::ChaosFault;
use crate::proto::frontseat::protobuf::chaos_fault::Fault as FaultMsg;

#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum ChaosError {
    #[error(
        "fault injection refused: this config does not enable it (add `[chaos]` with `enabled = true`; never on a vehicle)"
    )]
    NotEnabled,
}

/// The actor a fault port belongs to; each takes only its own faults.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FaultTarget {
    Interface,
    Driver,
    Translation,
}

/// What the actor does when it takes the latch.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fault {
    /// Panic in the handler.
    Panic,
    /// End without a panic and without cleanup (the driver only).
    Kill,
}

const NONE: u8 = 0;
const PANIC: u8 = 1;
const KILL: u8 = 2;

struct Latch {
    armed: AtomicU8,
    fired: Notify,
}

/// One actor's fault port. Cheap to clone (a clone shares the latch: the translation's survives
/// its restarts). Dropping every clone closes the port: the subscription is removed at the next
/// fault published.
#[derive(Clone)]
pub struct FaultPort {
    latch: Arc<Latch>,
    _subs: Arc<Vec<Subscription>>,
}

/// The last holder of a port takes its subscriptions off the bus: an actor that panics or is
/// killed drops its state without a `post_stop`, and a restart opens a new port, so leaving them
/// would add one subscription per fault (the leak `tools/chaos/tests/restart_leak.rs` counts).
impl Drop for FaultPort {
    fn drop(&mut self) {
        if let Some(subs) = Arc::get_mut(&mut self._subs) {
            for s in subs.drain(..) {
                s.cancel();
            }
        }
    }
}

impl std::fmt::Debug for FaultPort {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("FaultPort")
    }
}

impl FaultPort {
    /// Subscribes `target`'s port, or refuses when `cfg` does not enable chaos.
    pub fn open(cfg: &InterfaceConfig, bus: &Bus, target: FaultTarget) -> Result<Self, ChaosError> {
        Self::open_if(cfg.chaos.enabled, bus, target).ok_or(ChaosError::NotEnabled)
    }

    /// [`FaultPort::open`] for an actor that keeps only the `[chaos] enabled` flag of its config.
    pub(crate) fn open_if(enabled: bool, bus: &Bus, target: FaultTarget) -> Option<Self> {
        if !enabled {
            return None;
        }
        let latch = Arc::new(Latch {
            armed: AtomicU8::new(NONE),
            fired: Notify::new(),
        });
        let weak = Arc::downgrade(&latch);
        let arm = move |fault: &ChaosFault, wanted: fn(&FaultMsg) -> u8| {
            let latch = weak.upgrade().ok_or(Undeliverable)?;
            let what = fault.fault.as_ref().map_or(NONE, wanted);
            if what != NONE {
                tracing::warn!(?target, fault = ?fault.fault, "chaos: fault armed");
                latch.armed.store(what, Ordering::Release);
                latch.fired.notify_one();
            }
            Ok(())
        };
        let subs = match target {
            FaultTarget::Interface => {
                InterfaceFaultsInbox::subscribe_all(bus, "InterfaceFaults", 64, move |m| {
                    let InterfaceFaultsInbox::Fault(env) = m;
                    arm(&env.msg, |f| match f {
                        FaultMsg::InterfacePanic(_) => PANIC,
                        _ => NONE,
                    })
                })
            }
            FaultTarget::Driver => {
                DriverFaultsInbox::subscribe_all(bus, "DriverFaults", 64, move |m| {
                    let DriverFaultsInbox::Fault(env) = m;
                    arm(&env.msg, |f| match f {
                        FaultMsg::DriverPanic(_) => PANIC,
                        FaultMsg::KillDriver(_) => KILL,
                        _ => NONE,
                    })
                })
            }
            FaultTarget::Translation => {
                TranslationFaultsInbox::subscribe_all(bus, "TranslationFaults", 64, move |m| {
                    let TranslationFaultsInbox::Fault(env) = m;
                    arm(&env.msg, |f| match f {
                        FaultMsg::TranslationPanic(_) => PANIC,
                        _ => NONE,
                    })
                })
            }
        };
        Some(Self {
            latch,
            _subs: Arc::new(subs),
        })
    }

    /// The armed fault, once: the actor calls this at the top of its handler.
    pub fn take(&self) -> Option<Fault> {
        match self.latch.armed.swap(NONE, Ordering::AcqRel) {
            PANIC => Some(Fault::Panic),
            KILL => Some(Fault::Kill),
            _ => None,
        }
    }

    /// Resolves with the next fault armed (for a task that waits in a `select!`).
    pub async fn fired(&self) -> Fault {
        loop {
            let notified = self.latch.fired.notified();
            if let Some(f) = self.take() {
                return f;
            }
            notified.await;
        }
    }
}

/// [`FaultPort::take`] on an optional port.
pub fn take(port: &Option<FaultPort>) -> Option<Fault> {
    port.as_ref().and_then(FaultPort::take)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::groups::FRONTSEAT_CHAOS_FAULT;

    fn fault(f: FaultMsg) -> ChaosFault {
        ChaosFault { fault: Some(f) }
    }

    #[test]
    fn a_config_without_chaos_gets_no_port_and_a_fault_reaches_nothing() {
        let bus = Bus::new();
        let cfg = InterfaceConfig::default();
        assert!(!cfg.chaos.enabled);
        for target in [
            FaultTarget::Interface,
            FaultTarget::Driver,
            FaultTarget::Translation,
        ] {
            assert_eq!(
                FaultPort::open(&cfg, &bus, target).err(),
                Some(ChaosError::NotEnabled)
            );
        }
        let r = bus.publish(&FRONTSEAT_CHAOS_FAULT, fault(FaultMsg::DriverPanic(true)));
        assert_eq!(r.delivered, 0);
    }

    #[test]
    fn each_port_takes_only_its_own_faults_once() {
        let bus = Bus::new();
        let mut cfg = InterfaceConfig::default();
        cfg.chaos.enabled = true;
        let iface = FaultPort::open(&cfg, &bus, FaultTarget::Interface).unwrap();
        let driver = FaultPort::open(&cfg, &bus, FaultTarget::Driver).unwrap();
        let translation = FaultPort::open(&cfg, &bus, FaultTarget::Translation).unwrap();
        bus.publish(&FRONTSEAT_CHAOS_FAULT, fault(FaultMsg::KillDriver(true)));
        assert_eq!(iface.take(), None);
        assert_eq!(translation.take(), None);
        assert_eq!(driver.take(), Some(Fault::Kill));
        assert_eq!(driver.take(), None, "a fault fires once");
        bus.publish(&FRONTSEAT_CHAOS_FAULT, fault(FaultMsg::DriverPanic(true)));
        assert_eq!(driver.take(), Some(Fault::Panic));
        bus.publish(
            &FRONTSEAT_CHAOS_FAULT,
            fault(FaultMsg::InterfacePanic(true)),
        );
        assert_eq!(iface.take(), Some(Fault::Panic));
        bus.publish(
            &FRONTSEAT_CHAOS_FAULT,
            fault(FaultMsg::TranslationPanic(true)),
        );
        assert_eq!(translation.take(), Some(Fault::Panic));
    }

    #[tokio::test]
    async fn a_closed_port_unsubscribes_and_fired_wakes_a_waiting_task() {
        let bus = Bus::new();
        let mut cfg = InterfaceConfig::default();
        cfg.chaos.enabled = true;
        let port = FaultPort::open(&cfg, &bus, FaultTarget::Translation).unwrap();
        let waiter = {
            let port = port.clone();
            tokio::spawn(async move { port.fired().await })
        };
        tokio::task::yield_now().await;
        bus.publish(
            &FRONTSEAT_CHAOS_FAULT,
            fault(FaultMsg::TranslationPanic(true)),
        );
        let got = tokio::time::timeout(std::time::Duration::from_secs(5), waiter)
            .await
            .expect("woken within the bound")
            .unwrap();
        assert_eq!(got, Fault::Panic);
        drop(port);
        // The first publish after the port closed finds its receiver gone and removes it.
        bus.publish(
            &FRONTSEAT_CHAOS_FAULT,
            fault(FaultMsg::TranslationPanic(true)),
        );
        assert_eq!(
            bus.publish(
                &FRONTSEAT_CHAOS_FAULT,
                fault(FaultMsg::TranslationPanic(true))
            )
            .delivered,
            0
        );
    }
}
