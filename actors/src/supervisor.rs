//! The supervision tree's generic supervisor: a ractor actor that starts its children linked to
//! itself and restarts them by policy, the way OTP and dora-rs do it — never / on-failure /
//! always, after a delay that doubles from `backoff_initial` to `backoff_max`.
//!
//! Two sides, two policies ([`Side`]). A vehicle-side child (the FrontSeatInterface and its
//! driver) is restarted at most `max_restarts` within `restart_window`; past the limit (or when a
//! `never` child fails) the supervisor gives up and reports a [`ServiceExit::RestartLimit`], so
//! the process exits non-zero and systemd restarts it. A helm-side child (translation, gateways,
//! web, health) is restarted without end, its backoff capped and jittered: a helm fault that
//! repeats must never end the process and with it the vehicle link. While a helm-side child is
//! down the supervisor reports itself *degraded* (which child, since when). Every restart is
//! logged and counted; [`SupervisorSnapshot`] says who is up.
//!
//! The pure decision ([`Decider`]) is separate from the actor so it is table-tested. It is the only
//! restart decision in the process: a part that supervises a child of its own nests a supervisor
//! (the FrontSeatInterface its DriverActor, with [`spawn_nested`], hearing of the driver's end
//! through a [`ChildObserver`]; the web scope its hub). The tree `frontseat interfaces` prints is
//! rendered ([`render_tree`]) from the [`Node`]s of the very [`ChildSpec`]s a service starts.

use std::collections::VecDeque;
use std::future::Future;
use std::pin::Pin;
use std::sync::Arc;
use std::time::Duration;

use frontseat_config::{RestartConfig, RestartPolicy};
use ractor::{Actor, ActorCell, ActorProcessingErr, ActorRef, RpcReplyPort, SupervisionEvent};
use tokio::sync::watch;
use tokio::time::Instant;

use crate::bus::Bus;
use crate::ports::RootSupervisorPorts;
use crate::proto::frontseat::protobuf::{SupervisedActor, SupervisionStatus};

/// Why the service ended.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ServiceExit {
    /// Orderly shutdown.
    Clean,
    /// exit_on_error and an error state was entered. Its code is Goby3's (0, frontseat_interface.cpp
    /// 176-184); `frontseat interface` exits with the configured `exit_on_error_code` instead.
    ErrorState(String),
    /// A vehicle-side child (the driver, the interface) failed more often than its limit allows.
    RestartLimit(String),
    /// The interface actor itself failed.
    Failed(String),
}

impl ServiceExit {
    pub fn code(&self) -> i32 {
        match self {
            ServiceExit::Clean => 0,
            ServiceExit::ErrorState(_) => 0,
            ServiceExit::RestartLimit(_) => 3,
            ServiceExit::Failed(_) => 4,
        }
    }
}

/// Which side of the frontseat link a child is on, and so what repeated failures of it do.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Side {
    /// The vehicle side, or any child whose repeated failure must end its supervisor: at most
    /// `max_restarts` within the window, then give up (the process ends for systemd).
    #[default]
    Vehicle,
    /// The helm side: restarted without end (capped, jittered backoff); never ends the process.
    Helm,
}

impl Side {
    pub fn name(self) -> &'static str {
        match self {
            Side::Vehicle => "vehicle",
            Side::Helm => "helm",
        }
    }
}

/// Remembered restart times per child at most (the helm side has no limit to count towards).
const MAX_REMEMBERED_RESTARTS: usize = 1024;

/// What a supervisor knows about how to restart one child.
#[derive(Clone, Debug, PartialEq)]
pub struct Policy {
    pub side: Side,
    pub restart: RestartPolicy,
    pub max_restarts: u32,
    pub window: Duration,
    pub backoff_initial: Duration,
    pub backoff_max: Duration,
}

impl Policy {
    /// The same policy on the helm side.
    pub fn helm_side(self) -> Self {
        Self {
            side: Side::Helm,
            ..self
        }
    }
}

impl From<&RestartConfig> for Policy {
    fn from(c: &RestartConfig) -> Self {
        Self {
            side: Side::Vehicle,
            restart: c.policy,
            max_restarts: c.max_restarts,
            window: Duration::from_secs_f64(c.restart_window_s.max(0.0)),
            backoff_initial: Duration::from_millis(c.backoff_initial_ms),
            backoff_max: Duration::from_millis(c.backoff_max_ms.max(c.backoff_initial_ms)),
        }
    }
}

/// How a child ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ending {
    Failed,
    Stopped,
}

/// What to do about it.
#[derive(Clone, Debug, PartialEq)]
pub enum Decision {
    /// Restart after this delay (the n-th restart in the window).
    Restart { after: Duration, nth: u32 },
    /// Leave it down (an orderly end under on-failure or never).
    LeaveDown,
    /// Give up: the process should end non-zero.
    GiveUp(String),
}

/// A child's failure as it reaches its supervisor (the error a supervised actor fails with).
/// `exit` is the process exit the child asks for should its supervisor give up on it; an exit of
/// [`ServiceExit::RestartLimit`] means the child already exhausted a restart limit of its own
/// (the DriverActor's under the FrontSeatInterface), so its supervisor escalates at once instead
/// of multiplying that limit by its own; likewise an error state under exit_on_error.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ChildFailure {
    pub why: String,
    pub exit: Option<ServiceExit>,
}

impl ChildFailure {
    pub fn new(why: impl Into<String>) -> Self {
        Self {
            why: why.into(),
            exit: None,
        }
    }

    /// The text of a panic caught by a JoinHandle.
    pub fn from_join(what: &str, e: tokio::task::JoinError) -> Self {
        if e.is_panic() {
            let p = e.into_panic();
            let text = p
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| p.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "panic".into());
            Self::new(format!("{what} panicked: {text}"))
        } else {
            Self::new(format!("{what}: {e}"))
        }
    }

    /// The child decided the process should end (an error state under exit_on_error, or an
    /// exhausted restart limit of its own): restarting it would overrule that decision.
    fn escalates(&self) -> bool {
        matches!(
            self.exit,
            Some(ServiceExit::RestartLimit(_) | ServiceExit::ErrorState(_))
        )
    }
}

impl std::fmt::Display for ChildFailure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.why)
    }
}

impl std::error::Error for ChildFailure {}

/// The restart bookkeeping of one child: pure, clock passed in (and the jitter's seed).
#[derive(Clone, Debug)]
pub struct Decider {
    policy: Policy,
    recent: VecDeque<Instant>,
    pub restarts: u32,
    /// xorshift state for the helm side's jitter: children failing together (one cause) must
    /// not come back in lockstep.
    jitter: u64,
}

impl Decider {
    pub fn new(policy: Policy) -> Self {
        let seed = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0x9e37_79b9, |d| d.as_nanos() as u64);
        Self::with_seed(policy, seed)
    }

    pub fn with_seed(policy: Policy, seed: u64) -> Self {
        Self {
            policy,
            recent: VecDeque::new(),
            restarts: 0,
            jitter: seed | 1,
        }
    }

    /// A factor in [0.5, 1): "equal jitter", so the delay stays within half of its cap.
    fn jitter_factor(&mut self) -> f64 {
        let mut x = self.jitter;
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        self.jitter = x;
        0.5 + (x >> 11) as f64 / (1u64 << 53) as f64 / 2.0
    }

    pub fn decide(&mut self, name: &str, ending: Ending, now: Instant) -> Decision {
        if self.policy.side == Side::Helm {
            return self.decide_helm(ending, now);
        }
        let wanted = match (self.policy.restart, ending) {
            (RestartPolicy::Always, _) | (RestartPolicy::OnFailure, Ending::Failed) => true,
            (RestartPolicy::Never, Ending::Failed) => {
                return Decision::GiveUp(format!(
                    "{name} failed and its restart policy is `never`"
                ));
            }
            _ => false,
        };
        if !wanted {
            return Decision::LeaveDown;
        }
        while let Some(t) = self.recent.front() {
            if now.saturating_duration_since(*t) > self.policy.window {
                self.recent.pop_front();
            } else {
                break;
            }
        }
        if self.recent.len() as u32 >= self.policy.max_restarts {
            return Decision::GiveUp(format!(
                "{name} ended {} times within {:?} (max_restarts {}); giving up so the service manager restarts the process",
                self.recent.len() + 1,
                self.policy.window,
                self.policy.max_restarts
            ));
        }
        let n = self.recent.len() as u32;
        let after = self
            .policy
            .backoff_initial
            .saturating_mul(2u32.saturating_pow(n))
            .min(self.policy.backoff_max);
        self.recent.push_back(now);
        self.restarts += 1;
        Decision::Restart {
            after,
            nth: self.restarts,
        }
    }

    /// The helm side never gives up: restarted by its policy (a `never` child is left down,
    /// degraded), after a delay doubling with the restarts in the window up to the cap, jittered.
    fn decide_helm(&mut self, ending: Ending, now: Instant) -> Decision {
        let wanted = match (self.policy.restart, ending) {
            (RestartPolicy::Always, _) | (RestartPolicy::OnFailure, Ending::Failed) => true,
            (RestartPolicy::OnFailure | RestartPolicy::Never, _) => false,
        };
        if !wanted {
            return Decision::LeaveDown;
        }
        while let Some(t) = self.recent.front() {
            if now.saturating_duration_since(*t) > self.policy.window
                || self.recent.len() >= MAX_REMEMBERED_RESTARTS
            {
                self.recent.pop_front();
            } else {
                break;
            }
        }
        let n = u32::try_from(self.recent.len()).unwrap_or(u32::MAX);
        let cap = self
            .policy
            .backoff_initial
            .saturating_mul(2u32.saturating_pow(n))
            .min(self.policy.backoff_max);
        let after = cap.mul_f64(self.jitter_factor());
        self.recent.push_back(now);
        self.restarts = self.restarts.saturating_add(1);
        Decision::Restart {
            after,
            nth: self.restarts,
        }
    }
}

/// How long a supervisor waits for each child to stop when it stops itself.
pub const CHILD_STOP_BOUND: Duration = Duration::from_secs(3);

/// Starts one child linked to the supervisor cell given; the child's cell comes back.
pub type StartFn = Arc<
    dyn Fn(ActorCell) -> Pin<Box<dyn Future<Output = Result<ActorCell, String>> + Send>>
        + Send
        + Sync,
>;

/// One child of a supervisor.
#[derive(Clone)]
pub struct ChildSpec {
    pub name: String,
    pub policy: Policy,
    pub start: StartFn,
    /// What the printed tree says of it besides its name and policy.
    pub about: About,
}

/// What the tree `frontseat interfaces` prints says of a child besides its name and policy.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct About {
    /// When it runs and where its policy is configured, e.g. "with [web] enabled; [supervision.web]".
    pub note: String,
    /// The children it supervises itself (the interface's DriverActor, the web scope's hub).
    pub nested: Vec<Node>,
}

/// One child as the printed tree shows it: the name and policy its [`ChildSpec`] starts it with.
#[derive(Clone, Debug, PartialEq)]
pub struct Node {
    pub name: String,
    pub policy: Policy,
    pub about: About,
}

impl Node {
    pub fn new(name: &str, policy: Policy, note: &str) -> Self {
        Self {
            name: name.to_string(),
            policy,
            about: About {
                note: note.to_string(),
                nested: Vec::new(),
            },
        }
    }

    /// The spec that starts this child with `start`: the tree and the start share name and policy.
    pub fn spec(self, start: StartFn) -> ChildSpec {
        ChildSpec {
            name: self.name,
            policy: self.policy,
            start,
            about: self.about,
        }
    }
}

impl ChildSpec {
    /// This child as the printed tree shows it.
    pub fn node(&self) -> Node {
        Node {
            name: self.name.clone(),
            policy: self.policy.clone(),
            about: self.about.clone(),
        }
    }

    pub fn noted(mut self, note: &str) -> Self {
        self.about.note = note.to_string();
        self
    }

    pub fn nesting(mut self, nested: Vec<Node>) -> Self {
        self.about.nested = nested;
        self
    }
}

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
                tracing::error!(supervisor = %sup, child = %child.spec.name, %why, "helm-side actor failed and is left down (policy never): degraded");
                None
            }
            Decision::LeaveDown => {
                tracing::info!(supervisor = %sup, child = %child.spec.name, %why, "supervised actor stopped");
                None
            }
            Decision::GiveUp(reason) => {
                tracing::error!(supervisor = %sup, child = %child.spec.name, "{reason}");
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
                        tracing::info!(supervisor = %st.name, child = %st.children[i].spec.name, "supervised actor restarted");
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

/// What the printed tree says before the trees of the services.
pub const TREE_PREAMBLE: &str = "\
# supervision tree (every restart is logged, counted, and published on frontseat::supervision::status)
# two sides, two policies: only the vehicle side can end the process; a helm-side child is
# restarted without end (backoff doubling to backoff_max_ms, jittered), and while it is down the
# process is degraded (supervision status: degraded, the child's down_since; goby_coroner health:
# DEGRADED; metric frontseat.supervision.helm_side_down), never dead; a vehicle-side child is
# restarted at most max_restarts within restart_window_s, then its supervisor gives up (exit 3, or
# the child's own code); a helm-side `never` child that fails is left down, degraded; children
# stop in reverse start order
";

/// "100 ms", "2 s", "1.5 s".
fn span(d: Duration) -> String {
    if d.subsec_millis() == 0 && d.as_secs() > 0 {
        format!("{} s", d.as_secs())
    } else if d < Duration::from_secs(1) {
        format!("{} ms", d.as_millis())
    } else {
        format!("{} s", d.as_secs_f64())
    }
}

fn policy_words(p: &Policy) -> String {
    let restart = match p.restart {
        RestartPolicy::Never => "never",
        RestartPolicy::OnFailure => "on-failure",
        RestartPolicy::Always => "always",
    };
    let backoff = format!(
        "after {} doubling to {}",
        span(p.backoff_initial),
        span(p.backoff_max)
    );
    match p.side {
        Side::Vehicle => format!(
            "{restart}, {backoff}, at most {} in {}",
            p.max_restarts,
            span(p.window)
        ),
        Side::Helm => format!("{restart}, {backoff}, jittered, without end"),
    }
}

fn render_nodes(out: &mut String, nodes: &[Node], indent: &str) {
    for (i, n) in nodes.iter().enumerate() {
        let last = i + 1 == nodes.len();
        let (branch, more) = if last {
            ("└── ", "    ")
        } else {
            ("├── ", "│   ")
        };
        let side = match n.policy.side {
            Side::Vehicle => "VEHICLE",
            Side::Helm => "helm",
        };
        let width = 26usize.saturating_sub(indent.chars().count());
        out.push_str(&format!(
            "#   {indent}{branch}{:<width$}{side:<8} {}\n",
            n.name,
            policy_words(&n.policy)
        ));
        let below = format!("{indent}{more}");
        let bar = if n.about.nested.is_empty() {
            " "
        } else {
            "│"
        };
        if !n.about.note.is_empty() {
            out.push_str(&format!("#   {below}{bar}   {}\n", n.about.note));
        }
        render_nodes(out, &n.about.nested, &below);
    }
}

/// One service's tree under its root supervisor, from the nodes of the very [`ChildSpec`]s it
/// starts (in start order), as `frontseat interfaces` prints it.
pub fn render_tree(title: &str, root_note: &str, children: &[Node]) -> String {
    let mut out = format!("# {title}\n#   root supervisor   {root_note}\n");
    render_nodes(&mut out, children, "");
    out
}

/// The names in a tree [`render_tree`] printed, each with its depth (1: a root's child).
pub fn tree_names(tree: &str) -> Vec<(usize, String)> {
    tree.lines()
        .filter_map(|l| {
            let at = l.find("── ")?;
            let depth = l[..at].chars().count().saturating_sub(4) / 4 + 1;
            let name = l[at + "── ".len()..].split_whitespace().next()?;
            Some((depth, name.to_string()))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn policy(restart: RestartPolicy, max: u32) -> Policy {
        Policy {
            side: Side::Vehicle,
            restart,
            max_restarts: max,
            window: Duration::from_secs(60),
            backoff_initial: Duration::from_millis(100),
            backoff_max: Duration::from_millis(1000),
        }
    }

    #[test]
    fn the_tree_is_rendered_from_the_nodes_and_read_back() {
        let mut scope = Node::new(
            "Scope",
            policy(RestartPolicy::OnFailure, 3).helm_side(),
            "a",
        );
        scope.about.nested = vec![Node::new("Inner", policy(RestartPolicy::Always, 5), "")];
        let nodes = vec![
            Node::new("First", policy(RestartPolicy::Never, 2), "first note"),
            scope,
            Node::new("Last", policy(RestartPolicy::OnFailure, 4), ""),
        ];
        let tree = render_tree("svc", "root note", &nodes);
        assert_eq!(
            tree_names(&tree),
            vec![
                (1, "First".to_string()),
                (1, "Scope".to_string()),
                (2, "Inner".to_string()),
                (1, "Last".to_string()),
            ],
            "{tree}"
        );
        assert!(
            tree.contains("First                     VEHICLE  never, after 100 ms doubling to 1 s, at most 2 in 60 s"),
            "{tree}"
        );
        assert!(
            tree.contains(
                "helm     on-failure, after 100 ms doubling to 1 s, jittered, without end"
            ),
            "{tree}"
        );
        assert!(tree.contains("│   └── Inner"), "{tree}");
        assert!(tree.contains("first note"), "{tree}");
    }

    #[tokio::test(start_paused = true)]
    async fn policy_table() {
        let now = Instant::now();
        let rows: [(&str, RestartPolicy, Ending, bool); 6] = [
            (
                "on-failure restarts a failure",
                RestartPolicy::OnFailure,
                Ending::Failed,
                true,
            ),
            (
                "on-failure leaves a stop down",
                RestartPolicy::OnFailure,
                Ending::Stopped,
                false,
            ),
            (
                "always restarts a failure",
                RestartPolicy::Always,
                Ending::Failed,
                true,
            ),
            (
                "always restarts a stop",
                RestartPolicy::Always,
                Ending::Stopped,
                true,
            ),
            (
                "never leaves a stop down",
                RestartPolicy::Never,
                Ending::Stopped,
                false,
            ),
            (
                "never gives up on a failure",
                RestartPolicy::Never,
                Ending::Failed,
                false,
            ),
        ];
        for (name, p, ending, restarts) in rows {
            let d = Decider::new(policy(p, 5)).decide("child", ending, now);
            assert_eq!(
                matches!(d, Decision::Restart { .. }),
                restarts,
                "{name}: {d:?}"
            );
            if p == RestartPolicy::Never && ending == Ending::Failed {
                assert!(matches!(d, Decision::GiveUp(_)), "{name}");
            }
        }
    }

    #[tokio::test(start_paused = true)]
    async fn backoff_doubles_to_the_cap_and_the_window_forgives() {
        let mut d = Decider::new(policy(RestartPolicy::OnFailure, 5));
        let mut delays = Vec::new();
        for _ in 0..5 {
            match d.decide("c", Ending::Failed, Instant::now()) {
                Decision::Restart { after, .. } => delays.push(after.as_millis()),
                other => panic!("{other:?}"),
            }
        }
        assert_eq!(delays, vec![100, 200, 400, 800, 1000]);
        assert!(matches!(
            d.decide("c", Ending::Failed, Instant::now()),
            Decision::GiveUp(_)
        ));
        tokio::time::advance(Duration::from_secs(61)).await;
        assert_eq!(
            d.decide("c", Ending::Failed, Instant::now()),
            Decision::Restart {
                after: Duration::from_millis(100),
                nth: 6
            }
        );
    }

    #[tokio::test(start_paused = true)]
    async fn the_helm_side_never_gives_up_and_its_backoff_is_capped_and_jittered() {
        let mut d = Decider::with_seed(policy(RestartPolicy::OnFailure, 2).helm_side(), 42);
        let mut delays = Vec::new();
        for _ in 0..2000 {
            match d.decide("c", Ending::Failed, Instant::now()) {
                Decision::Restart { after, .. } => delays.push(after),
                other => panic!("the helm side gave up: {other:?}"),
            }
        }
        // Doubling from 100 ms, capped at 1000 ms, each in [cap / 2, cap).
        let caps = [100u64, 200, 400, 800, 1000];
        for (n, a) in delays.iter().enumerate() {
            let cap = Duration::from_millis(caps[n.min(caps.len() - 1)]);
            assert!(
                *a >= cap / 2 && *a < cap,
                "restart {n}: {a:?} for cap {cap:?}"
            );
        }
        let distinct: std::collections::BTreeSet<_> = delays[10..].iter().collect();
        assert!(distinct.len() > 100, "jittered, not in lockstep");
        assert_eq!(d.restarts, 2000);
        // Its bookkeeping stays bounded however often it fails.
        assert!(d.recent.len() <= MAX_REMEMBERED_RESTARTS);
    }

    #[tokio::test(start_paused = true)]
    async fn the_helm_side_honours_never_and_on_failure_without_giving_up() {
        let now = Instant::now();
        let never = policy(RestartPolicy::Never, 5).helm_side();
        assert_eq!(
            Decider::new(never).decide("c", Ending::Failed, now),
            Decision::LeaveDown
        );
        let on_failure = policy(RestartPolicy::OnFailure, 5).helm_side();
        assert_eq!(
            Decider::new(on_failure).decide("c", Ending::Stopped, now),
            Decision::LeaveDown
        );
        let always = policy(RestartPolicy::Always, 0).helm_side();
        assert!(matches!(
            Decider::new(always).decide("c", Ending::Stopped, now),
            Decision::Restart { .. }
        ));
    }
}
