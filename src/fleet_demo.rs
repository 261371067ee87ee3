//! `frontseat demo --fleet N`: the lecture's trail example on Zenoh. One basic simulator and one
//! `frontseat interface` *process* per vehicle, started and stopped by the launcher
//! (frontseat-launch) from a launch file this writes (so `frontseat launch` can run the same
//! fleet); then, in this process, one helm per vehicle reaching its interface over Zenoh only: a
//! leader flying the homework path (the example helm) and followers keeping a V behind it from
//! the leader's node_status, received over Zenoh (frontseat_demo_helm::trail). Writes one track
//! CSV per vehicle and one SVG of all of them.

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
use frontseat_launch::LaunchConfig;
use frontseat_launch::config::{LatLon, ProcessEntry, ReadyConfig, ReadyKind, VehicleEntry};
use prost::Message;
use tokio::sync::{oneshot, watch};

use crate::demo::DemoArgs;

/// Most vehicles `--fleet` flies (one interface process each on a shared 2-core laptop).
pub const MAX_FLEET: usize = 12;
/// The leader's vehicle name; followers are `follower1`, `follower2`, …
pub const LEADER: &str = "leader";
/// How long the interfaces may take to come up.
const UP_BOUND: Duration = Duration::from_secs(60);
/// Metres per degree of latitude, near enough for placing start points a few tens of metres
/// apart (the tracks themselves are in the interfaces' exact local grid).
const M_PER_DEG: f64 = 111_320.0;

fn free_port() -> std::io::Result<u16> {
    Ok(std::net::TcpListener::bind("127.0.0.1:0")?
        .local_addr()?
        .port())
}

pub fn names(n: usize) -> Vec<String> {
    std::iter::once(LEADER.to_string())
        .chain((1..n).map(|k| format!("follower{k}")))
        .collect()
}

/// The launch file of the fleet: the simulator, then one interface per vehicle, each from the
/// defaults with its name, ports, the shared datum and its start point (followers in their
/// slots behind a leader heading east, the homework path's first leg).
fn launch_config(
    args: &DemoArgs,
    n: usize,
    sim_port: u16,
    zenoh_ports: &[u16],
) -> (LaunchConfig, Vec<Slot>) {
    let origin = frontseat_config::LatLonConfig::default();
    let slots: Vec<Slot> = (1..n)
        .map(|k| Slot::in_v(k, args.trail_behind, args.trail_side))
        .collect();
    let mut cfg = LaunchConfig {
        stop_timeout_s: 3.0,
        ..Default::default()
    };
    cfg.process.push(ProcessEntry {
        name: "sim".into(),
        command: vec![
            "frontseat".into(),
            "sim".into(),
            "--port".into(),
            sim_port.to_string(),
        ],
        ready: ReadyConfig {
            kind: ReadyKind::Notify,
            ..Default::default()
        },
        ..Default::default()
    });
    for (i, name) in names(n).into_iter().enumerate() {
        let (x, y) = match i {
            0 => (0.0, 0.0),
            k => slots[k - 1].position(0.0, 0.0, 90.0),
        };
        let lat = origin.lat + y / M_PER_DEG;
        let lon = origin.lon + x / (M_PER_DEG * origin.lat.to_radians().cos());
        // The topside takes the --web-listen address; the vehicles' own pages the next ports.
        let web_listen = args.web.then(|| web_address(&args.web_listen, i + 1));
        cfg.vehicle.push(VehicleEntry {
            name,
            sim_port: Some(sim_port),
            zenoh_listen: vec![format!("tcp/127.0.0.1:{}", zenoh_ports[i])],
            start: Some(LatLon { lat, lon }),
            datum: Some(LatLon {
                lat: origin.lat,
                lon: origin.lon,
            }),
            web_listen,
            // A helm cut off (its link, its process) takes its vehicle out of COMMAND.
            set: [
                ("sim_warp_factor".to_string(), serde_json::json!(args.warp)),
                ("helm_state_timeout".to_string(), serde_json::json!(3.0)),
            ]
            .into(),
            ..Default::default()
        });
    }
    if args.web {
        cfg.process.push(ProcessEntry {
            name: "topside".into(),
            command: vec![
                "frontseat".into(),
                "topside".into(),
                "-c".into(),
                "topside.toml".into(),
            ],
            stage: frontseat_launch::config::Stage::AfterVehicles,
            ready: ReadyConfig {
                kind: ReadyKind::Tcp,
                address: args.web_listen.clone(),
                ..Default::default()
            },
            ..Default::default()
        });
    }
    (cfg, slots)
}

/// The topside of `--web`: every interface's Zenoh endpoint, and a link to each vehicle's page.
fn topside_config(
    args: &DemoArgs,
    n: usize,
    zenoh_ports: &[u16],
    topside_port: u16,
) -> frontseat_topside::TopsideConfig {
    let mut t = frontseat_topside::TopsideConfig::default();
    t.zenoh.connect = zenoh_ports
        .iter()
        .map(|p| format!("tcp/127.0.0.1:{p}"))
        .collect();
    t.web.listen = args.web_listen.clone();
    // The helms' session connects here too: peers do not relay, and the topside shows what the
    // helms command.
    t.zenoh.listen = vec![format!("tcp/127.0.0.1:{topside_port}")];
    t.vehicle = names(n)
        .into_iter()
        .enumerate()
        .map(|(i, name)| frontseat_topside::config::VehicleLink {
            name,
            page: format!("http://{}/", web_address(&args.web_listen, i + 1)),
        })
        .collect();
    t
}

/// The web address of vehicle `i`: the given one for the leader, the next ports for the others.
fn web_address(base: &str, i: usize) -> String {
    match base.parse::<std::net::SocketAddr>() {
        Ok(mut a) => {
            a.set_port(a.port().saturating_add(i as u16));
            a.to_string()
        }
        Err(_) => base.to_string(),
    }
}

/// What reached the followers of the leader's node_status, and what was refused.
#[derive(Default)]
struct LeaderFeed {
    received: AtomicU64,
    refused: AtomicU64,
}

pub async fn run(args: DemoArgs) -> ExitCode {
    let n = args.fleet.unwrap_or(3);
    if !(2..=MAX_FLEET).contains(&n) {
        eprintln!("--fleet must be 2 to {MAX_FLEET} vehicles (a leader and its followers)");
        return ExitCode::from(2);
    }
    if args.vehicle != crate::vehicle_kind::VehicleKind::Basic || args.record.is_some() {
        eprintln!(
            "--fleet flies basic-simulator vehicles and records nothing: drop --vehicle and --record"
        );
        return ExitCode::from(2);
    }
    if !(args.warp.is_finite() && args.warp > 0.0 && args.warp <= 100.0) {
        eprintln!("--warp must be in (0, 100] with --fleet");
        return ExitCode::from(2);
    }
    for (what, v) in [
        ("--trail-behind", args.trail_behind),
        ("--trail-side", args.trail_side),
    ] {
        if !(v.is_finite() && (0.0..=200.0).contains(&v)) {
            eprintln!("{what} must be in [0, 200] m");
            return ExitCode::from(2);
        }
    }
    if let Err(e) = std::fs::create_dir_all(&args.out) {
        eprintln!("cannot create {}: {e}", args.out.display());
        return ExitCode::from(1);
    }
    if !args.fleet_connect.is_empty() {
        return helms_only(&args, n).await;
    }
    let ports: std::io::Result<Vec<u16>> = (0..=n + 1).map(|_| free_port()).collect();
    let Ok(ports) = ports else {
        eprintln!("cannot find free loopback ports");
        return ExitCode::from(1);
    };
    let (sim_port, topside_port, zenoh_ports) = (ports[0], ports[1], &ports[2..]);
    let (cfg, slots) = launch_config(&args, n, sim_port, zenoh_ports);
    if args.web {
        if args.web_listen.parse::<std::net::SocketAddr>().is_err() {
            eprintln!("--web-listen must be an IP address and port");
            return ExitCode::from(2);
        }
        let t = topside_config(&args, n, zenoh_ports, topside_port);
        let path = args.out.join("topside.toml");
        let written = toml::to_string(&t)
            .map_err(|e| e.to_string())
            .and_then(|text| std::fs::write(&path, text).map_err(|e| e.to_string()));
        if let Err(e) = written {
            eprintln!("cannot write {}: {e}", path.display());
            return ExitCode::from(1);
        }
    }
    let launch_file = args.out.join("fleet-launch.toml");
    match toml::to_string(&cfg) {
        Ok(text) => {
            let head = "# The fleet `frontseat demo --fleet` launched (ephemeral ports: edit them to run it\n# again with `frontseat launch -c fleet-launch.toml`).\n";
            if let Err(e) = std::fs::write(&launch_file, format!("{head}{text}")) {
                eprintln!("cannot write {}: {e}", launch_file.display());
                return ExitCode::from(1);
            }
        }
        Err(e) => {
            eprintln!("cannot write the launch file: {e}");
            return ExitCode::from(1);
        }
    }
    let exe = match std::env::current_exe() {
        Ok(p) => p,
        Err(e) => {
            eprintln!("cannot find this binary: {e}");
            return ExitCode::from(1);
        }
    };
    eprintln!(
        "frontseat demo --fleet {n}: simulator on 127.0.0.1:{sim_port}, {n} interface processes ({}), warp {}",
        names(n).join(", "),
        args.warp
    );
    let (stop_tx, stop_rx) = oneshot::channel::<()>();
    let (up_tx, up_rx) = oneshot::channel();
    let file = launch_file.clone();
    let mut launcher = tokio::spawn(async move {
        frontseat_launch::run_with(
            cfg,
            &file,
            exe,
            async {
                let _ = stop_rx.await;
            },
            Some(up_tx),
        )
        .await
    });
    let up = tokio::select! {
        r = tokio::time::timeout(UP_BOUND, up_rx) => matches!(r, Ok(Ok(()))),
        _ = &mut launcher => false,
    };
    if !up {
        eprintln!("the fleet did not come up; see the [sim] and [interface-…] lines above");
        let _ = stop_tx.send(());
        return match tokio::time::timeout(Duration::from_secs(20), launcher).await {
            Ok(Ok(o)) if o.exit_code() != 0 => ExitCode::from(o.exit_code()),
            _ => ExitCode::from(1),
        };
    }
    let endpoints: Vec<String> = zenoh_ports
        .iter()
        .chain(args.web.then_some(topside_port).iter())
        .map(|p| format!("tcp/127.0.0.1:{p}"))
        .collect();
    let flown = fly(&args, n, endpoints, &slots).await;
    if args.web && flown.is_ok() {
        eprintln!(
            "frontseat demo: fleet done; topside on http://{}/ (each vehicle's page on the next ports) — Ctrl-C to stop",
            args.web_listen
        );
        crate::service::shutdown_signal().await;
    }
    let _ = stop_tx.send(());
    let outcome = match tokio::time::timeout(Duration::from_secs(30), launcher).await {
        Ok(Ok(o)) => o,
        _ => frontseat_launch::Outcome::Launcher("the launcher did not stop in time".into()),
    };
    let tracks = match flown {
        Ok(t) => t,
        Err(e) => {
            eprintln!("frontseat demo --fleet: {e}");
            return ExitCode::from(1);
        }
    };
    let code = write_outputs(&args.out, &tracks);
    if outcome != frontseat_launch::Outcome::Clean {
        eprintln!("frontseat demo --fleet: the launcher ended with {outcome:?}");
        return ExitCode::from(outcome.exit_code().max(1));
    }
    code
}

/// The flown fleet: each vehicle's name and track, and whether the leader completed its path.
struct Flown {
    tracks: Vec<(String, Vec<TrackPoint>)>,
    completed: bool,
    closest_approach_m: f64,
    leader_fixes: u64,
    refused: u64,
}

/// Connects one Zenoh session to every interface, bridges each vehicle's helm bus to its
/// platform, and flies the leader's path with the followers trailing until it is done.
async fn fly(
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
async fn helms_only(args: &DemoArgs, n: usize) -> ExitCode {
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

fn write_outputs(out: &Path, flown: &Flown) -> ExitCode {
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
