//! What an operator sees when an OpenCPN setting is wrong: `frontseat topside --check` and
//! `frontseat interface --check` refuse, naming the vehicle and the rule, before anything starts.

mod common;

use std::process::Command;

use common::procs::scratch;

fn check(service: &str, toml: &str) -> (i32, String) {
    let dir = scratch("opencpn_config", service);
    let path = dir.join(format!("{service}.toml"));
    std::fs::write(&path, toml).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_frontseat"))
        .args([service, "--check", "-c"])
        .arg(&path)
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        format!(
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        ),
    )
}

#[test]
fn a_duplicate_or_special_mmsi_is_refused_naming_the_vehicle() {
    let (code, text) = check(
        "topside",
        "[ais]\nenabled = true\n\
         [[ais.vehicle]]\nname = \"auv1\"\nmmsi = 299000001\n\
         [[ais.vehicle]]\nname = \"auv2\"\nmmsi = 299000001\n\
         [[ais.vehicle]]\nname = \"asv\"\nmmsi = 970000001\n\
         [[ais.vehicle]]\nname = \"buoy\"\nmmsi = 12345\n",
    );
    assert_eq!(code, 2, "{text}");
    assert!(
        text.contains("vehicle `auv2` has the MMSI of vehicle `auv1`"),
        "{text}"
    );
    assert!(text.contains("vehicle `asv`: 97x is a SART"), "{text}");
    assert!(text.contains("vehicle `buoy`: not 9 digits"), "{text}");
    let (code, text) = check(
        "topside",
        "[ais]\nenabled = true\n[[ais.vehicle]]\nname = \"auv1\"\nmmsi = 299000001\n",
    );
    assert_eq!(code, 0, "{text}");
}

#[test]
fn the_opencpn_helm_beyond_loopback_or_beside_moos_is_refused() {
    let helm = "helm_state_timeout = 3.0\n[opencpn.helm]\nenabled = true\n";
    let (code, text) = check("interface", &format!("{helm}listen = \"0.0.0.0:10111\"\n"));
    assert_eq!(code, 2, "{text}");
    assert!(text.contains("NMEA has no token"), "{text}");
    let (code, text) = check(
        "interface",
        &format!("{helm}listen = \"0.0.0.0:10111\"\nallow_non_loopback = true\n"),
    );
    assert_eq!(code, 0, "{text}");
    let (code, text) = check(
        "interface",
        "helm_state_timeout = 3.0\n[moos]\n[opencpn.helm]\nenabled = true\n",
    );
    assert_eq!(code, 2, "{text}");
    assert!(text.contains("one helm input per vehicle"), "{text}");
    let (code, text) = check("interface", "[opencpn.helm]\nenabled = true\n");
    assert_eq!(code, 2, "{text}");
    assert!(text.contains("helm_state_timeout"), "{text}");
}
