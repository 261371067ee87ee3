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

/// Log lines keep the target this module had as one file, whatever part now writes them:
/// operators filter and grep on it.
const LOG_TARGET: &str = "frontseat_actors::supervisor";

mod actor;
mod policy;
mod spec;
mod tree;

pub use actor::{
    CHILD_STOP_BOUND, ChildDown, ChildObserver, ChildReport, Supervisor, SupervisorArgs,
    SupervisorHandle, SupervisorMsg, SupervisorSnapshot, SupervisorState, spawn_nested,
};
pub use policy::{ChildFailure, Decider, Decision, Ending, Policy, ServiceExit, Side};
pub use spec::{About, ChildSpec, Node, StartFn};
pub use tree::{TREE_PREAMBLE, render_tree, tree_names};
