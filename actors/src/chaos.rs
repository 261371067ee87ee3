//! The ChaosAgent: the only thing that acts on `frontseat::chaos::fault`. It is started only for
//! a config with `[chaos] enabled = true`; asked to start otherwise it refuses with an error, so a
//! vehicle's config can never be driven into faults by a stray publisher.

use frontseat_config::InterfaceConfig;
use ractor::ActorRef;

use crate::bus::{Bus, Subscription, Undeliverable};
use crate::interface::FsiMsg;
use crate::ports::ChaosAgentInbox;

#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum ChaosError {
    #[error(
        "fault injection refused: this config does not enable it (add `[chaos]` with `enabled = true`; never on a vehicle)"
    )]
    NotEnabled,
}

pub struct ChaosAgent {
    subs: Vec<Subscription>,
}

impl ChaosAgent {
    pub fn start(
        cfg: &InterfaceConfig,
        bus: &Bus,
        interface: ActorRef<FsiMsg>,
    ) -> Result<Self, ChaosError> {
        if !cfg.chaos.enabled {
            return Err(ChaosError::NotEnabled);
        }
        tracing::warn!(
            "chaos enabled: faults published on frontseat::chaos::fault will be injected"
        );
        let subs = ChaosAgentInbox::subscribe_all(bus, "ChaosAgent", 1024, move |m| match m {
            ChaosAgentInbox::Fault(env) => interface
                .cast(FsiMsg::Chaos(*env.msg))
                .map_err(|_| Undeliverable),
        });
        Ok(Self { subs })
    }

    pub fn stop(self) {
        for s in self.subs {
            s.cancel();
        }
    }
}
