//! The running interface as its users hold it: start (with the driver the config names), a
//! snapshot probe, how it ended, and an orderly shutdown.

use std::time::Duration;

use frontseat_config::InterfaceConfig;
use ractor::{Actor, ActorRef};
use tokio::sync::watch;

use crate::bus::Bus;
use crate::driver::DriverFactory;
use crate::supervisor::ServiceExit;

use super::actor::{FrontSeatInterface, FsiArgs};
use super::messages::{FsiMsg, Snapshot};
use super::settings::InterfaceSettings;

/// The running interface: the actor, and how it ended.
pub struct InterfaceService {
    actor: ActorRef<FsiMsg>,
    join: tokio::task::JoinHandle<()>,
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
        let (actor, join) = Actor::spawn(
            None,
            FrontSeatInterface,
            FsiArgs {
                settings,
                bus: bus.clone(),
                factory,
                exit: tx,
            },
        )
        .await
        .map_err(|e| StartError::Spawn(e.to_string()))?;
        Ok(Self {
            actor,
            join,
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
        loop {
            if let Some(e) = self.exit.borrow().clone() {
                return e;
            }
            if self.join.is_finished() {
                return self
                    .exit
                    .borrow()
                    .clone()
                    .unwrap_or(ServiceExit::Failed("interface actor ended".into()));
            }
            tokio::select! {
                r = self.exit.changed() => if r.is_err() {
                    return ServiceExit::Failed("interface actor ended".into());
                },
                _ = &mut self.join => {}
            }
        }
    }

    /// Orderly shutdown within `within`: stop accepting commands, publish a last status, close
    /// the frontseat connection.
    pub async fn shutdown(mut self, within: Duration) -> ServiceExit {
        let _ = self.actor.call(FsiMsg::Shutdown, Some(within)).await;
        // `wait` may have consumed the join already (a JoinHandle must not be polled twice).
        if !self.join.is_finished() {
            let _ = tokio::time::timeout(within, &mut self.join).await;
        }
        // An interface actor that was killed ran no cleanup: its DriverActor (and so the
        // frontseat connection) would outlive it, beside the one a restart starts.
        self.actor
            .stop_children_and_wait(Some("interface stopped".into()), Some(within))
            .await;
        self.exit.borrow().clone().unwrap_or(ServiceExit::Clean)
    }
}
