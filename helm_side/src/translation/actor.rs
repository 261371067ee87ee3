//! The translation as a supervised actor of the root supervisor: the actor owns one running
//! translation and fails when its data path ends, so a restart reconnects and re-registers; the
//! child spec the supervision tree starts it from; and the observer that follows whichever
//! translation runs now.

use std::sync::Arc;

use frontseat_config::MoosConfig;
use ractor::{Actor, ActorProcessingErr, ActorRef};

use frontseat_actors::bus::Bus;
use frontseat_actors::chaos::FaultPort;
use frontseat_actors::proto::frontseat::protobuf::TranslationStatus;

use super::task::{TranslationCounters, TranslationHandle, TranslationWatch, spawn_with_faults};

/// The watch of whichever translation runs now: its supervisor replaces the translation on a
/// restart, and with it the counters (they start again from zero).
#[derive(Clone, Debug, Default)]
pub struct TranslationObserver(Arc<std::sync::Mutex<Option<TranslationWatch>>>);

impl TranslationObserver {
    fn set(&self, w: TranslationWatch) {
        *self.0.lock().unwrap_or_else(|p| p.into_inner()) = Some(w);
    }
    pub fn current(&self) -> Option<TranslationWatch> {
        self.0.lock().unwrap_or_else(|p| p.into_inner()).clone()
    }
    pub fn status(&self) -> Option<TranslationStatus> {
        self.current().map(|w| w.status())
    }
    pub fn counters(&self) -> Option<TranslationCounters> {
        self.current().map(|w| w.counters())
    }
}

/// The FrontSeatTranslation as a supervised actor of the root supervisor: it owns one running
/// translation (MOOS client, registrations, bus subscriptions, the data-path task). The data path
/// stays a task fed directly by the MOOS client and the bus (no extra hop through a mailbox); the
/// actor watches it, so a panic on the data path fails the actor and its supervisor restarts it,
/// which reconnects and re-registers with the MOOSDB.
pub struct TranslationActor;

#[derive(Clone)]
pub struct TranslationArgs {
    pub cfg: MoosConfig,
    pub vehicle: String,
    pub bus: Bus,
    /// Only with `[chaos] enabled`; survives restarts: a fault panics whichever translation
    /// runs now.
    pub faults: Option<FaultPort>,
    /// Survives restarts: sees the status and counters of whichever translation runs now.
    pub observer: TranslationObserver,
}

pub enum TranslationMsg {
    /// The data-path task ended: `Some(why)` when it panicked or ended on its own.
    TaskEnded(String),
}

pub struct TranslationActorState {
    handle: Option<TranslationHandle>,
}

impl Actor for TranslationActor {
    type Msg = TranslationMsg;
    type State = TranslationActorState;
    type Arguments = TranslationArgs;

    async fn pre_start(
        &self,
        myself: ActorRef<Self::Msg>,
        args: TranslationArgs,
    ) -> Result<Self::State, ActorProcessingErr> {
        let mut handle =
            spawn_with_faults(&args.cfg, &args.vehicle, &args.bus, args.faults).await?;
        args.observer.set(handle.watch());
        if let Some(task) = handle.task.take() {
            tokio::spawn(async move {
                let why = match task.await {
                    Ok(()) => "the translation task ended by itself".to_string(),
                    Err(e) if e.is_panic() => {
                        let p = e.into_panic();
                        p.downcast_ref::<&str>()
                            .map(|s| s.to_string())
                            .or_else(|| p.downcast_ref::<String>().cloned())
                            .unwrap_or_else(|| "panic".into())
                    }
                    Err(e) => e.to_string(),
                };
                // Gone already when the actor itself is stopping: nothing to report then.
                let _ = myself.cast(TranslationMsg::TaskEnded(why));
            });
        }
        Ok(TranslationActorState {
            handle: Some(handle),
        })
    }

    async fn handle(
        &self,
        _myself: ActorRef<Self::Msg>,
        msg: Self::Msg,
        _st: &mut Self::State,
    ) -> Result<(), ActorProcessingErr> {
        match msg {
            TranslationMsg::TaskEnded(why) => {
                Err(format!("FrontSeatTranslation data path ended: {why}").into())
            }
        }
    }

    async fn post_stop(
        &self,
        _myself: ActorRef<Self::Msg>,
        st: &mut Self::State,
    ) -> Result<(), ActorProcessingErr> {
        if let Some(h) = st.handle.take() {
            h.shutdown().await;
        }
        Ok(())
    }
}

/// The supervisor's child spec of the translation.
pub fn child_spec(
    args: TranslationArgs,
    policy: frontseat_actors::supervisor::Policy,
) -> frontseat_actors::supervisor::ChildSpec {
    frontseat_actors::supervisor::ChildSpec {
        name: "FrontSeatTranslation".into(),
        policy,
        about: Default::default(),
        start: Arc::new(move |sup| {
            let args = args.clone();
            Box::pin(async move {
                let (actor, _join) = Actor::spawn_linked(None, TranslationActor, args, sup)
                    .await
                    .map_err(|e| e.to_string())?;
                Ok(actor.get_cell())
            })
        }),
    }
}
