//! A FrontSeatState by Goby3's proto name, as the vehicle drivers' mode tables write it (Iver3's
//! mode assignments, ArduPilot's mode map): a module of its own so both sections can use it.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// A FrontSeatState, by Goby3's proto name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
pub enum FrontSeatStateName {
    FrontseatNotConnected,
    FrontseatIdle,
    FrontseatInControl,
    FrontseatAcceptingCommands,
}
