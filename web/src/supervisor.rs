//! Keeps the web hub running: the hub is a linked child of this small supervisor, restarted
//! after a failure (bounded: past `MAX_RESTARTS` within `WINDOW` the web scope gives up and says
//! so, while the interface goes on). A restart drops every tab's stream; the browser's
//! EventSource reconnects by itself and gets a fresh snapshot. The HTTP side reads the current
//! hub through [`HubHandle`].

use std::sync::{Arc, RwLock};
use std::time::{Duration, Instant};

use ractor::{Actor, ActorProcessingErr, ActorRef, SupervisionEvent};

use crate::hub::{Hub, HubArgs, HubMsg};

const MAX_RESTARTS: usize = 5;
const WINDOW: Duration = Duration::from_secs(60);

/// The hub currently running, shared with the HTTP handlers.
#[derive(Clone)]
pub struct HubHandle(Arc<RwLock<Option<ActorRef<HubMsg>>>>);

impl HubHandle {
    pub fn get(&self) -> Option<ActorRef<HubMsg>> {
        self.0.read().unwrap_or_else(|p| p.into_inner()).clone()
    }
    fn set(&self, hub: Option<ActorRef<HubMsg>>) {
        *self.0.write().unwrap_or_else(|p| p.into_inner()) = hub;
    }
}

pub struct WebSupervisor;

pub struct SupArgs {
    pub hub: HubArgs,
    pub handle: HubHandle,
}

pub struct SupState {
    args: HubArgs,
    handle: HubHandle,
    restarts: Vec<Instant>,
}

impl WebSupervisor {
    /// Starts the supervisor and its hub; returns the handle the HTTP side uses.
    pub async fn start(hub: HubArgs) -> Result<(ActorRef<()>, HubHandle), ractor::SpawnErr> {
        let handle = HubHandle(Arc::new(RwLock::new(None)));
        let (sup, _) = Actor::spawn(
            None,
            WebSupervisor,
            SupArgs {
                hub,
                handle: handle.clone(),
            },
        )
        .await?;
        Ok((sup, handle))
    }
}

async fn spawn_hub(
    myself: &ActorRef<()>,
    args: &HubArgs,
) -> Result<ActorRef<HubMsg>, ActorProcessingErr> {
    let (hub, _) = Actor::spawn_linked(None, Hub, args.clone(), myself.get_cell()).await?;
    Ok(hub)
}

impl Actor for WebSupervisor {
    type Msg = ();
    type State = SupState;
    type Arguments = SupArgs;

    async fn pre_start(
        &self,
        myself: ActorRef<()>,
        args: SupArgs,
    ) -> Result<SupState, ActorProcessingErr> {
        let hub = spawn_hub(&myself, &args.hub).await?;
        args.handle.set(Some(hub));
        Ok(SupState {
            args: args.hub,
            handle: args.handle,
            restarts: Vec::new(),
        })
    }

    async fn handle_supervisor_evt(
        &self,
        myself: ActorRef<()>,
        evt: SupervisionEvent,
        st: &mut SupState,
    ) -> Result<(), ActorProcessingErr> {
        let why = match &evt {
            SupervisionEvent::ActorFailed(_, e) => e.to_string(),
            SupervisionEvent::ActorTerminated(_, _, reason) => {
                reason.clone().unwrap_or_else(|| "stopped".into())
            }
            _ => return Ok(()),
        };
        st.handle.set(None);
        let now = Instant::now();
        st.restarts.retain(|t| now.duration_since(*t) < WINDOW);
        if st.restarts.len() >= MAX_RESTARTS {
            tracing::error!(%why, "web hub failed too often; the web scope stops (the interface goes on)");
            myself.stop(Some("hub restart limit".into()));
            return Ok(());
        }
        st.restarts.push(now);
        tracing::error!(%why, restarts = st.restarts.len(), "web hub ended; restarting it");
        let hub = spawn_hub(&myself, &st.args).await?;
        st.handle.set(Some(hub));
        Ok(())
    }

    async fn post_stop(
        &self,
        _myself: ActorRef<()>,
        st: &mut SupState,
    ) -> Result<(), ActorProcessingErr> {
        if let Some(hub) = st.handle.get() {
            hub.stop(None);
        }
        st.handle.set(None);
        Ok(())
    }
}
