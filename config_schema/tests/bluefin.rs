//! `[driver.bluefin]`: Goby3's bluefin_config names, defaults and units load, and bad values
//! are refused with their field path.

use frontseat_config::{AcceptingCommandsHook, ConfigError, InterfaceConfig, parse};

#[test]
fn goby3_field_names_load() {
    let cfg: InterfaceConfig = parse(
        r#"
[driver]
name = "bluefin"
[driver.bluefin]
huxley_tcp_address = "10.0.0.5"
huxley_tcp_port = 29501
reconnect_interval = 20
nmea_resend_attempts = 4
nmea_resend_interval = 3
allowed_nmea_demerits = 5
allow_missing_nav_interval = 8
heartbeat_interval = 2
extra_bplog = ["svs", "VER"]
send_tmr_messages = false
disable_ack = true
accepting_commands_hook = "BFCTL_TRIGGER"
use_rpm_table_for_speed = true
[[driver.bluefin.rpm_table]]
speed = 0.5
rpm = 300
[[driver.bluefin.rpm_table]]
speed = 1.5
rpm = 1000
"#,
        "bf.toml",
    )
    .unwrap();
    let b = &cfg.driver.bluefin;
    assert_eq!(cfg.driver.name, "bluefin");
    assert_eq!(
        (b.huxley_tcp_address.as_str(), b.huxley_tcp_port),
        ("10.0.0.5", 29501)
    );
    assert_eq!(
        b.accepting_commands_hook,
        AcceptingCommandsHook::BfctlTrigger
    );
    assert_eq!(b.rpm_table.len(), 2);
    assert!(b.disable_ack && !b.send_tmr_messages);
}

#[test]
fn defaults_are_goby3s() {
    let b = InterfaceConfig::default().driver.bluefin;
    assert_eq!(b.huxley_tcp_port, 29500);
    assert_eq!(
        (
            b.reconnect_interval,
            b.nmea_resend_attempts,
            b.nmea_resend_interval,
            b.allowed_nmea_demerits,
            b.allow_missing_nav_interval,
            b.heartbeat_interval
        ),
        (10, 3, 5, 3, 5, 1)
    );
    assert!(b.send_tmr_messages && !b.disable_ack && !b.use_rpm_table_for_speed);
    assert_eq!(
        b.accepting_commands_hook,
        AcceptingCommandsHook::BfmscTrigger
    );
}

#[test]
fn bad_values_name_their_field() {
    for (text, path) in [
        (
            "[driver.bluefin]\nnmea_resend_interval = 0\n",
            "driver.bluefin.nmea_resend_interval",
        ),
        (
            "[driver.bluefin]\nheartbeat_interval = 0\n",
            "driver.bluefin.heartbeat_interval",
        ),
        (
            "[driver.bluefin]\nhuxley_tcp_port = 0\n",
            "driver.bluefin.huxley_tcp_port",
        ),
        (
            "[driver.bluefin]\nhuxley_tcp_address = \"\"\n",
            "driver.bluefin.huxley_tcp_address",
        ),
        (
            "[driver.bluefin]\nextra_bplog = [\"TOOLONG\"]\n",
            "driver.bluefin.extra_bplog[0]",
        ),
        (
            "[driver.bluefin]\nuse_rpm_table_for_speed = true\n",
            "driver.bluefin.rpm_table",
        ),
    ] {
        match parse::<InterfaceConfig>(text, "bf.toml") {
            Err(ConfigError::Invalid { errors, .. }) => {
                assert!(errors.iter().any(|e| e.path == path), "{text}: {errors:?}")
            }
            other => panic!("{text}: expected a validation error at {path}, got {other:?}"),
        }
    }
    assert!(matches!(
        parse::<InterfaceConfig>(
            "[driver.bluefin]\naccepting_commands_hook = \"SOMETIMES\"\n",
            "bf.toml"
        ),
        Err(ConfigError::Parse { .. })
    ));
}
