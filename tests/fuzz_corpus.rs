//! Replays the checked-in fuzz corpus (`fuzz/corpus/<target>/`, and a vehicle's own in
//! `vehicles/<vehicle>/fuzz/corpus/`) through the same target bodies the fuzzer runs
//! (`fuzz/src/lib.rs`, included here), so every input that ever found a bug or a new path stays a
//! regression test under a plain `cargo test`.

#[path = "../fuzz/src/lib.rs"]
mod targets;

use std::path::PathBuf;

fn replay(target: &str, body: fn(&[u8])) {
    replay_dir(&format!("fuzz/corpus/{target}"), target, body);
}

/// Replays the corpus in `dir` (relative to the repository root).
fn replay_dir(dir: &str, target: &str, body: fn(&[u8])) {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(dir);
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    assert!(
        files.len() >= 20,
        "{}: only {} corpus files",
        dir.display(),
        files.len()
    );
    for f in &files {
        let data = std::fs::read(f).unwrap();
        let r = std::panic::catch_unwind(|| body(&data));
        assert!(r.is_ok(), "{target}: {} panics", f.display());
    }
}

#[test]
fn sim_codec_corpus() {
    replay("sim_codec", targets::sim_codec);
}

#[test]
fn driver_line_corpus() {
    replay_dir(
        "vehicles/basic_simulator/fuzz/corpus",
        "driver_line",
        targets::driver_line,
    );
}

#[test]
fn moos_decode_corpus() {
    replay("moos_decode", targets::moos_decode);
}

#[test]
fn config_corpus() {
    replay("config", targets::config);
}

#[test]
fn sv2_frame_corpus() {
    replay_dir(
        "vehicles/waveglider_sv2/fuzz/corpus",
        "sv2_frame",
        targets::sv2_frame,
    );
}

#[test]
fn iver_sentence_corpus() {
    replay_dir(
        "vehicles/iver3/fuzz/corpus",
        "iver_sentence",
        targets::iver_sentence,
    );
}

#[test]
fn bluefin_codec_corpus() {
    replay_dir(
        "vehicles/bluefin/fuzz/corpus",
        "bluefin_codec",
        targets::bluefin_codec,
    );
}

#[test]
fn zmtp_guard_corpus() {
    replay("zmtp_guard", targets::zmtp_guard);
}

#[test]
fn imc_packet_corpus() {
    replay_dir(
        "vehicles/dune/fuzz/corpus",
        "imc_packet",
        targets::imc_packet,
    );
}

#[test]
fn mavlink_frame_corpus() {
    replay_dir(
        "vehicles/ardupilot/fuzz/corpus",
        "mavlink_frame",
        targets::mavlink_frame,
    );
}
