//! Configuration of `frontseat moos-gateway`: the FrontSeatTranslation on its own, between a
//! MOOSDB and the interface reached over Zenoh (Goby3's goby_moos_gateway).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::check::Checker;
use crate::sections::{InterprocessConfig, MoosConfig, TelemetryConfig};
use crate::{FieldError, ServiceConfig};

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
    /// Zenoh transport to reach the interface; enabled by default here, and it must stay enabled.
    #[serde(default = "gateway_interprocess")]
    pub interprocess: InterprocessConfig,
    /// OpenTelemetry trace export.
    #[serde(default)]
    pub telemetry: TelemetryConfig,
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
            telemetry: TelemetryConfig::default(),
        }
    }
}

impl ServiceConfig for GatewayConfig {
    const SERVICE: &'static str = "moos-gateway";

    fn validate(&self) -> Vec<FieldError> {
        let mut c = Checker::default();
        self.moos.check("moos", &mut c);
        if !self.interprocess.enabled {
            c.push(FieldError::new(
                "interprocess.enabled",
                false,
                "the gateway reaches the interface only over Zenoh; it must be true",
            ));
        }
        self.interprocess.check("interprocess", &mut c);
        self.telemetry.check("telemetry", &mut c);
        c.errors
    }
}
