//! libFuzzer entry for `frontseat_record::fuzz_read` (the body is shared with
//! record/tests/fuzz_corpus.rs): recordings are untrusted files.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| frontseat_record::fuzz_read(data));
