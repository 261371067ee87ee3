//! The Simulator's place on the bus when the basic simulator runs inside this process (demo,
//! tests, chaos): each vehicle's ground truth goes out on `frontseat::sim::ground_truth`, faults
//! come in on `frontseat::sim::fault`. The simulator itself stays a plain crate with no bus.

use frontseat_sim::{CtrlState, Fault, SimHandle, Truth};

use crate::bus::{Bus, Subscription, Undeliverable};
use crate::clock::SimClock;
use crate::ports::{SimulatorInbox, SimulatorPorts};
use crate::proto::frontseat::protobuf::{SimFault, sim_fault};
use crate::proto::goby::middleware::frontseat::protobuf::{
    CartesianCoordinate, EulerAngles, NodeStatus, Speed,
};
use crate::proto::goby::middleware::protobuf::LatLonPoint;

pub struct EmbeddedSimulator {
    truth_task: tokio::task::JoinHandle<()>,
    fault_task: tokio::task::JoinHandle<()>,
    subs: Vec<Subscription>,
}

impl Drop for EmbeddedSimulator {
    fn drop(&mut self) {
        self.truth_task.abort();
        self.fault_task.abort();
        for s in self.subs.drain(..) {
            s.cancel();
        }
    }
}

/// NodeStatus of a vehicle's ground truth; local_fix is around the vehicle's START point.
pub fn truth_to_node_status(t: &Truth) -> NodeStatus {
    NodeStatus {
        time: SimClock::unix_now(),
        name: Some(format!("sim-vehicle-{}", t.vehicle)),
        global_fix: LatLonPoint {
            lat: t.lat,
            lon: t.lon,
            depth: Some(t.depth),
            altitude: None,
        },
        local_fix: Some(CartesianCoordinate {
            x: t.x,
            y: t.y,
            z: Some(-t.depth),
        }),
        pose: EulerAngles {
            heading: Some(t.heading),
            ..Default::default()
        },
        speed: Speed {
            over_ground: t.speed,
            over_water: None,
        },
        ..Default::default()
    }
}

pub fn fault_from_proto(f: &SimFault) -> Option<Fault> {
    Some(match f.fault.as_ref()? {
        sim_fault::Fault::DropConnection(_) => Fault::DropConnection,
        sim_fault::Fault::StopNavSeconds(s) => Fault::StopNav { seconds: *s },
        sim_fault::Fault::GarbageLines(n) => Fault::Garbage { lines: *n },
        sim_fault::Fault::OversizedLine(_) => Fault::OversizedLine,
        sim_fault::Fault::Panic(_) => Fault::Panic,
        sim_fault::Fault::Ctrl(c) => match sim_fault::Ctrl::try_from(*c).ok()? {
            sim_fault::Ctrl::Payload => Fault::Ctrl(CtrlState::Payload),
            sim_fault::Ctrl::Auv => Fault::Ctrl(CtrlState::Auv),
            sim_fault::Ctrl::Idle => Fault::Ctrl(CtrlState::Idle),
        },
    })
}

/// Puts a running simulator on the bus.
pub fn embed(sim: &SimHandle, bus: &Bus) -> EmbeddedSimulator {
    let ports = SimulatorPorts::new(bus);
    let mut truth = sim.subscribe_truth();
    let truth_task = tokio::spawn(async move {
        loop {
            match truth.recv().await {
                Ok(t) => {
                    ports.publish_ground_truth(truth_to_node_status(&t));
                }
                Err(tokio::sync::broadcast::error::RecvError::Lagged(n)) => {
                    tracing::debug!(missed = n, "ground truth publisher lagged");
                }
                Err(tokio::sync::broadcast::error::RecvError::Closed) => return,
            }
        }
    });
    let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel::<SimulatorInbox>();
    let subs = SimulatorInbox::subscribe_all(bus, "Simulator", 256, move |m| {
        tx.send(m).map_err(|_| Undeliverable)
    });
    let handle = sim.clone();
    let fault_task = tokio::spawn(async move {
        while let Some(m) = rx.recv().await {
            match m {
                SimulatorInbox::Fault(env) => match fault_from_proto(&env.msg) {
                    Some(f) => {
                        let vehicle = env.msg.vehicle.filter(|v| *v != 0);
                        tracing::info!(?f, ?vehicle, "injecting simulator fault");
                        handle.inject(vehicle, f);
                    }
                    None => tracing::warn!("SimFault without a known fault; ignored"),
                },
            }
        }
    });
    EmbeddedSimulator {
        truth_task,
        fault_task,
        subs,
    }
}
