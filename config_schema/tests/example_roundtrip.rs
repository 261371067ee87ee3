//! The example config, fed back, loads and equals the defaults; its commented-out optional
//! settings load too once uncommented; optional sections stay optional.

use frontseat_config::{
    ConfigError, GatewayConfig, InterfaceConfig, MoosConfig, ServiceConfig, SimConfig, example,
    load, parse,
};

fn round_trip<T: ServiceConfig + PartialEq + std::fmt::Debug>() {
    let text = example::<T>();
    let parsed: T = parse(&text, "example.toml").unwrap_or_else(|e| panic!("{e}\n{text}"));
    assert_eq!(parsed, T::default(), "{}", T::SERVICE);
    assert_eq!(
        T::default().validate(),
        vec![],
        "defaults of {} validate",
        T::SERVICE
    );
}

#[test]
fn interface_example_round_trips() {
    round_trip::<InterfaceConfig>();
}

#[test]
fn sim_example_round_trips() {
    round_trip::<SimConfig>();
}

#[test]
fn gateway_example_round_trips() {
    round_trip::<GatewayConfig>();
}

/// Removes the '#' from disabled settings (`#key = …`, `#[table]`, `#[[array]]`), leaving the
/// `# description` lines alone.
fn uncomment_all(text: &str) -> String {
    text.lines()
        .map(|l| match l.strip_prefix('#') {
            Some(rest) if rest.starts_with('[') => rest.to_owned(),
            Some(rest)
                if rest.split_once(" = ").is_some_and(|(k, _)| {
                    !k.is_empty() && k.chars().all(|c| c.is_ascii_lowercase() || c == '_')
                }) =>
            {
                rest.to_owned()
            }
            _ => l.to_owned(),
        })
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn interface_example_has_every_setting_and_commented_ones_work() {
    let text = example::<InterfaceConfig>();
    for key in [
        "name = \"\"",
        "type = \"AUV\"",
        "require_helm = true",
        "helm_running_timeout = 10.0",
        "frontseat_connected_timeout = 10.0",
        "status_period = 5.0",
        "exit_on_error = false",
        "sim_warp_factor = 1.0",
        "[driver.basic_simulator.start.vehicle]",
        "tcp_port = 54321",
        "hdg_rate = 45.0",
        "#[moos]",
        "#server = \"127.0.0.1\"",
        "#port = 9000",
        "#altitude = ",
        "#library = ",
        "queue_capacity = 1024",
        "[web]",
        "listen = \"127.0.0.1:50001\"",
        "#token = ",
        "#[interprocess.tls]",
        "#root_ca_certificate = \"/etc/frontseat/tls/ca.pem\"",
        "#mutual = true",
        "#[interprocess.access]",
        "#vehicles = []",
        "#commanders = []",
    ] {
        assert!(text.contains(key), "example lacks {key:?}:\n{text}");
    }
    assert!(text.contains("Unit: s."), "units are printed");

    let on: InterfaceConfig = parse(&uncomment_all(&text), "on.toml").unwrap();
    assert_eq!(on.moos, Some(MoosConfig::default()));
    assert_eq!(on.origin.altitude, Some(0.0));
    assert!(on.driver.library.is_some());
    assert!(on.web.token.is_some());
    // Everything else is unchanged by uncommenting.
    let mut rest = on.clone();
    rest.web.token = None;
    rest.moos = None;
    rest.origin.altitude = None;
    rest.driver.library = None;
    assert_eq!(on.driver.iver3.remote_helm_version_major, Some(5));
    rest.driver.iver3.remote_helm_version_major = None;
    assert!(on.driver.iver3.ntp_serial_port.is_some());
    rest.driver.iver3.ntp_serial_port = None;
    assert!(on.record.path.is_some());
    rest.record.path = None;
    assert!(on.record.foxglove.token.is_some());
    rest.record.foxglove.token = None;
    assert!(on.interprocess.tls.is_some() && on.interprocess.access.is_some());
    rest.interprocess.tls = None;
    rest.interprocess.access = None;
    assert!(on.opencpn.is_some());
    rest.opencpn = None;
    assert_eq!(rest, InterfaceConfig::default());
}

#[test]
fn sim_example_faults_are_commented_and_load_when_uncommented() {
    let text = example::<SimConfig>();
    assert!(text.contains("#[[faults]]"));
    let parsed: SimConfig = parse(&text, "sim.toml").unwrap();
    assert!(parsed.faults.is_empty());
    let on: SimConfig = parse(&uncomment_all(&text), "sim.toml").unwrap();
    assert_eq!(on.faults.len(), 3);
}

#[test]
fn moos_absent_means_no_bridge_and_a_table_enables_it() {
    let none: InterfaceConfig = parse("name = \"auv1\"\n", "a.toml").unwrap();
    assert_eq!(none.moos, None);

    let empty: InterfaceConfig = parse("[moos]\n", "a.toml").unwrap();
    assert_eq!(empty.moos, Some(MoosConfig::default()));

    let some: InterfaceConfig =
        parse("[moos]\nserver = \"10.0.0.5\"\nport = 9001\n", "a.toml").unwrap();
    let moos = some.moos.unwrap();
    assert_eq!((moos.server.as_str(), moos.port), ("10.0.0.5", 9001));
    assert_eq!(moos.app_name, "iFrontSeat");
}

#[test]
fn gateway_requires_moos() {
    let err = parse::<GatewayConfig>("name = \"auv1\"\n", "gw.toml").unwrap_err();
    assert!(
        matches!(&err, ConfigError::Parse { message, .. } if message.contains("moos")),
        "{err}"
    );
    let ok: GatewayConfig = parse("[moos]\n", "gw.toml").unwrap();
    assert!(ok.interprocess.enabled);
}

#[test]
fn goby_style_integers_are_accepted_for_floats() {
    let cfg: InterfaceConfig = parse(
        "helm_running_timeout = 20\nsim_warp_factor = 2\n[origin]\nlat = 42\nlon = -71\n",
        "a.toml",
    )
    .unwrap();
    assert_eq!(cfg.helm_running_timeout, 20.0);
    assert_eq!(cfg.sim_warp_factor, 2.0);
    assert_eq!((cfg.origin.lat, cfg.origin.lon), (42.0, -71.0));
}

#[test]
fn vehicle_type_uses_goby_names() {
    let cfg: InterfaceConfig = parse("type = \"USV_POWERED\"\n", "a.toml").unwrap();
    assert_eq!(cfg.r#type.as_str(), "USV_POWERED");
    assert_eq!(cfg.r#type.proto_value(), 21);
}

fn temp_file(name: &str, contents: &[u8]) -> std::path::PathBuf {
    let path = std::env::temp_dir().join(format!(
        "frontseat-config-test-{}-{name}",
        std::process::id()
    ));
    std::fs::write(&path, contents).unwrap();
    path
}

#[test]
fn load_reads_a_file_and_names_it_in_errors() {
    let good = temp_file("good.toml", example::<InterfaceConfig>().as_bytes());
    let cfg: InterfaceConfig = load(&good).unwrap();
    assert_eq!(cfg, InterfaceConfig::default());

    let bad = temp_file("bad.toml", b"[origin]\nlat = 95\n");
    let err = load::<InterfaceConfig>(&bad).unwrap_err();
    assert_eq!(
        err.to_string(),
        format!("{}: origin.lat = 95: outside [-90, 90]", bad.display())
    );

    let missing = std::env::temp_dir().join("frontseat-config-test-does-not-exist.toml");
    let err = load::<InterfaceConfig>(&missing).unwrap_err();
    assert!(matches!(err, ConfigError::Io { .. }));
    assert!(err.to_string().starts_with(&missing.display().to_string()));

    let huge = temp_file("huge.toml", &vec![b'#'; 2 << 20]);
    let err = load::<InterfaceConfig>(&huge).unwrap_err();
    assert!(matches!(err, ConfigError::Io { .. }), "{err}");

    // Not UTF-8: a parse error with its line and column, like any other.
    let not_utf8 = temp_file("binary.toml", b"name = \"a\"\nx = \"\xff\xfe\"\n");
    let err = load::<InterfaceConfig>(&not_utf8).unwrap_err();
    assert!(
        matches!(
            err,
            ConfigError::Parse {
                line: 2,
                column: 6,
                ..
            }
        ),
        "{err:?}"
    );
    assert_eq!(
        err.to_string(),
        format!(
            "{}:2:6: byte 0xFF is not UTF-8: a config file is UTF-8 text",
            not_utf8.display()
        )
    );

    for p in [good, bad, huge, not_utf8] {
        let _ = std::fs::remove_file(p);
    }
}
