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

/// Every checked-in corpus stays small (the bound `fuzz/run.sh` also checks after a merge): at most
/// 300 files and 2 MiB per target, so the repository keeps minimized corpora, not a campaign's bulk.
#[test]
fn corpora_are_bounded() {
    const MAX_FILES: usize = 300;
    const MAX_BYTES: u64 = 2 * 1024 * 1024;
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let script = std::fs::read_to_string(root.join("fuzz/run.sh")).unwrap();
    assert!(
        script.contains(&format!("max_files={MAX_FILES}\n"))
            && script.contains("max_bytes=$((2 * 1024 * 1024))\n"),
        "fuzz/run.sh states another bound"
    );
    // The script's target list: every target with its corpus directory.
    let dirs: Vec<(&str, &str)> = script
        .lines()
        .map(str::trim)
        .filter_map(|l| l.split_once(':'))
        .filter(|(t, d)| {
            !t.is_empty()
                && t.chars()
                    .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_')
                && (d.starts_with("fuzz/corpus/")
                    || d.starts_with("vehicles/") && d.ends_with("/fuzz/corpus"))
        })
        .collect();
    // …and it names every fuzz target, so CI's run and the campaign cover them all.
    let manifest = std::fs::read_to_string(root.join("fuzz/Cargo.toml")).unwrap();
    let bins: Vec<&str> = manifest
        .lines()
        .filter_map(|l| l.strip_prefix("name = \""))
        .filter_map(|l| l.strip_suffix('"'))
        .filter(|n| *n != "frontseat-fuzz")
        .collect();
    let mut listed: Vec<&str> = dirs.iter().map(|(t, _)| *t).collect();
    let mut bins_sorted = bins.clone();
    listed.sort_unstable();
    bins_sorted.sort_unstable();
    assert_eq!(
        listed, bins_sorted,
        "fuzz/run.sh's targets vs fuzz/Cargo.toml's"
    );
    for (target, dir) in dirs {
        let dir = root.join(dir);
        let (mut n, mut bytes) = (0, 0);
        for e in std::fs::read_dir(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display())) {
            let m = e.unwrap().metadata().unwrap();
            if m.is_file() {
                n += 1;
                bytes += m.len();
            }
        }
        assert!(
            n <= MAX_FILES && bytes <= MAX_BYTES,
            "{target}: {} holds {n} files, {bytes} bytes (bound {MAX_FILES} files, {MAX_BYTES} bytes)",
            dir.display()
        );
    }
}
