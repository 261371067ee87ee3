//! systemd integration of the long-running services: the sd_notify messages (READY=1, STATUS=,
//! WATCHDOG=1, STOPPING=1), the task that turns every published InterfaceStatus into a STATUS line,
//! and the watchdog task that pings only while the supervised actors answer. Outside systemd
//! (no NOTIFY_SOCKET) everything here is a no-op, so the services call it unconditionally.

use std::future::Future;
use std::pin::Pin;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use crate::bus::{Bus, Undeliverable};
use crate::interface::FsiMsg;
use crate::ports::{SystemdInterfaceWatchInbox, SystemdTranslationWatchInbox};
use crate::proto::frontseat::protobuf::TranslationStatus;
use crate::proto::goby::middleware::frontseat::protobuf::{
    FrontSeatError, HelmError, HelmState, InterfaceStatus,
};
use crate::state_machine::state_words;
use sd_notify::NotifyState;
use tokio::sync::mpsc::UnboundedSender;
use tokio::task::JoinHandle;

enum Sink {
    /// Not started by systemd (or by anything that listens): every message is dropped.
    Off,
    /// The datagram socket named by NOTIFY_SOCKET.
    Systemd,
    /// Messages as systemd would receive them, one String per datagram (tests, embedding).
    Channel(UnboundedSender<String>),
}

/// Sends sd_notify messages to the service manager, if there is one.
pub struct Notifier {
    sink: Sink,
    watchdog: Option<Duration>,
    /// One warning per failure streak: a vanished manager must not flood the journal.
    failing: AtomicBool,
}

impl Notifier {
    /// Enabled only when NOTIFY_SOCKET is set; the watchdog only when WATCHDOG_USEC is set (and
    /// WATCHDOG_PID, if given, is this process).
    pub fn from_env() -> Self {
        let enabled = std::env::var_os("NOTIFY_SOCKET").is_some_and(|s| !s.is_empty());
        let watchdog = if enabled {
            sd_notify::watchdog_enabled().filter(|d| !d.is_zero())
        } else {
            None
        };
        if enabled {
            tracing::info!(
                watchdog_usec = ?watchdog,
                "reporting to systemd (READY, STATUS, STOPPING{})",
                if watchdog.is_some() { ", WATCHDOG" } else { "" }
            );
        }
        Self {
            sink: if enabled { Sink::Systemd } else { Sink::Off },
            watchdog,
            failing: AtomicBool::new(false),
        }
    }

    /// A notifier whose messages go to a channel instead of a socket, with the watchdog interval
    /// systemd would have given in WATCHDOG_USEC.
    #[allow(dead_code)] // used by tests/deploy/sd_notify.rs, which includes this module
    pub fn recording(
        watchdog_usec: Option<Duration>,
    ) -> (Self, tokio::sync::mpsc::UnboundedReceiver<String>) {
        let (tx, rx) = tokio::sync::mpsc::unbounded_channel();
        (
            Self {
                sink: Sink::Channel(tx),
                watchdog: watchdog_usec.filter(|d| !d.is_zero()),
                failing: AtomicBool::new(false),
            },
            rx,
        )
    }

    /// Whether messages go anywhere.
    #[allow(dead_code)] // used by tests/deploy/sd_notify.rs
    pub fn enabled(&self) -> bool {
        !matches!(self.sink, Sink::Off)
    }

    /// READY=1: send once the driver has started and the bus is up.
    pub fn ready(&self) {
        self.send(&[NotifyState::Ready]);
    }

    /// STATUS=<text>, shown by `systemctl status`.
    pub fn status(&self, text: &str) {
        // A newline would end the STATUS= assignment early and turn the rest into another one.
        let one_line = text.replace(['\n', '\r'], " ");
        self.send(&[NotifyState::Status(&one_line)]);
    }

    /// STOPPING=1: the orderly shutdown has begun.
    pub fn stopping(&self) {
        self.send(&[NotifyState::Stopping]);
    }

    /// WATCHDOG=1. Prefer `spawn_watchdog`, which sends it only while the actors answer.
    pub fn watchdog(&self) {
        self.send(&[NotifyState::Watchdog]);
    }

    /// How often to send WATCHDOG=1: half of WATCHDOG_USEC, as sd_watchdog_enabled(3) advises.
    pub fn watchdog_period(&self) -> Option<Duration> {
        self.watchdog.map(|d| d / 2)
    }

    fn send(&self, states: &[NotifyState]) {
        let result = match &self.sink {
            Sink::Off => return,
            Sink::Systemd => sd_notify::notify(states),
            Sink::Channel(tx) => {
                let msg: String = states.iter().map(|s| format!("{s}\n")).collect();
                tx.send(msg)
                    .map_err(|_| std::io::Error::other("receiver gone"))
            }
        };
        match result {
            Ok(()) => {
                if self.failing.swap(false, Ordering::Relaxed) {
                    tracing::info!("sd_notify works again");
                }
            }
            Err(e) => {
                if !self.failing.swap(true, Ordering::Relaxed) {
                    tracing::warn!(error = %e, "sd_notify failed; systemd does not see our state");
                }
            }
        }
    }
}

/// Lower-case word of a protobuf enum name with its prefix removed: FRONTSEAT_IN_CONTROL →
/// in_control.
fn word(name: &str, prefix: &str) -> String {
    name.strip_prefix(prefix)
        .unwrap_or(name)
        .to_ascii_lowercase()
}

/// The STATUS text of one InterfaceStatus: Goby3's state words, then the frontseat and helm
/// states, then the error when there is one, e.g.
/// `error:fs frontseat=not_connected helm=drive error=frontseat_not_connected`.
pub fn status_text(s: &InterfaceStatus) -> String {
    let mut text = format!(
        "{} frontseat={} helm={}",
        state_words(s.state()),
        word(s.frontseat_state().as_str_name(), "FRONTSEAT_"),
        word(s.helm_state().as_str_name(), "HELM_"),
    );
    if s.helm_error() != HelmError::ErrorHelmNone {
        text.push_str(" error=");
        text.push_str(&word(s.helm_error().as_str_name(), "ERROR_"));
    }
    if s.frontseat_error() != FrontSeatError::ErrorFrontseatNone {
        text.push_str(" error=");
        text.push_str(&word(s.frontseat_error().as_str_name(), "ERROR_"));
    }
    text
}

/// STATUS=<state words> frontseat=<..> helm=<..> at every status change. Subscribes before it
/// returns, so call it before starting the interface to report the first `standby` too. Ends when
/// the bus is gone.
pub fn spawn_status_reporter(n: Arc<Notifier>, bus: &Bus) -> JoinHandle<()> {
    let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel();
    let sub = SystemdInterfaceWatchInbox::subscribe_all(bus, "systemd", 64, move |m| {
        tx.send(m).map_err(|_| Undeliverable)
    });
    tokio::spawn(async move {
        let _sub = sub;
        let mut last = String::new();
        while let Some(SystemdInterfaceWatchInbox::Status(env)) = rx.recv().await {
            let text = status_text(&env.msg);
            drop(env);
            // The periodic status repeats itself; systemd only needs the changes.
            if text != last {
                n.status(&text);
                last = text;
            }
        }
    })
}

/// The STATUS text of the MOOS gateway: whether the MOOSDB link is up, the helm as pHelmIvP
/// reports it, and stale setpoints, e.g. `moos:connected helm=drive` or
/// `moos:disconnected helm=not_running desired=stale reconnects=2`.
pub fn translation_status_text(s: &TranslationStatus) -> String {
    let helm = s
        .helm_state
        .and_then(|h| HelmState::try_from(h).ok())
        .unwrap_or(HelmState::HelmNotRunning);
    let mut text = format!(
        "moos:{} helm={}",
        if s.moos_connected() {
            "connected"
        } else {
            "disconnected"
        },
        word(helm.as_str_name(), "HELM_"),
    );
    if s.desired_stale() {
        text.push_str(" desired=stale");
    }
    if s.reconnects() > 0 {
        text.push_str(&format!(" reconnects={}", s.reconnects()));
    }
    text
}

/// STATUS= for the MOOS gateway at every change of its TranslationStatus; like
/// `spawn_status_reporter`, it subscribes before it returns and ends with the bus.
pub fn spawn_translation_reporter(n: Arc<Notifier>, bus: &Bus) -> JoinHandle<()> {
    let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel();
    let sub = SystemdTranslationWatchInbox::subscribe_all(bus, "systemd", 64, move |m| {
        tx.send(m).map_err(|_| Undeliverable)
    });
    tokio::spawn(async move {
        let _sub = sub;
        let mut last = String::new();
        while let Some(SystemdTranslationWatchInbox::Status(env)) = rx.recv().await {
            let text = translation_status_text(&env.msg);
            drop(env);
            if text != last {
                n.status(&text);
                last = text;
            }
        }
    })
}

/// WATCHDOG=1 every half WATCHDOG_USEC, only while `alive()` resolves true within that period
/// (e.g. the interface answered a snapshot): a hung actor withholds the ping and systemd kills and
/// restarts the service. None when systemd asked for no watchdog.
pub fn spawn_watchdog<F, Fut>(n: Arc<Notifier>, alive: F) -> Option<JoinHandle<()>>
where
    F: Fn() -> Fut + Send + 'static,
    Fut: Future<Output = bool> + Send + 'static,
{
    let period = n.watchdog_period()?;
    Some(tokio::spawn(async move {
        let mut tick = tokio::time::interval(period);
        // After a stall, one ping is enough; a burst would hide how late we were.
        tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
        let mut withheld = false;
        loop {
            tick.tick().await;
            let ok = tokio::time::timeout(period, alive()).await.unwrap_or(false);
            if ok {
                if withheld {
                    tracing::info!("supervised actors answer again; watchdog pings resumed");
                    withheld = false;
                }
                n.watchdog();
            } else if !withheld {
                tracing::error!(
                    ?period,
                    "a supervised actor did not answer; withholding WATCHDOG=1 so systemd restarts us"
                );
                withheld = true;
            }
        }
    }))
}

/// The liveness probe of the interface for `spawn_watchdog`: true when the FrontSeatInterface
/// now running (the root supervisor may have restarted it) answers a snapshot within `within`.
/// It holds only the actor reference, so the service itself stays with its supervisor.
pub fn interface_probe(
    current: InterfaceRef,
    within: Duration,
) -> impl Fn() -> Pin<Box<dyn Future<Output = bool> + Send>> + Send + Sync + 'static {
    move || {
        let actor = current.lock().unwrap_or_else(|p| p.into_inner()).clone();
        Box::pin(async move {
            let Some(actor) = actor else { return false };
            match actor.call(FsiMsg::Snapshot, Some(within)).await {
                // Alive: the interface answered, and its driver (if running) is not stuck.
                Ok(ractor::rpc::CallResult::Success(s)) => {
                    if !s.driver_responsive {
                        tracing::error!("the driver actor is stuck in a handler");
                    }
                    s.driver_responsive
                }
                Ok(_) => false,
                Err(_) => false,
            }
        })
    }
}

/// The FrontSeatInterface actor now running, set by each (re)start under the root supervisor.
pub type InterfaceRef = std::sync::Arc<std::sync::Mutex<Option<ractor::ActorRef<FsiMsg>>>>;
