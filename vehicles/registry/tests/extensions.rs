//! Every built-in driver, as the registry builds it, given every other vehicle's extended
//! CommandRequest through the one generic `send_extension`: refused with the text, code and
//! request id the vehicle-named trait methods answered with before (one answer when a response
//! was requested, none otherwise), and another vehicle's extended data ignored. The drivers are
//! not started: a refusal needs no vehicle.

use std::time::Duration;

use frontseat_actors::driver::{DriverExtension, RecordingSink};
use frontseat_actors::proto::frontseat::protobuf::{ardupilot, bluefin, iver};
use frontseat_config::InterfaceConfig;

/// (vehicle in words, an extended CommandRequest of it with `response_requested`, id 41).
fn commands(response_requested: bool) -> Vec<(&'static str, DriverExtension)> {
    let (r, id) = (Some(response_requested), Some(41));
    vec![
        (
            "Bluefin",
            DriverExtension::encode(
                frontseat_bluefin::driver::COMMAND,
                "Bluefin",
                &bluefin::CommandRequest {
                    response_requested: r,
                    request_id: id,
                    ..Default::default()
                },
            ),
        ),
        (
            "Iver3",
            DriverExtension::encode(
                frontseat_iver3::driver::COMMAND,
                "Iver3",
                &iver::CommandRequest {
                    response_requested: r,
                    request_id: id,
                    ..Default::default()
                },
            ),
        ),
        (
            "ArduPilot",
            DriverExtension::encode(
                frontseat_ardupilot::driver::COMMAND,
                "ArduPilot",
                &ardupilot::CommandRequest {
                    response_requested: r,
                    request_id: id,
                    ..Default::default()
                },
            ),
        ),
    ]
}

/// The vehicle each built-in driver speaks, if it has an extension.
fn own(driver: &str) -> Option<&'static str> {
    match driver {
        "bluefin" => Some("Bluefin"),
        "iver3" => Some("Iver3"),
        "ardupilot" => Some("ArduPilot"),
        _ => None,
    }
}

#[test]
fn another_vehicles_command_is_refused_in_the_same_words_by_every_driver() {
    let mut refusals = 0;
    for b in frontseat_drivers::BUILT_IN {
        let mut cfg = InterfaceConfig::default();
        cfg.driver.name = b.name.into();
        let factory = frontseat_drivers::factory_with_env(&cfg, &|_| None).unwrap();
        for (vehicle, ext) in commands(true) {
            if own(b.name) == Some(vehicle) {
                continue;
            }
            let mut d = factory();
            let mut sink = RecordingSink::default();
            d.send_extension(&ext, Duration::ZERO, &mut sink);
            assert_eq!(sink.responses.len(), 1, "{} given {vehicle}", b.name);
            let r = &sink.responses[0];
            assert_eq!(r.request_successful, Some(false));
            assert_eq!(r.request_id, Some(41));
            assert_eq!(r.error_code, Some(1));
            assert_eq!(
                r.error_string(),
                format!("driver `{}` does not take {vehicle} commands", b.name)
            );
            assert!(sink.raw_out.is_empty() && sink.extensions.is_empty());
            refusals += 1;
        }
    }
    // 6 drivers × 3 vehicles, less the 3 that are their own.
    assert_eq!(refusals, 15);
}

#[test]
fn without_response_requested_a_refusal_is_silent_and_other_vehicles_data_ignored() {
    let data = DriverExtension::encode(
        frontseat_bluefin::driver::DATA,
        "Bluefin",
        &bluefin::InterfaceData::default(),
    );
    for b in frontseat_drivers::BUILT_IN
        .iter()
        .filter(|b| b.name != "bluefin")
    {
        let mut cfg = InterfaceConfig::default();
        cfg.driver.name = b.name.into();
        let mut d = frontseat_drivers::factory_with_env(&cfg, &|_| None).unwrap()();
        let mut sink = RecordingSink::default();
        for (vehicle, ext) in commands(false) {
            if own(b.name) != Some(vehicle) {
                d.send_extension(&ext, Duration::ZERO, &mut sink);
            }
        }
        d.send_extension(&data, Duration::ZERO, &mut sink);
        assert!(sink.responses.is_empty(), "{}", b.name);
        assert!(sink.raw_out.is_empty(), "{}", b.name);
    }
}
