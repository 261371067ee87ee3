//! frontseat's record of a mission: every message the process's bus carries, written to MCAP
//! files that any MCAP tool decodes on its own (each channel carries the protobuf
//! FileDescriptorSet of its message type), read back for `frontseat log info|export`, and
//! replayed onto a bus as the recorded vehicle.
//!
//! - [`recorder`]: the bus → MCAP writer (bounded queue, rotation, disk budget, crash-safe flushes).
//! - [`reader`]: a streaming, bounded reader of possibly truncated files (after a crash).
//! - [`info`], [`export`]: the summaries and flattened exports of `frontseat log`.
//! - [`replay`]: a recording published onto a bus with its timing, marked as replayed.
#![forbid(unsafe_code)]

pub mod export;
pub mod info;
pub mod reader;
pub mod recorder;
pub mod replay;
pub mod schema;
mod time;

pub use reader::{ReadError, Recording};
pub use recorder::{RecordMeta, Recorder, RecorderError, RecorderStats};

/// The MCAP `profile` field: none of the well-known profiles (ros1, ros2) fits a Goby3 bus.
pub const PROFILE: &str = "frontseat";
/// Name of the metadata record describing the run (vehicle, datum, config digest, ...).
pub const META_RUN: &str = "frontseat.run";
/// Name of the metadata record written when a file is closed: what the recorder counted.
pub const META_RECORDER: &str = "frontseat.recorder";
/// Channel metadata key telling where the channel's messages came from (local, imported, replayed).
pub const CHANNEL_ORIGIN: &str = "origin";
