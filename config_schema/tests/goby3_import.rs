//! Goby3 .pb.cfg files as Goby3 users have them: each of Goby3's own example configs (fixtures/
//! goby3/, printed by Goby3 itself) is read as printed (its blank required values are errors
//! with their line) and with the blanks filled in (it imports to TOML that loads, on the driver
//! its extension block names, with every field either a setting or a named note).

use std::path::{Path, PathBuf};

use frontseat_config::goby3_import::{goby3_driver_for_library, import_gateway, import_interface};
use frontseat_config::{
    ConfigError, FrontSeatStateName, GatewayConfig, Goby3Transport, InterfaceConfig,
};

fn fixture(name: &str) -> String {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/goby3")
        .join(name);
    let text = std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    // Goby3 prints this line to stdout as it loads the driver library: not part of the config.
    text.lines()
        .filter(|l| !l.starts_with("Loading frontseat driver library:"))
        .map(|l| format!("{l}\n"))
        .collect()
}

/// The example with every blank required value filled in, as a user would before running it.
fn filled(name: &str) -> String {
    fixture(name)
        .lines()
        .map(|line| {
            let t = line.trim_start();
            let Some((key, rest)) = t.split_once(':') else {
                return format!("{line}\n");
            };
            // Required values print blank, required strings as "".
            let rest = rest.trim_start();
            let rest = rest
                .strip_prefix("\"\"")
                .map(str::trim_start)
                .unwrap_or(rest);
            if !rest.starts_with('#') || key.contains(' ') || key == "extra_bplog" {
                return format!("{line}\n");
            }
            let value = match key {
                // Not required: left as printed.
                "name" | "file_dir" | "socket_name" | "ip_address" | "ntp_serial_port" => {
                    return format!("{line}\n");
                }
                "lat" => "42.358",
                "lon" => "-71.087",
                "huxley_tcp_address" | "tcp_address" => "\"127.0.0.1\"",
                "serial_port" => "\"/dev/ttyUSB0\"",
                "pm_serial_port" => "\"/dev/ttyUSB1\"",
                "remote_helm_version_major" => "5",
                "speed" => "1.5",
                "rpm" => "900",
                other => panic!("{name}: no fill for required {other}"),
            };
            let indent = &line[..line.len() - t.len()];
            format!("{indent}{key}: {value}  {rest}\n")
        })
        .collect()
}

fn interface(name: &str) -> (InterfaceConfig, String, Vec<String>) {
    let imported = import_interface(&filled(name), name).unwrap_or_else(|e| panic!("{e}"));
    let cfg = frontseat_config::parse::<InterfaceConfig>(&imported.toml, name)
        .unwrap_or_else(|e| panic!("{e}\n{}", imported.toml));
    (cfg, imported.toml.clone(), imported.warnings())
}

#[test]
fn goby3_examples_as_printed_name_the_blank_required_value_and_its_line() {
    for name in [
        "goby_frontseat_interface_basic_simulator.example.pb.cfg",
        "goby_frontseat_interface_bluefin.example.pb.cfg",
        "goby_frontseat_interface_iver.example.pb.cfg",
        "goby_frontseat_interface_waveglider_sv2.example.pb.cfg",
    ] {
        let text = fixture(name);
        match import_interface(&text, name) {
            Err(ConfigError::Parse { line, message, .. }) => {
                let at = text.lines().nth(line - 1).unwrap_or_default();
                assert!(
                    at.contains(':') && at.contains("(required)"),
                    "{name}: line {line} is {at:?} ({message})"
                );
            }
            other => panic!("{name}: {other:?}"),
        }
    }
}

#[test]
fn basic_simulator_example_runs_the_basic_simulator_driver_on_gobyd_and_moos() {
    let (cfg, toml, warnings) =
        interface("goby_frontseat_interface_basic_simulator.example.pb.cfg");
    assert_eq!(cfg.driver.name, "basic_simulator");
    let bs = &cfg.driver.basic_simulator;
    assert_eq!(bs.tcp_address, "127.0.0.1");
    assert_eq!(bs.tcp_port, 54321);
    assert_eq!((bs.start.lat, bs.start.lon), (42.358, -71.087));
    assert_eq!(bs.start.control_freq, 10.0);
    assert_eq!(bs.start.vehicle.hdg_rate, 45.0);
    assert_eq!((cfg.origin.lat, cfg.origin.lon), (42.358, -71.087));
    assert_eq!(cfg.origin.altitude, None, "Goby3's nan altitude is unknown");
    assert!(cfg.require_helm);
    assert_eq!(cfg.status_period, 5.0);
    assert_eq!(cfg.sim_warp_factor, 1.0);
    assert!(cfg.goby3.enabled, "a Goby3 interface always joins gobyd");
    assert_eq!(cfg.goby3.platform, "default_goby_platform");
    assert_eq!(cfg.goby3.transport, Goby3Transport::Ipc);
    let moos = cfg
        .moos
        .as_ref()
        .expect("the moos_helm block runs the MOOS bridge");
    assert_eq!((moos.server.as_str(), moos.port), ("localhost", 9000));
    // A comment per setting names its Goby3 field; the ignored ones are named too.
    assert!(
        toml.contains("require_helm = true  # frontseat_cfg.require_helm"),
        "{toml}"
    );
    assert!(
        toml.contains(
            "[goby.middleware.frontseat.protobuf.basic_simulator_config].start.vehicle.accel"
        ),
        "{toml}"
    );
    for ignored in [
        "app.glog_config.tty_verbosity",
        "app.glog_config.file_log.omit.latest_symlink",
        "app.simulation.time.use_sim_time",
        "[goby.moos.protobuf.moos_helm].moos_parser_technique",
    ] {
        assert!(
            warnings.iter().any(|w| w.contains(ignored)),
            "{ignored} not named in {warnings:#?}"
        );
        assert!(toml.contains(ignored), "{ignored} not in the TOML");
    }
}

#[test]
fn every_field_of_every_example_is_a_setting_or_named() {
    for name in [
        "goby_frontseat_interface_basic_simulator.example.pb.cfg",
        "goby_frontseat_interface_bluefin.example.pb.cfg",
        "goby_frontseat_interface_iver.example.pb.cfg",
        "goby_frontseat_interface_waveglider_sv2.example.pb.cfg",
    ] {
        let (_, toml, _) = interface(name);
        let text = filled(name);
        // Each `key: value` line of the Goby3 file shows up by its key in the TOML (as a
        // setting's source or an ignored field's path).
        for line in text.lines() {
            let t = line.trim_start();
            if t.starts_with('#') || t.starts_with('[') {
                continue;
            }
            let Some((key, rest)) = t.split_once(':') else {
                continue;
            };
            if key.contains(' ') || rest.trim_start().starts_with('#') || key.is_empty() {
                continue;
            }
            assert!(
                toml.contains(&format!(".{key} "))
                    || toml.contains(&format!(".{key}\n"))
                    // a field of a list entry (rpm_table { speed rpm }) inside its inline table
                    || toml.contains(&format!(" {key} = ")),
                "{name}: {key} is not in\n{toml}"
            );
        }
    }
}

#[test]
fn bluefin_example_selects_the_bluefin_driver_with_its_rpm_table() {
    let (cfg, _, _) = interface("goby_frontseat_interface_bluefin.example.pb.cfg");
    assert_eq!(cfg.driver.name, "bluefin");
    let b = &cfg.driver.bluefin;
    assert_eq!(b.huxley_tcp_address, "127.0.0.1");
    assert_eq!(b.huxley_tcp_port, 29500);
    assert_eq!(b.nmea_resend_attempts, 3);
    assert_eq!(b.nmea_resend_interval, 5);
    assert_eq!(b.rpm_table.len(), 1);
    assert_eq!((b.rpm_table[0].speed, b.rpm_table[0].rpm), (1.5, 900));
    assert!(b.send_tmr_messages);
}

#[test]
fn iver_example_selects_the_iver3_driver_with_its_mode_assignments() {
    let (cfg, _, _) = interface("goby_frontseat_interface_iver.example.pb.cfg");
    assert_eq!(cfg.driver.name, "iver3");
    let i = &cfg.driver.iver3;
    assert_eq!(i.serial_port, "/dev/ttyUSB0");
    assert_eq!(i.serial_baud, 19200);
    assert_eq!(i.remote_helm_version_major, Some(5));
    assert_eq!(
        i.mode_assignments.parking,
        FrontSeatStateName::FrontseatInControl
    );
    assert_eq!(
        i.mode_assignments.stopped,
        FrontSeatStateName::FrontseatIdle
    );
}

#[test]
fn waveglider_example_selects_the_sv2_driver() {
    let (cfg, _, _) = interface("goby_frontseat_interface_waveglider_sv2.example.pb.cfg");
    assert_eq!(cfg.driver.name, "waveglider_sv2");
    let w = &cfg.driver.waveglider_sv2;
    assert_eq!(w.pm_serial_port, "/dev/ttyUSB1");
    assert_eq!((w.pm_serial_baud, w.board_id, w.task_id), (115200, 3, 1));
}

#[test]
fn moos_gateway_example_bridges_through_gobyd() {
    let name = "goby_moos_gateway_ivp.example.pb.cfg";
    let imported = import_gateway(&fixture(name), name).unwrap_or_else(|e| panic!("{e}"));
    let cfg = frontseat_config::parse::<GatewayConfig>(&imported.toml, name)
        .unwrap_or_else(|e| panic!("{e}\n{}", imported.toml));
    assert!(cfg.goby3.enabled);
    assert!(
        !cfg.interprocess.enabled,
        "Goby3's gateway reaches gobyd only"
    );
    assert_eq!(
        (cfg.moos.server.as_str(), cfg.moos.port),
        ("localhost", 9000)
    );
    assert_eq!(cfg.moos.time_warp, 1.0);
    assert!(
        imported
            .warnings()
            .iter()
            .any(|w| w.contains("poll_frequency"))
    );
}

fn refused(text: &str) -> Vec<String> {
    match import_interface(text, "t.pb.cfg") {
        Err(ConfigError::Invalid { errors, .. }) => errors.iter().map(|e| e.to_string()).collect(),
        other => panic!("expected refusal, got {other:?}"),
    }
}

const MINIMAL: &str = "frontseat_cfg { origin { lat: 42 lon: -71 } }\n";

#[test]
fn a_minimal_config_imports_to_the_defaults_on_gobyd() {
    let imported = import_interface(MINIMAL, "t.pb.cfg").unwrap();
    let cfg = frontseat_config::parse::<InterfaceConfig>(&imported.toml, "t").unwrap();
    let want = InterfaceConfig {
        origin: frontseat_config::LatLonConfig {
            lat: 42.0,
            lon: -71.0,
            ..Default::default()
        },
        goby3: frontseat_config::Goby3Config {
            enabled: true,
            ..Default::default()
        },
        ..Default::default()
    };
    assert_eq!(cfg, want);
}

#[test]
fn goby3_mistakes_and_settings_we_cannot_honour_are_errors_not_guesses() {
    // An unknown field is an error with its line, as in Goby3.
    match import_interface("frontseat_cfg {\n  requre_helm: true\n}\n", "t.pb.cfg") {
        Err(ConfigError::Parse { line, message, .. }) => {
            assert_eq!(line, 2, "{message}");
            assert!(message.contains("requre_helm"), "{message}");
        }
        other => panic!("{other:?}"),
    }
    // Two warps that differ.
    let e = refused(
        "app { simulation { time { warp_factor: 10 } } }\nfrontseat_cfg { sim_warp_factor: 5 }\n",
    );
    assert!(e[0].contains("sim_warp_factor"), "{e:?}");
    // Two drivers' blocks.
    let e = refused(
        "frontseat_cfg {\n [goby.middleware.frontseat.protobuf.bluefin_config] { huxley_tcp_address: \"a\" }\n \
         [goby.middleware.frontseat.protobuf.waveglider_sv2_config] { pm_serial_port: \"/dev/x\" }\n}\n",
    );
    assert!(e[0].contains("more than one driver"), "{e:?}");
    // A MOOS encoding we do not speak.
    let e =
        refused("frontseat_cfg {}\n[goby.moos.protobuf.moos_helm] { use_binary_protobuf: true }\n");
    assert!(e[0].contains("use_binary_protobuf"), "{e:?}");
    // Two datums.
    let e = refused(
        "app { geodesy { lat_origin: 10 lon_origin: -71 } }\nfrontseat_cfg { origin { lat: 42 lon: -71 } }\n",
    );
    assert!(e[0].contains("lat_origin"), "{e:?}");
}

#[test]
fn the_app_warp_drives_the_interface_and_its_moos_side_and_geodesy_gives_the_datum() {
    let text = "app { simulation { time { use_sim_time: true warp_factor: 10 } } \
                geodesy { lat_origin: 41.5 lon_origin: -70.5 } }\n\
                frontseat_cfg { }\n[goby.moos.protobuf.moos_helm] { port: 9001 }\n";
    let imported = import_interface(text, "t.pb.cfg").unwrap();
    let cfg = frontseat_config::parse::<InterfaceConfig>(&imported.toml, "t").unwrap();
    assert_eq!(cfg.sim_warp_factor, 10.0);
    let moos = cfg.moos.unwrap();
    assert_eq!(moos.port, 9001);
    assert_eq!(moos.with_warp(cfg.sim_warp_factor).time_warp, 10.0);
    assert_eq!((cfg.origin.lat, cfg.origin.lon), (41.5, -70.5));
}

#[test]
fn a_pb_cfg_file_loads_through_the_normal_loader() {
    let dir = std::env::temp_dir().join(format!("fs-goby3-import-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path: PathBuf = dir.join("vehicle.pb.cfg");
    std::fs::write(
        &path,
        filled("goby_frontseat_interface_bluefin.example.pb.cfg"),
    )
    .unwrap();
    let (cfg, notes) = frontseat_config::load_with_notes::<InterfaceConfig>(&path).unwrap();
    assert_eq!(cfg.driver.name, "bluefin");
    assert!(notes.iter().any(|n| n.contains("glog_config")), "{notes:?}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn goby3_driver_libraries_name_our_drivers() {
    assert_eq!(
        goby3_driver_for_library("libgoby_frontseat_bluefin.so.30"),
        Some("bluefin")
    );
    assert_eq!(goby3_driver_for_library("libfrontseat_mine.so"), None);
}
