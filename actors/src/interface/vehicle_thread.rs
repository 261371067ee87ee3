//! Where the vehicle side runs: the FrontSeatInterface, its driver's supervisor and DriverActor,
//! and the link tasks the driver spawns share one dedicated OS thread (`frontseat-vehicle`) with
//! its own current-thread tokio runtime. A NAV line or a setpoint passes between them without
//! waking another thread, and no helm-side task — slow, stuck, or blocking every worker thread
//! of the process's runtime — holds a thread the vehicle side needs. The two sides meet only on
//! the bus, whose publish never waits (a subscriber that does not keep up misses messages,
//! counted).
//!
//! Under a current-thread runtime (`#[tokio::test]`, paused time) the vehicle side runs on the
//! caller's runtime instead: a second runtime would not share a paused clock.

use std::time::Duration;

use ractor::{Actor, ActorRef};
use tokio::runtime::RuntimeFlavor;
use tokio::sync::{oneshot, watch};

use super::actor::{FrontSeatInterface, FsiArgs};
use super::messages::FsiMsg;

/// The vehicle side's thread, by name (in `top -H`, a debugger, a panic message).
pub const THREAD_NAME: &str = "frontseat-vehicle";

/// After the interface actor ended, how long its driver's supervisor, DriverActor and links
/// have to finish (an orderly stop closes the frontseat connection) before the thread's runtime
/// ends what is left.
const WIND_DOWN: Duration = Duration::from_secs(2);

/// The interface actor where it runs, and a watch that turns true when its task has ended.
pub(super) struct Started {
    pub(super) actor: ActorRef<FsiMsg>,
    pub(super) ended: watch::Receiver<bool>,
}

/// Spawns the FrontSeatInterface (which spawns the rest of the vehicle side from its own task):
/// on a new vehicle thread, or inline under a current-thread runtime.
pub(super) async fn spawn(args: FsiArgs) -> Result<Started, String> {
    let (ended_tx, ended) = watch::channel(false);
    if inline() {
        let (actor, join) = Actor::spawn(None, FrontSeatInterface, args)
            .await
            .map_err(|e| e.to_string())?;
        tokio::spawn(async move {
            let _ = join.await;
            ended_tx.send_replace(true);
        });
        return Ok(Started { actor, ended });
    }
    let (started_tx, started_rx) = oneshot::channel();
    std::thread::Builder::new()
        .name(THREAD_NAME.into())
        .spawn(move || run(args, started_tx, ended_tx))
        .map_err(|e| format!("cannot start the vehicle thread: {e}"))?;
    let actor = started_rx
        .await
        .map_err(|_| "the vehicle thread ended before the interface started".to_string())??;
    Ok(Started { actor, ended })
}

/// A current-thread caller (a test, paused time) keeps the vehicle side on its own runtime.
fn inline() -> bool {
    tokio::runtime::Handle::try_current()
        .map(|h| h.runtime_flavor() == RuntimeFlavor::CurrentThread)
        .unwrap_or(false)
}

/// The vehicle thread: its runtime lives as long as the interface actor, and a wind-down after.
fn run(
    args: FsiArgs,
    started: oneshot::Sender<Result<ActorRef<FsiMsg>, String>>,
    ended: watch::Sender<bool>,
) {
    let rt = match tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
    {
        Ok(rt) => rt,
        Err(e) => {
            let _ = started.send(Err(format!("cannot start the vehicle runtime: {e}")));
            return;
        }
    };
    rt.block_on(async move {
        let (actor, join) = match Actor::spawn(None, FrontSeatInterface, args).await {
            Ok(a) => a,
            Err(e) => {
                let _ = started.send(Err(e.to_string()));
                return;
            }
        };
        if started.send(Ok(actor.clone())).is_err() {
            // Whoever started it is gone (its start was cancelled): nobody could stop it.
            actor.stop(Some("start abandoned".into()));
        }
        let _ = join.await;
        ended.send_replace(true);
        let tasks = tokio::runtime::Handle::current().metrics();
        let until = tokio::time::Instant::now() + WIND_DOWN;
        while tasks.num_alive_tasks() > 0 && tokio::time::Instant::now() < until {
            tokio::time::sleep(Duration::from_millis(10)).await;
        }
    });
}
