//! The glTF/GLB loader on arbitrary bytes: an error or a scene, never a panic, a hang or an
//! allocation the input's declared sizes alone make huge.
#![no_main]

use gi_host::scene::Scene;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    // Relative URIs resolve in the repository's scenes/, so that the seeds taken from there find
    // their buffers and textures (the file itself is never read).
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/fuzz-input.gltf");
    let _ = Scene::from_bytes(path, data);
});
