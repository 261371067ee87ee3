//! Keeps the web hub running: the hub is the one child of a supervisor of the runtime's own kind
//! (`frontseat_actors::supervisor`), restarted however it ends (a failure or a kill), at most
//! `HUB_MAX_RESTARTS` within a minute; past that the hub supervisor gives up, the web scope
//! reports it as failed and the root supervisor applies `[supervision.web]` to the whole scope.
//! A restart drops every tab's stream; the browser's EventSource reconnects by itself and gets
//! a fresh snapshot. The HTTP side reads the current hub through [`HubHandle`].

use std::sync::{Arc, RwLock};
use std::time::Duration;

use frontseat_actors::supervisor::{Node, Policy, Side, SupervisorHandle};
use frontseat_config::RestartPolicy;
use ractor::{Actor, ActorRef, ActorStatus};

use crate::hub::{Hub, HubArgs, HubMsg};

const HUB_MAX_RESTARTS: u32 = 5;

/// The hub currently running, shared with the HTTP handlers.
#[derive(Clone)]
pub struct HubHandle(Arc<RwLock<Option<ActorRef<HubMsg>>>>);

impl HubHandle {
    /// The running hub; `None` between a hub's end and its restart.
    pub fn get(&self) -> Option<ActorRef<HubMsg>> {
        self.0
            .read()
            .unwrap_or_else(|p| p.into_inner())
            .clone()
            .filter(|h| h.get_status() == ActorStatus::Running)
    }
    fn set(&self, hub: Option<ActorRef<HubMsg>>) {
        *self.0.write().unwrap_or_else(|p| p.into_inner()) = hub;
    }
}

fn hub_policy() -> Policy {
    // Bounded on purpose: past it the WebScope fails, and the root restarts the scope, without
    // end (the web is on the helm side).
    Policy {
        side: Side::Vehicle,
        restart: RestartPolicy::Always,
        max_restarts: HUB_MAX_RESTARTS,
        window: Duration::from_secs(60),
        backoff_initial: Duration::from_millis(10),
        backoff_max: Duration::from_millis(1000),
    }
}

/// The hub as its supervisor starts it and the tree `frontseat interfaces` prints shows it.
pub fn hub_node() -> Node {
    Node::new(
        "WebHub",
        hub_policy(),
        "restarted however it ends; past the limit the scope fails and the root restarts the scope",
    )
}

/// Starts the hub under its supervisor; returns the supervisor and the handle the HTTP side uses.
pub async fn start(hub: HubArgs) -> Result<(SupervisorHandle, HubHandle), String> {
    let handle = HubHandle(Arc::new(RwLock::new(None)));
    let current = handle.clone();
    let spec = hub_node().spec(Arc::new(move |sup| {
        let args = hub.clone();
        let current = current.clone();
        Box::pin(async move {
            let (h, _) = Actor::spawn_linked(None, Hub, args, sup)
                .await
                .map_err(|e| e.to_string())?;
            current.set(Some(h.clone()));
            Ok(h.get_cell())
        })
    }));
    let sup = SupervisorHandle::start("web", vec![spec], None).await?;
    Ok((sup, handle))
}
