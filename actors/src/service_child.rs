//! Supervising a running service that is not itself one actor: the FrontSeatInterface (an actor
//! with its DriverActor), the Zenoh and Goby3 gateways, the web scope and the simulator server are
//! each a [`Service`] — something that started, can end by itself, and can be stopped in order.
//! [`service_child`] makes one a child of a [`Supervisor`](crate::supervisor::Supervisor): a thin
//! actor owns it and fails when it fails (a panic on one of its tasks included), so the
//! supervisor restarts it by its policy. The service's data paths stay its own tasks; nothing on
//! them goes through this actor's mailbox.

use std::future::Future;
use std::pin::Pin;
use std::sync::Arc;
use std::time::Duration;

use ractor::{Actor, ActorProcessingErr, ActorRef};
use tokio::sync::oneshot;

use crate::interface::{InterfaceService, ServiceExit};
use crate::supervisor::{CHILD_STOP_BOUND, ChildFailure, ChildSpec, Policy};

pub type BoxFuture<'a, T> = Pin<Box<dyn Future<Output = T> + Send + 'a>>;

/// A running part of a process that a supervisor can watch and stop.
pub trait Service: Send + 'static {
    /// Resolves when the service ended by itself: `Ok` for an orderly end, `Err` for a failure.
    fn ended(&mut self) -> BoxFuture<'_, Result<(), ChildFailure>>;
    /// An orderly stop, within `within`.
    fn stop(self: Box<Self>, within: Duration) -> BoxFuture<'static, ()>;
}

/// Starts the service afresh (the first start and every restart).
pub type StartService =
    Arc<dyn Fn() -> BoxFuture<'static, Result<Box<dyn Service>, String>> + Send + Sync>;

/// The child spec that runs `start`'s service under a supervisor.
pub fn service_child(name: &str, policy: Policy, start: StartService) -> ChildSpec {
    let child_name = name.to_string();
    ChildSpec {
        name: name.to_string(),
        policy,
        about: Default::default(),
        start: Arc::new(move |sup| {
            let args = ServiceArgs {
                name: child_name.clone(),
                start: start.clone(),
            };
            Box::pin(async move {
                let (actor, _join) = Actor::spawn_linked(None, ServiceActor, args, sup)
                    .await
                    .map_err(|e| e.to_string())?;
                Ok(actor.get_cell())
            })
        }),
    }
}

/// [`service_child`] from a context cloned for every start and an async start function, so
/// that callers do not repeat the clone-into-the-closure dance.
pub fn service_child_with<C, F, Fut>(name: &str, policy: Policy, ctx: C, start: F) -> ChildSpec
where
    C: Clone + Send + Sync + 'static,
    F: Fn(C) -> Fut + Send + Sync + 'static,
    Fut: Future<Output = Result<Box<dyn Service>, String>> + Send + 'static,
{
    let start = Arc::new(start);
    service_child(
        name,
        policy,
        Arc::new(move || {
            let fut = start(ctx.clone());
            Box::pin(fut)
        }),
    )
}

pub struct ServiceActor;

pub struct ServiceArgs {
    name: String,
    start: StartService,
}

pub enum ServiceMsg {
    Ended(Result<(), ChildFailure>),
}

pub struct ServiceState {
    stop: Option<oneshot::Sender<()>>,
    watcher: Option<tokio::task::JoinHandle<()>>,
}

impl Actor for ServiceActor {
    type Msg = ServiceMsg;
    type State = ServiceState;
    type Arguments = ServiceArgs;

    async fn pre_start(
        &self,
        myself: ActorRef<ServiceMsg>,
        args: ServiceArgs,
    ) -> Result<ServiceState, ActorProcessingErr> {
        let mut svc = (args.start)()
            .await
            .map_err(|e| format!("{}: {e}", args.name))?;
        let (stop_tx, stop_rx) = oneshot::channel::<()>();
        // The owner task: waits for the service to end or to be told to stop, and stops it
        // either way so that nothing of it outlives this actor.
        let owner = tokio::spawn(async move {
            let outcome = tokio::select! {
                r = svc.ended() => Some(r),
                _ = stop_rx => None,
            };
            svc.stop(CHILD_STOP_BOUND).await;
            outcome
        });
        let name = args.name;
        let watcher = tokio::spawn(async move {
            let outcome = match owner.await {
                Ok(o) => o,
                Err(e) => Some(Err(ChildFailure::from_join(&name, e))),
            };
            if let Some(r) = outcome {
                // Gone already when the actor itself is stopping: nothing to report then.
                let _ = myself.cast(ServiceMsg::Ended(r));
            }
        });
        Ok(ServiceState {
            stop: Some(stop_tx),
            watcher: Some(watcher),
        })
    }

    async fn handle(
        &self,
        myself: ActorRef<ServiceMsg>,
        msg: ServiceMsg,
        _st: &mut ServiceState,
    ) -> Result<(), ActorProcessingErr> {
        match msg {
            ServiceMsg::Ended(Ok(())) => {
                myself.stop(Some("ended by itself".into()));
                Ok(())
            }
            ServiceMsg::Ended(Err(f)) => Err(Box::new(f)),
        }
    }

    async fn post_stop(
        &self,
        _myself: ActorRef<ServiceMsg>,
        st: &mut ServiceState,
    ) -> Result<(), ActorProcessingErr> {
        if let Some(stop) = st.stop.take() {
            let _ = stop.send(());
        }
        if let Some(w) = st.watcher.take() {
            let _ = tokio::time::timeout(CHILD_STOP_BOUND + Duration::from_millis(500), w).await;
        }
        Ok(())
    }
}

/// The FrontSeatInterface (with its DriverActor) as a supervised service. An error state, the
/// driver's exhausted restart limit and the interface actor's failure end it with their exit.
impl Service for InterfaceService {
    fn ended(&mut self) -> BoxFuture<'_, Result<(), ChildFailure>> {
        Box::pin(async move {
            match self.wait().await {
                ServiceExit::Clean => Ok(()),
                other => Err(ChildFailure {
                    why: format!("FrontSeatInterface ended: {other:?}"),
                    exit: Some(other),
                }),
            }
        })
    }

    fn stop(self: Box<Self>, within: Duration) -> BoxFuture<'static, ()> {
        Box::pin(async move {
            let _ = (*self).shutdown(within).await;
        })
    }
}

/// The goby_coroner responder: it ends by itself only when its task failed.
impl Service for crate::health::HealthReporter {
    fn ended(&mut self) -> BoxFuture<'_, Result<(), ChildFailure>> {
        Box::pin(async move {
            Err(ChildFailure::new(
                crate::health::HealthReporter::ended(self).await,
            ))
        })
    }
    fn stop(self: Box<Self>, _within: Duration) -> BoxFuture<'static, ()> {
        Box::pin(async move { drop(self) })
    }
}

/// The basic simulator's server: it ends by itself only when its accept task failed.
impl Service for frontseat_sim::SimHandle {
    fn ended(&mut self) -> BoxFuture<'_, Result<(), ChildFailure>> {
        Box::pin(async move {
            match frontseat_sim::SimHandle::ended(self).await {
                None => Ok(()),
                Some(why) => Err(ChildFailure::new(format!("simulator server: {why}"))),
            }
        })
    }

    fn stop(self: Box<Self>, _within: Duration) -> BoxFuture<'static, ()> {
        Box::pin(async move { self.shutdown().await })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::supervisor::SupervisorHandle;
    use frontseat_config::RestartPolicy;
    use std::sync::atomic::{AtomicU32, Ordering};
    use tokio::sync::watch;

    /// A service that ends when told to (through a watch), the way a failing task would.
    struct Toy {
        end: watch::Receiver<Option<Result<(), ChildFailure>>>,
        stops: Arc<AtomicU32>,
    }

    impl Service for Toy {
        fn ended(&mut self) -> BoxFuture<'_, Result<(), ChildFailure>> {
            Box::pin(async move {
                loop {
                    if let Some(r) = self.end.borrow_and_update().clone() {
                        if matches!(&r, Err(f) if f.why == "panic") {
                            panic!("toy service panicked");
                        }
                        return r;
                    }
                    if self.end.changed().await.is_err() {
                        return Ok(());
                    }
                }
            })
        }
        fn stop(self: Box<Self>, _within: Duration) -> BoxFuture<'static, ()> {
            self.stops.fetch_add(1, Ordering::SeqCst);
            Box::pin(async {})
        }
    }

    fn policy(restart: RestartPolicy, max: u32) -> Policy {
        Policy {
            side: crate::supervisor::Side::Vehicle,
            restart,
            max_restarts: max,
            window: Duration::from_secs(60),
            backoff_initial: Duration::from_millis(1),
            backoff_max: Duration::from_millis(2),
        }
    }

    type Ending = watch::Sender<Option<Result<(), ChildFailure>>>;

    struct Rig {
        starts: Arc<AtomicU32>,
        stops: Arc<AtomicU32>,
        end: Arc<std::sync::Mutex<Ending>>,
    }

    fn toy(p: Policy) -> (ChildSpec, Rig) {
        let starts = Arc::new(AtomicU32::new(0));
        let stops = Arc::new(AtomicU32::new(0));
        let (tx, _) = watch::channel(None);
        let end = Arc::new(std::sync::Mutex::new(tx));
        let rig = Rig {
            starts: starts.clone(),
            stops: stops.clone(),
            end: end.clone(),
        };
        let start: StartService = Arc::new(move || {
            let starts = starts.clone();
            let stops = stops.clone();
            let end = end.clone();
            Box::pin(async move {
                starts.fetch_add(1, Ordering::SeqCst);
                // Every start gets a fresh watch, as a restarted service gets fresh tasks.
                let (tx, rx) = watch::channel(None);
                *end.lock().map_err(|e| e.to_string())? = tx;
                Ok(Box::new(Toy { end: rx, stops }) as Box<dyn Service>)
            })
        });
        (service_child("toy", p, start), rig)
    }

    impl Rig {
        fn end_with(&self, r: Result<(), ChildFailure>) {
            if let Ok(tx) = self.end.lock() {
                tx.send_replace(Some(r));
            }
        }
        async fn starts_reach(&self, n: u32) {
            let deadline = tokio::time::Instant::now() + Duration::from_secs(5);
            while self.starts.load(Ordering::SeqCst) < n {
                assert!(
                    tokio::time::Instant::now() < deadline,
                    "starts stuck at {}",
                    self.starts.load(Ordering::SeqCst)
                );
                tokio::task::yield_now().await;
                tokio::time::sleep(Duration::from_millis(1)).await;
            }
        }
    }

    #[tokio::test]
    async fn a_failing_or_panicking_service_is_stopped_and_restarted() {
        let (spec, rig) = toy(policy(RestartPolicy::OnFailure, 5));
        let root = SupervisorHandle::start("test", vec![spec], None)
            .await
            .unwrap();
        rig.starts_reach(1).await;
        rig.end_with(Err(ChildFailure::new("boom")));
        rig.starts_reach(2).await;
        assert_eq!(
            rig.stops.load(Ordering::SeqCst),
            1,
            "the failed one was stopped"
        );
        rig.end_with(Err(ChildFailure::new("panic")));
        rig.starts_reach(3).await;
        let snap = root.snapshot(Duration::from_secs(1)).await.unwrap();
        assert_eq!(snap.children[0].restarts, 2);
        assert!(
            snap.children[0]
                .last_failure
                .as_deref()
                .is_some_and(|f| f.contains("toy service panicked")),
            "{snap:?}"
        );
        root.shutdown(Duration::from_secs(3)).await;
        assert_eq!(
            rig.stops.load(Ordering::SeqCst),
            2,
            "the running one was stopped too"
        );
    }

    #[tokio::test]
    async fn an_exhausted_inner_limit_escalates_with_its_exit() {
        let (spec, rig) = toy(policy(RestartPolicy::OnFailure, 5));
        let mut root = SupervisorHandle::start("test", vec![spec], None)
            .await
            .unwrap();
        rig.starts_reach(1).await;
        rig.end_with(Err(ChildFailure {
            why: "driver restart limit".into(),
            exit: Some(ServiceExit::RestartLimit("driver".into())),
        }));
        let exit = tokio::time::timeout(Duration::from_secs(5), root.wait())
            .await
            .unwrap();
        assert_eq!(exit.code(), 3, "{exit:?}");
        assert_eq!(rig.starts.load(Ordering::SeqCst), 1, "not restarted");
    }

    #[tokio::test]
    async fn never_keeps_the_childs_own_exit() {
        let (spec, rig) = toy(policy(RestartPolicy::Never, 5));
        let mut root = SupervisorHandle::start("test", vec![spec], None)
            .await
            .unwrap();
        rig.starts_reach(1).await;
        rig.end_with(Err(ChildFailure {
            why: "error state".into(),
            exit: Some(ServiceExit::ErrorState("fs error".into())),
        }));
        let exit = tokio::time::timeout(Duration::from_secs(5), root.wait())
            .await
            .unwrap();
        assert!(matches!(exit, ServiceExit::ErrorState(_)), "{exit:?}");
        assert_eq!(exit.code(), 0, "Goby3 quits with 0 on exit_on_error");
        assert_eq!(rig.stops.load(Ordering::SeqCst), 1);
    }

    #[tokio::test]
    async fn an_orderly_end_stays_down_under_on_failure() {
        let (spec, rig) = toy(policy(RestartPolicy::OnFailure, 5));
        let root = SupervisorHandle::start("test", vec![spec], None)
            .await
            .unwrap();
        rig.starts_reach(1).await;
        rig.end_with(Ok(()));
        let deadline = tokio::time::Instant::now() + Duration::from_secs(5);
        loop {
            let snap = root.snapshot(Duration::from_secs(1)).await.unwrap();
            if !snap.children[0].up {
                assert_eq!(snap.children[0].restarts, 0);
                break;
            }
            assert!(tokio::time::Instant::now() < deadline, "{snap:?}");
            tokio::time::sleep(Duration::from_millis(1)).await;
        }
        assert_eq!(rig.starts.load(Ordering::SeqCst), 1);
        root.shutdown(Duration::from_secs(3)).await;
    }
}
