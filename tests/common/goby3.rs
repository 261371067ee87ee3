//! A Goby3 client of a (stand-in) gobyd for the end-to-end tests: what a separate Goby3
//! application would be, on its own bus.

use frontseat_actors::bus::Bus;
use frontseat_config::Goby3Config;
use frontseat_helm_side::GatewayOptions;
use frontseat_helm_side::goby3::{self, Goby3Handle, Goby3Settings};

/// A Goby3 client of gobyd at `base` named `client`, carrying the groups of the `hosted` actor,
/// for platform auv1; quick reconnects so a test waits little.
pub fn goby3_client(bus: &Bus, base: &str, client: &str, hosted: &str) -> Goby3Handle {
    let cfg = Goby3Config {
        enabled: true,
        socket_name: base.to_string(),
        client_name: client.into(),
        settle_ms: 100,
        reconnect_initial_ms: 20,
        reconnect_max_ms: 200,
        manager_timeout_seconds: 1.0,
        ..Default::default()
    };
    let settings = Goby3Settings::from_config(&cfg, "auv1").unwrap();
    goby3::start(bus, settings, &[hosted], GatewayOptions::default()).unwrap()
}
