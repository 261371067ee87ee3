//! The supervisor actor: starts its children linked to itself, hears each one end, asks the
//! [`Decider`] what to do and restarts, leaves down or gives up; publishes who is up on
//! `frontseat::supervision::status` and stops its children last-started-first. A
//! [`SupervisorHandle`] runs a root supervisor; [`spawn_nested`] one inside an actor.

use std::sync::Arc;
use std::time::Duration;

use ractor::{Actor, ActorCell, ActorProcessingErr, ActorRef, RpcReplyPort, SupervisionEvent};
use tokio::sync::watch;
use tokio::time::Instant;

use super::policy::{ChildFailure, Decider, Decision, Ending, ServiceExit, Side};
use super::spec::ChildSpec;
use crate::bus::Bus;
use crate::ports::RootSupervisorPorts;
use crate::proto::frontseat::protobuf::{SupervisedActor, SupervisionStatus};

/// How long a supervisor waits for each child to stop when it stops itself.
pub const CHILD_STOP_BOUND: Duration = Duration::from_secs(3);

/// One child as the supervisor sees it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ChildReport {
    pub name: String,
    pub up: bool,
    pub restarts: u32,
    pub last_failure: Option<String>,
    pub side: Side,
    /// While down: since when.
    pub down_since: Option<std::time::SystemTime>,
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SupervisorSnapshot {
    pub name: String,
    pub children: Vec<ChildReport>,
}

impl SupervisorSnapshot {
    /// A helm-side child is down: the process runs, degraded.
    pub fn degraded(&self) -> bool {
        self.children.iter().any(|c| c.side == Side::Helm && !c.up)
    }
}

pub enum SupervisorMsg {
    Restart(usize),
    Snapshot(RpcReplyPort<SupervisorSnapshot>),
}

/// A child's end as its supervisor tells an observer, before it decides what to do about it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ChildDown {
    pub name: String,
    pub why: String,
    /// A failure (a panic, an error, a start that failed), not an orderly end.
    pub failed: bool,
}

/// Hears of every child's end: how the actor hosting a nested supervisor (the
/// FrontSeatInterface, of its DriverActor's) learns that the child is down while the
/// supervisor alone decides on the restart.
pub type ChildObserver = Arc<dyn Fn(ChildDown) + Send + Sync>;

pub struct SupervisorArgs {
    pub name: String,
    pub children: Vec<ChildSpec>,
    pub exit: watch::Sender<Option<ServiceExit>>,
    /// Where the status goes (`frontseat::supervision::status`), if anywhere.
    pub bus: Option<Bus>,
    pub observer: Option<ChildObserver>,
}

struct Child {
    spec: ChildSpec,
    cell: Option<ActorCell>,
    decider: Decider,
    last_failure: Option<String>,
    down_since: Option<std::time::SystemTime>,
}

pub struct SupervisorState {
    name: String,
    children: Vec<Child>,
    exit: watch::Sender<Option<ServiceExit>>,
    giving_up: bool,
    ports: Option<RootSupervisorPorts>,
    observer: Option<ChildObserver>,
}

pub struct Supervisor;

impl SupervisorState {
    fn snapshot(&self) -> SupervisorSnapshot {
        SupervisorSnapshot {
            name: self.name.clone(),
            children: self
                .children
                .iter()
                .map(|c| ChildReport {
                    name: c.spec.name.clone(),
                    up: c.cell.is_some(),
                    restarts: c.decider.restarts,
                    last_failure: c.last_failure.clone(),
                    side: c.spec.policy.side,
                    down_since: c.down_since,
                })
                .collect(),
        }
    }

    /// Every start, end and restart is visible on the bus (and so over Zenoh, Goby3, the web).
    fn publish(&self) {
        let Some(ports) = &self.ports else { return };
        let snap = self.snapshot();
        let degraded = snap.degraded();
        ports.publish_status(SupervisionStatus {
            supervisor: Some(snap.name),
            children: snap
                .children
                .into_iter()
                .map(|c| SupervisedActor {
                    name: Some(c.name),
                    up: Some(c.up),
                    restarts: Some(c.restarts),
                    last_failure: c.last_failure,
                    side: Some(c.side.name().to_string()),
                    down_since: c.down_since.and_then(|t| {
                        t.duration_since(std::time::UNIX_EPOCH)
                            .ok()
                            .map(|d| d.as_secs_f64())
                    }),
                })
                .collect(),
            gave_up: Some(self.giving_up),
            degraded: Some(degraded),
        });
    }

    /// Last started, first stopped, each drained before the next: the interface publishes its
    /// last status while the gateways that export it are still up.
    async fn stop_children(&mut self) {
        for c in self.children.iter_mut().rev() {
            if let Some(cell) = c.cell.take() {
                let _ = cell
                    .stop_and_wait(Some("supervisor stopping".into()), Some(CHILD_STOP_BOUND))
                    .await;
            }
        }
    }

    fn index_of(&self, cell: &ActorCell) -> Option<usize> {
        let id = cell.get_id();
        self.children
            .iter()
            .position(|c| c.cell.as_ref().is_some_and(|x| x.get_id() == id))
    }

    /// A child ended. `Some` when the supervisor gives up: its handler then fails with it, so a
    /// parent supervisor (if any) sees this supervisor fail, and the exit watch has the reason.
    fn ended(
        &mut self,
        myself: &ActorRef<SupervisorMsg>,
        i: usize,
        ending: Ending,
        failure: Option<ChildFailure>,
    ) -> Option<ChildFailure> {
        let sup = self.name.clone();
        let child = &mut self.children[i];
        child.cell = None;
        child
            .down_since
            .get_or_insert_with(std::time::SystemTime::now);
        if child.spec.policy.side == Side::Helm {
            frontseat_telemetry::metrics::helm_side_down();
        }
        let why = failure
            .as_ref()
            .map(|f| f.why.clone())
            .unwrap_or_else(|| "stopped".into());
        if ending == Ending::Failed {
            child.last_failure = Some(why.clone());
        }
        if let Some(observer) = &self.observer {
            observer(ChildDown {
                name: child.spec.name.clone(),
                why: why.clone(),
                failed: ending == Ending::Failed,
            });
        }
        if self.giving_up {
            return None;
        }
        let mut decision = child
            .decider
            .decide(&child.spec.name, ending, Instant::now());
        if child.spec.policy.side == Side::Vehicle
            && failure.as_ref().is_some_and(ChildFailure::escalates)
        {
            decision = Decision::GiveUp(format!(
                "{} gave up past its own restart limit: {why}",
                child.spec.name
            ));
        }
        if let Decision::GiveUp(_) = decision {
            self.giving_up = true;
        }
        self.publish();
        let child = &mut self.children[i];
        match decision {
            Decision::Restart { after, nth } => {
                tracing::warn!(
                    target: super::LOG_TARGET,
                    supervisor = %sup,
                    child = %child.spec.name,
                    restart = nth,
                    delay = ?after,
                    %why,
                    "supervised actor ended; restarting"
                );
                myself.send_after(after, move || SupervisorMsg::Restart(i));
                None
            }
            Decision::LeaveDown if ending == Ending::Failed => {
                tracing::error!(target: super::LOG_TARGET, supervisor = %sup, child = %child.spec.name, %why, "helm-side actor failed and is left down (policy never): degraded");
                None
            }
            Decision::LeaveDown => {
                tracing::info!(target: super::LOG_TARGET, supervisor = %sup, child = %child.spec.name, %why, "supervised actor stopped");
                None
            }
            Decision::GiveUp(reason) => {
                tracing::error!(target: super::LOG_TARGET, supervisor = %sup, child = %child.spec.name, "{reason}");
                // The child's own exit when it named one (an error state: 2, its restart
                // limit: 3, the interface failing: 4), else the restart limit's.
                let exit = failure
                    .and_then(|f| f.exit)
                    .filter(|e| *e != ServiceExit::Clean)
                    .unwrap_or_else(|| ServiceExit::RestartLimit(reason.clone()));
                self.exit.send_replace(Some(exit.clone()));
                Some(ChildFailure {
                    why: format!("supervisor {sup} gave up: {reason}"),
                    exit: Some(ServiceExit::RestartLimit(reason)),
                })
            }
        }
    }
}

impl Actor for Supervisor {
    type Msg = SupervisorMsg;
    type State = SupervisorState;
    type Arguments = SupervisorArgs;

    async fn pre_start(
        &self,
        myself: ActorRef<Self::Msg>,
        args: SupervisorArgs,
    ) -> Result<Self::State, ActorProcessingErr> {
        let mut children = Vec::with_capacity(args.children.len());
        for spec in args.children {
            let cell = (spec.start)(myself.get_cell())
                .await
                .map_err(|e| format!("{}: {e}", spec.name))?;
            children.push(Child {
                decider: Decider::new(spec.policy.clone()),
                spec,
                cell: Some(cell),
                last_failure: None,
                down_since: None,
            });
        }
        let st = SupervisorState {
            name: args.name,
            children,
            exit: args.exit,
            giving_up: false,
            ports: args.bus.as_ref().map(RootSupervisorPorts::new),
            observer: args.observer,
        };
        st.publish();
        Ok(st)
    }

    async fn handle(
        &self,
        myself: ActorRef<Self::Msg>,
        msg: Self::Msg,
        st: &mut Self::State,
    ) -> Result<(), ActorProcessingErr> {
        match msg {
            SupervisorMsg::Restart(i) => {
                if st.giving_up || st.children.get(i).is_none_or(|c| c.cell.is_some()) {
                    return Ok(());
                }
                let start = st.children[i].spec.start.clone();
                match start(myself.get_cell()).await {
                    Ok(cell) => {
                        tracing::info!(target: super::LOG_TARGET, supervisor = %st.name, child = %st.children[i].spec.name, "supervised actor restarted");
                        st.children[i].cell = Some(cell);
                        st.children[i].down_since = None;
                        st.publish();
                    }
                    Err(e) => {
                        // A start that fails counts as one more failure of the child.
                        let failure = ChildFailure::new(format!("restart failed: {e}"));
                        if let Some(gave_up) = st.ended(&myself, i, Ending::Failed, Some(failure)) {
                            st.stop_children().await;
                            return Err(Box::new(gave_up));
                        }
                    }
                }
            }
            SupervisorMsg::Snapshot(reply) => {
                let _ = reply.send(st.snapshot());
            }
        }
        Ok(())
    }

    async fn handle_supervisor_evt(
        &self,
        myself: ActorRef<Self::Msg>,
        evt: SupervisionEvent,
        st: &mut Self::State,
    ) -> Result<(), ActorProcessingErr> {
        // Overridden so that a child's end never stops the supervisor itself (ractor's default).
        let gave_up = match evt {
            SupervisionEvent::ActorFailed(cell, err) => match st.index_of(&cell) {
                Some(i) => {
                    let failure = err
                        .downcast_ref::<ChildFailure>()
                        .cloned()
                        .unwrap_or_else(|| ChildFailure::new(err.to_string()));
                    st.ended(&myself, i, Ending::Failed, Some(failure))
                }
                None => None,
            },
            SupervisionEvent::ActorTerminated(cell, _, reason) => match st.index_of(&cell) {
                Some(i) => {
                    let stop = reason.map(ChildFailure::new);
                    st.ended(&myself, i, Ending::Stopped, stop)
                }
                None => None,
            },
            _ => None,
        };
        match gave_up {
            Some(f) => {
                // A failing actor gets no post_stop: its children are stopped here.
                st.stop_children().await;
                Err(Box::new(f))
            }
            None => Ok(()),
        }
    }

    async fn post_stop(
        &self,
        _myself: ActorRef<Self::Msg>,
        st: &mut Self::State,
    ) -> Result<(), ActorProcessingErr> {
        st.stop_children().await;
        Ok(())
    }
}

/// A running supervisor and the exit it reports.
pub struct SupervisorHandle {
    actor: ActorRef<SupervisorMsg>,
    join: tokio::task::JoinHandle<()>,
    exit: watch::Receiver<Option<ServiceExit>>,
}

impl SupervisorHandle {
    /// A supervisor whose status goes on `bus` (`frontseat::supervision::status`) when given.
    pub async fn start(
        name: &str,
        children: Vec<ChildSpec>,
        bus: Option<&Bus>,
    ) -> Result<Self, String> {
        let (tx, rx) = watch::channel(None);
        let (actor, join) = Actor::spawn(
            None,
            Supervisor,
            SupervisorArgs {
                name: name.to_string(),
                children,
                exit: tx,
                bus: bus.cloned(),
                observer: None,
            },
        )
        .await
        .map_err(|e| e.to_string())?;
        Ok(Self {
            actor,
            join,
            exit: rx,
        })
    }

    pub async fn snapshot(&self, within: Duration) -> Option<SupervisorSnapshot> {
        match self.actor.call(SupervisorMsg::Snapshot, Some(within)).await {
            Ok(ractor::rpc::CallResult::Success(s)) => Some(s),
            _ => None,
        }
    }

    /// The exit, if the supervisor gave up or stopped already.
    pub fn exit_now(&self) -> Option<ServiceExit> {
        self.exit.borrow().clone()
    }

    /// Resolves when the supervisor gave up (restart limit) or stopped.
    pub async fn wait(&mut self) -> ServiceExit {
        loop {
            if let Some(e) = self.exit.borrow().clone() {
                return e;
            }
            if self.exit.changed().await.is_err() {
                return self.exit.borrow().clone().unwrap_or(ServiceExit::Clean);
            }
        }
    }

    /// Stops every child and the supervisor.
    pub async fn shutdown(self, within: Duration) {
        self.actor.stop(Some("shutdown".into()));
        let _ = tokio::time::timeout(within, self.join).await;
    }
}

/// A supervisor nested under `parent`, an actor that hosts a supervision tree of its own: giving
/// up reaches the parent as this supervisor's failure (a [`ChildFailure`] whose exit is
/// [`ServiceExit::RestartLimit`]), and `observer` hears of each child's end before the restart
/// is decided. Its status is not published (the root's is the process's).
pub async fn spawn_nested(
    name: &str,
    children: Vec<ChildSpec>,
    parent: ActorCell,
    observer: Option<ChildObserver>,
) -> Result<ActorRef<SupervisorMsg>, String> {
    // Nobody reads the exit: the parent learns of giving up from the failure itself.
    let (exit, _) = watch::channel(None);
    let (actor, _join) = Actor::spawn_linked(
        None,
        Supervisor,
        SupervisorArgs {
            name: name.to_string(),
            children,
            exit,
            bus: None,
            observer,
        },
        parent,
    )
    .await
    .map_err(|e| e.to_string())?;
    Ok(actor)
}
