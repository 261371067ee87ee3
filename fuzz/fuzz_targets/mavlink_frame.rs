//! libFuzzer entry for `frontseat_fuzz::mavlink_frame` (the body is shared with tests/fuzz_corpus.rs).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| frontseat_fuzz::mavlink_frame(data));
