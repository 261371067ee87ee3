//! A helm in its own process, talking to `frontseat interface` over Zenoh only: the Goby3 course
//! homework. helm_state DRIVE at 1 Hz; once the interface reports COMMAND, 1.5 m/s due east for
//! T1 s, due south for T2 s, then northwest until the vehicle stops closing on its start. Leg
//! times are vehicle seconds: wall seconds times --warp, which must match the interface's
//! sim_warp_factor when the simulator runs warped.
//!
//! cargo run -p frontseat-helm-side --example helm -- [--connect tcp/127.0.0.1:7447]
//!     [--platform auv1] [--t1 60] [--t2 60] [--speed 1.5] [--warp 1] [--timeout 600]
//! Exits 0 when the triangle is done, 1 on timeout, 2 on bad arguments.

use std::process::ExitCode;
use std::time::Duration;

use frontseat_actors::groups;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::{
    DesiredCourse, HelmState, HelmStateReport, InterfaceState, InterfaceStatus, NodeStatus,
};
use frontseat_helm_side::{client_config, key_for, put_message};
use prost::Message;

struct Args {
    connect: String,
    platform: String,
    t1: f64,
    t2: f64,
    speed: f64,
    warp: f64,
    timeout: f64,
}

fn parse_args() -> Result<Args, String> {
    let mut a = Args {
        connect: "tcp/127.0.0.1:7447".into(),
        platform: "auv1".into(),
        t1: 60.0,
        t2: 60.0,
        speed: 1.5,
        warp: 1.0,
        timeout: 600.0,
    };
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        let mut val = || it.next().ok_or(format!("{flag} needs a value"));
        let num = |v: String| v.parse::<f64>().map_err(|e| format!("{flag} {v:?}: {e}"));
        match flag.as_str() {
            "--connect" => a.connect = val()?,
            "--platform" => a.platform = val()?,
            "--t1" => a.t1 = num(val()?)?,
            "--t2" => a.t2 = num(val()?)?,
            "--speed" => a.speed = num(val()?)?,
            "--warp" => a.warp = num(val()?)?,
            "--timeout" => a.timeout = num(val()?)?,
            other => return Err(format!("unknown argument {other:?}")),
        }
    }
    Ok(a)
}

enum In {
    Nav(Box<NodeStatus>),
    Status(InterfaceStatus),
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Leg {
    Waiting,
    East,
    South,
    NorthWest,
}

#[tokio::main]
async fn main() -> ExitCode {
    let args = match parse_args() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("helm: {e}");
            return ExitCode::from(2);
        }
    };
    let session = match client_config(std::slice::from_ref(&args.connect)) {
        Ok(cfg) => match zenoh::open(cfg).await {
            Ok(s) => s,
            Err(e) => {
                eprintln!("helm: cannot reach {}: {e}", args.connect);
                return ExitCode::from(1);
            }
        },
        Err(e) => {
            eprintln!("helm: {e}");
            return ExitCode::from(2);
        }
    };
    let key = |g: &str| key_for(&args.platform, g);
    let (tx, mut rx) = tokio::sync::mpsc::channel::<In>(1024);
    let tx2 = tx.clone();
    // Bad bytes from the network are skipped, never unwrapped.
    let _nav = session
        .declare_subscriber(key(groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS.name()))
        .callback(move |s| {
            if let Ok(m) = NodeStatus::decode(&*s.payload().to_bytes()) {
                let _ = tx.try_send(In::Nav(Box::new(m)));
            }
        })
        .await;
    let _status = session
        .declare_subscriber(key(groups::GOBY_MIDDLEWARE_FRONTSEAT_STATUS.name()))
        .callback(move |s| {
            if let Ok(m) = InterfaceStatus::decode(&*s.payload().to_bytes()) {
                let _ = tx2.try_send(In::Status(m));
            }
        })
        .await;
    let helm_key = key(groups::GOBY_MIDDLEWARE_FRONTSEAT_HELM_STATE.name());
    let course_key = key(groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE.name());
    let helm_type = groups::GOBY_MIDDLEWARE_FRONTSEAT_HELM_STATE.type_name();
    let course_type = groups::GOBY_MIDDLEWARE_FRONTSEAT_DESIRED_COURSE.type_name();
    let drive = HelmStateReport {
        state: HelmState::HelmDrive as i32,
    };

    let t_start = std::time::Instant::now();
    let mut heartbeat = tokio::time::interval(Duration::from_secs(1));
    let deadline = tokio::time::sleep(Duration::from_secs_f64(args.timeout));
    tokio::pin!(deadline);
    let mut leg = Leg::Waiting;
    let mut in_command = false;
    let (mut start, mut leg_t0, mut min_d) = ((0.0, 0.0), 0.0, f64::INFINITY);
    loop {
        tokio::select! {
            _ = &mut deadline => {
                eprintln!("helm: timed out in leg {leg:?}");
                return ExitCode::from(1);
            }
            _ = heartbeat.tick() => {
                if let Err(e) = put_message(&session, &helm_key, helm_type, &drive, None) {
                    eprintln!("helm: helm_state: {e}");
                }
            }
            m = rx.recv() => match m {
                None => return ExitCode::from(1),
                Some(In::Status(s)) => {
                    let now = s.state() == InterfaceState::InterfaceCommand;
                    if now != in_command {
                        println!("interface state {:?}", s.state());
                    }
                    in_command = now;
                }
                Some(In::Nav(ns)) => {
                    let Some(p) = ns.local_fix.as_ref().map(|f| (f.x, f.y)) else { continue };
                    let t = t_start.elapsed().as_secs_f64() * args.warp;
                    let next = match leg {
                        Leg::Waiting if in_command => { start = p; Some(Leg::East) }
                        Leg::East if t - leg_t0 >= args.t1 => Some(Leg::South),
                        Leg::South if t - leg_t0 >= args.t2 => Some(Leg::NorthWest),
                        Leg::NorthWest => {
                            let d = ((p.0 - start.0).powi(2) + (p.1 - start.1).powi(2)).sqrt();
                            if d < min_d {
                                min_d = d;
                            } else if t - leg_t0 > 10.0 && d > min_d + 0.5 {
                                println!("triangle done: closest approach {min_d:.1} m from the start at ({:.1}, {:.1})", p.0, p.1);
                                let stop = DesiredCourse { time: ns.time, heading: Some(315.0), speed: Some(0.0), ..Default::default() };
                                let _ = put_message(&session, &course_key, course_type, &stop, None);
                                let _ = session.close().await;
                                return ExitCode::SUCCESS;
                            }
                            None
                        }
                        _ => None,
                    };
                    if let Some(n) = next {
                        println!("leg {n:?} at t={t:.1} s, position ({:.1}, {:.1})", p.0, p.1);
                        leg = n;
                        leg_t0 = t;
                    }
                    let heading = match leg {
                        Leg::Waiting => continue,
                        Leg::East => 90.0,
                        Leg::South => 180.0,
                        Leg::NorthWest => 315.0,
                    };
                    let dc = DesiredCourse { time: ns.time, heading: Some(heading), speed: Some(args.speed), depth: Some(0.0), ..Default::default() };
                    if let Err(e) = put_message(&session, &course_key, course_type, &dc, None) {
                        eprintln!("helm: desired_course: {e}");
                    }
                }
            }
        }
    }
}
