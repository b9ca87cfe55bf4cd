//! The environment readers (OpenEXR, Radiance HDR) on arbitrary bytes, then the environment's
//! sampling distribution.
//! The body is `gi_host::fuzzing::environment`, which the replay test also runs.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    gi_host::fuzzing::environment(data);
});
