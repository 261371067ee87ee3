//! A scripted pHelmIvP on a MOOSDB, for the tests that fly through a MOOS bridge: it posts
//! IVPHELM_STATE DRIVE and DESIRED_* at 4 Hz, as pHelmIvP's iterations would, and reads
//! NAV_HEADING back.

use std::time::Duration;

use frontseat_moos::{MoosClient, MoosClientConfig, MoosEvent};
use tokio::sync::mpsc::Receiver;
use tokio::time::{Instant, timeout_at};

pub struct ScriptedHelm {
    pub moos: MoosClient,
    events: Receiver<MoosEvent>,
    task: tokio::task::JoinHandle<()>,
}

impl ScriptedHelm {
    /// Connects to the MOOSDB on 127.0.0.1:`port` (MOOSTimeWarp `warp`) and drives `heading`
    /// at 1.5 m/s on the surface.
    pub fn start(port: u16, heading: f64, warp: f64) -> Self {
        let (moos, events) = MoosClient::start(MoosClientConfig {
            server: format!("127.0.0.1:{port}"),
            reconnect_initial: Duration::from_millis(50),
            reconnect_max: Duration::from_millis(200),
            time_warp: warp,
            ..MoosClientConfig::new("pHelmIvP")
        })
        .expect("scripted pHelmIvP starts");
        moos.register("NAV_HEADING", 0.0)
            .expect("register NAV_HEADING");
        let poster = moos.clone();
        let task = tokio::spawn(async move {
            let mut tick = tokio::time::interval(Duration::from_millis(250));
            loop {
                tick.tick().await;
                let _ = poster.notify_string("IVPHELM_STATE", "DRIVE", None);
                let _ = poster.notify_double("DESIRED_DEPTH", 0.0, None);
                let _ = poster.notify_double("DESIRED_SPEED", 1.5, None);
                let _ = poster.notify_double("DESIRED_HEADING", heading, None);
            }
        });
        Self { moos, events, task }
    }

    /// Whether NAV_HEADING came within 5° of `target` before `deadline`.
    pub async fn sees_heading(&mut self, target: f64, deadline: Instant) -> bool {
        let near = |m: &frontseat_moos::MoosMessage| {
            m.key == "NAV_HEADING" && m.as_double().is_some_and(|h| heading_near(h, target, 5.0))
        };
        loop {
            match timeout_at(deadline, self.events.recv()).await {
                Ok(Some(MoosEvent::Mail(m))) if near(&m) => return true,
                Ok(Some(MoosEvent::Packet(p))) if p.iter().any(near) => return true,
                Ok(Some(_)) => {}
                _ => return false,
            }
        }
    }

    pub async fn stop(self) {
        self.task.abort();
        self.moos.shutdown().await;
    }
}

pub fn heading_near(h: f64, target: f64, tol: f64) -> bool {
    let d = (h - target).rem_euclid(360.0);
    d.min(360.0 - d) <= tol
}
