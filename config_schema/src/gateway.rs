//! Configuration of `frontseat moos-gateway`: the FrontSeatTranslation on its own, between a
//! MOOSDB and the interface reached over Zenoh and/or gobyd (Goby3's goby_moos_gateway).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::check::Checker;
use crate::goby3::Goby3Config;
use crate::sections::{InterprocessConfig, MoosConfig, TelemetryConfig};
use crate::{FieldError, RestartConfig, ServiceConfig};

/// Configuration of the standalone MOOS gateway (`frontseat moos-gateway -c FILE`). The [moos]
/// section is required here.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct GatewayConfig {
    /// Vehicle name: the default Zenoh platform name, so it must match the interface's.
    #[serde(default)]
    pub name: String,
    /// The MOOSDB to bridge (required; an empty [moos] table means all defaults).
    pub moos: MoosConfig,
    /// Zenoh transport to reach the interface; enabled by default here. Zenoh, [goby3] or both
    /// must be enabled.
    #[serde(default = "gateway_interprocess")]
    pub interprocess: InterprocessConfig,
    /// Reaching the interface through a Goby3 gobyd instead of (or beside) Zenoh.
    #[serde(default)]
    pub goby3: Goby3Config,
    /// OpenTelemetry trace export.
    #[serde(default)]
    pub telemetry: TelemetryConfig,
    /// Restart policies of the root supervisor's children.
    #[serde(default)]
    pub supervision: GatewaySupervisionConfig,
    /// Recording every message this process sees (the helm's side) to MCAP files.
    #[serde(default)]
    pub record: crate::RecordConfig,
}

/// The MOOS gateway's root supervisor: one restart policy per child.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct GatewaySupervisionConfig {
    /// The Zenoh gateway (`[interprocess] enabled`).
    pub zenoh: RestartConfig,
    /// The Goby3 transport (`[goby3] enabled`).
    pub goby3: RestartConfig,
    /// The FrontSeatTranslation (the MOOS bridge itself).
    pub translation: RestartConfig,
}

/// The gateway is a client of the interface's Zenoh endpoint by default: listening on the
/// interface's own default endpoint would collide with it on one host.
fn gateway_interprocess() -> InterprocessConfig {
    InterprocessConfig {
        enabled: true,
        listen: Vec::new(),
        connect: vec!["tcp/127.0.0.1:7447".to_string()],
        ..InterprocessConfig::default()
    }
}

impl Default for GatewayConfig {
    fn default() -> Self {
        Self {
            name: String::new(),
            moos: MoosConfig::default(),
            interprocess: gateway_interprocess(),
            goby3: Goby3Config::default(),
            telemetry: TelemetryConfig::default(),
            supervision: GatewaySupervisionConfig::default(),
            record: crate::RecordConfig::default(),
        }
    }
}

impl ServiceConfig for GatewayConfig {
    const SERVICE: &'static str = "moos-gateway";

    fn import_goby3(
        text: &str,
        file: &str,
    ) -> Option<Result<crate::goby3_import::Imported, crate::ConfigError>> {
        Some(crate::goby3_import::import_gateway(text, file))
    }

    fn validate(&self) -> Vec<FieldError> {
        let mut c = Checker::default();
        crate::names::check_optional("name", &self.name, &mut c);
        self.moos.check("moos", &mut c);
        if !self.interprocess.enabled && !self.goby3.enabled {
            c.push(FieldError::new(
                "interprocess.enabled",
                false,
                "the gateway reaches the interface over Zenoh or gobyd: enable [interprocess] or [goby3]",
            ));
        }
        self.interprocess.check("interprocess", &mut c);
        self.goby3.check("goby3", &mut c);
        self.telemetry.check("telemetry", &mut c);
        let sup = &self.supervision;
        sup.zenoh.check_at("supervision.zenoh", &mut c);
        sup.goby3.check_at("supervision.goby3", &mut c);
        sup.translation.check_at("supervision.translation", &mut c);
        self.record.check("record", &mut c);
        c.errors
    }

    fn warnings(&self) -> Vec<String> {
        self.interprocess.warnings("interprocess")
    }
}
