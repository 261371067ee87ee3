//! What the setpoint lane tests share: actors/tests/setpoint_lane.rs and each vehicle crate's
//! tests/setpoint_lane.rs (which include this file by path, so it uses only what all of them
//! have: frontseat-actors with `test-util`, frontseat-config, frontseat-drivers, tokio).
//! It owns the test helm, bringing the real interface to COMMAND, the back-to-back mix of
//! setpoints a helm's task publishes, and counting the answers to the command_requests.
#![allow(dead_code)]

use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, mpsc};
use std::time::{Duration, Instant};

use frontseat_actors::bus::test_util::UntypedBus as _;
use frontseat_actors::bus::{Bus, Envelope, Subscription};
use frontseat_actors::groups;
use frontseat_actors::interface::{InterfaceService, Snapshot};
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    CommandRequest, CommandResponse, DesiredCourse, HelmState, HelmStateReport, InterfaceState,
};
use frontseat_config::InterfaceConfig;

/// A course east at `speed` to `depth` (every depth the tests use is inside the default
/// envelope's 300 m).
pub fn course(depth: f64, speed: f64) -> DesiredCourse {
    DesiredCourse {
        heading: Some(90.0),
        speed: Some(speed),
        depth: Some(depth),
        ..Default::default()
    }
}

/// A helm that keeps saying it drives (as pHelmIvP does), from a plain thread, until stopped.
pub struct Helm(Arc<AtomicBool>);

impl Helm {
    pub fn stop(&self) {
        self.0.store(false, Ordering::Release);
    }
}

/// The real interface with the built-in drivers on `cfg`, a helm driving, once it reported
/// COMMAND within `deadline`.
pub async fn in_command(
    cfg: &InterfaceConfig,
    deadline: Duration,
) -> (Bus, InterfaceService, Helm) {
    let bus = Bus::new();
    let (state_tx, states) = mpsc::channel();
    let state_tx = Mutex::new(state_tx);
    let _status = bus.subscribe(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_STATUS,
        "test-status",
        1024,
        move |env| {
            let _ = state_tx.lock().unwrap().send(env.msg.state());
            Ok(())
        },
    );
    let service = InterfaceService::start(cfg, &bus, frontseat_drivers::BUILT_IN)
        .await
        .expect("the interface starts");
    let helm = Arc::new(AtomicBool::new(true));
    {
        let (bus, helm) = (bus.clone(), helm.clone());
        std::thread::spawn(move || {
            while helm.load(Ordering::Acquire) {
                bus.publish(
                    &groups::GOBY_MIDDLEWARE_FRONTSEAT_HELM_STATE,
                    HelmStateReport {
                        state: HelmState::HelmDrive as i32,
                    },
                );
                std::thread::sleep(Duration::from_millis(100));
            }
        });
    }
    tokio::task::spawn_blocking(move || {
        let until = Instant::now() + deadline;
        loop {
            match states.recv_timeout(until.saturating_duration_since(Instant::now())) {
                Ok(InterfaceState::InterfaceCommand) => return,
                Ok(_) => {}
                Err(e) => panic!("the interface never reached COMMAND: {e}"),
            }
        }
    })
    .await
    .unwrap();
    (bus, service, Helm(helm))
}

/// The next `n` things `rx` gets, each within `deadline`; `what` names one in the panic.
pub fn recv_n<T>(rx: &mpsc::Receiver<T>, n: usize, deadline: Duration, what: &str) -> Vec<T> {
    (0..n)
        .map(|i| {
            rx.recv_timeout(deadline)
                .unwrap_or_else(|_| panic!("{what} {i} of {n} never reached the vehicle"))
        })
        .collect()
}

/// What [`publish_mix`] published: the depths that should reach the vehicle, in order; the ids
/// of the command_requests that asked for an answer; how many courses the envelope refuses.
pub struct Mix {
    pub expected: Vec<f64>,
    pub asked: Vec<i32>,
    pub refused: u64,
}

/// Back to back from a plain thread, depth `i` for i in 1..=n: courses (the lane's), every 10th
/// a command_request carrying its course (the actors' path; asking for an answer with id `i`
/// when `ask`), every 7th a course over the speed limit (refused, never written).
pub async fn publish_mix(bus: &Bus, n: u32, ask: bool) -> Mix {
    let bus = bus.clone();
    let publisher = std::thread::spawn(move || {
        let mut mix = Mix {
            expected: Vec::new(),
            asked: Vec::new(),
            refused: 0,
        };
        for i in 1..=n {
            let depth = f64::from(i);
            if i % 7 == 0 {
                bus.publish(
                    &groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE,
                    course(depth, 1e6),
                );
                mix.refused += 1;
                continue;
            }
            if i % 10 == 0 {
                let mut request = CommandRequest {
                    desired_course: Some(course(depth, 1.0)),
                    ..Default::default()
                };
                if ask {
                    request.response_requested = Some(true);
                    request.request_id = Some(i as i32);
                    mix.asked.push(i as i32);
                }
                bus.publish(&groups::GOBY_MIDDLEWARE_FRONTSEAT_COMMAND_REQUEST, request);
            } else {
                bus.publish(
                    &groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE,
                    course(depth, 1.0),
                );
            }
            mix.expected.push(depth);
        }
        mix
    });
    tokio::task::spawn_blocking(move || publisher.join().unwrap())
        .await
        .unwrap()
}

/// [`publish_mix`], then what `read` gets of the `n` setpoints that passed (on a blocking thread,
/// `reader` lent to it and given back) must be their depths, once each, in publish order.
pub async fn mix_arrives_in_order<R: Send + 'static>(
    bus: &Bus,
    n: u32,
    ask: bool,
    reader: R,
    read: fn(&R, usize) -> Vec<f64>,
) -> (Mix, R) {
    let mix = publish_mix(bus, n, ask).await;
    let passed = mix.expected.len();
    let (got, reader) = tokio::task::spawn_blocking(move || (read(&reader, passed), reader))
        .await
        .unwrap();
    assert_eq!(
        got, mix.expected,
        "every setpoint that passed reached the vehicle once, in publish order, none refused, none resent"
    );
    (mix, reader)
}

/// The COMMAND_RESPONSE group as a channel, for [`one_answer_each`].
pub fn responses(
    bus: &Bus,
) -> (
    Subscription,
    tokio::sync::mpsc::UnboundedReceiver<Envelope<CommandResponse>>,
) {
    bus.subscribe_channel(
        &groups::GOBY_MIDDLEWARE_FRONTSEAT_COMMAND_RESPONSE,
        "test-responses",
        10_000,
    )
}

/// Asserts the envelope refused `refused` courses between `before` and `after`, and that the
/// lane took some of the `passed` that passed (printing how they split); returns how many.
pub fn took_the_lane(before: &Snapshot, after: &Snapshot, passed: usize, refused: u64) -> u64 {
    assert_eq!(after.setpoints_refused - before.setpoints_refused, refused);
    let direct = after.setpoints_direct - before.setpoints_direct;
    println!(
        "{direct} courses through the lane, {} through the actors",
        passed as u64 - direct
    );
    assert!(direct > 0, "no course went through the lane");
    direct
}

/// Asserts every command_request in `asked` got exactly one successful answer on `responses`
/// (within `deadline`) and nothing else did; returns the service's snapshot, taken before the
/// last look for late duplicates so they have had time to come.
pub async fn one_answer_each(
    responses: &mut tokio::sync::mpsc::UnboundedReceiver<Envelope<CommandResponse>>,
    asked: &[i32],
    service: &InterfaceService,
    deadline: Duration,
) -> Snapshot {
    let mut answers: HashMap<i32, u32> = HashMap::new();
    let until = tokio::time::Instant::now() + deadline;
    while answers.len() < asked.len() {
        let env = tokio::time::timeout_at(until, responses.recv())
            .await
            .expect("every asked command_request answered in time")
            .expect("bus alive");
        let id = env.msg.request_id.expect("an answer names its request");
        assert_eq!(env.msg.request_successful, Some(true), "{:?}", env.msg);
        *answers.entry(id).or_default() += 1;
    }
    let after = service.snapshot(deadline).await.expect("a snapshot");
    // Late duplicates would have come with the others' answers; none may.
    while let Ok(env) = responses.try_recv() {
        *answers.entry(env.msg.request_id.unwrap_or(-1)).or_default() += 1;
    }
    let mut want = asked.to_vec();
    want.sort_unstable();
    let mut got: Vec<i32> = answers.keys().copied().collect();
    got.sort_unstable();
    assert_eq!(got, want, "answers only to what asked");
    assert!(
        answers.values().all(|&c| c == 1),
        "exactly one answer each: {answers:?}"
    );
    after
}
