//! The demo's flying, in this process: one helm per vehicle reaching its interface over Zenoh
//! only — a leader flying the homework path (the example helm) and followers keeping a V behind
//! it from the leader's node_status received over Zenoh (frontseat_demo_helm::trail) — and what
//! it writes: one track CSV per vehicle and one SVG of all of them.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use frontseat_actors::bus::Bus;
use frontseat_actors::clock::SimClock;
use frontseat_actors::groups;
use frontseat_actors::proto::goby::middleware::frontseat::protobuf::NodeStatus;
use frontseat_config::{InterprocessConfig, InterprocessMode};
use frontseat_demo_helm::trail::{self, LeaderFix, Slot, TrailParams};
use frontseat_demo_helm::{self as demo_helm, DemoParams, TrackPoint};
use frontseat_helm_side::{GatewayOptions, key_for};
use prost::Message;
use tokio::sync::watch;

use super::fleet::{LEADER, names};
use crate::demo::DemoArgs;

/// What reached the followers of the leader's node_status, and what was refused.
#[derive(Default)]
struct LeaderFeed {
    received: AtomicU64,
    refused: AtomicU64,
}

/// The flown fleet: each vehicle's name and track, and whether the leader completed its path.
pub struct Flown {
    tracks: Vec<(String, Vec<TrackPoint>)>,
    completed: bool,
    closest_approach_m: f64,
    leader_fixes: u64,
    refused: u64,
}

/// Connects one Zenoh session to every interface, bridges each vehicle's helm bus to its
/// platform, and flies the leader's path with the followers trailing until it is done.
pub async fn fly(
    args: &DemoArgs,
    n: usize,
    endpoints: Vec<String>,
    slots: &[Slot],
) -> Result<Flown, String> {
    let ip = InterprocessConfig {
        enabled: true,
        mode: InterprocessMode::Peer,
        listen: Vec::new(),
        connect: endpoints,
        platform: String::new(),
        ..Default::default()
    };
    let zcfg = frontseat_helm_side::zenoh_config(&ip, frontseat_helm_side::DEFAULT_MAX_PAYLOAD)
        .map_err(|e| e.to_string())?;
    let session = frontseat_helm_side::zenoh::open(zcfg)
        .await
        .map_err(|e| format!("cannot open the Zenoh session: {e}"))?;
    let names = names(n);
    let mut buses = Vec::new();
    let mut gateways = Vec::new();
    for name in &names {
        let bus = Bus::new();
        let plan = frontseat_helm_side::plan(groups::ALL, name, &["DemoHelm"])
            .map_err(|e| e.to_string())?;
        let g = frontseat_helm_side::start_on(
            &bus,
            session.clone(),
            plan,
            name,
            GatewayOptions::default(),
        )
        .await
        .map_err(|e| format!("{name}: {e}"))?;
        buses.push(bus);
        gateways.push(g);
    }
    // The leader's node_status, as every follower hears it over Zenoh: bounded, decoded, checked.
    let (fix_tx, fix_rx) = watch::channel(None::<LeaderFix>);
    let feed = Arc::new(LeaderFeed::default());
    let counted = feed.clone();
    let leader_key = key_for(LEADER, groups::GOBY_MIDDLEWARE_FRONTSEAT_NODE_STATUS.name());
    let _leader_sub = session
        .declare_subscriber(leader_key.clone())
        .callback(move |s| {
            let bytes = s.payload().to_bytes();
            let fix = (bytes.len() <= frontseat_helm_side::DEFAULT_MAX_PAYLOAD)
                .then(|| NodeStatus::decode(&*bytes).ok())
                .flatten()
                .and_then(|ns| {
                    let l = ns.local_fix.as_ref()?;
                    Some(LeaderFix {
                        x: l.x,
                        y: l.y,
                        heading: ns.pose.heading(),
                        speed: ns.speed.over_ground,
                    })
                })
                .filter(LeaderFix::plausible);
            match fix {
                Some(f) => {
                    counted.received.fetch_add(1, Ordering::Relaxed);
                    let _ = fix_tx.send(Some(f));
                }
                None => {
                    let k = counted.refused.fetch_add(1, Ordering::Relaxed) + 1;
                    if frontseat_helm_side::wire::worth_logging(k) {
                        tracing::warn!(
                            count = k,
                            "leader node_status refused (oversized, undecodable or implausible)"
                        );
                    }
                }
            }
        })
        .await
        .map_err(|e| format!("cannot subscribe {leader_key}: {e}"))?;
    let clock = SimClock::new(args.warp);
    let (done_tx, done_rx) = watch::channel(false);
    let mut followers = Vec::new();
    for (k, slot) in slots.iter().enumerate() {
        let bus = buses[k + 1].clone();
        let (fix, done) = (fix_rx.clone(), done_rx.clone());
        let params = TrailParams::new(*slot);
        followers.push(tokio::spawn(async move {
            trail::run(&bus, clock, params, fix, done).await
        }));
    }
    let params = DemoParams {
        east_s: args.east,
        south_s: args.south,
        ..Default::default()
    };
    let lines = args.lines;
    let report = demo_helm::run(&buses[0], clock, params, |s| {
        if lines {
            println!("{LEADER}: {}", s.line());
        }
    })
    .await;
    let _ = done_tx.send(true);
    let mut tracks = vec![(LEADER.to_string(), report.track)];
    for (k, f) in followers.into_iter().enumerate() {
        let t = f
            .await
            .map_err(|e| format!("follower{} helm: {e}", k + 1))?;
        tracks.push((names[k + 1].clone(), t));
    }
    // The followers' last stop must leave before the session closes.
    tokio::time::sleep(Duration::from_millis(200)).await;
    drop(gateways);
    let _ = session.close().await;
    Ok(Flown {
        tracks,
        completed: report.completed,
        closest_approach_m: report.closest_approach_m,
        leader_fixes: feed.received.load(Ordering::Relaxed),
        refused: feed.refused.load(Ordering::Relaxed),
    })
}

/// `--fleet-connect`: the helms alone, against interfaces someone else started (other hosts).
pub async fn helms_only(args: &DemoArgs, n: usize) -> ExitCode {
    if args.fleet_connect.len() != n {
        eprintln!(
            "--fleet-connect names {} endpoints for --fleet {n}: one per vehicle, leader first",
            args.fleet_connect.len()
        );
        return ExitCode::from(2);
    }
    let slots: Vec<Slot> = (1..n)
        .map(|k| Slot::in_v(k, args.trail_behind, args.trail_side))
        .collect();
    eprintln!(
        "frontseat demo --fleet {n}: helms only, for {} at {}",
        names(n).join(", "),
        args.fleet_connect.join(", ")
    );
    match fly(args, n, args.fleet_connect.clone(), &slots).await {
        Ok(flown) => write_outputs(&args.out, &flown),
        Err(e) => {
            eprintln!("frontseat demo --fleet: {e}");
            ExitCode::from(1)
        }
    }
}

fn csv_path(out: &Path, name: &str) -> PathBuf {
    out.join(format!("track-{name}.csv"))
}

pub fn write_outputs(out: &Path, flown: &Flown) -> ExitCode {
    for (name, track) in &flown.tracks {
        let path = csv_path(out, name);
        if let Err(e) = std::fs::write(&path, demo_helm::track_csv(track)) {
            eprintln!("cannot write {}: {e}", path.display());
            return ExitCode::from(1);
        }
    }
    let svg = out.join("fleet.svg");
    let title = format!(
        "frontseat demo --fleet {}: {LEADER} on the homework path, followers trailing",
        flown.tracks.len()
    );
    if let Err(e) = std::fs::write(&svg, demo_helm::fleet_svg(&title, &flown.tracks)) {
        eprintln!("cannot write {}: {e}", svg.display());
        return ExitCode::from(1);
    }
    for (name, track) in &flown.tracks {
        println!(
            "{name}: {} points -> {}",
            track.len(),
            csv_path(out, name).display()
        );
    }
    println!(
        "leader node_status heard over Zenoh: {} (refused {}); closest approach to the start: {:.1} m; wrote {}",
        flown.leader_fixes,
        flown.refused,
        flown.closest_approach_m,
        svg.display()
    );
    if flown.completed {
        ExitCode::SUCCESS
    } else {
        eprintln!("the leader did not complete the path");
        ExitCode::from(1)
    }
}
