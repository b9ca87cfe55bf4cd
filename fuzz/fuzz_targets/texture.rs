//! The texture decoders (PNG, JPEG, KTX2, DDS, recognised by their content) on arbitrary bytes.
//! The body is `gi_host::fuzzing::texture`, which the replay test also runs.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    gi_host::fuzzing::texture(data);
});
