//! Answers goby_coroner, Goby3's health monitor: each HealthRequest on `goby::health::request`
//! gets this process's ProcessHealth on `goby::health::response` (wiring in
//! `interface_yaml/health.yaml`), so a Goby3 system that watches its applications sees the
//! frontseat interface like any Goby3 application instead of "not responding".
//!
//! What it reports comes from what the process already publishes: each child of the root
//! supervisor (`frontseat::supervision::status`: up → OK, down → FAILED with its last failure)
//! and the interface's state (`goby::middleware::frontseat::status`: an error state → DEGRADED).
//! The process's state is the worst of them, as goby_coroner aggregates. It observes those two
//! groups the way the systemd reporter does; it publishes nothing else.

use std::sync::Arc;

use tokio::sync::mpsc;

use crate::bus::{Bus, Subscription, Undeliverable};
use crate::ports::{
    HealthInterfaceWatchInbox, HealthReporterInbox, HealthReporterPorts,
    HealthSupervisionWatchInbox,
};
use crate::proto::frontseat::protobuf::SupervisionStatus;
use crate::proto::goby::middleware::frontseat::protobuf::{InterfaceState, InterfaceStatus};
use crate::proto::goby::middleware::protobuf::{HealthState, ProcessHealth, ThreadHealth};
use crate::state_machine::state_words;

/// Requests waiting to be answered; more are dropped (coroner asks about once a second).
const REQUEST_QUEUE: usize = 16;

/// This process's health from what it knows now. Pure, so it is table-tested.
pub fn process_health(
    name: &str,
    pid: u32,
    supervision: Option<&SupervisionStatus>,
    interface: Option<&InterfaceStatus>,
) -> ProcessHealth {
    let mut children = Vec::new();
    if let Some(s) = supervision {
        for (uid, c) in s.children.iter().enumerate() {
            let up = c.up.unwrap_or(false);
            // A helm-side child down leaves the vehicle link up: degraded, not failed.
            let helm = c.side.as_deref() == Some("helm");
            let since = c
                .down_since
                .map(|t| format!(" (down since Unix time {t:.0})"))
                .unwrap_or_default();
            children.push(ThreadHealth {
                name: c.name.clone().unwrap_or_default(),
                uid: i32::try_from(uid).ok(),
                state: match (up, helm) {
                    (true, _) => HealthState::HealthOk as i32,
                    (false, true) => HealthState::HealthDegraded as i32,
                    (false, false) => HealthState::HealthFailed as i32,
                },
                error_message: if up {
                    None
                } else {
                    Some(format!(
                        "{}{since}",
                        c.last_failure.as_deref().unwrap_or("down")
                    ))
                },
                ..Default::default()
            });
        }
    }
    if let Some(st) = interface {
        let state = st.state();
        let degraded = matches!(
            state,
            InterfaceState::InterfaceFsError | InterfaceState::InterfaceHelmError
        );
        children.push(ThreadHealth {
            name: format!("interface state: {}", state_words(state)),
            state: if degraded {
                HealthState::HealthDegraded as i32
            } else {
                HealthState::HealthOk as i32
            },
            ..Default::default()
        });
    }
    let gave_up = supervision.is_some_and(|s| s.gave_up.unwrap_or(false));
    let worst = children
        .iter()
        .map(|c| c.state)
        .chain(gave_up.then_some(HealthState::HealthFailed as i32))
        .max()
        .unwrap_or(HealthState::HealthOk as i32);
    ProcessHealth {
        name: name.to_string(),
        pid: Some(pid),
        main: ThreadHealth {
            name: name.to_string(),
            thread_id: i32::try_from(pid).ok(),
            state: worst,
            child: children,
            ..Default::default()
        },
    }
}

enum Event {
    Request,
    Supervision(Arc<SupervisionStatus>),
    Interface(Arc<InterfaceStatus>),
}

/// The running reporter; dropping it stops it.
pub struct HealthReporter {
    task: tokio::task::JoinHandle<()>,
    subs: Vec<Subscription>,
}

impl HealthReporter {
    /// Answers as `name` (goby_coroner's `--expected_name`).
    pub fn spawn(bus: &Bus, name: &str) -> Self {
        let (tx, mut rx) = mpsc::channel::<Event>(REQUEST_QUEUE + 128);
        let send = |tx: &mpsc::Sender<Event>, ev| tx.try_send(ev).map_err(|_| Undeliverable);
        let t = tx.clone();
        let mut subs = HealthReporterInbox::subscribe_all(bus, "HealthReporter", REQUEST_QUEUE, {
            move |m| match m {
                HealthReporterInbox::Request(_) => send(&t, Event::Request),
            }
        });
        let t = tx.clone();
        subs.extend(HealthSupervisionWatchInbox::subscribe_all(
            bus,
            "HealthReporter",
            64,
            move |m| match m {
                HealthSupervisionWatchInbox::Status(env) => send(&t, Event::Supervision(env.msg)),
            },
        ));
        let t = tx;
        subs.extend(HealthInterfaceWatchInbox::subscribe_all(
            bus,
            "HealthReporter",
            64,
            move |m| match m {
                HealthInterfaceWatchInbox::Status(env) => send(&t, Event::Interface(env.msg)),
            },
        ));
        let ports = HealthReporterPorts::new(bus);
        let name = name.to_string();
        let task = tokio::spawn(async move {
            let (mut sup, mut iface) = (None, None);
            while let Some(ev) = rx.recv().await {
                match ev {
                    Event::Supervision(s) => sup = Some(s),
                    Event::Interface(s) => iface = Some(s),
                    Event::Request => {
                        let h = process_health(
                            &name,
                            std::process::id(),
                            sup.as_deref(),
                            iface.as_deref(),
                        );
                        ports.publish_response(h);
                    }
                }
            }
        });
        Self { task, subs }
    }

    /// Resolves if the reporter's task ended (it only does when it failed): the reason.
    pub async fn ended(&mut self) -> String {
        let r = (&mut self.task).await;
        // A finished JoinHandle must not be polled again (drop only aborts it).
        self.task = tokio::spawn(async {});
        match r {
            Ok(()) => "the health reporter ended".into(),
            Err(e) => format!("the health reporter failed: {e}"),
        }
    }
}

impl Drop for HealthReporter {
    fn drop(&mut self) {
        for s in self.subs.drain(..) {
            s.cancel();
        }
        self.task.abort();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::groups;
    use crate::proto::frontseat::protobuf::SupervisedActor;

    fn child(name: &str, up: bool, failure: Option<&str>) -> SupervisedActor {
        SupervisedActor {
            name: Some(name.into()),
            up: Some(up),
            restarts: Some(0),
            last_failure: failure.map(str::to_string),
            side: Some("vehicle".into()),
            down_since: None,
        }
    }

    fn helm_child(name: &str, failure: &str) -> SupervisedActor {
        SupervisedActor {
            side: Some("helm".into()),
            down_since: Some(1.7e9),
            ..child(name, false, Some(failure))
        }
    }

    fn status(state: InterfaceState) -> InterfaceStatus {
        InterfaceStatus {
            state: Some(state as i32),
            ..Default::default()
        }
    }

    #[test]
    fn health_table() {
        let all_up = SupervisionStatus {
            supervisor: Some("root".into()),
            children: vec![
                child("FrontSeatInterface", true, None),
                child("Goby3Gateway", true, None),
            ],
            gave_up: Some(false),
            degraded: Some(false),
        };
        let one_down = SupervisionStatus {
            children: vec![
                child("FrontSeatTranslation", true, None),
                child("FrontSeatInterface", false, Some("panicked: boom")),
            ],
            ..all_up.clone()
        };
        let helm_down = SupervisionStatus {
            children: vec![
                child("FrontSeatInterface", true, None),
                helm_child("FrontSeatTranslation", "panicked: boom"),
            ],
            degraded: Some(true),
            ..all_up.clone()
        };
        let rows = [
            ("nothing known yet: OK", None, None, HealthState::HealthOk),
            (
                "every child up, in command: OK",
                Some(&all_up),
                Some(status(InterfaceState::InterfaceCommand)),
                HealthState::HealthOk,
            ),
            (
                "an error state: DEGRADED",
                Some(&all_up),
                Some(status(InterfaceState::InterfaceFsError)),
                HealthState::HealthDegraded,
            ),
            (
                "a vehicle-side child down: FAILED",
                Some(&one_down),
                Some(status(InterfaceState::InterfaceCommand)),
                HealthState::HealthFailed,
            ),
            (
                "a helm-side child down: DEGRADED",
                Some(&helm_down),
                Some(status(InterfaceState::InterfaceCommand)),
                HealthState::HealthDegraded,
            ),
        ];
        for (name, sup, iface, want) in rows {
            let h = process_health("goby_frontseat_interface", 42, sup, iface.as_ref());
            assert_eq!(h.main.state(), want, "{name}");
            assert_eq!(h.name, "goby_frontseat_interface");
            assert_eq!(h.pid, Some(42));
        }
        let h = process_health(
            "x",
            1,
            Some(&one_down),
            Some(&status(InterfaceState::InterfaceCommand)),
        );
        let down = &h.main.child[1];
        assert_eq!(down.name, "FrontSeatInterface");
        assert_eq!(down.error_message.as_deref(), Some("panicked: boom"));
        assert_eq!(h.main.child[2].name, "interface state: running:command");
        let h = process_health("x", 1, Some(&helm_down), None);
        let down = &h.main.child[1];
        assert_eq!(down.state(), HealthState::HealthDegraded);
        assert_eq!(
            down.error_message.as_deref(),
            Some("panicked: boom (down since Unix time 1700000000)")
        );
    }

    #[tokio::test]
    async fn a_request_on_the_bus_is_answered() {
        let bus = Bus::new();
        let (_s, mut rx) = bus.subscribe_channel(&groups::GOBY_HEALTH_RESPONSE, "test", 8);
        let _r = HealthReporter::spawn(&bus, "goby_frontseat_interface");
        bus.publish(
            &groups::GOBY_MIDDLEWARE_FRONTSEAT_STATUS,
            status(InterfaceState::InterfaceHelmError),
        );
        bus.publish(&groups::GOBY_HEALTH_REQUEST, Default::default());
        let env = tokio::time::timeout(std::time::Duration::from_secs(5), rx.recv())
            .await
            .expect("an answer in time")
            .expect("bus open");
        assert_eq!(env.msg.name, "goby_frontseat_interface");
        assert_eq!(env.msg.main.state(), HealthState::HealthDegraded);
    }
}
