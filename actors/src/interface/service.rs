//! The running interface as its users hold it: start (with the driver the config names), a
//! snapshot probe, how it ended, and an orderly shutdown.

use std::time::Duration;

use frontseat_config::InterfaceConfig;
use ractor::ActorRef;
use tokio::sync::watch;

use crate::bus::Bus;
use crate::driver::DriverFactory;
use crate::supervisor::ServiceExit;

use super::actor::FsiArgs;
use super::messages::{FsiMsg, Snapshot};
use super::settings::InterfaceSettings;
use super::vehicle_thread::{self, Started};

/// The running interface: the actor, and how it ended. The actor and the rest of the vehicle
/// side run on their own thread ([`vehicle_thread`]); this handle is held on the caller's.
pub struct InterfaceService {
    actor: ActorRef<FsiMsg>,
    /// True once the interface actor's task has ended.
    ended: watch::Receiver<bool>,
    exit: watch::Receiver<Option<ServiceExit>>,
}

#[derive(Debug, thiserror::Error)]
pub enum StartError {
    #[error("driver: {0}")]
    Driver(#[from] crate::drivers::DriverSelectError),
    #[error("could not start the interface actor: {0}")]
    Spawn(String),
}

impl InterfaceService {
    /// Starts the interface with the driver the config names, a plugin or one of `built_in`
    /// (the registry's list, `frontseat_drivers::BUILT_IN`).
    pub async fn start(
        cfg: &InterfaceConfig,
        bus: &Bus,
        built_in: &[crate::drivers::BuiltIn],
    ) -> Result<Self, StartError> {
        let driver = crate::drivers::select(cfg, built_in)?;
        let settings = InterfaceSettings::from_config(cfg).for_driver(&driver);
        Self::start_with(settings, bus, driver.factory).await
    }

    pub async fn start_with(
        settings: InterfaceSettings,
        bus: &Bus,
        factory: DriverFactory,
    ) -> Result<Self, StartError> {
        let (tx, rx) = watch::channel(None);
        let Started { actor, ended } = vehicle_thread::spawn(FsiArgs {
            settings,
            bus: bus.clone(),
            factory,
            exit: tx,
        })
        .await
        .map_err(StartError::Spawn)?;
        Ok(Self {
            actor,
            ended,
            exit: rx,
        })
    }

    pub fn actor(&self) -> &ActorRef<FsiMsg> {
        &self.actor
    }

    /// A snapshot, or None if the actor did not answer within `within` (a hung actor).
    pub async fn snapshot(&self, within: Duration) -> Option<Snapshot> {
        let call = self.actor.call(FsiMsg::Snapshot, Some(within));
        match call.await {
            Ok(ractor::rpc::CallResult::Success(s)) => Some(s),
            _ => None,
        }
    }

    /// Resolves when the service ends by itself (error exit, restart limit, actor failure).
    pub async fn wait(&mut self) -> ServiceExit {
        let ended = || ServiceExit::Failed("interface actor ended".into());
        loop {
            if let Some(e) = self.exit.borrow().clone() {
                return e;
            }
            if *self.ended.borrow() {
                return self.exit.borrow().clone().unwrap_or_else(ended);
            }
            tokio::select! {
                r = self.exit.changed() => if r.is_err() {
                    return ended();
                },
                r = self.ended.changed() => if r.is_err() {
                    return self.exit.borrow().clone().unwrap_or_else(ended);
                },
            }
        }
    }

    /// Orderly shutdown within `within`: stop accepting commands, publish a last status, close
    /// the frontseat connection.
    pub async fn shutdown(mut self, within: Duration) -> ServiceExit {
        let _ = self.actor.call(FsiMsg::Shutdown, Some(within)).await;
        let _ = tokio::time::timeout(within, self.ended.wait_for(|ended| *ended)).await;
        // An interface actor that was killed ran no cleanup: its DriverActor (and so the
        // frontseat connection) would outlive it, beside the one a restart starts.
        self.actor
            .stop_children_and_wait(Some("interface stopped".into()), Some(within))
            .await;
        self.exit.borrow().clone().unwrap_or(ServiceExit::Clean)
    }
}
