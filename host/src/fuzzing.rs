//! What the fuzz targets (`fuzz/`, libFuzzer) feed each reader: one function per target, shared
//! with the replay test (`host/tests/fuzz_regressions.rs`) that runs their seeds and mutations of
//! them in every test run, so that CI exercises the same entry points without a fuzzing build.
//! Each returns whether the input was accepted; none may panic, hang or allocate without bound.

use crate::image_io::HdrImage;
use crate::scene::lights::Environment;
use crate::scene::{Scene, texture_files};
use std::path::Path;

/// The first bytes of every OpenEXR file.
const EXR_MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];

/// The glTF/GLB loader on `data` (GLB or glTF JSON). Relative URIs resolve in the repository's
/// `scenes/`, so that seeds taken from there find their buffers and textures.
pub fn scene(data: &[u8]) -> bool {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/fuzz-input.gltf");
    Scene::from_bytes(path, data).is_ok()
}

/// The texture decoders (PNG, JPEG, KTX2, DDS, recognised by their content) on `data`, as the
/// loader calls them for a base colour or emissive (sRGB) texture.
pub fn texture(data: &[u8]) -> bool {
    texture_files::decode(data, true).is_ok()
}

/// The environment readers on `data` (OpenEXR by its magic bytes, Radiance HDR otherwise, or
/// PNG/JPEG, which the `.hdr` path also reads by content), then the environment's sampling
/// distribution.
pub fn environment(data: &[u8]) -> bool {
    let name = if data.starts_with(&EXR_MAGIC) {
        "environment.exr"
    } else {
        "environment.hdr"
    };
    HdrImage::decode(name, data).is_ok_and(|image| Environment::from_image(&image).is_ok())
}
