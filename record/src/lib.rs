//! frontseat's record of a mission: every message the process's bus carries, written to MCAP
//! files that any MCAP tool decodes on its own (each channel carries the protobuf
//! FileDescriptorSet of its message type), read back for `frontseat log info|export`, and
//! replayed onto a bus as the recorded vehicle.
//!
//! - [`recorder`]: the bus → MCAP writer (bounded queue, rotation, disk budget, crash-safe flushes).
//! - [`reader`]: a streaming, bounded reader of possibly truncated files (after a crash).
//! - [`recover`]: a file a crash left without its summary finished in place (`log recover`).
//! - [`info`], [`export`]: the summaries and flattened exports of `frontseat log`.
//! - [`goby_log`], [`import`]: goby_logger `.goby` files read and converted to MCAP.
//! - [`foxglove`]: the same groups served live over the Foxglove WebSocket protocol (read-only).
//! - [`service`]: `[record]` (recorder and live server) started for any process in a few lines.
//! - [`replay`]: a recording published onto a bus with its timing, marked as replayed.
#![forbid(unsafe_code)]

#[doc(hidden)]
pub mod crafted;
pub mod export;
pub mod foxglove;
pub mod goby_log;
pub mod import;
pub mod info;
pub mod output;
pub mod plot;
pub mod reader;
pub mod recorder;
pub mod recover;
pub mod replay;
pub mod schema;
pub mod service;
mod time;

pub use reader::{ReadError, Recording};
pub use recorder::{RecordInput, RecordMeta, Recorder, RecorderError, RecorderStats};

/// The MCAP `profile` field: none of the well-known profiles (ros1, ros2) fits a Goby3 bus.
pub const PROFILE: &str = "frontseat";
/// Name of the metadata record describing the run (vehicle, datum, config digest, ...).
pub const META_RUN: &str = "frontseat.run";
/// Name of the metadata record written when a file is closed: what the recorder counted.
pub const META_RECORDER: &str = "frontseat.recorder";
/// Name of the metadata record a finished crash's file carries (`log recover`, the recorder at
/// start): when, how many messages were kept, and why the original ended where it did.
pub const META_RECOVERED: &str = "frontseat.recovered";
/// Name of the metadata record `log import` writes listing the entries it could not convert:
/// key `<SCHEME> <group>` (e.g. `DCCL goby::acomms::...`), value the count.
pub const META_IMPORT_SKIPPED: &str = "frontseat.import.skipped";
/// Channel metadata key telling where the channel's messages came from (local, imported, replayed).
pub const CHANNEL_ORIGIN: &str = "origin";
/// Channel metadata key naming the vehicle of a channel in a file that holds several (the
/// topside's, whose topics are `<platform>/<group>`).
pub const CHANNEL_PLATFORM: &str = "platform";

/// The fuzz target body (`fuzz/fuzz_targets/mcap_reader.rs`, and the corpus replay in
/// `record/tests/fuzz_corpus.rs`): any bytes go through the reader, `info` and `export` without a
/// panic, and `info` counts exactly the messages the reader yields.
pub fn fuzz_read(data: &[u8]) {
    let mut rec = Recording::new(data);
    let mut n = 0u64;
    let mut first_topic = None;
    while let Ok(Some(m)) = rec.next_message() {
        n += 1;
        if first_topic.is_none() {
            first_topic = rec.channel(m.channel_id).map(|c| c.topic.to_string());
        }
    }
    if let Ok(i) = info::info(Recording::new(data)) {
        assert_eq!(i.messages, n, "info and the reader disagree");
        assert_eq!(i.groups.iter().map(|g| g.count).sum::<u64>(), n);
        let _ = i.render();
    }
    if let Some(t) = first_topic {
        for f in [export::Format::Csv, export::Format::Json] {
            let _ = export::export(Recording::new(data), &t, f, &mut std::io::sink());
        }
    }
}

/// The fuzz target body of `fuzz/fuzz_targets/goby_import.rs` (and the damaged-file tests): any
/// bytes go through `log import` without a panic, and whatever it writes is a complete MCAP file
/// holding exactly the messages it counted.
pub fn fuzz_import(data: &[u8]) {
    let mut out = std::io::Cursor::new(Vec::new());
    if let Ok(s) = import::import(data, &mut out, "fuzz.goby") {
        let bytes = out.into_inner();
        let i = info::info(Recording::new(bytes.as_slice())).expect("an import writes MCAP");
        assert_eq!(i.messages, s.written, "import counted what it wrote");
        assert_eq!(i.truncated, None, "an import closes its file");
    }
}
