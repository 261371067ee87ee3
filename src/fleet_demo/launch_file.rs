//! The launch file `frontseat demo --fleet` writes and runs (so `frontseat launch` can run the
//! same fleet): the simulator, then one `frontseat interface` per vehicle, each from the defaults
//! with its name, ports, the shared datum and its start slot; with `--web`, the topside and its
//! config.

use std::path::{Path, PathBuf};

use frontseat_demo_helm::trail::Slot;
use frontseat_launch::LaunchConfig;
use frontseat_launch::config::{LatLon, ProcessEntry, ReadyConfig, ReadyKind, VehicleEntry};

use super::fleet::names;
use crate::demo::DemoArgs;

/// Metres per degree of latitude, near enough for placing start points a few tens of metres
/// apart (the tracks themselves are in the interfaces' exact local grid).
const M_PER_DEG: f64 = 111_320.0;

/// The launch file of the fleet: the simulator, then one interface per vehicle, each from the
/// defaults with its name, ports, the shared datum and its start point (followers in their
/// slots behind a leader heading east, the homework path's first leg).
pub fn launch_config(
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
        // --ais: each interface reports itself (`[opencpn.ais]`), MMSIs from the simulated range.
        let ais = args.ais.as_ref().map(|to| {
            let v = serde_json::json!({"name": name, "mmsi": frontseat_config::opencpn::SIM_MMSI_FIRST + i as u32});
            let section = serde_json::json!({"enabled": true, "udp": [to], "vehicle": [v]});
            ("opencpn.ais".to_string(), section)
        });
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
            .into_iter()
            .chain(ais)
            .collect(),
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

/// Writes the topside's config (`--web`) as `topside.toml` in `out`; Err is the line to print.
pub fn write_topside(
    args: &DemoArgs,
    n: usize,
    zenoh_ports: &[u16],
    topside_port: u16,
) -> Result<(), String> {
    let t = topside_config(args, n, zenoh_ports, topside_port);
    let path = args.out.join("topside.toml");
    let written = toml::to_string(&t)
        .map_err(|e| e.to_string())
        .and_then(|text| std::fs::write(&path, text).map_err(|e| e.to_string()));
    written.map_err(|e| format!("cannot write {}: {e}", path.display()))
}

/// Writes the fleet's launch file, `fleet-launch.toml` in `out`, with a head saying how to run it
/// again; returns its path, or the line to print.
pub fn write_launch_file(out: &Path, cfg: &LaunchConfig) -> Result<PathBuf, String> {
    let launch_file = out.join("fleet-launch.toml");
    match toml::to_string(cfg) {
        Ok(text) => {
            let head = "# The fleet `frontseat demo --fleet` launched (ephemeral ports: edit them to run it\n# again with `frontseat launch -c fleet-launch.toml`).\n";
            if let Err(e) = std::fs::write(&launch_file, format!("{head}{text}")) {
                return Err(format!("cannot write {}: {e}", launch_file.display()));
            }
        }
        Err(e) => return Err(format!("cannot write the launch file: {e}")),
    }
    Ok(launch_file)
}
