//! The glTF/GLB loader on arbitrary bytes: an error or a scene, never a panic, a hang or an
//! allocation the input's declared sizes alone make huge.
//! The body is `gi_host::fuzzing::scene`, which the replay test also runs.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    gi_host::fuzzing::scene(data);
});
