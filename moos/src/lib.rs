//! MOOS wire protocol (MOOSDB V10, "ELKS CAN'T DANCE 2/8/10"): a pure codec, an async tokio
//! client that reconnects and re-registers by itself, and a small MOOSDB-compatible broker for
//! tests and for users without a MOOSDB. The authority is `shared/protocol/moos/protocol.md`.
#![forbid(unsafe_code)]

pub mod broker;
pub mod client;
pub mod codec;
pub mod error;
pub mod hops;
mod sock;
pub mod time;

pub use broker::{Broker, BrokerConfig, BrokerCounters, BrokerHandle};

pub use client::{ClientCounters, MoosClient, MoosClientConfig, MoosEvent};
pub use codec::{DataType, MoosMessage, MoosValue, MsgType, PacketDecoder, Text, Welcome};
pub use error::{MoosError, Result};
pub use time::{moos_time, unix_time};
