//! The Goby3 transport of the gateway: makes this process a client of an existing Goby3 system's
//! gobyd, like any Goby3 application. The groups come from the same [`crate::plan`] as Zenoh's
//! (every interprocess group a hosted actor publishes goes out, every one it subscribes comes
//! in), framed as Goby3 does (`/group/PROTOBUF/type/pid/thread/` NUL payload, see [`frame`]);
//! what was imported is never exported again. The connection lives in a background task
//! ([`link`]) that never blocks the bus: gobyd absent, restarted or gone is logged, counted,
//! retried with capped backoff, and reported as the bus link [`GOBY3_LINK`].

pub mod frame;
pub mod guard;
mod link;
pub mod manager;
mod settings;
pub mod standin;
mod traffic;

use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::Duration;

use frontseat_actors::bus::{Bus, GOBY3_LINK, Subscription};
use frontseat_actors::generated::groups;
use tokio::sync::watch;

use crate::{GatewayError, GatewayOptions, Plan, plan};
pub use manager::Transport;
pub use settings::Goby3Settings;
use traffic::{Counters, Exporter, Importer};
pub use traffic::{Goby3Stats, Origin3};

/// The running Goby3 transport. Dropping it stops the link task; [`Goby3Handle::close`] also
/// unsubscribes from the bus.
pub struct Goby3Handle {
    plan: Plan,
    settings: Goby3Settings,
    me: Origin3,
    counters: Arc<Counters>,
    bus_subs: Vec<Subscription>,
    stop: watch::Sender<bool>,
    task: tokio::task::JoinHandle<()>,
}

impl std::fmt::Debug for Goby3Handle {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Goby3Handle")
            .field("settings", &self.settings)
            .field("stats", &self.stats())
            .finish()
    }
}

impl Goby3Handle {
    pub fn stats(&self) -> Goby3Stats {
        self.counters.snapshot()
    }
    pub fn link_up(&self) -> bool {
        self.counters.link_up.load(Ordering::Relaxed)
    }
    pub fn plan(&self) -> &Plan {
        &self.plan
    }
    pub fn settings(&self) -> &Goby3Settings {
        &self.settings
    }
    /// The pid and thread id our frames carry.
    pub fn origin(&self) -> Origin3 {
        self.me
    }
    /// Resolves when the link task ended by itself (it only does when it failed): the reason.
    pub async fn ended(&mut self) -> String {
        let r = (&mut self.task).await;
        // A finished JoinHandle must not be polled again (`close` awaits the one it finds).
        self.task = tokio::spawn(async {});
        match r {
            Ok(()) => "the Goby3 link task ended".into(),
            Err(e) => format!("the Goby3 link task failed: {e}"),
        }
    }

    /// Unsubscribes from the bus and ends the link (sockets closed, nothing more sent).
    pub async fn close(mut self) {
        for s in std::mem::take(&mut self.bus_subs) {
            s.cancel();
        }
        let _ = self.stop.send(true);
        let task = std::mem::replace(&mut self.task, tokio::spawn(async {}));
        if tokio::time::timeout(Duration::from_secs(2), task)
            .await
            .is_err()
        {
            tracing::warn!("Goby3 link did not stop within 2 s");
        }
    }
}

/// The Goby3 transport as a child of the root supervisor.
impl frontseat_actors::service_child::Service for Goby3Handle {
    fn ended(
        &mut self,
    ) -> frontseat_actors::service_child::BoxFuture<
        '_,
        Result<(), frontseat_actors::supervisor::ChildFailure>,
    > {
        Box::pin(async move {
            Err(frontseat_actors::supervisor::ChildFailure::new(
                Goby3Handle::ended(self).await,
            ))
        })
    }
    fn stop(
        self: Box<Self>,
        _within: Duration,
    ) -> frontseat_actors::service_child::BoxFuture<'static, ()> {
        // `close` bounds itself (2 s for the link task).
        Box::pin(async move {
            let stats = self.stats();
            (*self).close().await;
            tracing::info!(?stats, "Goby3 transport stopped");
        })
    }
}

impl Drop for Goby3Handle {
    fn drop(&mut self) {
        self.task.abort();
    }
}

/// Starts the Goby3 transport for a process hosting `hosted` actors (e.g.
/// `["FrontSeatInterface"]`). Returns at once: joining gobyd happens in the background, and
/// until it has, local publications are dropped and counted. Needs a tokio runtime.
pub fn start(
    bus: &Bus,
    settings: Goby3Settings,
    hosted: &[&str],
    opts: GatewayOptions,
) -> Result<Goby3Handle, GatewayError> {
    let plan = plan::routes(groups::ALL, hosted)?;
    start_plan(bus, settings, plan, opts)
}

/// [`start`] for a process that only publishes what `hosted` actors publish and takes nothing
/// from gobyd: `frontseat replay --onto gobyd`, standing in for a recorded vehicle's interface.
/// With no imports, nothing another Goby3 application sends (a helm's desired_course) enters
/// this bus.
pub fn start_publisher(
    bus: &Bus,
    settings: Goby3Settings,
    hosted: &[&str],
    opts: GatewayOptions,
) -> Result<Goby3Handle, GatewayError> {
    let mut plan = plan::routes(groups::ALL, hosted)?;
    plan.imports.clear();
    start_plan(bus, settings, plan, opts)
}

fn start_plan(
    bus: &Bus,
    settings: Goby3Settings,
    plan: Plan,
    opts: GatewayOptions,
) -> Result<Goby3Handle, GatewayError> {
    let counters = Arc::new(Counters::default());
    let me = Origin3::this_process();

    let echoed = counters.clone();
    let (bus_subs, rx) = crate::subscribe_exports(
        bus,
        &plan,
        "goby3-gateway",
        opts.export_capacity,
        move || {
            echoed.not_echoed.fetch_add(1, Ordering::Relaxed);
        },
    )?;

    let exporter = Exporter {
        routes: plan
            .exports
            .iter()
            .map(|r| (r.group.to_string(), r.type_name))
            .collect(),
        me,
    };
    let importer = Importer {
        bus: bus.clone(),
        routes: plan
            .imports
            .iter()
            .map(|r| (r.group.to_string(), r.type_name, r.group))
            .collect(),
        me,
        max: opts.max_payload,
        counters: counters.clone(),
    };
    bus.set_link_up(GOBY3_LINK, false);
    let (stop, stop_rx) = watch::channel(false);
    let task = tokio::spawn(link::run(
        link::Link {
            settings: settings.clone(),
            me,
            counters: counters.clone(),
            bus: bus.clone(),
        },
        exporter,
        importer,
        rx,
        stop_rx,
    ));
    tracing::info!(
        platform = %settings.platform,
        manager = %settings.transport.manager_endpoint(),
        client_name = %settings.client_name,
        exports = ?plan.exports.iter().map(|r| r.group).collect::<Vec<_>>(),
        imports = ?plan.imports.iter().map(|r| r.group).collect::<Vec<_>>(),
        "Goby3 transport started; joining gobyd in the background"
    );
    Ok(Goby3Handle {
        plan,
        settings,
        me,
        counters,
        bus_subs,
        stop,
        task,
    })
}
