//! The helm-side children that more than one process hosts (`frontseat interface` and
//! `frontseat moos-gateway`): the Goby3 transport (a gobyd client) and the goby_coroner
//! responder. Each root decides where they stand in its tree and under which policy.

use std::sync::Arc;

use frontseat_actors::bus::Bus;
use frontseat_actors::service_child::{Service, service_child_with};
use frontseat_actors::supervisor::ChildSpec;
use frontseat_config::Goby3Config;
use frontseat_helm_side::goby3::{Goby3Handle, Goby3Settings};
use frontseat_helm_side::{GatewayError, GatewayOptions};

/// Starts the Goby3 transport for `hosted` actors; `None` when `[goby3] enabled = false`. It
/// returns at once: gobyd is joined (and re-joined) in the background.
fn start_goby3(
    cfg: &Goby3Config,
    name: &str,
    bus: &Bus,
    hosted: &[&str],
) -> Result<Option<Goby3Handle>, GatewayError> {
    if !cfg.enabled {
        return Ok(None);
    }
    let settings = Goby3Settings::from_config(cfg, name)?;
    frontseat_helm_side::goby3::start(bus, settings, hosted, GatewayOptions::default()).map(Some)
}

/// The Goby3 transport as a child of a root supervisor, for `hosted` actors.
pub fn goby3_child(
    cfg: &Goby3Config,
    name: &str,
    bus: &Bus,
    hosted: Vec<&'static str>,
    policy: frontseat_actors::supervisor::Policy,
) -> ChildSpec {
    let ctx = (Arc::new(cfg.clone()), name.to_string(), bus.clone(), hosted);
    service_child_with(
        "Goby3Gateway",
        policy,
        ctx,
        |(cfg, name, bus, hosted)| async move {
            match start_goby3(&cfg, &name, &bus, &hosted) {
                Ok(Some(g)) => Ok(Box::new(g) as Box<dyn Service>),
                Ok(None) => Err("[goby3] is not enabled".to_string()),
                Err(e) => Err(e.to_string()),
            }
        },
    )
}

/// The goby_coroner responder as a child of a root supervisor, answering as `name`; restarted
/// by the default policy (it holds nothing but the last statuses).
pub fn health_child(name: &str, bus: &Bus) -> ChildSpec {
    service_child_with(
        "HealthReporter",
        (&frontseat_config::RestartConfig::default()).into(),
        (name.to_string(), bus.clone()),
        |(name, bus)| async move {
            Ok(
                Box::new(frontseat_actors::health::HealthReporter::spawn(&bus, &name))
                    as Box<dyn Service>,
            )
        },
    )
}
