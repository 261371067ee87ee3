//! A child as a service declares it: how it starts ([`ChildSpec`], its [`StartFn`]) and how the
//! printed tree shows it ([`Node`], [`About`]); the two share name and policy, so the tree
//! `frontseat interfaces` prints is the one the service starts.

use std::future::Future;
use std::pin::Pin;
use std::sync::Arc;

use ractor::ActorCell;

use super::policy::Policy;

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
