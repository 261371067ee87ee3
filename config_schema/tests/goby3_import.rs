//! Goby3 .pb.cfg files as Goby3 users have them: each of Goby3's own example configs (fixtures/
//! goby3/, printed by Goby3 itself) is read as printed (the basic simulator's imports, its
//! blanks filled in with warnings; a real vehicle's blank datum is an error with its line) and
//! with the blanks filled in (it imports to TOML that loads, on the driver its extension block
//! names, with every field either a setting or a named note).

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

/// The example file byte for byte, as Goby3 printed it (its banner line included).
fn raw(name: &str) -> String {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/goby3")
        .join(name);
    std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

#[test]
fn real_vehicle_examples_as_printed_refuse_their_blank_datum_at_its_line() {
    for name in [
        "goby_frontseat_interface_bluefin.example.pb.cfg",
        "goby_frontseat_interface_iver.example.pb.cfg",
        "goby_frontseat_interface_waveglider_sv2.example.pb.cfg",
    ] {
        let text = raw(name);
        match import_interface(&text, name) {
            Err(e @ ConfigError::Parse { line, column, .. }) => {
                let at = text.lines().nth(line - 1).unwrap_or_default();
                assert_eq!((line, column), (66, 5), "{name}: {e}");
                assert_eq!(at.trim_start(), "lat:   #  (required)", "{name}");
                assert_eq!(
                    e.to_string(),
                    format!(
                        "{name}:66:5: Goby3 config (protobuf text format): \
                         frontseat_cfg.origin.lat has no value (Goby3's -e placeholder for a \
                         value you give): a real vehicle's datum cannot be guessed: every local \
                         x/y a helm steers by is measured from it (give it here or in app.geodesy)"
                    )
                );
            }
            other => panic!("{name}: {other:?}"),
        }
    }
}

#[test]
fn basic_simulator_example_as_goby3_prints_it_imports_with_every_fill_in_named() {
    let name = "goby_frontseat_interface_basic_simulator.example.pb.cfg";
    let imported = import_interface(&raw(name), name).unwrap_or_else(|e| panic!("{e}"));
    let cfg = frontseat_config::parse::<InterfaceConfig>(&imported.toml, name)
        .unwrap_or_else(|e| panic!("{e}\n{}", imported.toml));
    assert_eq!(cfg.driver.name, "basic_simulator");
    let bs = &cfg.driver.basic_simulator;
    // The blanks: frontseat's default datum, the simulated vehicle starting there, on loopback.
    let datum = (
        frontseat_config::DEFAULT_ORIGIN_LAT,
        frontseat_config::DEFAULT_ORIGIN_LON,
    );
    assert_eq!((cfg.origin.lat, cfg.origin.lon), datum);
    assert_eq!((bs.start.lat, bs.start.lon), datum);
    assert_eq!((bs.tcp_address.as_str(), bs.tcp_port), ("127.0.0.1", 54321));
    // What Goby3 printed with a value is kept.
    assert_eq!(bs.start.control_freq, 10.0);
    assert_eq!(cfg.origin.altitude, None);
    assert!(cfg.require_helm);
    assert_eq!(cfg.moos.as_ref().map(|m| m.port), Some(9000));
    // Every fill-in is a warning naming the Goby3 field; the banner line is named and skipped.
    let warnings = imported.warnings().join("\n");
    for field in [
        "(line 1) = \"Loading frontseat driver library: libgoby_frontseat_basic_simulator.so.30\"",
        "frontseat_cfg.origin.lat = (blank) ignored: no datum given",
        "frontseat_cfg.origin.lon = (blank)",
        "basic_simulator_config].start.lat = (blank) ignored: the simulated vehicle starts at the datum",
        "basic_simulator_config].start.lon = (blank)",
        "basic_simulator_config].tcp_address = \"\" ignored: empty (Goby3's -e placeholder): frontseat's default 127.0.0.1",
    ] {
        assert!(warnings.contains(field), "no {field:?} in:\n{warnings}");
    }
    // The TOML says where each filled value came from.
    assert!(
        imported
            .toml
            .contains("frontseat_cfg.origin.lat blank (Goby3's -e placeholder)"),
        "{}",
        imported.toml
    );
}

#[test]
fn a_blank_datum_takes_app_geodesy_and_other_blanks_are_refused_at_their_line() {
    let text = "app { geodesy { lat_origin: 41.5 lon_origin: -70.5 } }\n\
                frontseat_cfg {\n  origin {\n    lat:   #  (required)\n    lon:\n  }\n  \
                [goby.middleware.frontseat.protobuf.bluefin_config] { huxley_tcp_address: \"h\" }\n}\n";
    let imported = import_interface(text, "t.pb.cfg").unwrap_or_else(|e| panic!("{e}"));
    let cfg = frontseat_config::parse::<InterfaceConfig>(&imported.toml, "t").unwrap();
    assert_eq!((cfg.origin.lat, cfg.origin.lon), (41.5, -70.5));
    assert_eq!(cfg.driver.name, "bluefin");
    // A blank the importer has no safe value for: refused where it is.
    let text = "frontseat_cfg {\n  origin { lat: 42 lon: -71 }\n  \
                [goby.middleware.frontseat.protobuf.bluefin_config] {\n    \
                huxley_tcp_address: \"h\"\n    rpm_table {\n      speed:   #  (required)\n      \
                rpm: 900\n    }\n  }\n}\n";
    match import_interface(text, "t.pb.cfg") {
        Err(
            e @ ConfigError::Parse {
                line: 6, column: 7, ..
            },
        ) => assert!(
            e.to_string().contains(
                "frontseat_cfg.[goby.middleware.frontseat.protobuf.bluefin_config].rpm_table.speed \
                 has no value"
            ),
            "{e}"
        ),
        other => panic!("{other:?}"),
    }
    // Half a datum is not completed from the default, even for the simulator.
    let text = "frontseat_cfg {\n  origin {\n    lat:   #  (required)\n    lon: -70\n  }\n  \
                [goby.middleware.frontseat.protobuf.basic_simulator_config] { }\n}\n";
    match import_interface(text, "t.pb.cfg") {
        Err(
            e @ ConfigError::Parse {
                line: 3, column: 5, ..
            },
        ) => {
            assert!(e.to_string().contains("half a datum"), "{e}")
        }
        other => panic!("{other:?}"),
    }
    // Goby3's banner anywhere but the first line is not skipped: not config, an error.
    let text = "frontseat_cfg { origin { lat: 42 lon: -71 } }\n\
                Loading frontseat driver library: libgoby_frontseat_bluefin.so.30\n";
    assert!(matches!(
        import_interface(text, "t.pb.cfg"),
        Err(ConfigError::Parse { line: 2, .. })
    ));
}

#[test]
fn a_byte_that_is_not_utf8_is_refused_at_its_line_and_column_like_any_parse_error() {
    let dir = std::env::temp_dir().join(format!("fs-goby3-utf8-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let cases: [(&str, &[u8], usize, usize, &str); 3] = [
        // In a comment (Goby3's parser skips comments whole).
        (
            "comment.pb.cfg",
            b"frontseat_cfg {\n  origin { lat: 42 lon: -71 }\n  # caf\xe9\n}\n",
            3,
            8,
            "byte 0xE9 is not UTF-8",
        ),
        // In a string value, after a two-byte character that is UTF-8 (columns count characters).
        (
            "string.pb.cfg",
            b"app { name: \"\xc3\xa9t\xff\" }\nfrontseat_cfg { origin { lat: 42 lon: -71 } }\n",
            1,
            16,
            "byte 0xFF is not UTF-8",
        ),
        // Cut inside a character at the end.
        (
            "cut.pb.cfg",
            b"frontseat_cfg { origin { lat: 42 lon: -71 } }\n# \xe2\x82",
            2,
            3,
            "the file ends inside a UTF-8 character (byte 0xE2)",
        ),
    ];
    for (name, bytes, line, column, what) in cases {
        let path = dir.join(name);
        std::fs::write(&path, bytes).unwrap();
        let want = format!(
            "{}:{line}:{column}: Goby3 config (protobuf text format): {what}: a config file is \
             UTF-8 text",
            path.display()
        );
        for err in [
            frontseat_config::load_with_notes::<InterfaceConfig>(&path).unwrap_err(),
            frontseat_config::import_goby3::<InterfaceConfig>(&path).unwrap_err(),
            frontseat_config::load_with_notes::<GatewayConfig>(&path).unwrap_err(),
        ] {
            assert!(
                matches!(err, ConfigError::Parse { line: l, column: c, .. } if (l, c) == (line, column)),
                "{name}: {err:?}"
            );
            assert_eq!(err.to_string(), want, "{name}");
        }
    }
    // The same shape as any other parse error of a .pb.cfg.
    let path = dir.join("unknown.pb.cfg");
    std::fs::write(&path, "frontseat_cfg {\n  requre_helm: true\n}\n").unwrap();
    let err = frontseat_config::load_with_notes::<InterfaceConfig>(&path).unwrap_err();
    assert!(
        err.to_string().starts_with(&format!(
            "{}:2:3: Goby3 config (protobuf text format): ",
            path.display()
        )),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).ok();
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

#[test]
fn every_prefix_of_a_printed_example_imports_or_is_a_typed_error() {
    for name in [
        "goby_frontseat_interface_basic_simulator.example.pb.cfg",
        "goby_frontseat_interface_bluefin.example.pb.cfg",
    ] {
        let text = raw(name);
        let mut errors = 0;
        for (i, _) in text.char_indices().step_by(3) {
            match import_interface(&text[..i], name) {
                Ok(_) => {}
                Err(ConfigError::Parse { .. } | ConfigError::Invalid { .. }) => errors += 1,
                Err(e) => panic!("{name}[..{i}]: {e}"),
            }
        }
        assert!(errors > 0, "{name}: some prefixes cut a block in half");
    }
}
