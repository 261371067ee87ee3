//! The helm on the bus: DRIVE (or PARK, as a fault asks) and a stream of setpoints, each a
//! CommandRequest that asks for its CommandResponse under a fresh request_id.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicI32, Ordering};
use std::time::Duration;

use frontseat_actors::bus::Bus;
use frontseat_actors::ports::ChaosHelmPorts;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CommandRequest, DesiredCourse, HelmState, HelmStateReport,
};
use tokio::sync::watch;

/// A helm on the bus: helm_state every 50 ms (and at once on a change), and every 20 ms a
/// desired_course plus a CommandRequest with response_requested and a fresh request_id.
pub(crate) struct Helm {
    pub(crate) state: watch::Sender<HelmState>,
    pub(crate) commanding: Arc<AtomicBool>,
    pub(crate) last_id: Arc<AtomicI32>,
    pub(crate) task: tokio::task::JoinHandle<()>,
}

impl Helm {
    pub(crate) fn start(bus: &Bus) -> Self {
        let (state, mut rx) = watch::channel(HelmState::HelmDrive);
        let commanding = Arc::new(AtomicBool::new(true));
        let last_id = Arc::new(AtomicI32::new(0));
        let ports = ChaosHelmPorts::new(bus);
        let (c, ids) = (commanding.clone(), last_id.clone());
        let task = tokio::spawn(async move {
            let mut tick = tokio::time::interval(Duration::from_millis(20));
            tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
            let mut n: u64 = 0;
            loop {
                let publish_state = tokio::select! {
                    _ = tick.tick() => { n += 1; n.is_multiple_of(3) }
                    r = rx.changed() => { if r.is_err() { return } true }
                };
                if publish_state {
                    let s = *rx.borrow_and_update();
                    ports.publish_helm_state(HelmStateReport { state: s as i32 });
                }
                if c.load(Ordering::SeqCst) {
                    let heading = ((n * 37) % 360) as f64;
                    let course = DesiredCourse {
                        heading: Some(heading),
                        speed: Some(1.5),
                        depth: Some(0.0),
                        ..Default::default()
                    };
                    ports.publish_desired_course(course);
                    let id = ids.fetch_add(1, Ordering::SeqCst) + 1;
                    ports.publish_command_request(CommandRequest {
                        desired_course: Some(course),
                        response_requested: Some(true),
                        request_id: Some(id),
                        ..Default::default()
                    });
                }
            }
        });
        Self {
            state,
            commanding,
            last_id,
            task,
        }
    }
}

impl Drop for Helm {
    fn drop(&mut self) {
        self.task.abort();
    }
}
