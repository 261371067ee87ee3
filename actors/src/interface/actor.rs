//! The FrontSeatInterface actor: its start (subscriptions, timers, the driver's nested
//! supervisor), its dispatch of each message to the handling modules, the supervision events of
//! the driver's supervisor (giving up ends the service), and its cleanup.

use std::collections::HashMap;
use std::sync::Arc;
use std::time::Duration;

use ractor::{Actor, ActorProcessingErr, ActorRef, SupervisionEvent};
use tokio::sync::watch;

use crate::bus::{Bus, Envelope, Undeliverable};
use crate::chaos::{FaultPort, FaultTarget};
use crate::clock::{SimClock, heartbeat_now};
use crate::driver::DriverFactory;
use crate::nav_gate::DepthContinuity;
use crate::ports::{FrontSeatInterfaceInbox, FrontSeatInterfacePorts};
use crate::proto::goby::middleware::frontseat::protobuf::CommandRequest;
use crate::ratelog::RateLimitedLog;
use crate::setpoint_lane::SetpointLane;
use crate::state_machine::{Inputs, StateMachine};
use crate::supervisor::{ChildDown, ChildFailure, ChildObserver, ServiceExit, spawn_nested};
use frontseat_sim::geodesy::LocalGrid;

use super::messages::{DRIVER_HUNG_AFTER, FsiMsg, Snapshot, error_code};
use super::settings::InterfaceSettings;
use super::state::{Counters, FsiState, state_name};

pub struct FrontSeatInterface;

pub struct FsiArgs {
    pub settings: InterfaceSettings,
    pub bus: Bus,
    pub factory: DriverFactory,
    pub exit: watch::Sender<Option<ServiceExit>>,
}

impl Actor for FrontSeatInterface {
    type Msg = FsiMsg;
    type State = FsiState;
    type Arguments = FsiArgs;

    async fn pre_start(
        &self,
        myself: ActorRef<FsiMsg>,
        args: FsiArgs,
    ) -> Result<FsiState, ActorProcessingErr> {
        let metrics = frontseat_telemetry::metrics::register(&args.settings.name, state_name);
        let lane = SetpointLane::new(args.settings.limits, metrics.clone());
        let me = myself.clone();
        let route = lane.clone();
        use FrontSeatInterfaceInbox as I;
        let subs = FrontSeatInterfaceInbox::subscribe_all(
            &args.bus,
            "FrontSeatInterface",
            args.settings.queue_capacity,
            move |m| {
                // Runs on the publisher's thread: a course the lane takes is at the vehicle
                // when this returns; everything bound for the vehicle that comes here holds
                // the lane's fence until it has left the actors.
                let m = match m {
                    I::DesiredCourse(env) => match route.offer(env) {
                        Ok(()) => return Ok(()),
                        Err(env) => I::DesiredCourse(env),
                    },
                    I::CommandRequest(env) => I::CommandRequest(route.fenced(env)),
                    I::VehicleExtension(env) => I::VehicleExtension(route.fenced(env)),
                    I::RawSendRequest(env) => I::RawSendRequest(route.fenced(env)),
                    other => other,
                };
                me.cast(FsiMsg::Bus(m)).map_err(|_| Undeliverable)
            },
        );
        let clock = SimClock::new(args.settings.warp);
        let frame = match LocalGrid::new(args.settings.origin.0, args.settings.origin.1) {
            Ok(f) => Some(f),
            Err(e) => {
                tracing::error!(target: super::LOG_TARGET, error = %e, "bad origin: local_fix will not be computed");
                None
            }
        };
        let mut timers =
            vec![myself.send_interval(clock.wall(Duration::from_millis(100)), || FsiMsg::Tick)];
        if !args.settings.status_period.is_zero() {
            timers.push(
                myself.send_interval(clock.wall(args.settings.status_period), || {
                    FsiMsg::StatusTick
                }),
            );
        }
        let faults =
            FaultPort::open_if(args.settings.fault_ports, &args.bus, FaultTarget::Interface);
        let mut state = FsiState {
            faults,
            sm: StateMachine::new(args.settings.sm.clone()),
            ports: FrontSeatInterfacePorts::new(&args.bus),
            bus: args.bus,
            factory: args.factory,
            clock,
            inputs: Inputs::default(),
            helm_heard: tokio::time::Instant::now(),
            helm_state_timeout: clock.wall(args.settings.helm_state_timeout),
            frame,
            drivers: None,
            driver_live: false,
            driver_up: false,
            driver_heartbeat: Arc::new(std::sync::atomic::AtomicU64::new(heartbeat_now())),
            restarts: 0,
            pending: HashMap::new(),
            counters: Counters::default(),
            lane,
            refused_log: RateLimitedLog::for_bad_input(),
            nav_log: RateLimitedLog::for_bad_input(),
            nav_drop_log: RateLimitedLog::for_bad_input(),
            depth_continuity: DepthContinuity::default(),
            raw_log: RateLimitedLog::for_bad_input(),
            raw_refused_log: RateLimitedLog::for_bad_input(),
            metrics,
            shutting_down: false,
            exit: args.exit,
            subs,
            timers,
            s: args.settings,
        };
        let me = myself.clone();
        let observer: ChildObserver = Arc::new(move |down: ChildDown| {
            let _ = me.cast(FsiMsg::DriverDown(down.why));
        });
        let child = state.driver_child(&myself);
        state.drivers = Some(
            spawn_nested(
                "FrontSeatInterface",
                vec![child],
                myself.get_cell(),
                Some(observer),
            )
            .await?,
        );
        state.publish_status();
        tracing::info!(target: super::LOG_TARGET, state = "standby", "frontseat interface started");
        Ok(state)
    }

    async fn handle(
        &self,
        myself: ActorRef<FsiMsg>,
        msg: FsiMsg,
        st: &mut FsiState,
    ) -> Result<(), ActorProcessingErr> {
        use tracing::Instrument;
        let span = tracing::trace_span!(
            target: "frontseat_actors",
            "actor.handle",
            actor = "FrontSeatInterface",
            message = msg.kind(),
        );
        let result = self.handle_inner(myself, msg, st).instrument(span).await;
        st.sync_lane();
        result
    }

    async fn handle_supervisor_evt(
        &self,
        myself: ActorRef<FsiMsg>,
        evt: SupervisionEvent,
        st: &mut FsiState,
    ) -> Result<(), ActorProcessingErr> {
        self.supervise(myself, evt, st).await
    }

    async fn post_stop(
        &self,
        myself: ActorRef<FsiMsg>,
        st: &mut FsiState,
    ) -> Result<(), ActorProcessingErr> {
        self.cleanup(myself, st).await
    }
}

impl FrontSeatInterface {
    async fn handle_inner(
        &self,
        myself: ActorRef<FsiMsg>,
        msg: FsiMsg,
        st: &mut FsiState,
    ) -> Result<(), ActorProcessingErr> {
        use FrontSeatInterfaceInbox as I;
        if crate::chaos::take(&st.faults).is_some() {
            tracing::warn!(target: super::LOG_TARGET, "chaos: making the FrontSeatInterface panic");
            panic!("chaos: FrontSeatInterface panic injected");
        }
        match msg {
            FsiMsg::Bus(inbox) => match inbox {
                I::CommandRequest(env) => st.handle_command(env),
                I::DesiredCourse(env) => {
                    let req = CommandRequest {
                        desired_course: Some(*env.msg),
                        ..Default::default()
                    };
                    let env2 = Envelope::rewrap(env, req);
                    st.handle_command(env2);
                }
                I::DataToFrontseat(env) => {
                    if st.listen_or_command() {
                        st.ports
                            .publish_data_to_frontseat_with(env.msg.clone(), env.meta());
                    } else {
                        st.counters.data_gated += 1;
                        tracing::debug!(target: super::LOG_TARGET, "data_to_frontseat dropped: not in listen or command");
                    }
                }
                I::VehicleExtension(env) => st.handle_extension_to_frontseat(env),
                I::RawSendRequest(env) => st.handle_raw_send(env),
                I::HelmState(env) => {
                    let helm = env.msg.state();
                    if helm != st.inputs.helm {
                        tracing::info!(target: super::LOG_TARGET, ?helm, "helm state");
                    }
                    st.inputs.helm = helm;
                    st.helm_heard = tokio::time::Instant::now();
                    st.evaluate(&myself);
                }
                I::DatumUpdate(env) => {
                    let d = env.msg.datum;
                    match LocalGrid::new(d.lat, d.lon) {
                        Ok(f) => {
                            tracing::info!(target: super::LOG_TARGET, lat = d.lat, lon = d.lon, "datum updated");
                            st.frame = Some(f);
                        }
                        Err(e) => {
                            tracing::warn!(target: super::LOG_TARGET, error = %e, "datum_update refused")
                        }
                    }
                }
                I::CommandResponse(env) => st.handle_driver_response(env),
                I::DataFromFrontseat(env) => st.handle_data_from_frontseat(env),
                I::ExtensionFromFrontseat(env) => st.handle_extension_data(env),
                I::RawFromFrontseat(env) => {
                    st.ports.publish_raw_in_with(env.msg.clone(), env.meta());
                }
                I::RawToFrontseat(env) => {
                    st.ports.publish_raw_out_with(env.msg.clone(), env.meta());
                }
                I::Status(env) => {
                    // A status from a driver we already consider dead must not revive it.
                    if st.driver_live {
                        st.inputs.frontseat = env.msg.frontseat_state();
                        st.inputs.providing_data = env.msg.providing_data();
                        st.evaluate(&myself);
                    }
                }
            },
            FsiMsg::Tick => {
                if !st.helm_state_timeout.is_zero()
                    && st.inputs.helm != crate::proto::goby::middleware::frontseat::protobuf::HelmState::HelmNotRunning
                    && st.helm_heard.elapsed() > st.helm_state_timeout
                {
                    tracing::warn!(
                        target: super::LOG_TARGET,
                        timeout = ?st.helm_state_timeout,
                        "helm_state not heard within helm_state_timeout: helm treated as not running"
                    );
                    st.inputs.helm =
                        crate::proto::goby::middleware::frontseat::protobuf::HelmState::HelmNotRunning;
                }
                st.fail_pending(
                    error_code::TIMEOUT,
                    "no answer from the frontseat in time",
                    true,
                );
                st.log_due_summaries();
                st.evaluate(&myself);
            }
            FsiMsg::StatusTick => st.publish_status(),
            FsiMsg::DriverStarting { restarts } => {
                st.driver_live = true;
                st.restarts = restarts;
            }
            FsiMsg::DriverUp => st.driver_up = st.driver_live,
            FsiMsg::DriverDown(why) => st.driver_down(&myself, &why),
            FsiMsg::Shutdown(reply) => {
                tracing::info!(
                    target: super::LOG_TARGET,
                    "orderly shutdown: refusing commands, closing the frontseat connection"
                );
                st.shutting_down = true;
                st.fail_pending(error_code::SHUTTING_DOWN, "interface shutting down", false);
                st.publish_status();
                if let Some(d) = st.drivers.take() {
                    // The driver's supervisor stops it (an orderly stop: the driver closes its
                    // frontseat connection) and restarts nothing. Give it a moment to flush.
                    let _ = d
                        .stop_and_wait(
                            Some("orderly shutdown".into()),
                            Some(Duration::from_millis(500)),
                        )
                        .await;
                }
                st.exit.send_replace(Some(ServiceExit::Clean));
                let _ = reply.send(());
                myself.stop(Some("orderly shutdown".into()));
            }
            FsiMsg::Snapshot(reply) => {
                let _ = reply.send(Snapshot {
                    status: st.status(),
                    providing_data: st.inputs.providing_data,
                    driver_restarts: st.restarts,
                    driver_up: st.driver_up,
                    driver_responsive: !st.driver_up
                        || heartbeat_now().saturating_sub(
                            st.driver_heartbeat
                                .load(std::sync::atomic::Ordering::Relaxed),
                        ) < DRIVER_HUNG_AFTER.as_millis() as u64,
                    commands_gated: st.counters.commands_gated,
                    setpoints_refused: st.counters.setpoints_refused,
                    nav_refused: st.counters.nav_refused,
                    nav_fields_dropped: st.counters.nav_fields_dropped,
                    nav_field_violations: st.counters.nav_field_violations,
                    raw_sent: st.counters.raw_sent,
                    raw_refused: st.counters.raw_refused,
                    setpoints_direct: st.lane.direct_sent(),
                });
            }
        }
        Ok(())
    }

    async fn supervise(
        &self,
        myself: ActorRef<FsiMsg>,
        evt: SupervisionEvent,
        st: &mut FsiState,
    ) -> Result<(), ActorProcessingErr> {
        // ractor's default would stop us with the child. The driver's supervisor ends only when
        // it gave up (its failure carries the restart limit's reason) or when we stopped it.
        let is_drivers = |cell: &ractor::ActorCell| {
            st.drivers.as_ref().map(|d| d.get_id()) == Some(cell.get_id())
        };
        let exit = match evt {
            SupervisionEvent::ActorFailed(cell, err) if is_drivers(&cell) => {
                match err.downcast_ref::<ChildFailure>() {
                    Some(ChildFailure {
                        exit: Some(ServiceExit::RestartLimit(reason)),
                        ..
                    }) => ServiceExit::RestartLimit(reason.clone()),
                    _ => ServiceExit::Failed(format!("driver supervisor failed: {err}")),
                }
            }
            SupervisionEvent::ActorTerminated(cell, _, reason) if is_drivers(&cell) => {
                ServiceExit::Failed(format!(
                    "driver supervisor stopped: {}",
                    reason.unwrap_or_default()
                ))
            }
            _ => return Ok(()),
        };
        st.drivers = None;
        let why = match &exit {
            ServiceExit::RestartLimit(w) | ServiceExit::Failed(w) => w.clone(),
            _ => String::new(),
        };
        // This may come before the supervisor's word that the driver is down.
        st.driver_down(&myself, &why);
        if !st.shutting_down {
            tracing::error!(target: super::LOG_TARGET, "{why}");
            st.finish(&myself, exit);
        }
        Ok(())
    }

    async fn cleanup(
        &self,
        _myself: ActorRef<FsiMsg>,
        st: &mut FsiState,
    ) -> Result<(), ActorProcessingErr> {
        for t in st.timers.drain(..) {
            t.abort();
        }
        for s in st.subs.drain(..) {
            s.cancel();
        }
        if st.exit.borrow().is_none() {
            st.exit.send_replace(Some(ServiceExit::Clean));
        }
        Ok(())
    }
}
