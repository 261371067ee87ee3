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

/// The start-up log names the link the selected driver uses; before, it printed the basic
/// simulator's address whatever the driver was.
#[test]
fn vehicle_link_names_the_selected_drivers_link() {
    let link = |toml: &str| -> String {
        let cfg: InterfaceConfig = parse(toml, "link.toml").expect("valid test config");
        cfg.driver.vehicle_link()
    };
    assert_eq!(
        link("[driver.basic_simulator]\ntcp_address = \"127.0.0.1\"\ntcp_port = 54321\n"),
        "tcp 127.0.0.1:54321"
    );
    assert_eq!(
        link(
            "[driver]\nname = \"bluefin\"\n[driver.bluefin]\nhuxley_tcp_address = \"10.0.0.9\"\nhuxley_tcp_port = 29500\n"
        ),
        "tcp 10.0.0.9:29500"
    );
    assert_eq!(
        link(
            "[driver]\nname = \"iver3\"\n[driver.iver3]\nserial_port = \"/dev/ttyUSB3\"\nserial_baud = 19200\nremote_helm_version_major = 4\n"
        ),
        "serial /dev/ttyUSB3 @ 19200 baud"
    );
    assert_eq!(
        link(
            "[driver]\nname = \"waveglider_sv2\"\n[driver.waveglider_sv2]\npm_serial_port = \"/dev/ttyS1\"\n[driver.waveglider_sv2.link]\ntransport = \"tcp\"\ntcp_address = \"127.0.0.1\"\ntcp_port = 4001\n"
        ),
        "tcp 127.0.0.1:4001"
    );
    assert_eq!(
        link(
            "[driver]\nname = \"ardupilot\"\n[driver.ardupilot]\naddress = \"udpin:127.0.0.1:14550\"\n"
        ),
        "mavlink udpin:127.0.0.1:14550"
    );
    assert_eq!(
        link("[driver]\nname = \"dune\"\n[driver.dune]\naddress = \"10.0.10.40\"\nport = 6006\n"),
        "imc tcp 10.0.10.40:6006"
    );
    assert_eq!(
        link("[driver]\nlibrary = \"/opt/libmine.so\"\n"),
        "plugin /opt/libmine.so"
    );
}
