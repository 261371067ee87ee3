//! libFuzzer entry for `frontseat_record::fuzz_import`: a `.goby` file copied off a vehicle is
//! untrusted input to `frontseat log import`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| frontseat_record::fuzz_import(data));
