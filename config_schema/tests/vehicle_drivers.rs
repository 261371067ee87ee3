//! `[driver.iver3]` and `[driver.waveglider_sv2]`: Goby3's field names parse, the required
//! fields are required only for the selected driver, and each rule names its field path.

use frontseat_config::{
    FrontSeatStateName, InterfaceConfig, ParityConfig, ServiceConfig, TransportKind, parse,
};

fn paths(cfg: &InterfaceConfig) -> Vec<String> {
    cfg.validate().into_iter().map(|e| e.path).collect()
}

#[test]
fn iver3_section_with_goby_names_parses() {
    let cfg: InterfaceConfig = parse(
        r#"
[driver]
name = "iver3"
[driver.iver3]
serial_port = "/dev/ttyUSB0"
serial_baud = 9600
remote_helm_version_major = 4
max_pitch_angle_degrees = 30
oms_timeout = 10
[driver.iver3.mode_assignments]
parking = "FRONTSEAT_IDLE"
[driver.iver3.link]
parity = "even"
"#,
        "iver.toml",
    )
    .unwrap();
    let i = &cfg.driver.iver3;
    assert_eq!(i.serial_baud, 9600);
    assert_eq!(i.remote_helm_version_major, Some(4));
    assert_eq!(
        i.mode_assignments.parking,
        FrontSeatStateName::FrontseatIdle
    );
    assert_eq!(
        i.mode_assignments.normal,
        FrontSeatStateName::FrontseatAcceptingCommands
    );
    assert_eq!(i.link.parity, ParityConfig::Even);
}

#[test]
fn required_fields_only_for_the_selected_driver() {
    assert!(paths(&InterfaceConfig::default()).is_empty());
    let mut cfg = InterfaceConfig::default();
    cfg.driver.name = "iver3".into();
    assert_eq!(
        paths(&cfg),
        vec![
            "driver.iver3.serial_port",
            "driver.iver3.remote_helm_version_major"
        ]
    );
    cfg.driver.iver3.link.transport = TransportKind::Tcp;
    cfg.driver.iver3.remote_helm_version_major = Some(5);
    cfg.driver.iver3.oms_timeout = 121;
    assert_eq!(paths(&cfg), vec!["driver.iver3.oms_timeout"]);

    let mut cfg = InterfaceConfig::default();
    cfg.driver.name = "waveglider_sv2".into();
    cfg.driver.waveglider_sv2.board_id = 256;
    cfg.driver.waveglider_sv2.link.stop_bits = 3;
    assert_eq!(
        paths(&cfg),
        vec![
            "driver.waveglider_sv2.pm_serial_port",
            "driver.waveglider_sv2.link.stop_bits",
            "driver.waveglider_sv2.board_id",
        ]
    );
    cfg.driver.name = "no_such_driver".into();
    assert_eq!(paths(&cfg), vec!["driver.name"]);
}
