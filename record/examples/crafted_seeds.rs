//! Writes the crafted hostile files of `frontseat_record::crafted` into the fuzz corpora as seeds
//! (`fuzz/corpus/mcap_reader/crafted_*`, `fuzz/corpus/goby_import/crafted_*`), at sizes under
//! the fuzzer's `-max_len`. `record/tests/fuzz_corpus.rs` checks the checked-in seeds are what
//! this writes. Run from the repository root:
//! `cargo run -p frontseat-record --example crafted_seeds`.

fn main() -> std::io::Result<()> {
    for (dir, name, bytes) in frontseat_record::crafted::seeds() {
        let p = std::path::Path::new("fuzz/corpus").join(dir).join(name);
        std::fs::write(&p, bytes)?;
        println!("{}", p.display());
    }
    Ok(())
}
