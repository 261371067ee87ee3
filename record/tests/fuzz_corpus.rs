//! Replays the checked-in corpus of the `mcap_reader` fuzz target (`fuzz/corpus/mcap_reader/`:
//! recordings in each compression, cut at many points, with flipped bytes, and hostile lengths)
//! through the same body the fuzzer runs, [`frontseat_record::fuzz_read`].

use std::path::PathBuf;

#[test]
fn mcap_reader_corpus() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../fuzz/corpus/mcap_reader");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    assert!(files.len() >= 20, "only {} corpus files", files.len());
    let mut whole = 0;
    for f in &files {
        let data = std::fs::read(f).unwrap();
        let r = std::panic::catch_unwind(|| frontseat_record::fuzz_read(&data));
        assert!(r.is_ok(), "{} panics", f.display());
        if f.to_string_lossy().ends_with("_whole.mcap") {
            // The intact files are real recordings: they read completely.
            let i = frontseat_record::info::info(frontseat_record::Recording::new(data.as_slice()))
                .unwrap();
            assert_eq!((i.messages, i.truncated), (6, None), "{}", f.display());
            whole += 1;
        }
    }
    assert_eq!(whole, 3, "one intact recording per compression");
}

/// The `goby_import` target's seeds (`fuzz/corpus/goby_import/`: the fixture whole and cut)
/// through [`frontseat_record::fuzz_import`].
#[test]
fn goby_import_corpus() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../fuzz/corpus/goby_import");
    let mut n = 0;
    for e in std::fs::read_dir(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display())) {
        let p = e.unwrap().path();
        let data = std::fs::read(&p).unwrap();
        let r = std::panic::catch_unwind(|| frontseat_record::fuzz_import(&data));
        assert!(r.is_ok(), "{} panics", p.display());
        n += 1;
    }
    assert!(n >= 2, "only {n} seeds");
}

/// The crafted seeds (`frontseat_record::crafted`: the shapes of issue 37's review) are checked
/// in as the generator writes them, so a fuzz run starts from them.
#[test]
fn crafted_seeds_are_checked_in() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../fuzz/corpus");
    for (dir, name, bytes) in frontseat_record::crafted::seeds() {
        let p = root.join(dir).join(name);
        let on_disk = std::fs::read(&p).unwrap_or_else(|e| {
            panic!(
                "{}: {e} (cargo run -p frontseat-record --example crafted_seeds)",
                p.display()
            )
        });
        assert!(
            on_disk == bytes,
            "{} differs from its generator",
            p.display()
        );
        assert!(bytes.len() < 70_000, "{name}: over the fuzzer's -max_len");
    }
}
