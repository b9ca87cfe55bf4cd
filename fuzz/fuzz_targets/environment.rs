//! The environment readers on arbitrary bytes: OpenEXR, and Radiance HDR (or PNG/JPEG, which the
//! `.hdr` path also reads by their content), then the environment's sampling distribution.
#![no_main]

use gi_host::image_io::HdrImage;
use gi_host::scene::lights::Environment;
use libfuzzer_sys::fuzz_target;

/// The first bytes of every OpenEXR file.
const EXR_MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];

fuzz_target!(|data: &[u8]| {
    let name = if data.starts_with(&EXR_MAGIC) {
        "environment.exr"
    } else {
        "environment.hdr"
    };
    if let Ok(image) = HdrImage::decode(name, data) {
        let _ = Environment::from_image(&image);
    }
});
