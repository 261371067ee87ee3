//! libFuzzer entry for `frontseat_fuzz::imc_packet` (the body is shared with tests/fuzz_corpus.rs).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| frontseat_fuzz::imc_packet(data));
